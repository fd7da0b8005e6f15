//! snell: a ray tracer on Intel Embree 3 for refraction that other renderers
//! get wrong or make slow: nested dielectrics with priorities (false hits
//! skipped inside an Embree filter), curved rays in gradient-index media, and
//! analytic refraction warps.
//!
//! This page is the library's guide. The design (the layers, the nested rule
//! and why it is correct, the warp's method) is in `docs/design.md`, the scene
//! format in `docs/scene-format.md`; each module's documentation tells its
//! part. The names re-exported here are what a user needs: load a scene
//! ([`load_scene`], [`load_scene_str`]), render it ([`render()`] with
//! [`RenderSettings`] and [`RenderOptions`], giving a [`Rendered`] image with
//! its [`Aovs`] and [`Counters`]), follow one ray through nested solids
//! ([`refraction_path`]), warp points through glass ([`Plate`],
//! [`HollowCylinder`]) and trace curved rays in a gradient-index field
//! ([`IndexField`], [`media::grin_trace`]).
//!
//! # Conventions and units
//!
//! - Lengths are metres, the frame is right-handed with y up; angles in scene
//!   files are degrees.
//! - Images are linear RGB, one `glam::Vec3A` per pixel, row-major with row 0
//!   at the top; `.exr` files keep them as linear floats, `.png` files are
//!   8-bit sRGB ([`image_io::save`]).
//! - Indices of refraction are absolute: `ambient_ior` is the medium between
//!   objects. Where solids overlap, the higher `priority` owns the region.
//! - A render is a function of the scene and its [`RenderSettings`] (film,
//!   samples per pixel, seed, nested strategy): every sample's random numbers
//!   are seeded by (seed, pixel, sample), so the image is the same bit for bit
//!   on any number of threads. [`RenderOptions`] (threads, progress, AOVs)
//!   never change the pixels. Settings start from the scene file and are
//!   overridden on the settings, never on the scene.
//! - The renderer works in `f32`; the warps and the gradient-index tracer in
//!   `f64` (`glam::DVec3`).
//! - Errors are one [`Error`] type: a scene error names the file, the key path
//!   (`objects[2].material.ior`), the line and the column.
//!
//! # Features
//!
//! - `cli` (default): the `snell` command line; turns on the two below and
//!   adds clap and ctrlc.
//! - `tooling`: benchmarks (`bench`, `ceiling`), the report (`report`, drawn
//!   with plotters), the fuzzers (`fuzz`, `fuzz_import`) and the render
//!   farm's parts (`part`, `farm`, `merge`).
//! - `progress-bar`: a terminal progress bar while rendering (indicatif).
//!
//! With `default-features = false` the crate is the core library alone:
//! scenes (with the glTF and Mitsuba importers), rendering, the tracer, the
//! warps and the media.
//!
//! # Load a scene, render it, read the statistics
//!
//! [`load_scene`] reads a file (meshes and textures are found beside it):
//! snell TOML, glTF 2.0 (`.gltf`, `.glb`) or Mitsuba 3 XML (`.xml`), the
//! importers' choices set by [`BuildOptions::import`] ([`ImportOptions`]);
//! [`load_scene_str`] takes the text, a name for error messages and the
//! directory that relative paths start from.
//!
//! ```
//! use snell::{load_scene_str, render, Aov, BuildOptions, RenderOptions, RenderSettings};
//!
//! let text = r#"
//! ambient_ior = 1.0
//! [camera]
//! position = [0.0, 0.0, 4.0]
//! target = [0.0, 0.0, 0.0]
//! fov = 40.0
//! [film]
//! width = 32
//! height = 24
//! spp = 4
//! [environment]
//! type = "constant"
//! radiance = [1.0, 1.0, 1.0]
//! [[objects]]
//! name = "ball"
//! shape = { type = "sphere", center = [0.0, 0.0, 0.0], radius = 1.0 }
//! material = { type = "dielectric", ior = 1.5 }
//! "#;
//! let scene = load_scene_str("ball.toml", text, std::path::Path::new("."), &BuildOptions::default())?;
//! // Settings start from the file's film; override them here, never on the scene.
//! let settings = RenderSettings::from_scene(&scene).with_spp(2);
//! let opts = RenderOptions { threads: Some(1), want_aovs: true, ..Default::default() };
//! let image = render(&scene, &settings, &opts)?;
//! assert_eq!((image.width, image.height), (32, 24));
//! assert_eq!(image.stats.counters.samples, 32 * 24 * 2);
//! // A clear glass ball in a white furnace: every pixel is white (energy is conserved).
//! let mean: f32 = image.pixels.iter().map(|p| p.x).sum::<f32>() / image.pixels.len() as f32;
//! assert!((mean - 1.0).abs() < 0.05, "{mean}");
//! // A diagnostic layer per pixel: one solid, so nothing is nested and no hit is false.
//! assert!(image.aovs.layer(Aov::FalseHits).iter().all(|&v| v == 0.0));
//! // Linear float EXR (or 8-bit sRGB PNG, by the extension), written atomically.
//! let out = std::env::temp_dir().join("snell-guide-ball.exr");
//! snell::image_io::save(&out, image.width, image.height, &image.pixels, &[], &[])?;
//! # std::fs::remove_file(&out).ok();
//! # Ok::<(), snell::Error>(())
//! ```
//!
//! A scene key can be overridden by its path before the scene is built, as
//! `snell render --set` does: [`overrides::apply`] on a
//! [`scene::source::Source`], then [`load_scene_source`]; an error at an
//! overridden key is located in the override.
//!
//! # Trace one ray through nested solids
//!
//! Water (priority 1) overlapping the glass that holds it (priority 2): the
//! glass wins where they overlap, so a ray along the axis crosses three true
//! surfaces, and the water's surface inside the glass is a false hit.
//!
//! ```
//! use glam::Vec3A;
//! use snell::{load_scene_str, refraction_path, BuildOptions, Counters, Tracer};
//!
//! let text = r#"
//! ambient_ior = 1.0
//! [camera]
//! position = [0.0, 0.0, 5.0]
//! target = [0.0, 0.0, 0.0]
//! fov = 40.0
//! [film]
//! width = 8
//! height = 8
//! spp = 1
//! [[objects]]
//! name = "water"
//! shape = { type = "box", center = [0.0, 0.0, 0.0], size = [1.0, 1.0, 1.0] }
//! material = { type = "dielectric", ior = 1.33, priority = 1 }
//! [[objects]]
//! name = "glass"
//! shape = { type = "box", center = [0.6, 0.0, 0.0], size = [1.0, 2.0, 2.0] }
//! material = { type = "dielectric", ior = 1.5, priority = 2 }
//! "#;
//! let scene = load_scene_str("nested.toml", text, std::path::Path::new("."), &BuildOptions::default())?;
//! let mut counters = Counters::default();
//! let path = refraction_path(
//!     Tracer::new(&scene), // the in-filter skip; `.with_strategy(..)` for another
//!     Vec3A::new(-3.0, 0.1, 0.2),
//!     Vec3A::X,
//!     &[],   // the ray starts outside every solid
//!     16,
//!     &mut counters,
//! )?;
//! // air → water → glass (the water's far face at x = 0.5 lies in the glass: false) → air
//! let indices: Vec<(f32, f32)> = path.events.iter().map(|e| (e.n1, e.n2)).collect();
//! assert_eq!(indices, vec![(1.0, 1.33), (1.33, 1.5), (1.5, 1.0)]);
//! assert_eq!(counters.false_hits, 1);
//! assert!(path.escaped && path.final_list.is_empty());
//! # Ok::<(), snell::Error>(())
//! ```
//!
//! # Warp points through glass
//!
//! The warps move a point to where a straight eye ray sees it through the
//! glass (Mukai et al.), exactly in 3-D and in `f64`: a plate has one image of
//! each point, a hollow cylinder several (one per path family). A scene with
//! a `[warp]` table renders this way with `warp_render`.
//!
//! ```
//! use glam::DVec3;
//! use snell::{HollowCylinder, Plate};
//!
//! let eye = DVec3::new(0.0, 0.0, 5.0);
//! // A 0.1 m plate of n = 1.5 whose near face is at z = 1, facing the eye.
//! let plate = Plate::try_new(DVec3::new(0.0, 0.0, 1.0), -DVec3::Z, 0.1, 1.5).unwrap();
//! let image = plate.warp(eye, DVec3::new(0.0, 0.0, -2.0)).unwrap();
//! // On the axis the point comes W (1 - 1/n) towards the eye.
//! assert!((image.shift - 0.1 * (1.0 - 1.0 / 1.5)).abs() < 1e-12);
//! assert!((image.position - DVec3::new(0.0, 0.0, -2.0 + image.shift)).length() < 1e-12);
//!
//! // A tube along y (radii 1 and 0.8, n = 1.5) between the eye and a point behind it.
//! let tube = HollowCylinder::try_new(DVec3::ZERO, DVec3::Y, 1.0, 0.8, 1.5).unwrap();
//! let images = tube.images(eye, DVec3::new(0.3, 0.0, -3.0)).unwrap();
//! assert!(!images.is_empty());
//! for i in &images {
//!     // Each image lies on its eye ray, as far from the eye as the point.
//!     assert!((i.position - (eye + i.direction * (DVec3::new(0.3, 0.0, -3.0) - eye).length())).length() < 1e-9);
//! }
//! ```
//!
//! # Trace a curved ray in a gradient-index medium
//!
//! [`IndexField`] is an index of refraction over space (a linear gradient, a
//! hot road, an inversion layer, …); [`media::grin_trace::trace`] follows one
//! ray through it by the chosen method. In a scene, a `[medium]` table puts a
//! field in a box and the renderer casts curved rays through it as chords.
//!
//! ```
//! use glam::DVec3;
//! use snell::media::grin_trace::{trace, Query};
//! use snell::media::Method;
//! use snell::IndexField;
//!
//! // n = 1 + 0.01 h: rays bend towards the denser air above.
//! let field = IndexField::Linear { n0: 1.0, m: 0.01, up: DVec3::Y, base: 0.0 };
//! let dir = DVec3::new(10f64.to_radians().cos(), 10f64.to_radians().sin(), 0.0);
//! let end = |method, tolerance| {
//!     let q = Query::along(&field, DVec3::ZERO, dir, 100.0, method, tolerance, 1.0);
//!     trace(&q).map(|a| a.end.unwrap()).map_err(snell::Error::Invalid)
//! };
//! // Dormand–Prince at 1e-10 m per step against the closed form (a catenary).
//! let (rk45, exact) = (end(Method::Rk45, 1e-10)?, end(Method::Exact, 1.0)?);
//! assert!((rk45 - exact).length() < 1e-6, "{rk45} vs {exact}");
//! assert!(exact.y > 100.0 * 10f64.to_radians().sin()); // above the straight line
//! # Ok::<(), snell::Error>(())
//! ```
//!
//! # Layers
//!
//! Bottom to top (`tests/layering.rs` enforces them): [`ray`], [`optics`],
//! [`sampling`], [`counters`] → [`embree`] (the only FFI and the only
//! `unsafe`; explicit SIMD, such as the cylinder warp's lanes, goes through
//! the safe `pulp` crate with run-time dispatch) → [`error`] → [`camera`],
//! [`media`], [`warp`] solvers, [`accum`], [`bsdf`] → [`scene`] (the model and its
//! builder) → [`dielectric`] (the nested rule) → [`integrator`] → [`render`](mod@render),
//! [`audit`] → overrides, the warp renderer, and with `tooling` the parts, the
//! farm, the benchmarks and the report.
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod accum;
pub mod audit;
/// Microfacet BSDFs (rough glass, metals, plastics) after Mitsuba 3: pure math, local frame.
pub mod bsdf;
pub mod camera;
pub mod counters;
pub mod dielectric;
#[allow(unsafe_code)] // the one FFI module: every unsafe block says why it is sound
pub mod embree;
pub mod error;
pub mod grin_fan;
pub mod image_io;
pub mod integrator;
pub mod media;
pub mod optics;
pub mod overrides;
pub mod provenance;
pub mod ray;
pub mod render;
pub mod sampling;
pub mod scene;
mod simd3;
pub mod timing;
pub mod warp;
pub mod warp_render;

