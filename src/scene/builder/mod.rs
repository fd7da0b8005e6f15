//! From a parsed description to a render scene: validation (every error names
//! the file, the key path and the line:column), transforms, meshes, Embree.
use super::desc::*;
use super::import::{ImportOptions, SceneText};
use super::model::{Containment, Environment, IntegratorKind, Material, RenderScene, Shape};
use super::source::Source;
use super::texture::{load_image, Rows, Texture};
use crate::camera::Camera;
use crate::embree::BuildQuality;
use crate::error::{Error, Result};
use glam::{DMat3, DVec3, Vec3A as V3};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use upload::analytic_rects;

/// Hard limits checked before any allocation (estimated memory in the message).
pub use super::model::MAX_PIXELS;

mod lights;
mod object;
mod upload;
mod warp;
/// Largest samples per pixel a scene may ask for.
pub const MAX_SPP: u64 = 1 << 24;
/// Deepest heightfield subdivision (4097² vertices, ~33 M triangles).
pub const MAX_HEIGHTFIELD_LEVELS: u32 = 12; // 4097² vertices, ~33 M triangles

/// How the scene is read and built for a render.
#[derive(Debug, Clone)]
pub struct BuildOptions {
    /// Override of the Embree robust flag (default: on when the scene has priority solids).
    pub robust: Option<bool>,
    /// Embree build quality of the scene.
    pub quality: BuildQuality,
    /// How glTF and Mitsuba scene files are imported.
    pub import: ImportOptions,
    /// Let the path tracer intersect a scene's few analytic shapes itself
    /// (`shapes::AnalyticSet`) when the scene qualifies: the same hits as
    /// Embree's callbacks, found faster. Off: always through Embree.
    pub analytic_set: bool,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            robust: None,
            quality: BuildQuality::Medium,
            import: ImportOptions::default(),
            analytic_set: true,
        }
    }
}

/// Load and build a scene file: snell TOML, or glTF (`.gltf`, `.glb`) and
/// Mitsuba XML (`.xml`) through their importers (whose warnings end up in
/// the scene's `warnings`).
pub fn load_scene(path: &Path, opts: &BuildOptions) -> Result<RenderScene> {
    let text = SceneText::read(path, &opts.import)?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    build_scene_text(&text, &text.source, &dir, opts)
}

/// Build `src` (the TOML of `text`, possibly after `--set` overrides):
/// errors of an imported scene are placed in the imported file, and its
/// import warnings come first in the scene's warnings.
pub fn build_scene_text(
    text: &SceneText,
    src: &Source,
    dir: &Path,
    opts: &BuildOptions,
) -> Result<RenderScene> {
    let mut scene = load_scene_source(src, dir, opts).map_err(|e| text.relocate(e))?;
    let mut warnings = text.warnings();
    warnings.append(&mut scene.warnings);
    scene.warnings = warnings;
    Ok(scene)
}

/// Build a scene from TOML text; `file` names it in errors and `dir` resolves relative paths.
pub fn load_scene_str(file: &str, text: &str, dir: &Path, opts: &BuildOptions) -> Result<RenderScene> {
    load_scene_source(&Source::new(file, text.to_string()), dir, opts)
}

/// Build a scene from a [`Source`] (the file's text, or the text after `--set` overrides).
pub fn load_scene_source(src: &Source, dir: &Path, opts: &BuildOptions) -> Result<RenderScene> {
    let desc: SceneDesc = toml::from_str(&src.text).map_err(|e| src.toml_error(&e))?;
    Builder {
        src,
        dir: dir.to_path_buf(),
        opts: opts.clone(),
    }
    .build(&desc)
}

struct Builder<'a> {
    src: &'a Source,
    dir: PathBuf,
    opts: BuildOptions,
}

fn v3(a: Vec3) -> DVec3 {
    DVec3::from_array(a)
}

struct Pending {
    name: String,
    /// The scene key that declares `name` (for errors about it).
    name_key: String,
    shape: Shape,
    material: Material,
    emission: Option<Texture>,
    emission_two_sided: bool,
    light: Option<u32>,
    solid: Option<PendingSolid>,
    /// The analytic shape that may take this mesh's place (a rect's
    /// [`Rect`](crate::scene::shapes::Rect)) when the scene is built for
    /// the analytic set (`upload::analytic_rects`).
    analytic_twin: Option<crate::scene::shapes::Analytic>,
}

