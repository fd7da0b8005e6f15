//! The typed scene description, as written in TOML (docs/scene-format.md).
//! Every table denies unknown keys; semantic checks live in `scene::build`.
use serde::Deserialize;

pub type Vec3 = [f64; 3];

/// The whole scene file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDesc {
    pub camera: CameraDesc,
    #[serde(default)]
    pub film: FilmDesc,
    #[serde(default)]
    pub integrator: IntegratorDesc,
    /// Index of the medium the scene sits in (default: air, 1.000293).
    #[serde(default = "default_ambient_ior")]
    pub ambient_ior: f64,
    #[serde(default)]
    pub environment: Option<EnvironmentDesc>,
    #[serde(default)]
    pub lights: Vec<LightDesc>,
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
    pub glass: WarpGlassDesc,
    /// Screen-space subdivision tolerance: longest projected edge, in pixels.
    #[serde(default = "default_subdivide")]
    pub subdivide: f64,
    /// Weight the warp image by the Fresnel transmittance of the pixel's path.
    #[serde(default)]
    pub fresnel: bool,
    /// "exact" (default) or "paper" (Mukai et al.'s C→B→A approximation; the
    /// cylinder only, the plate's paper formula is exact).
    #[serde(default = "default_warp_method")]
    pub method: String,
    /// Size of the glass as geometry for the full trace: the plate's side
    /// length or the tube's height, in metres (the warp math takes it infinite).
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

/// The warp glass, as in `snell warp-points`.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum WarpGlassDesc {
    Plate {
        near_face_point: Vec3,
        normal: Vec3,
        thickness: f64,
        ior: f64,
    },
    HollowCylinder {
        axis_point: Vec3,
        axis_direction: Vec3,
        outer_radius: f64,
        inner_radius: f64,
        ior: f64,
    },
}

/// `[medium]`: an index field inside a box, traced as chords.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MediumDesc {
    pub field: crate::media::IndexField,
    pub bounds: BoundsDesc,
    /// rk45 (default), rk4, exact (linear fields), or the paper's slab/length/euler/paper_rk4.
    #[serde(default = "default_method")]
    pub method: String,
    /// Geometric chord tolerance in metres (chord–arc deviation), and rk45's error target.
    #[serde(default = "default_tolerance")]
    pub tolerance: f64,
    /// Step in metres for fixed-step methods.
    #[serde(default = "one")]
    pub step: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoundsDesc {
    pub min: Vec3,
    pub max: Vec3,
}

fn default_method() -> String {
    "rk45".into()
}
fn default_tolerance() -> f64 {
    1e-3
}

pub fn default_ambient_ior() -> f64 {
    1.000293
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    pub position: Vec3,
    pub target: Vec3,
    #[serde(default = "default_up")]
    pub up: Vec3,
    /// Full vertical field of view, degrees.
    pub fov: f64,
    /// Thin-lens aperture radius in metres (0 = pinhole).
    #[serde(default)]
    pub aperture_radius: f64,
    /// Focus distance along the view axis, metres (thin lens only).
    #[serde(default)]
    pub focus_distance: Option<f64>,
    /// Override of the automatic interior list at the camera: object names.
    #[serde(default)]
    pub inside: Option<Vec<String>>,
}