// Tooling: what the command line runs beyond rendering.
#[cfg(feature = "tooling")]
pub mod bench;
#[cfg(feature = "tooling")]
pub mod ceiling;
#[cfg(feature = "tooling")]
pub mod farm;
#[cfg(feature = "tooling")]
pub mod fuzz;
#[cfg(feature = "tooling")]
pub mod fuzz_import;
#[cfg(feature = "tooling")]
pub mod merge;
#[cfg(feature = "tooling")]
pub mod part;
#[cfg(feature = "tooling")]
pub mod report;

pub use counters::Counters;
pub use dielectric::{InteriorList, NestedStrategy};
pub use error::{Error, Result};
pub use integrator::{refraction_path, PathEvent, RefractionPath, Tracer};
pub use media::{IndexField, Medium};
pub use render::{
    render, render_part, Aov, Aovs, CancelToken, ProgressSink, RenderOptions, RenderSettings, RenderStats,
    Rendered,
};
pub use scene::{load_scene, load_scene_source, load_scene_str, BuildOptions, ImportOptions, RenderScene};
pub use warp::{HollowCylinder, Plate};

/// Every pulp vector level this CPU runs, the scalar one first: the tests
/// of the vector kernels compare them.
#[cfg(test)]
pub(crate) fn vector_levels() -> Vec<pulp::Arch> {
    #[cfg(target_arch = "x86_64")]
    {
        let mut v = vec![pulp::Arch::Scalar];
        v.extend(pulp::x86::V3::try_new().map(pulp::Arch::V3));
        v.extend(pulp::x86::V4::try_new().map(pulp::Arch::V4));
        v
    }
    #[cfg(not(target_arch = "x86_64"))]
    vec![pulp::Arch::new()]
}

/// The header line every benchmark prints first.
pub fn bench_header() -> String {
    format!("provenance: {}", provenance::line())
}
