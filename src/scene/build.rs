//! From a parsed description to a render scene: validation (every error names
//! the file, the key path and the line:column), transforms, meshes, Embree.
use super::desc::*;
use super::meshgen;
use super::shapes::{Analytic, Mesh};
use super::source::Source;
use super::texture::{load_image, ImageData, Texture};
use crate::camera::Camera;
use crate::embree::{BuildQuality, Device, SceneBuilder, SceneFlags};
use crate::error::{Error, Result};
use glam::{DMat3, DMat4, DVec3, Vec3A as V3};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Hard limits checked before any allocation (estimated memory in the message).
pub const MAX_PIXELS: u64 = 1 << 27; // 134 M pixels, ~1.6 GB of f32 RGB
pub const MAX_SPP: u64 = 1 << 24;
pub const MAX_HEIGHTFIELD_LEVELS: u32 = 12; // 4097² vertices, ~33 M triangles

/// How the scene is built for a render.
#[derive(Debug, Clone, Copy)]
pub struct BuildOptions {
    /// Override of the Embree robust flag (default: on when the scene has priority solids).
    pub robust: Option<bool>,
    pub quality: BuildQuality,
}

impl Default for BuildOptions {
    fn default() -> Self {
        BuildOptions {
            robust: None,
            quality: BuildQuality::Medium,
        }
    }
}

/// Surface response.
#[derive(Debug, Clone)]
pub enum Material {
    Diffuse {
        reflectance: Texture,
        two_sided: bool,
    },
    Mirror {
        reflectance: V3,
    },
    /// A closed solid of the priority scheme (index into `RenderScene::solids`).
    Solid(u32),
    /// An interface: `int_ior` on the side opposite the normal, `ext_ior` on the normal side.
    Interface {
        int_ior: f32,
        ext_ior: f32,
    },
    /// Absorbs everything (lights' bodies).
    Black,
}

/// Geometry shape as the integrator sees it.
#[derive(Debug, Clone)]
pub enum Shape {
    Mesh(Arc<Mesh>),
    Analytic(Analytic),
}

/// One Embree geometry (indexed by geomID).
#[derive(Debug, Clone)]
pub struct GeomRecord {
    pub name: String,
    pub shape: Shape,
    pub material: Material,
    pub emission: Option<Texture>,
    /// Index into `RenderScene::lights` when this surface is also an NEE light.
    pub light: Option<u32>,
}

impl GeomRecord {
    /// Does shading read texture coordinates here? (Analytic shapes' uv costs
    /// atan2/acos: 5% of a three_spheres render before it was made lazy.)
    pub fn needs_uv(&self) -> bool {
        let m = matches!(&self.material, Material::Diffuse { reflectance, .. } if reflectance.needs_uv());
        m || self.emission.as_ref().is_some_and(Texture::needs_uv)
    }
}

/// A priority solid (Schmidt & Budge).
#[derive(Debug, Clone)]
pub struct Solid {
    pub name: String,
    pub geom: u32,
    pub priority: i64,
    /// Dense total order: priority first, then declaration order (the later
    /// declared object wins a tie, as if its priority were higher by an infinitesimal).
    pub rank: u32,
    pub ior: f32,
    /// Beer–Lambert absorption coefficient per metre, per channel.
    pub sigma_a: V3,
    pub aabb: (DVec3, DVec3),
}

/// Light sources for next-event estimation.
#[derive(Debug, Clone)]
pub enum Light {
    Point {
        position: V3,
        intensity: V3,
    },
    Directional {
        /// Unit direction the light travels in.
        direction: V3,
        irradiance: V3,
    },
    Rect {
        corner: V3,
        edge_u: V3,
        edge_v: V3,
        normal: V3,
        area: f32,
        radiance: V3,
    },
    Sphere {
        center: V3,
        radius: f32,
        radiance: V3,
    },
}

#[derive(Debug, Clone)]
pub enum Environment {
    Black,
    Constant(V3),
    Map { image: Arc<ImageData>, scale: f32 },
}

