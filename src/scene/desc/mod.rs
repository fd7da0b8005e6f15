//! The typed scene description, as written in TOML (docs/scene-format.md).
//! Every table denies unknown keys; semantic checks live in `scene::builder`.
//!
//! Here the scene, its camera, film, integrator, environment, medium and
//! warp; `objects`, `lights` and `materials` hold the rest.
//!
//! Units are metres, angles in the file are degrees, the frame is right-handed
//! with y up. Directions (normals, axes) need not be unit length: the builder
//! normalises them and rejects zero vectors. Relative file names are resolved
//! against the scene file's directory.
mod lights;
mod materials;
mod objects;

pub use lights::*;
pub use materials::*;
pub use objects::*;

use serde::Deserialize;

/// A point, direction or RGB colour as three numbers `[x, y, z]` / `[r, g, b]`.
pub type Vec3 = [f64; 3];

/// The whole scene file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDesc {
    /// `[camera]` (required): where the image is seen from.
    pub camera: CameraDesc,
    /// `[film]`: resolution, samples per pixel, seed (defaults: 640×480, 16 spp, seed 0).
    #[serde(default)]
    pub film: FilmDesc,
    /// `[integrator]`: path tracer or Whitted, and the depth limits (default: path, 16, 5).
    #[serde(default)]
    pub integrator: IntegratorDesc,
    /// Index of the medium the scene sits in (default: air, 1.000293).
    #[serde(default = "default_ambient_ior")]
    pub ambient_ior: f64,
    /// `[environment]`: radiance arriving from infinitely far away (default: none, black).
    #[serde(default)]
    pub environment: Option<EnvironmentDesc>,
    /// `[[lights]]`: lights sampled directly by next-event estimation (default: none).
    #[serde(default)]
    pub lights: Vec<LightDesc>,
    /// `[[objects]]`: the shapes with their materials, in declaration order
    /// (which breaks priority ties: the later solid wins).
    #[serde(default)]
    pub objects: Vec<ObjectDesc>,
    /// One gradient-index medium (docs/grin.md): rays inside its bounds curve.
    #[serde(default)]
    pub medium: Option<MediumDesc>,
    /// One analytic warp glass (docs/warp.md): `snell render` traces it as a
    /// dielectric, `snell warp-render` warps the meshes behind it instead.
    #[serde(default)]
    pub warp: Option<WarpDesc>,
}

/// `[warp]`: the glass of an analytic refraction warp.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WarpDesc {
    /// `glass`: the plate or hollow cylinder the vertices are warped through.
    pub glass: WarpGlassDesc,
    /// Screen-space subdivision tolerance: longest projected edge, in pixels
    /// (default 4, at least 0.05).
    #[serde(default = "default_subdivide")]
    pub subdivide: f64,
    /// Weight the warp image by the Fresnel transmittance of the pixel's path
    /// (default false).
    #[serde(default)]
    pub fresnel: bool,
    /// "exact" (default) or "paper" (Mukai et al.'s C→B→A approximation; the
    /// cylinder only, the plate's paper formula is exact).
    #[serde(default = "default_warp_method")]
    pub method: String,
    /// Size of the glass as geometry for the full trace: the plate's side
    /// length or the tube's height, in metres (default 100; the warp math
    /// takes it infinite).
    #[serde(default = "default_warp_extent")]
    pub extent: f64,
}

fn default_subdivide() -> f64 {
    4.0
}
fn default_warp_method() -> String {
    "exact".into()
}
fn default_warp_extent() -> f64 {
    100.0
}

/// The warp glass, as in `snell warp-points`; the TOML key `kind` selects the
/// variant. The surroundings have index 1 (`ambient_ior = 1.0` is required).
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum WarpGlassDesc {
    /// `kind = "plate"`: a parallel plate, infinite in the warp math.
    Plate {
        /// A point on the face nearer the eye, metres.
        near_face_point: Vec3,
        /// Normal of the faces, pointing away from the eye (normalised by the builder).
        normal: Vec3,
        /// Distance between the two faces, metres (> 0).
        thickness: f64,
        /// Index of refraction of the glass (> 0).
        ior: f64,
    },
    /// `kind = "hollow_cylinder"`: a thick glass tube, infinitely tall in the warp math.
    HollowCylinder {
        /// A point on the axis, metres.
        axis_point: Vec3,
        /// Direction of the axis (normalised by the builder).
        axis_direction: Vec3,
        /// Radius of the outer wall, metres (> `inner_radius`).
        outer_radius: f64,
        /// Radius of the inner wall, metres (> 0).
        inner_radius: f64,
        /// Index of refraction of the glass (>= 1).
        ior: f64,
    },
}