fn default_up() -> Vec3 {
    [0.0, 1.0, 0.0]
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FilmDesc {
    #[serde(default = "default_width")]
    pub width: u64,
    #[serde(default = "default_height")]
    pub height: u64,
    #[serde(default = "default_spp")]
    pub spp: u64,
    #[serde(default)]
    pub seed: u64,
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

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct IntegratorDesc {
    /// "path" or "whitted".
    #[serde(rename = "type", default = "default_integrator")]
    pub kind: String,
    /// Path segments counting the camera ray (Mitsuba semantics).
    #[serde(default = "default_max_depth")]
    pub max_depth: u32,
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

#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum EnvironmentDesc {
    Constant(ConstantEnv),
    Map(MapEnv),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstantEnv {
    pub radiance: Vec3,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MapEnv {
    /// Lat-long EXR or HDR file, relative to the scene file.
    pub file: String,
    #[serde(default = "one")]
    pub scale: f64,
}

fn one() -> f64 {
    1.0
}

#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum LightDesc {
    Point(PointLightDesc),
    Directional(DirectionalLightDesc),
    Rect(RectLightDesc),
    Sphere(SphereLightDesc),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointLightDesc {
    #[serde(default)]
    pub name: Option<String>,
    pub position: Vec3,
    /// Radiant intensity, W/sr per channel.
    pub intensity: Vec3,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DirectionalLightDesc {
    #[serde(default)]
    pub name: Option<String>,
    /// Direction the light travels in.
    pub direction: Vec3,
    /// Irradiance on a surface facing the light, W/m² per channel.
    pub irradiance: Vec3,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RectLightDesc {
    #[serde(default)]
    pub name: Option<String>,
    pub center: Vec3,
    /// Emits only to the side this unit normal points to.
    pub normal: Vec3,
    pub u_axis: Vec3,
    pub size: [f64; 2],
    pub radiance: Vec3,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereLightDesc {
    #[serde(default)]
    pub name: Option<String>,
    pub center: Vec3,
    pub radius: f64,
    pub radiance: Vec3,
}

/// One object: a shape with a material, an optional emission and transforms.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectDesc {
    #[serde(default)]
    pub name: Option<String>,
    pub shape: ShapeDesc,
    pub material: MaterialDesc,
    #[serde(default)]
    pub emission: Option<EmissionDesc>,
    /// Applied in order: first element first.
    #[serde(default)]
    pub transform: Vec<TransformDesc>,
    /// Flip an inside-out closed mesh (with a warning) instead of rejecting it.
    #[serde(default)]
    pub flip_inside_out: bool,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ShapeDesc {
    Sphere(SphereDesc),
    Rect(RectDesc),
    Disk(DiskDesc),
    Box(BoxDesc),
    Cylinder(CylinderDesc),
    Tube(TubeDesc),
    Lathe(LatheDesc),
    Mesh(MeshDesc),
    Heightfield(HeightfieldDesc),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereDesc {
    pub center: Vec3,
    pub radius: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RectDesc {
    pub center: Vec3,
    pub normal: Vec3,
    pub u_axis: Vec3,
    pub size: [f64; 2],
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiskDesc {
    pub center: Vec3,
    pub normal: Vec3,
    pub radius: f64,
    #[serde(default)]
    pub inner_radius: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxDesc {
    pub center: Vec3,
    pub size: Vec3,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CylinderDesc {
    pub p0: Vec3,
    pub p1: Vec3,
    pub radius: f64,
    /// "out" (away from the axis, default) or "in".
    #[serde(default = "default_out")]
    pub normal: String,
    /// Closed with two disks (a solid); requires normal = "out".
    #[serde(default)]
    pub caps: bool,
}

fn default_out() -> String {
    "out".into()
}

/// A closed thick-walled tube: outer and inner wall plus two annular caps.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TubeDesc {
    pub p0: Vec3,
    pub p1: Vec3,
    pub outer_radius: f64,
    pub inner_radius: f64,
}

/// A profile of (radius, height) points revolved around the y axis.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LatheDesc {
    pub profile: Vec<[f64; 2]>,
    #[serde(default = "default_segments")]
    pub segments: u32,
    /// Shading normals smooth around the axis (default true); false shades
    /// every facet flat.
    #[serde(default = "yes")]
    pub smooth: bool,
    /// Profile joints turning by at most this many degrees are smoothed too
    /// (default 30); sharper ones (rims, base edges) stay sharp.
    #[serde(default = "default_crease")]
    pub crease_angle: f64,
}

fn default_crease() -> f64 {
    30.0
}

fn default_segments() -> u32 {
    128
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshDesc {
    /// OBJ file, relative to the scene file.
    pub file: String,
    /// Use the file's vertex normals for shading (default true).
    #[serde(default = "yes")]
    pub smooth: bool,
}

fn yes() -> bool {
    true
}

/// Diamond-square terrain on the xz plane centred at the origin, y up.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HeightfieldDesc {
    /// Extent along x and z, metres.
    pub size: [f64; 2],
    /// Grid of (2^levels + 1)² vertices.
    pub levels: u32,
    /// Amplitude of the first displacement, metres.
    pub height: f64,
    /// Factor applied to the amplitude at each level, in (0, 1).
    pub roughness: f64,
    #[serde(default)]
    pub seed: u64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformDesc {
    #[serde(default)]
    pub translate: Option<Vec3>,
    /// Rotation about `axis` by `degrees` (right-handed).
    #[serde(default)]
    pub rotate: Option<RotateDesc>,
    /// Uniform (number) or per-axis (array) scale.
    #[serde(default)]
    pub scale: Option<ScaleDesc>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotateDesc {
    pub axis: Vec3,
    pub degrees: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum ScaleDesc {
    Uniform(f64),
    PerAxis(Vec3),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum MaterialDesc {
    Diffuse(DiffuseDesc),
    Mirror(MirrorDesc),
    Dielectric(DielectricDesc),
    /// Black, non-reflecting (e.g. the back of an emitter).
    Black(BlackDesc),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiffuseDesc {
    pub reflectance: TextureDesc,
    /// Lambertian on both sides (default: one-sided, black from behind, as Mitsuba).
    #[serde(default)]
    pub two_sided: bool,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MirrorDesc {
    #[serde(default = "white")]
    pub reflectance: Vec3,
}

fn white() -> Vec3 {
    [1.0, 1.0, 1.0]
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BlackDesc {}

/// Either `ior` (a closed solid with a `priority`, nested the Schmidt–Budge
/// way) or `int_ior` + `ext_ior` (an interface surface: int is the side
/// opposite the normal).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DielectricDesc {
    #[serde(default)]
    pub ior: Option<f64>,
    #[serde(default)]
    pub priority: Option<i64>,
    #[serde(default)]
    pub int_ior: Option<f64>,
    #[serde(default)]
    pub ext_ior: Option<f64>,
    /// Beer–Lambert: the colour transmitted after `distance` metres inside.
    #[serde(default)]
    pub absorption: Option<AbsorptionDesc>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AbsorptionDesc {
    pub color: Vec3,
    pub distance: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum TextureDesc {
    Constant(Vec3),
    Table(TextureTable),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum TextureTable {
    Checker(CheckerDesc),
    Image(ImageTextureDesc),
}

/// World-space checker: colour0 where floor(a/size) + floor(b/size) is even.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckerDesc {
    pub axes: [String; 2],
    pub size: f64,
    pub color0: Vec3,
    pub color1: Vec3,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageTextureDesc {
    pub file: String,
    /// Repeats of the image over the shape's (u, v) in [0,1]².
    #[serde(default = "default_uv_scale")]
    pub uv_scale: [f64; 2],
}

fn default_uv_scale() -> [f64; 2] {
    [1.0, 1.0]
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmissionDesc {
    /// Emitted radiance (one-sided: to the side the normal points to).
    pub radiance: TextureDesc,
}