impl Environment {
    /// Radiance arriving along −`dir` (seen looking along `dir`).
    #[inline]
    pub fn eval(&self, dir: V3) -> V3 {
        match self {
            Environment::Black => V3::ZERO,
            Environment::Constant(c) => *c,
            Environment::Map { image, scale } => {
                let u = 0.5 + dir.x.atan2(-dir.z) / std::f32::consts::TAU;
                let v = dir.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
                image.lookup(u, v) * *scale
            }
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IntegratorKind {
    Path,
    Whitted,
}

/// Everything a render needs.
pub struct RenderScene {
    pub embree: crate::embree::Scene,
    pub geoms: Vec<GeomRecord>,
    pub solids: Vec<Solid>,
    /// Rank per geomID: the solid's rank, or `u32::MAX` for non-solids (never false).
    pub rank_by_geom: Vec<u32>,
    /// Solid index per geomID.
    pub solid_by_geom: Vec<Option<u32>>,
    pub lights: Vec<Light>,
    pub environment: Environment,
    /// The camera at the film resolution the scene file declares (a render
    /// at another resolution uses `Camera::with_resolution`).
    pub camera: Camera,
    /// Film width the scene file declares (pixels); renders take theirs
    /// from `render::RenderSettings`, which starts from these four.
    pub width: u32,
    /// Film height the scene file declares (pixels).
    pub height: u32,
    /// Samples per pixel the scene file declares.
    pub spp: u32,
    /// Seed the scene file declares.
    pub seed: u64,
    pub integrator: IntegratorKind,
    pub max_depth: u32,
    pub rr_depth: u32,
    pub ambient_ior: f32,
    /// Solids that contain the camera (found by point-in-solid tests or given).
    pub camera_interior: Vec<u32>,
    /// True when some solids may overlap (bounds intersect): only then can a
    /// false hit happen and only then is a filter installed.
    pub has_overlap: bool,
    /// The gradient-index medium, if any: rays inside its bounds are cast as chords.
    pub medium: Option<crate::media::Medium>,
    /// The analytic warp glass (`[warp]`), if any; its geometry is also in
    /// `geoms` (as `glass_geoms`) so that `snell render` traces it exactly.
    pub warp: Option<crate::warp::WarpSpec>,
    /// Warnings produced while loading (e.g. flipped meshes).
    pub warnings: Vec<String>,
    pub(crate) containment: Vec<Containment>,
}

/// Point-in-solid classification of each solid (independent of Embree).
#[derive(Debug, Clone)]
pub(crate) enum Containment {
    Mesh(Arc<crate::scene::shapes::ContainsGrid>),
    Analytic(Analytic),
}

impl RenderScene {
    /// Is `p` inside solid `s` (point-in-solid, independent of Embree)?
    pub fn solid_contains(&self, s: u32, p: DVec3) -> bool {
        match &self.containment[s as usize] {
            Containment::Mesh(m) => m.contains(p),
            Containment::Analytic(a) => a.contains(p).unwrap_or(false),
        }
    }

    /// Solids containing `p` (independent point-in-solid tests).
    pub fn solids_containing(&self, p: DVec3) -> Vec<u32> {
        self.containment
            .iter()
            .enumerate()
            .filter(|(_, c)| match c {
                Containment::Mesh(m) => m.contains(p),
                Containment::Analytic(a) => a.contains(p).unwrap_or(false),
            })
            .map(|(i, _)| i as u32)
            .collect()
    }
}

/// Load and build a scene file.
pub fn load_scene(path: &Path, opts: &BuildOptions) -> Result<RenderScene> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    load_scene_str(&path.display().to_string(), &text, &dir, opts)
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
        opts: *opts,
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
fn f(a: DVec3) -> V3 {
    V3::new(a.x as f32, a.y as f32, a.z as f32)
}

struct Pending {
    name: String,
    /// The scene key that declares `name` (for errors about it).
    name_key: String,
    shape: Shape,
    material: Material,
    emission: Option<Texture>,
    light: Option<u32>,
    solid: Option<PendingSolid>,
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
            Ok(f(v3(c)))
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

    fn texture(&self, key: &str, t: &TextureDesc) -> Result<Texture> {
        Ok(match t {
            TextureDesc::Constant(c) => Texture::Constant(self.color(key, *c)?),
            TextureDesc::Table(TextureTable::Checker(c)) => {
                let axis = |k: usize| -> Result<usize> {
                    match c.axes[k].as_str() {
                        "x" => Ok(0),
                        "y" => Ok(1),
                        "z" => Ok(2),
                        other => Err(self.err(
                            &format!("{key}.axes[{k}]"),
                            format!("expected \"x\", \"y\" or \"z\", got \"{other}\""),
                        )),
                    }
                };
                let axes = [axis(0)?, axis(1)?];
                if axes[0] == axes[1] {
                    return Err(self.err(&format!("{key}.axes"), "the two checker axes must differ"));
                }
                let size = self.positive(&format!("{key}.size"), c.size)?;
                if size < 1e-9 {
                    return Err(self.err(
                        &format!("{key}.size"),
                        format!("expected a square size >= 1e-9 m, got {size:e}"),
                    ));
                }
                Texture::Checker {
                    axes,
                    inv_size: (1.0 / size) as f32,
                    c0: self.color(&format!("{key}.color0"), c.color0)?,
                    c1: self.color(&format!("{key}.color1"), c.color1)?,
                }
            }
            TextureDesc::Table(TextureTable::Image(im)) => {
                let path = self.resolve(&im.file);
                let image = load_image(&path)
                    .map_err(|e| self.err(&format!("{key}.file"), format!("{}: {e}", path.display())))?;
                let s0 = self.positive(&format!("{key}.uv_scale[0]"), im.uv_scale[0])?;
                let s1 = self.positive(&format!("{key}.uv_scale[1]"), im.uv_scale[1])?;
                Texture::Image {
                    image: Arc::new(image),
                    scale: [s0 as f32, s1 as f32],
                }
            }
        })
    }

    fn transform(&self, key: &str, list: &[TransformDesc]) -> Result<DMat4> {
        let mut m = DMat4::IDENTITY;
        for (i, t) in list.iter().enumerate() {
            let k = format!("{key}[{i}]");
            let mut step = DMat4::IDENTITY;
            let mut count = 0;
            if let Some(s) = &t.scale {
                count += 1;
                let s = match s {
                    ScaleDesc::Uniform(u) => DVec3::splat(*u),
                    ScaleDesc::PerAxis(a) => v3(*a),
                };
                if !s.is_finite() || s.min_element() <= 0.0 {
                    return Err(self.err(&format!("{k}.scale"), "expected finite scale factors > 0"));
                }
                step = DMat4::from_scale(s);
            }
            if let Some(r) = &t.rotate {
                count += 1;
                let axis = self.unit(&format!("{k}.rotate.axis"), r.axis)?;
                if !r.degrees.is_finite() {
                    return Err(self.err(&format!("{k}.rotate.degrees"), "expected a finite angle"));
                }
                step = DMat4::from_axis_angle(axis, r.degrees.to_radians());
            }
            if let Some(tr) = t.translate {
                count += 1;
                step = DMat4::from_translation(self.finite3(&format!("{k}.translate"), tr)?);
            }
            if count != 1 {
                return Err(self.err(
                    &k,
                    "each transform step needs exactly one of translate, rotate, scale",
                ));
            }
            m = step * m;
        }
        Ok(m)
    }

    /// Validate `[warp]` and add its glass as dielectric geometry (interfaces
    /// glass | ambient) for the full trace.
    fn warp(&self, w: &WarpDesc, ambient: f64, pending: &mut Vec<Pending>) -> Result<crate::warp::WarpSpec> {
        use crate::warp::{HollowCylinder, Plate, WarpGlass, WarpMethod, WarpSpec};
        if ambient != 1.0 {
            return Err(self.err(
                "ambient_ior",
                format!("a [warp] scene needs ambient_ior = 1.0 (the warp math assumes air of index 1), got {ambient}"),
            ));
        }
        let method = match w.method.as_str() {
            "exact" => WarpMethod::Exact,
            "paper" => WarpMethod::Paper,
            o => {
                return Err(self.err(
                    "warp.method",
                    format!("expected \"exact\" or \"paper\", got \"{o}\""),
                ))
            }
        };
        if !(w.subdivide.is_finite() && w.subdivide >= 0.05) {
            return Err(self.err(
                "warp.subdivide",
                format!(
                    "expected a projected edge length >= 0.05 pixels, got {}",
                    w.subdivide
                ),
            ));
        }
        let extent = self.positive("warp.extent", w.extent)?;
        let first = pending.len() as u32;
        let glass = match &w.glass {
            WarpGlassDesc::Plate {
                near_face_point,
                normal,
                thickness,
                ior,
            } => {
                let q = self.finite3("warp.glass.near_face_point", *near_face_point)?;
                let nrm = self.unit("warp.glass.normal", *normal)?;
                let wt = self.positive("warp.glass.thickness", *thickness)?;
                let plate = Plate::try_new(q, nrm, wt, *ior).map_err(|e| self.err("warp.glass", e))?;
                // A box: `extent` square across, `thickness` deep, outward winding.
                let (u, v) = {
                    let helper = if nrm.x.abs() < 0.9 { DVec3::X } else { DVec3::Y };
                    let u = nrm.cross(helper).normalize();
                    (u, nrm.cross(u))
                };
                let h = extent * 0.5;
                let mut positions = Vec::with_capacity(8);
                for k in 0..8 {
                    let p = q
                        + u * if k & 1 == 0 { -h } else { h }
                        + v * if k & 2 == 0 { -h } else { h }
                        + nrm * if k & 4 == 0 { 0.0 } else { wt };
                    positions.push([p.x as f32, p.y as f32, p.z as f32]);
                }
                let quads = [
                    [0, 2, 3, 1],
                    [4, 5, 7, 6],
                    [0, 1, 5, 4],
                    [2, 6, 7, 3],
                    [0, 4, 6, 2],
                    [1, 3, 7, 5],
                ];
                let mut indices = Vec::new();
                for qd in quads {
                    indices.push([qd[0], qd[1], qd[2]]);
                    indices.push([qd[0], qd[2], qd[3]]);
                }
                let mut mesh = Mesh {
                    positions,
                    indices,
                    normals: None,
                    uvs: None,
                };
                if mesh.signed_volume() < 0.0 {
                    mesh.flip();
                }
                pending.push(Pending {
                    name: "warp_glass_plate".into(),
                    name_key: "warp.glass".into(),
                    shape: Shape::Mesh(Arc::new(mesh)),
                    material: Material::Interface {
                        int_ior: *ior as f32,
                        ext_ior: 1.0,
                    },
                    emission: None,
                    light: None,
                    solid: None,
                });
                WarpGlass::Plate(plate)
            }
            WarpGlassDesc::HollowCylinder {
                axis_point,
                axis_direction,
                outer_radius,
                inner_radius,
                ior,
            } => {
                let c = self.finite3("warp.glass.axis_point", *axis_point)?;
                let a = self.unit("warp.glass.axis_direction", *axis_direction)?;
                let tube = HollowCylinder::try_new(c, a, *outer_radius, *inner_radius, *ior)
                    .map_err(|e| self.err("warp.glass", e))?;
                for (name, radius, inward) in [
                    ("warp_glass_outer", *outer_radius, false),
                    ("warp_glass_inner", *inner_radius, true),
                ] {
                    pending.push(Pending {
                        name: name.into(),
                        name_key: "warp.glass".into(),
                        shape: Shape::Analytic(Analytic::Cylinder {
                            p0: c - a * (extent * 0.5),
                            axis: a,
                            height: extent,
                            radius,
                            inward,
                            caps: false,
                        }),
                        material: Material::Interface {
                            int_ior: *ior as f32,
                            ext_ior: 1.0,
                        },
                        emission: None,
                        light: None,
                        solid: None,
                    });
                }
                WarpGlass::Cylinder(tube)
            }
        };
        Ok(WarpSpec {
            glass,
            glass_geoms: (first..pending.len() as u32).collect(),
            subdivide: w.subdivide,
            fresnel: w.fresnel,
            method,
        })
    }

    fn build(&self, d: &SceneDesc) -> Result<RenderScene> {
        // Film and integrator: absurd sizes are rejected before any allocation.
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
        let ambient = self.positive("ambient_ior", d.ambient_ior)?;

        let c = &d.camera;
        let position = self.finite3("camera.position", c.position)?;
        let target = self.finite3("camera.target", c.target)?;
        let up = self.unit("camera.up", c.up)?;
        if !(c.fov.is_finite() && c.fov > 0.0 && c.fov < 180.0) {
            return Err(self.err(
                "camera.fov",
                format!(
                    "expected a vertical field of view in (0, 180) degrees, got {}",
                    c.fov
                ),
            ));
        }
        if !(c.aperture_radius.is_finite() && c.aperture_radius >= 0.0) {
            return Err(self.err("camera.aperture_radius", "expected a finite radius >= 0"));
        }
        let focus = match c.focus_distance {
            Some(fd) => self.positive("camera.focus_distance", fd)?,
            None => (target - position).length(),
        };
        let camera = Camera::try_new(
            f(position),
            f(target),
            f(up),
            c.fov as f32,
            film.width as u32,
            film.height as u32,
            c.aperture_radius as f32,
            focus as f32,
        )
        .map_err(|e| self.err("camera", e.to_string()))?;

        let environment = match &d.environment {
            None => Environment::Black,
            Some(EnvironmentDesc::Constant(cst)) => {
                Environment::Constant(self.color("environment.radiance", cst.radiance)?)
            }
            Some(EnvironmentDesc::Map(m)) => {
                let path = self.resolve(&m.file);
                let image = load_image(&path)
                    .map_err(|e| self.err("environment.file", format!("{}: {e}", path.display())))?;
                let scale = self.positive("environment.scale", m.scale)?;
                Environment::Map {
                    image: Arc::new(image),
                    scale: scale as f32,
                }
            }
        };

        if d.objects.is_empty() && d.lights.is_empty() {
            return Err(self.err("objects", "the scene is empty: no objects and no lights"));
        }

        let mut pending: Vec<Pending> = Vec::new();
        let mut lights = Vec::new();
        let mut warnings = Vec::new();

        for (i, l) in d.lights.iter().enumerate() {
            let k = format!("lights[{i}]");
            match l {
                LightDesc::Point(p) => lights.push(Light::Point {
                    position: f(self.finite3(&format!("{k}.position"), p.position)?),
                    intensity: self.color(&format!("{k}.intensity"), p.intensity)?,
                }),
                LightDesc::Directional(p) => lights.push(Light::Directional {
                    direction: f(self.unit(&format!("{k}.direction"), p.direction)?),
                    irradiance: self.color(&format!("{k}.irradiance"), p.irradiance)?,
                }),
                LightDesc::Rect(r) => {
                    let center = self.finite3(&format!("{k}.center"), r.center)?;
                    let normal = self.unit(&format!("{k}.normal"), r.normal)?;
                    let u = self.unit(&format!("{k}.u_axis"), r.u_axis)?;
                    if normal.dot(u).abs() > 1e-6 {
                        return Err(self.err(
                            &format!("{k}.u_axis"),
                            "u_axis must be perpendicular to the normal",
                        ));
                    }
                    let su = self.positive(&format!("{k}.size[0]"), r.size[0])?;
                    let sv = self.positive(&format!("{k}.size[1]"), r.size[1])?;
                    let radiance = self.color(&format!("{k}.radiance"), r.radiance)?;
                    let v = normal.cross(u);
                    let li = lights.len() as u32;
                    lights.push(Light::Rect {
                        corner: f(center - u * su * 0.5 - v * sv * 0.5),
                        edge_u: f(u * su),
                        edge_v: f(v * sv),
                        normal: f(normal),
                        area: (su * sv) as f32,
                        radiance,
                    });
                    pending.push(Pending {
                        name: r.name.clone().unwrap_or_else(|| k.clone()),
                        name_key: format!("{k}.name"),
                        shape: Shape::Mesh(Arc::new(meshgen::rect(center, normal, u, [su, sv]))),
                        material: Material::Black,
                        emission: Some(Texture::Constant(radiance)),
                        light: Some(li),
                        solid: None,
                    });
                }
                LightDesc::Sphere(s) => {
                    let center = self.finite3(&format!("{k}.center"), s.center)?;
                    let radius = self.positive(&format!("{k}.radius"), s.radius)?;
                    let radiance = self.color(&format!("{k}.radiance"), s.radiance)?;
                    let li = lights.len() as u32;
                    lights.push(Light::Sphere {
                        center: f(center),
                        radius: radius as f32,
                        radiance,
                    });
                    pending.push(Pending {
                        name: s.name.clone().unwrap_or_else(|| k.clone()),
                        name_key: format!("{k}.name"),
                        shape: Shape::Analytic(Analytic::Sphere { center, radius }),
                        material: Material::Black,
                        emission: Some(Texture::Constant(radiance)),
                        light: Some(li),
                        solid: None,
                    });
                }
            }
        }

        for (i, o) in d.objects.iter().enumerate() {
            pending.push(self.object(i, o, &mut warnings)?);
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

        // Solids: ranks by (priority, declaration order).
        let mut order: Vec<usize> = (0..pending.len())
            .filter(|&i| pending[i].solid.is_some())
            .collect();
        order.sort_by_key(|&i| (pending[i].solid.as_ref().map(|s| s.priority).unwrap_or(0), i));
        let mut rank_of = vec![u32::MAX; pending.len()];
        for (r, &i) in order.iter().enumerate() {
            rank_of[i] = r as u32;
        }
        let has_solids = !order.is_empty();
        let mut has_overlap = false;
        for (a, &i) in order.iter().enumerate() {
            for &j in &order[a + 1..] {
                let (pa, pb) = (
                    &pending[i].solid.as_ref().unwrap().aabb,
                    &pending[j].solid.as_ref().unwrap().aabb,
                );
                if pa.0.cmple(pb.1).all() && pb.0.cmple(pa.1).all() {
                    has_overlap = true;
                }
            }
        }

        // The context-filter flag costs nothing for queries without a filter
        // (callgrind: identical instruction counts for the re-cast), so it is
        // set whenever a filter could be needed, whatever strategy renders.
        let flags = SceneFlags {
            context_filter: has_overlap,
            robust: self.opts.robust.unwrap_or(has_solids),
        };
        let device = Device::new("")?;
        let mut eb = SceneBuilder::new(&device, flags, self.opts.quality)?;
        let mut geoms = Vec::with_capacity(pending.len());
        let mut solids = Vec::new();
        let mut containment = Vec::new();
        let mut rank_by_geom = Vec::new();
        let mut solid_by_geom = Vec::new();
        for (i, p) in pending.into_iter().enumerate() {
            let id = match &p.shape {
                Shape::Mesh(m) => eb.add_triangles(&m.positions, &m.indices)?,
                Shape::Analytic(a) => eb.add_user(Box::new(*a))?,
            };
            debug_assert_eq!(id as usize, geoms.len());
            let mut material = p.material;
            let mut solid_idx = None;
            if let Some(s) = p.solid {
                let si = solids.len() as u32;
                solids.push(Solid {
                    name: p.name.clone(),
                    geom: id,
                    priority: s.priority,
                    rank: rank_of[i],
                    ior: s.ior as f32,
                    sigma_a: s.sigma_a,
                    aabb: s.aabb,
                });
                containment.push(s.containment);
                material = Material::Solid(si);
                solid_idx = Some(si);
            }
            rank_by_geom.push(rank_of[i]);
            solid_by_geom.push(solid_idx);
            geoms.push(GeomRecord {
                name: p.name,
                shape: p.shape,
                material,
                emission: p.emission,
                light: p.light,
            });
        }
        let embree = eb.commit()?;

        let medium = match &d.medium {
            None => None,
            Some(m) => {
                let method: crate::media::Method = m
                    .method
                    .parse()
                    .map_err(|e: crate::media::MediumError| self.medium_err(e))?;
                let bounds = crate::media::Aabb::new(
                    self.finite3("medium.bounds.min", m.bounds.min)?,
                    self.finite3("medium.bounds.max", m.bounds.max)?,
                );
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
                    crate::media::Medium::try_new(m.field.clone(), bounds, method, m.tolerance, m.step)
                        .map_err(|e| self.medium_err(e))?,
                )
            }
        };
        let mut scene = RenderScene {
            warp,
            medium,
            embree,
            geoms,
            solids,
            rank_by_geom,
            solid_by_geom,
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
            has_overlap,
            warnings,
            containment,
        };
        scene.camera_interior = match &c.inside {
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
            None => scene.solids_containing(position),
        };
        Ok(scene)
    }

    fn object(&self, i: usize, o: &ObjectDesc, warnings: &mut Vec<String>) -> Result<Pending> {
        let k = format!("objects[{i}]");
        let name = o.name.clone().unwrap_or_else(|| k.clone());
        let xf = self.transform(&format!("{k}.transform"), &o.transform)?;
        let sk = format!("{k}.shape");
        // Similarity check for analytic shapes: a uniform scale times a rotation.
        let lin = DMat3::from_mat4(xf);
        let scale = lin.x_axis.length();
        let is_similarity = (lin.y_axis.length() - scale).abs() < 1e-9 * scale
            && (lin.z_axis.length() - scale).abs() < 1e-9 * scale
            && lin.x_axis.dot(lin.y_axis).abs() < 1e-9 * scale * scale
            && lin.x_axis.dot(lin.z_axis).abs() < 1e-9 * scale * scale
            && lin.y_axis.dot(lin.z_axis).abs() < 1e-9 * scale * scale;
        let analytic = |a: Analytic| -> Result<Shape> {
            if !is_similarity {
                return Err(self.err(
                    &format!("{k}.transform"),
                    "analytic shapes take only translations, rotations and uniform scales; use a mesh for other transforms",
                ));
            }
            Ok(Shape::Analytic(a))
        };
        let pt = |p: DVec3| xf.transform_point3(p);
        let dir = |d: DVec3| lin.mul_vec3(d).normalize();
        let mut closed_mesh = false;
        let mut shape = match &o.shape {
            ShapeDesc::Sphere(s) => analytic(Analytic::Sphere {
                center: pt(self.finite3(&format!("{sk}.center"), s.center)?),
                radius: self.positive(&format!("{sk}.radius"), s.radius)? * scale,
            })?,
            ShapeDesc::Rect(r) => {
                let c = self.finite3(&format!("{sk}.center"), r.center)?;
                let n = self.unit(&format!("{sk}.normal"), r.normal)?;
                let u = self.unit(&format!("{sk}.u_axis"), r.u_axis)?;
                if n.dot(u).abs() > 1e-6 {
                    return Err(self.err(
                        &format!("{sk}.u_axis"),
                        "u_axis must be perpendicular to the normal",
                    ));
                }
                let su = self.positive(&format!("{sk}.size[0]"), r.size[0])?;
                let sv = self.positive(&format!("{sk}.size[1]"), r.size[1])?;
                Shape::Mesh(Arc::new(self.xf_mesh(meshgen::rect(c, n, u, [su, sv]), &xf)))
            }
            ShapeDesc::Disk(dk) => {
                let r = self.positive(&format!("{sk}.radius"), dk.radius)?;
                if !(dk.inner_radius.is_finite() && dk.inner_radius >= 0.0 && dk.inner_radius < r) {
                    return Err(self.err(
                        &format!("{sk}.inner_radius"),
                        "expected 0 <= inner_radius < radius",
                    ));
                }
                analytic(Analytic::Disk {
                    center: pt(self.finite3(&format!("{sk}.center"), dk.center)?),
                    normal: dir(self.unit(&format!("{sk}.normal"), dk.normal)?),
                    radius: r * scale,
                    inner: dk.inner_radius * scale,
                })?
            }
            ShapeDesc::Box(b) => {
                let c = self.finite3(&format!("{sk}.center"), b.center)?;
                let s = self.finite3(&format!("{sk}.size"), b.size)?;
                if s.min_element() <= 0.0 {
                    return Err(self.err(&format!("{sk}.size"), "expected three sizes > 0"));
                }
                closed_mesh = true;
                Shape::Mesh(Arc::new(self.xf_mesh(meshgen::cuboid(c, s), &xf)))
            }
            ShapeDesc::Cylinder(cy) => {
                let p0 = self.finite3(&format!("{sk}.p0"), cy.p0)?;
                let p1 = self.finite3(&format!("{sk}.p1"), cy.p1)?;
                let r = self.positive(&format!("{sk}.radius"), cy.radius)?;
                let inward = match cy.normal.as_str() {
                    "out" => false,
                    "in" => true,
                    o => {
                        return Err(self.err(
                            &format!("{sk}.normal"),
                            format!("expected \"out\" or \"in\", got \"{o}\""),
                        ))
                    }
                };
                if cy.caps && inward {
                    return Err(self.err(
                        &format!("{sk}.caps"),
                        "a capped (solid) cylinder needs normal = \"out\"",
                    ));
                }
                let (a, b) = (pt(p0), pt(p1));
                let h = (b - a).length();
                if h <= 0.0 {
                    return Err(self.err(&format!("{sk}.p1"), "p0 and p1 must differ"));
                }
                analytic(Analytic::Cylinder {
                    p0: a,
                    axis: (b - a) / h,
                    height: h,
                    radius: r * scale,
                    inward,
                    caps: cy.caps,
                })?
            }
            ShapeDesc::Tube(t) => {
                let p0 = self.finite3(&format!("{sk}.p0"), t.p0)?;
                let p1 = self.finite3(&format!("{sk}.p1"), t.p1)?;
                let ro = self.positive(&format!("{sk}.outer_radius"), t.outer_radius)?;
                let ri = self.positive(&format!("{sk}.inner_radius"), t.inner_radius)?;
                if ri >= ro {
                    return Err(self.err(
                        &format!("{sk}.inner_radius"),
                        "expected inner_radius < outer_radius",
                    ));
                }
                let (a, b) = (pt(p0), pt(p1));
                let h = (b - a).length();
                if h <= 0.0 {
                    return Err(self.err(&format!("{sk}.p1"), "p0 and p1 must differ"));
                }
                analytic(Analytic::Tube {
                    p0: a,
                    axis: (b - a) / h,
                    height: h,
                    outer: ro * scale,
                    inner: ri * scale,
                })?
            }
            ShapeDesc::Lathe(l) => {
                if l.profile.len() < 2 {
                    return Err(self.err(
                        &format!("{sk}.profile"),
                        "expected at least two (radius, height) points",
                    ));
                }
                for (j, p) in l.profile.iter().enumerate() {
                    if !(p[0].is_finite() && p[1].is_finite() && p[0] >= 0.0) {
                        return Err(self.err(
                            &format!("{sk}.profile[{j}]"),
                            "expected (radius >= 0, height), finite",
                        ));
                    }
                }
                if !(3..=1 << 16).contains(&l.segments) {
                    return Err(self.err(&format!("{sk}.segments"), "expected 3..=65536 segments"));
                }
                let first = l.profile[0];
                let last = l.profile[l.profile.len() - 1];
                closed_mesh = first[0] == 0.0 && last[0] == 0.0;
                if !(0.0..=180.0).contains(&l.crease_angle) {
                    return Err(self.err(&format!("{sk}.crease_angle"), "expected degrees in 0..=180"));
                }
                let shading = if l.smooth {
                    meshgen::LatheShading::Smooth {
                        crease_deg: l.crease_angle,
                    }
                } else {
                    meshgen::LatheShading::Flat
                };
                Shape::Mesh(Arc::new(
                    self.xf_mesh(meshgen::lathe(&l.profile, l.segments, shading), &xf),
                ))
            }
            ShapeDesc::Mesh(m) => {
                let path = self.resolve(&m.file);
                let mesh = meshgen::load_obj(&path, m.smooth)
                    .map_err(|e| self.err(&format!("{sk}.file"), format!("{}: {e}", path.display())))?;
                closed_mesh = true; // only checked (and required) when used as a solid
                Shape::Mesh(Arc::new(self.xf_mesh(mesh, &xf)))
            }
            ShapeDesc::Heightfield(h) => {
                if h.levels == 0 || h.levels > MAX_HEIGHTFIELD_LEVELS {
                    // In f64: 2^levels overflows any integer for absurd levels.
                    let n = 2f64.powi(h.levels.min(2000) as i32) + 1.0;
                    return Err(self.err(
                        &format!("{sk}.levels"),
                        format!(
                            "expected 1..={MAX_HEIGHTFIELD_LEVELS} levels; {} levels would be {:.2e} triangles (~{:.1e} bytes)",
                            h.levels,
                            2.0 * (n - 1.0) * (n - 1.0),
                            n * n * 48.0
                        ),
                    ));
                }
                let sx = self.positive(&format!("{sk}.size[0]"), h.size[0])?;
                let sz = self.positive(&format!("{sk}.size[1]"), h.size[1])?;
                if !(h.height.is_finite() && h.height >= 0.0) {
                    return Err(self.err(&format!("{sk}.height"), "expected a finite height >= 0"));
                }
                if !(h.roughness > 0.0 && h.roughness < 1.0) {
                    return Err(self.err(&format!("{sk}.roughness"), "expected 0 < roughness < 1"));
                }
                Shape::Mesh(Arc::new(self.xf_mesh(
                    meshgen::heightfield([sx, sz], h.levels, h.height, h.roughness, h.seed),
                    &xf,
                )))
            }
        };
        // Embree works in f32: everything must stay finite (and sane) there.
        let (lo, hi) = match &shape {
            Shape::Mesh(m) => m.aabb(),
            Shape::Analytic(a) => a.aabb(),
        };
        if !(lo.is_finite() && hi.is_finite()) || lo.abs().max(hi.abs()).max_element() > 1e15 {
            return Err(self.err(
                &sk,
                "the shape's coordinates are not finite or exceed 1e15 m (Embree works in f32)",
            ));
        }
        if let Shape::Mesh(m) = &shape {
            if let Some(face) = meshgen::find_degenerate(m) {
                return Err(self.err(&sk, format!("triangle {} is degenerate (zero area)", face + 1)));
            }
        }

        let mk = format!("{k}.material");
        let mut solid = None;
        let material = match &o.material {
            MaterialDesc::Diffuse(dd) => {
                let t = self.texture(&format!("{mk}.reflectance"), &dd.reflectance)?;
                if t.max_value() > 1.0 {
                    return Err(self.err(
                        &format!("{mk}.reflectance"),
                        "a reflectance above 1 creates energy",
                    ));
                }
                Material::Diffuse {
                    reflectance: t,
                    two_sided: dd.two_sided,
                }
            }
            MaterialDesc::Mirror(m) => Material::Mirror {
                reflectance: self.color(&format!("{mk}.reflectance"), m.reflectance)?,
            },
            MaterialDesc::Black(_) => Material::Black,
            MaterialDesc::Dielectric(dd) => match (dd.ior, dd.int_ior, dd.ext_ior) {
                (Some(ior), None, None) => {
                    let ior = self.positive(&format!("{mk}.ior"), ior)?;
                    let sigma_a = match &dd.absorption {
                        None => V3::ZERO,
                        Some(a) => {
                            let c = self.color(&format!("{mk}.absorption.color"), a.color)?;
                            if c.min_element() <= 0.0 || c.max_element() > 1.0 {
                                return Err(self.err(
                                    &format!("{mk}.absorption.color"),
                                    "expected transmitted colour in (0, 1]",
                                ));
                            }
                            let dist = self.positive(&format!("{mk}.absorption.distance"), a.distance)?;
                            V3::new(-c.x.ln(), -c.y.ln(), -c.z.ln()) / dist as f32
                        }
                    };
                    // A priority solid must be closed and outward facing.
                    let mut flipped = None;
                    let containment = match &shape {
                        Shape::Analytic(a) => {
                            if a.contains(DVec3::ZERO).is_none() {
                                return Err(self.err(
                                    &sk,
                                    format!("dielectric solid \"{name}\" must be closed: use a sphere, a capped cylinder, a tube, a box, a closed lathe or a closed mesh (or int_ior/ext_ior for an open interface)"),
                                ));
                            }
                            Containment::Analytic(*a)
                        }
                        Shape::Mesh(m) => {
                            if !closed_mesh {
                                return Err(self
                                    .err(&sk, format!("dielectric solid \"{name}\" must be a closed mesh")));
                            }
                            m.check_closed().map_err(|e| {
                                self.err(
                                    &sk,
                                    format!("dielectric solid \"{name}\" is not a closed solid: {e}"),
                                )
                            })?;
                            let vol = m.signed_volume();
                            if vol <= 0.0 && !o.flip_inside_out {
                                return Err(self.err(
                                    &sk,
                                    format!("dielectric solid \"{name}\" is inside out (signed volume {vol:.3e} <= 0); set flip_inside_out = true to flip it"),
                                ));
                            }
                            if vol <= 0.0 {
                                warnings.push(format!(
                                    "{}: {k}: \"{name}\" was inside out (negative volume); flipped",
                                    self.src.file
                                ));
                                let mut fm = (**m).clone();
                                fm.flip();
                                flipped = Some(Arc::new(fm));
                            }
                            Containment::Mesh(Arc::new(crate::scene::shapes::ContainsGrid::new(
                                flipped.clone().unwrap_or_else(|| m.clone()),
                            )))
                        }
                    };
                    if let Some(fm) = flipped {
                        shape = Shape::Mesh(fm);
                    }
                    let aabb = match &shape {
                        Shape::Analytic(a) => a.aabb(),
                        Shape::Mesh(m) => m.aabb(),
                    };
                    solid = Some(PendingSolid {
                        priority: dd.priority.unwrap_or(0),
                        ior,
                        sigma_a,
                        containment,
                        aabb,
                    });
                    Material::Black // replaced by Material::Solid when the index is known
                }
                (None, Some(int), Some(ext)) => {
                    if dd.priority.is_some() {
                        return Err(self.err(
                            &format!("{mk}.priority"),
                            "priority applies to solids given by `ior`, not to int_ior/ext_ior interfaces",
                        ));
                    }
                    if dd.absorption.is_some() {
                        return Err(self.err(
                            &format!("{mk}.absorption"),
                            "absorption needs a closed solid given by `ior` (an interface has no inside)",
                        ));
                    }
                    Material::Interface {
                        int_ior: self.positive(&format!("{mk}.int_ior"), int)? as f32,
                        ext_ior: self.positive(&format!("{mk}.ext_ior"), ext)? as f32,
                    }
                }
                _ => {
                    return Err(self.err(&mk, "a dielectric needs either `ior` (a closed solid, with optional priority) or both `int_ior` and `ext_ior`"));
                }
            },
        };
        let emission = match &o.emission {
            Some(e) => Some(self.texture(&format!("{k}.emission.radiance"), &e.radiance)?),
            None => None,
        };
        Ok(Pending {
            name,
            name_key: format!("{k}.name"),
            shape,
            material,
            emission,
            light: None,
            solid,
        })
    }

    fn xf_mesh(&self, mut m: Mesh, xf: &DMat4) -> Mesh {
        if *xf == DMat4::IDENTITY {
            return m;
        }
        for p in &mut m.positions {
            let q = xf.transform_point3(DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64));
            *p = [q.x as f32, q.y as f32, q.z as f32];
        }
        let nm = DMat3::from_mat4(*xf).inverse().transpose();
        if let Some(ns) = &mut m.normals {
            for n in ns {
                let q = (nm * DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64)).normalize_or(DVec3::Y);
                *n = [q.x as f32, q.y as f32, q.z as f32];
            }
        }
        if DMat3::from_mat4(*xf).determinant() < 0.0 {
            // A mirroring transform would turn the mesh inside out: keep outward winding.
            for t in &mut m.indices {
                t.swap(1, 2);
            }
        }
        m
    }
}

impl RenderScene {
    /// Change the declared film resolution (the camera keeps its vertical
    /// field of view). Only the warp renderer uses this; path-traced renders
    /// leave the scene alone and take a `render::RenderSettings`.
    ///
    /// # Errors
    /// A zero or too large resolution.
    pub fn set_resolution(&mut self, width: u32, height: u32) -> Result<()> {
        if width == 0 || height == 0 || (width as u64) * (height as u64) > MAX_PIXELS {
            return Err(Error::Invalid(format!(
                "resolution {width}x{height} is out of range"
            )));
        }
        self.camera = self.camera.with_resolution(width, height);
        self.width = width;
        self.height = height;
        Ok(())
    }
}