/// `[medium]`: an index field inside a box, traced as chords.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumDesc {
    /// `field`: the index of refraction n(x) inside the box (docs/grin.md; key `kind`).
    #[serde(default)]
    pub field: Option<crate::media::IndexField>,
    /// `atmosphere`: instead of `field`, air given by its temperature profile
    /// and ground pressure, its index from Ciddor's equations (`media::atmosphere`).
    #[serde(default)]
    pub atmosphere: Option<crate::media::Atmosphere>,
    /// `bounds`: the world-space box the field fills; outside it rays are straight.
    pub bounds: BoundsDesc,
    /// auto (default: invariant for fields of height alone along a coordinate
    /// axis, else rk45), invariant, rk45, rk4, exact (linear fields), or the
    /// paper's slab/length/euler/paper_rk4.
    #[serde(default = "default_method")]
    pub method: String,
    /// Geometric chord tolerance in metres (chord–arc deviation), and rk45's
    /// error target (default 1e-3, at least 1e-9). Method invariant uses it
    /// only without a camera; in renders its chords follow `pixel_tolerance`.
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// Step in metres for fixed-step methods (default 1).
    #[serde(default = "one")]
    pub step: f64,
    /// Method invariant: how far a chord may stray from its arc, as a
    /// fraction of a pixel of the film (the pixel's footprint at the distance
    /// from the camera; default 0.1). Method rk45 through a 3-D field (a
    /// plume): the error each step of a flight may leave, in the same unit
    /// (default 1; docs/grin.md). Ignored by the other methods.
    #[serde(default)]
    pub pixel_tolerance: Option<f64>,
    /// Methods invariant and rk45's flights: rays after a diffuse or glossy
    /// bounce are held to this multiple of `pixel_tolerance` (default 16;
    /// 1 holds them as camera rays). What such a ray brings back is spread
    /// over the bounce's lobe (docs/grin.md).
    #[serde(default)]
    pub indirect_tolerance_scale: Option<f64>,
}

/// An axis-aligned world-space box, `{ min = [..], max = [..] }`, metres.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundsDesc {
    /// The corner with the smallest coordinates.
    pub min: Vec3,
    /// The corner with the largest coordinates.
    pub max: Vec3,
}

fn default_method() -> String {
    "auto".into()
}
fn default_tolerance() -> f64 {
    1e-3
}

/// The default `ambient_ior`: air at standard conditions, 1.000293.
pub fn default_ambient_ior() -> f64 {
    1.000293
}

/// `[camera]`: a pinhole, thin-lens or orthographic camera looking from
/// `position` at `target`. Conventions: `forward = normalize(target −
/// position)`, `right = normalize(forward × up)`, row 0 at the top of the
/// image.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    /// "perspective" (the default: pinhole or thin lens) or "orthographic".
    #[serde(rename = "type", default = "default_camera_type")]
    pub kind: String,
    /// Eye point (the lens centre), world space, metres; for an orthographic
    /// camera the centre of the view rectangle its rays start from.
    pub position: Vec3,
    /// Point the view axis passes through, world space, metres.
    pub target: Vec3,
    /// Up hint, need not be perpendicular to the view axis (default +y).
    #[serde(default = "default_up")]
    pub up: Vec3,
    /// Full vertical field of view, degrees, in (0, 180): required for a
    /// perspective camera, an error for an orthographic one.
    #[serde(default)]
    pub fov: Option<f64>,
    /// Orthographic: the view's `[width, height]` in metres, both > 0
    /// (required; an error for a perspective camera). Its aspect may differ
    /// from the film's (non-square pixels).
    #[serde(default)]
    pub size: Option<[f64; 2]>,
    /// Thin-lens aperture radius in metres (0 = pinhole, the default).
    #[serde(default)]
    pub aperture_radius: f64,
    /// Focus distance along the view axis, metres (thin lens only; default
    /// |target − position|).
    #[serde(default)]
    pub focus_distance: Option<f64>,
    /// Override of the automatic interior list at the camera: names of the
    /// dielectric solids the camera is inside (default: found by
    /// point-in-solid tests).
    #[serde(default)]
    pub inside: Option<Vec<String>>,
}

fn default_camera_type() -> String {
    "perspective".into()
}

fn default_up() -> Vec3 {
    [0.0, 1.0, 0.0]
}

