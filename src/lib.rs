//! snell: a ray tracer on Intel Embree 3 for refraction that other renderers
//! get wrong or make slow: nested dielectrics with priorities (false hits
//! skipped inside an Embree filter), curved rays in gradient-index media, and
//! analytic refraction warps. See DESIGN.md and docs/.
//!
//! Layers, bottom to top (`tests/layering.rs` enforces them): [`ray`],
//! [`optics`], [`sampling`], [`counters`] → [`embree`] (the only FFI; the one
//! other `unsafe` is the cylinder warp's AVX2 lanes, `warp::lanes`) →
//! [`error`] → [`camera`], [`media`], [`warp`] solvers, [`accum`] → [`scene`]
//! (the model and its builder) → [`dielectric`] (the nested rule) →
//! [`integrator`] → [`render`], [`audit`] → parts, farm, benches, the warp
//! renderer, the report.
//!
//! # Load a scene, render it, read the statistics
//!
//! ```
//! use snell::render::{render, RenderOptions, RenderSettings};
//! use snell::scene::{load_scene_str, BuildOptions};
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
//! let opts = RenderOptions { threads: Some(1), quiet: true, want_aovs: false };
//! let image = render(&scene, &settings, &opts)?;
//! assert_eq!((image.width, image.height), (32, 24));
//! assert_eq!(image.stats.counters.samples, 32 * 24 * 2);
//! // A clear glass ball in a white furnace: every pixel is white (energy is conserved).
//! let mean: f32 = image.pixels.iter().map(|p| p.x).sum::<f32>() / image.pixels.len() as f32;
//! assert!((mean - 1.0).abs() < 0.05, "{mean}");
//! # Ok::<(), snell::Error>(())
//! ```
//!
//! # Trace one ray through nested solids
//!
//! Water (priority 1) overlapping the glass that holds it (priority 2): the
//! glass wins where they overlap, so a ray along the axis crosses four true
//! surfaces, and the water's surface inside the glass is a false hit.
//!
//! ```
//! use glam::Vec3A;
//! use snell::counters::Counters;
//! use snell::integrator::{refraction_path, Tracer};
//! use snell::scene::{load_scene_str, BuildOptions};
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
//!     Tracer::new(&scene), // the in-filter skip; `Tracer { strategy, .. }` for another
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
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod accum;
pub mod audit;
pub mod bench;
pub mod camera;
pub mod ceiling;
pub mod counters;
pub mod cpu_time;
pub mod dielectric;
#[allow(unsafe_code)] // the one FFI module: every unsafe block says why it is sound
pub mod embree;
pub mod error;
pub mod farm;
pub mod fuzz;
pub mod fuzz_import;
pub mod image_io;
pub mod integrator;
pub mod media;
pub mod merge;
pub mod optics;
pub mod overrides;
pub mod part;
pub mod provenance;
pub mod ray;
pub mod render;
pub mod report;
pub mod sampling;
pub mod scene;
pub mod warp;
pub mod warp_render;

pub use error::{Error, Result};

/// The header line every benchmark prints first.
pub fn bench_header() -> String {
    format!("provenance: {}", provenance::line())
}