struct PendingSolid {
    priority: i64,
    ior: f64,
    sigma_a: V3,
    containment: Containment,
    aabb: (DVec3, DVec3),
}

impl Builder<'_> {
    fn err(&self, key: &str, msg: impl Into<String>) -> Error {
        self.src.error(key, msg)
    }

    fn medium_err(&self, e: crate::media::MediumError) -> Error {
        match e {
            crate::media::MediumError::Invalid { key, message } => self.err(&key, message),
        }
    }

    fn finite3(&self, key: &str, v: Vec3) -> Result<DVec3> {
        // Finite, and representable with room to spare in f32 (Embree's precision).
        if v.iter().all(|c| c.is_finite() && c.abs() <= 1e15) {
            Ok(v3(v))
        } else {
            Err(self.err(key, format!("expected finite numbers within ±1e15, got {v:?}")))
        }
    }

    fn unit(&self, key: &str, v: Vec3) -> Result<DVec3> {
        let d = self.finite3(key, v)?;
        if d.length() < 1e-12 {
            return Err(self.err(key, "expected a non-zero direction"));
        }
        Ok(d.normalize())
    }

    fn positive(&self, key: &str, x: f64) -> Result<f64> {
        if x.is_finite() && x > 0.0 && x <= 1e15 {
            Ok(x)
        } else {
            Err(self.err(key, format!("expected a finite number > 0, got {x}")))
        }
    }

    fn color(&self, key: &str, c: Vec3) -> Result<V3> {
        if c.iter().all(|x| x.is_finite() && *x >= 0.0 && *x <= 1e15) {
            Ok((v3(c)).as_vec3a())
        } else {
            Err(self.err(key, format!("expected three finite values >= 0, got {c:?}")))
        }
    }

    fn resolve(&self, file: &str) -> PathBuf {
        let p = Path::new(file);
        if p.is_absolute() {
            p.to_path_buf()
        } else {
            self.dir.join(p)
        }
    }

    /// The whole scene, section by section (each section's keys are
    /// validated where they are read, so errors name the key and its line).
    fn build(&self, d: &SceneDesc) -> Result<RenderScene> {
        let integrator = self.film_and_integrator(d)?;
        let ambient = self.positive("ambient_ior", d.ambient_ior)?;
        let (camera, position) = self.camera(d)?;
        let environment = self.environment(d)?;
        if d.objects.is_empty() && d.lights.is_empty() {
            return Err(self.err("objects", "the scene is empty: no objects and no lights"));
        }
        let mut pending: Vec<Pending> = Vec::new();
        let mut warnings = Vec::new();
        let mut lights = self.lights(d, &mut pending)?;
        let first_object = pending.len();
        for (i, o) in d.objects.iter().enumerate() {
            pending.push(self.object(i, o, &mut warnings)?);
        }
        // Every emitting object is a light too, after the `[[lights]]`
        // (whose indices, and so their images, stay as they were).
        for (g, p) in pending.iter_mut().enumerate().skip(first_object) {
            let key = format!("objects[{}]", g - first_object);
            if let Some(e) = self.emitter(&key, g as u32, p)? {
                p.light = Some(lights.len() as u32);
                lights.push(e);
            }
        }
        let warp = match &d.warp {
            None => None,
            Some(w) => Some(self.warp(w, ambient, &mut pending)?),
        };
        // Names must be unique (the camera's `inside` list refers to them).
        for (i, p) in pending.iter().enumerate() {
            if pending[..i].iter().any(|q| q.name == p.name) {
                return Err(self.err(&p.name_key, format!("duplicate object name \"{}\"", p.name)));
            }
        }
        // The path tracer's packets (a scene without a medium) may take the
        // analytic shapes out of Embree.
        let set_wanted = self.opts.analytic_set && integrator == IntegratorKind::Path && d.medium.is_none();
        // The warp renderer moves mesh vertices: a `[warp]` scene's rects
        // stay meshes.
        if set_wanted && d.warp.is_none() {
            analytic_rects(&mut pending);
        }
        let up = self.upload(pending, set_wanted)?;
        // The medium sees the camera (pixel tolerances) and the geometry as
        // boxes (stretches that can meet nothing need no chords).
        let medium = self.medium(d)?;
        if let (Some(m), Some(_)) = (&medium, camera.orthographic_view()) {
            // Pixel tolerances are a fraction of the angle a pixel subtends
            // from the eye (media/footprint.rs); an orthographic camera has
            // neither, so its medium keeps `tolerance` metres, as without a
            // camera, and a pixel tolerance would be silently ignored.
            if m.pixel_tolerance().is_some() {
                return Err(self.err(
                    "medium.pixel_tolerance",
                    "an orthographic camera has no pixel angle to hold chords to: \
                     use medium.tolerance (metres) with it",
                ));
            }
        }
        let medium = medium.map(|m| {
            let m = match camera.orthographic_view() {
                None => m.with_view(position, camera.pixel_angle() as f64),
                Some(_) => m,
            };
            m.with_obstacles(up.geoms.iter().map(|g| {
                let (lo, hi) = match &g.shape {
                    crate::scene::Shape::Mesh(m) => m.aabb(),
                    crate::scene::Shape::Analytic(a) => a.aabb(),
                };
                crate::media::Aabb::new(lo, hi)
            }))
        });
        let film = &d.film;
        let mut scene = RenderScene {
            #[cfg(test)]
            bsdf_variant: Default::default(),
            warp,
            medium,
            embree: up.embree,
            analytic_set: up.analytic_set,
            geoms: up.geoms,
            solids: up.solids,
            rank_by_geom: up.rank_by_geom,
            solid_by_geom: up.solid_by_geom,
            lights,
            environment,
            camera,
            width: film.width as u32,
            height: film.height as u32,
            spp: film.spp as u32,
            seed: film.seed,
            integrator,
            max_depth: d.integrator.max_depth,
            rr_depth: d.integrator.rr_depth,
            ambient_ior: ambient as f32,
            camera_interior: Vec::new(),
            has_overlap: up.has_overlap,
            masked_solids: up.masked_solids,
            mesh_solids: Vec::new(),
            solid_boxes: Default::default(),
            neighbours: Default::default(),
            lowest_unmasked_rank: u32::MAX,
            warnings,
            containment: up.containment,
        };
        scene.lowest_unmasked_rank = (0..scene.solids.len() as u32)
            .filter(|i| !scene.masked_solids.contains(i))
            .map(|i| scene.solids[i as usize].rank)
            .min()
            .unwrap_or(u32::MAX);
        scene.solid_boxes = crate::scene::model::SolidBoxes::new(scene.solids.iter().map(|s| s.aabb));
        scene.mesh_solids = scene
            .solids
            .iter()
            .enumerate()
            .filter(|(_, s)| matches!(scene.geoms[s.geom as usize].shape, crate::scene::Shape::Mesh(_)))
            .map(|(i, s)| (i as u32, s.aabb))
            .collect();
        scene.camera_interior = self.camera_interior(&d.camera, &scene, position)?;
        Ok(scene)
    }

    /// `[film]` and `[integrator]`: absurd sizes are rejected before any allocation.
    fn film_and_integrator(&self, d: &SceneDesc) -> Result<IntegratorKind> {
        let film = &d.film;
        if film.width == 0 || film.height == 0 {
            return Err(self.err("film.width", "width and height must be at least 1"));
        }
        let pixels = film.width.saturating_mul(film.height);
        if film.width > 1 << 16 || film.height > 1 << 16 || pixels > MAX_PIXELS {
            return Err(self.err(
                "film.width",
                format!(
                    "{}x{} pixels would need about {:.1} GB of film memory (limit {} pixels)",
                    film.width,
                    film.height,
                    pixels as f64 * 12.0 / 1e9,
                    MAX_PIXELS
                ),
            ));
        }
        if film.spp == 0 || film.spp > MAX_SPP {
            return Err(self.err(
                "film.spp",
                format!("expected 1..={MAX_SPP} samples per pixel, got {}", film.spp),
            ));
        }
        if film.filter != "box" {
            return Err(self.err(
                "film.filter",
                format!("expected \"box\", got \"{}\"", film.filter),
            ));
        }
        let integrator = match d.integrator.kind.as_str() {
            "path" => IntegratorKind::Path,
            "whitted" => IntegratorKind::Whitted,
            o => {
                return Err(self.err(
                    "integrator.type",
                    format!("expected \"path\" or \"whitted\", got \"{o}\""),
                ))
            }
        };
        if d.integrator.max_depth == 0 || d.integrator.max_depth > 1024 {
            return Err(self.err("integrator.max_depth", "expected 1..=1024 path segments"));
        }
        if d.integrator.rr_depth == 0 {
            return Err(self.err("integrator.rr_depth", "expected a depth >= 1"));
        }

        Ok(integrator)
    }

    /// `[camera]`: the camera at the film's resolution, and its position.
    fn camera(&self, d: &SceneDesc) -> Result<(Camera, DVec3)> {
        let film = &d.film;
        let c = &d.camera;
        let position = self.finite3("camera.position", c.position)?;
        let target = self.finite3("camera.target", c.target)?;
        let up = self.unit("camera.up", c.up)?;
        let camera = match c.kind.as_str() {
            "perspective" => {
                if c.size.is_some() {
                    return Err(self.err(
                        "camera.size",
                        "a perspective camera's view is its fov (size is for type = \"orthographic\")",
                    ));
                }
                let fov = c.fov.ok_or_else(|| {
                    self.err("camera.fov", "a perspective camera needs fov (its full vertical field of view, degrees)")
                })?;
                if !(fov.is_finite() && fov > 0.0 && fov < 180.0) {
                    return Err(self.err(
                        "camera.fov",
                        format!("expected a vertical field of view in (0, 180) degrees, got {fov}"),
                    ));
                }
                if !(c.aperture_radius.is_finite() && c.aperture_radius >= 0.0) {
                    return Err(self.err("camera.aperture_radius", "expected a finite radius >= 0"));
                }
                let focus = match c.focus_distance {
                    Some(fd) => self.positive("camera.focus_distance", fd)?,
                    None => (target - position).length(),
                };
                Camera::try_new(
                    position.as_vec3a(),
                    target.as_vec3a(),
                    up.as_vec3a(),
                    fov as f32,
                    film.width as u32,
                    film.height as u32,
                    c.aperture_radius as f32,
                    focus as f32,
                )
            }
            "orthographic" => {
                // Keys of the perspective camera would be silently ignored:
                // a scene that sets them means something this camera lacks.
                if c.fov.is_some() {
                    return Err(self.err(
                        "camera.fov",
                        "an orthographic camera has no field of view: its view is size = [width, height] in metres",
                    ));
                }
                if c.aperture_radius != 0.0 {
                    return Err(self.err(
                        "camera.aperture_radius",
                        "an orthographic camera has no lens (thin-lens depth of field is for perspective cameras)",
                    ));
                }
                if c.focus_distance.is_some() {
                    return Err(self.err(
                        "camera.focus_distance",
                        "an orthographic camera has no lens (thin-lens depth of field is for perspective cameras)",
                    ));
                }
                let Some([w, h]) = c.size else {
                    return Err(self.err(
                        "camera.size",
                        "an orthographic camera needs size = [width, height], its view in metres",
                    ));
                };
                // f32 rays: a side below ~1e-6 m or above 1e15 m cannot be
                // resolved into pixels across a film.
                for (v, side) in [(w, "width"), (h, "height")] {
                    if !(v.is_finite() && v > 1e-6 && v <= 1e15) {
                        return Err(self.err(
                            "camera.size",
                            format!("expected the view's {side} in metres within (1e-6, 1e15], got {v}"),
                        ));
                    }
                }
                Camera::try_orthographic(
                    position.as_vec3a(),
                    target.as_vec3a(),
                    up.as_vec3a(),
                    (w as f32, h as f32),
                    film.width as u32,
                    film.height as u32,
                )
            }
            other => {
                return Err(self.err(
                    "camera.type",
                    format!("unknown camera type \"{other}\" (expected perspective or orthographic)"),
                ))
            }
        }
        .map_err(|e| self.err("camera", e.to_string()))?;
        Ok((camera, position))
    }

    /// `[environment]`.
    fn environment(&self, d: &SceneDesc) -> Result<Environment> {
        Ok(match &d.environment {
            None => Environment::Black,
            Some(EnvironmentDesc::Constant(cst)) => {
                Environment::Constant(self.color("environment.radiance", cst.radiance)?)
            }
            Some(EnvironmentDesc::Map(m)) => {
                let path = self.resolve(&m.file);
                let image = load_image(&path)
                    .map_err(|e| self.err("environment.file", format!("{}: {e}", path.display())))?;
                let scale = self.positive("environment.scale", m.scale)?;
                let rows = match m.rows.as_str() {
                    "centres" => Rows::Centres,
                    "poles" => Rows::Poles,
                    other => {
                        return Err(self.err(
                            "environment.rows",
                            format!("expected \"centres\" (the default) or \"poles\", got \"{other}\""),
                        ))
                    }
                };
                let to_local = if m.to_world.is_empty() {
                    None
                } else {
                    Some(self.env_rotation(&m.to_world)?.transpose().as_mat3().into())
                };
                let sampler = crate::scene::envmap::EnvSampler::new(&image, rows).map(Arc::new);
                Environment::Map {
                    sampler,
                    image: Arc::new(image),
                    scale: scale as f32,
                    to_local,
                    rows,
                }
            }
            Some(EnvironmentDesc::Sky(k)) => {
                let dir = self.unit("environment.sun_direction", k.sun_direction)?;
                let diameter = k.sun_diameter;
                if !(diameter.is_finite() && diameter > 0.0 && diameter <= 90.0) {
                    return Err(self.err(
                        "environment.sun_diameter",
                        format!("expected an angular diameter in (0, 90] degrees, got {diameter}"),
                    ));
                }
                let irradiance = self.color("environment.sun_irradiance", k.sun_irradiance)?;
                Environment::Sky(crate::scene::sun::Sky {
                    sun: crate::scene::sun::Sun::new(dir, diameter, irradiance),
                    zenith: self.color("environment.zenith", k.zenith)?,
                    horizon: self.color("environment.horizon", k.horizon)?,
                    ground: self.color("environment.ground", k.ground)?,
                })
            }
        })
    }

    /// `environment.to_world`: its steps' product, which must be a
    /// rotation (a map's directions neither move nor stretch).
    fn env_rotation(&self, steps: &[TransformDesc]) -> Result<DMat3> {
        let key = "environment.to_world";
        let m = self.transform(key, steps)?;
        if m.w_axis.truncate() != DVec3::ZERO {
            return Err(self.err(
                key,
                "expected a rotation: an environment is infinitely far away, a translation cannot move it",
            ));
        }
        let r = DMat3::from_mat4(m);
        let gram = r.transpose() * r - DMat3::IDENTITY;
        let off = gram.to_cols_array().iter().fold(0.0f64, |a, x| a.max(x.abs()));
        let det = r.determinant();
        // Rounding in a hand-written matrix, not a scale or skew.
        if !(off <= 1e-6 && det > 0.0) {
            return Err(self.err(
                key,
                format!(
                    "expected a rotation (orthonormal, no mirror), got a transform that {} (largest entry of RᵀR − I {off:.2e}, determinant {det:.6})",
                    if det <= 0.0 { "mirrors" } else { "scales or skews" }
                ),
            ));
        }
        Ok(r)
    }

    /// `[medium]`: the gradient-index medium, if any.
    fn medium(&self, d: &SceneDesc) -> Result<Option<crate::media::Medium>> {
        Ok(match &d.medium {
            None => None,
            Some(m) => {
                let bounds = crate::media::Aabb::new(
                    self.finite3("medium.bounds.min", m.bounds.min)?,
                    self.finite3("medium.bounds.max", m.bounds.max)?,
                );
                let field = match (&m.field, &m.atmosphere) {
                    (Some(f), None) => f.clone(),
                    (None, Some(a)) => {
                        // The table spans the bounds' heights along `up`.
                        let up = a.up.normalize_or_zero();
                        let hs = bounds.corners().map(|c| c.dot(up) - a.base);
                        let (lo, hi) = hs.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| (l.min(v), h.max(v)));
                        a.to_field("medium.atmosphere", lo, hi).map_err(|e| self.medium_err(e))?
                    }
                    (Some(_), Some(_)) => {
                        return Err(self.err("medium.atmosphere", "expected either `field` or `atmosphere`, not both".to_string()))
                    }
                    (None, None) => {
                        return Err(self.err(
                            "medium",
                            "expected `field = { kind = ... }` or `atmosphere = { heights = [...], celsius = [...] }`".to_string(),
                        ))
                    }
                };
                let method: crate::media::Method = if m.method == "auto" {
                    crate::media::Method::auto_for(&field)
                } else {
                    m.method
                        .parse()
                        .map_err(|e: crate::media::MediumError| self.medium_err(e))?
                };
                if m.tolerance.is_finite() && m.tolerance < 1e-9 {
                    return Err(self.err(
                        "medium.tolerance",
                        format!(
                            "a chord tolerance of {} m would need ~{:.0e} chords per metre; expected >= 1e-9",
                            m.tolerance,
                            (1.0 / m.tolerance).sqrt()
                        ),
                    ));
                }
                Some(
                    crate::media::Medium::try_new(field, bounds, method, m.tolerance, m.step)
                        .and_then(|x| x.with_pixel_tolerance(m.pixel_tolerance))
                        .and_then(|x| x.with_indirect_tolerance_scale(m.indirect_tolerance_scale))
                        .map_err(|e| self.medium_err(e))?,
                )
            }
        })
    }

    /// The solids containing the camera: `camera.inside` by name, or found
    /// by point-in-solid tests.
    fn camera_interior(&self, c: &CameraDesc, scene: &RenderScene, position: DVec3) -> Result<Vec<u32>> {
        Ok(match &c.inside {
            Some(names) => {
                let mut v = Vec::new();
                for (k, n) in names.iter().enumerate() {
                    let si = scene.solids.iter().position(|s| &s.name == n).ok_or_else(|| {
                        self.err(
                            &format!("camera.inside[{k}]"),
                            format!("no dielectric solid named \"{n}\""),
                        )
                    })?;
                    v.push(si as u32);
                }
                v
            }
            None => {
                let list = scene.solids_containing(position);
                if scene.camera.orthographic_view().is_some() {
                    self.view_in_one_interior(scene, &list)?;
                }
                list
            }
        })
    }

    /// An orthographic camera's rays start all over its view rectangle, but
    /// every camera ray begins with the one interior list found at
    /// `camera.position`: a rectangle that crosses a solid's surface would
    /// start some rays with the wrong list (wrong indices at their first
    /// hit). So the rectangle's points on a 33 × 33 grid (its edges
    /// included) must all be inside the same solids as its centre. A grid
    /// can miss a solid thinner than its spacing poking through; such a
    /// scene needs `camera.inside`, which is taken as given.
    fn view_in_one_interior(&self, scene: &RenderScene, list: &[u32]) -> Result<()> {
        const N: u32 = 32;
        let (w, h) = scene.camera.size();
        for j in 0..=N {
            for i in 0..=N {
                let (x, y) = (i as f32 * w as f32 / N as f32, j as f32 * h as f32 / N as f32);
                let o = scene.camera.ray(x, y, (0.0, 0.0)).0.as_dvec3();
                let here = scene.solids_containing(o);
                if here != list {
                    let odd = here
                        .iter()
                        .chain(list)
                        .find(|&&s| here.contains(&s) != list.contains(&s))
                        .map_or("?", |&s| scene.solids[s as usize].name.as_str());
                    return Err(self.err(
                        "camera.size",
                        format!(
                            "the orthographic view rectangle crosses the surface of solid \"{odd}\" \
                             (at {o:?}): every camera ray starts with the interior list at camera.position, \
                             so the rectangle must lie wholly inside or outside each solid \
                             (move or shrink it, or give camera.inside)"
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}