/// `[film]`: the image and its sampling.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilmDesc {
    /// Image width in pixels, 1..=65536 (default 640; width × height is
    /// limited to 2^27 pixels).
    #[serde(default = "default_width")]
    pub width: u64,
    /// Image height in pixels, 1..=65536 (default 480).
    #[serde(default = "default_height")]
    pub height: u64,
    /// Samples per pixel, 1..=16777216 (default 16).
    #[serde(default = "default_spp")]
    pub spp: u64,
    /// Seed every random number derives from, with the pixel and sample (default 0).
    #[serde(default)]
    pub seed: u64,
    /// Pixel filter: only "box" (the default), the plain mean of the pixel's samples.
    #[serde(default = "default_filter")]
    pub filter: String,
}

fn default_width() -> u64 {
    640
}
fn default_height() -> u64 {
    480
}
fn default_spp() -> u64 {
    16
}
fn default_filter() -> String {
    "box".into()
}

impl Default for FilmDesc {
    fn default() -> Self {
        FilmDesc {
            width: default_width(),
            height: default_height(),
            spp: default_spp(),
            seed: 0,
            filter: default_filter(),
        }
    }
}

/// `[integrator]`: which light transport algorithm, and how deep.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegratorDesc {
    /// TOML key `type`: "path" (the unbiased path tracer, default) or
    /// "whitted" (quick previews).
    #[serde(rename = "type", default = "default_integrator")]
    pub kind: String,
    /// Path segments counting the camera ray (Mitsuba semantics), 1..=1024
    /// (default 16).
    #[serde(default = "default_max_depth")]
    pub max_depth: u32,
    /// Russian roulette applies once a path has more than this many segments
    /// (default 5, at least 1).
    #[serde(default = "default_rr_depth")]
    pub rr_depth: u32,
}

fn default_integrator() -> String {
    "path".into()
}
fn default_max_depth() -> u32 {
    16
}
fn default_rr_depth() -> u32 {
    5
}

impl Default for IntegratorDesc {
    fn default() -> Self {
        IntegratorDesc {
            kind: default_integrator(),
            max_depth: default_max_depth(),
            rr_depth: default_rr_depth(),
        }
    }
}

/// `[environment]`: light from infinitely far away, seen by rays that leave
/// the scene. The TOML key `type` selects the variant.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum EnvironmentDesc {
    /// `type = "constant"`: the same radiance from every direction.
    Constant(ConstantEnv),
    /// `type = "map"`: a lat-long image.
    Map(MapEnv),
    /// `type = "sky"`: a sun disk of finite size in an analytic sky; the
    /// path tracer samples the disk by next-event estimation.
    Sky(SkyEnv),
}

/// A sun in an analytic sky (`scene::sun`). The sky's radiance blends from
/// `horizon` to `zenith` linearly in sin(elevation) (y up); below the
/// horizon it is `ground`; the sun's disk replaces it where the disk is.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SkyEnv {
    /// Direction towards the sun's centre (normalised; any length > 0).
    pub sun_direction: Vec3,
    /// The sun's full angular diameter in degrees, in (0, 90] (default 0.53).
    #[serde(default = "default_sun_diameter")]
    pub sun_diameter: f64,
    /// Irradiance the sun gives (W/m² per channel, >= 0): the disk has the
    /// uniform radiance irradiance / (2π(1 − cos(diameter/2))).
    pub sun_irradiance: Vec3,
    /// Sky radiance straight up (default black).
    #[serde(default)]
    pub zenith: Vec3,
    /// Sky radiance at the horizon (default black).
    #[serde(default)]
    pub horizon: Vec3,
    /// Radiance from below the horizon (default black).
    #[serde(default)]
    pub ground: Vec3,
}

fn default_sun_diameter() -> f64 {
    crate::scene::sun::SUN_DIAMETER_DEG
}

/// A constant environment.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstantEnv {
    /// Radiance, W/(sr·m²) per RGB channel, >= 0.
    pub radiance: Vec3,
}

/// An environment map.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapEnv {
    /// Lat-long EXR or HDR file, relative to the scene file (PNG/JPEG are
    /// sRGB-decoded).
    pub file: String,
    /// Factor applied to the map's values (default 1, > 0).
    #[serde(default = "one")]
    pub scale: f64,
    /// Steps placing the map in the world, as an object's `transform`;
    /// together a rotation (default: none).
    #[serde(default)]
    pub to_world: Vec<TransformDesc>,
    /// Where the image's rows sit: `"centres"` (default; row j's centre
    /// at polar angle (j + 0.5)/H · 180°) or `"poles"` (row 0 on the upper
    /// pole, row H − 1 on the lower: Mitsuba 3's `envmap`).
    #[serde(default = "default_rows")]
    pub rows: String,
}

fn default_rows() -> String {
    "centres".into()
}

fn one() -> f64 {
    1.0
}
