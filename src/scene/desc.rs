//! The typed scene description, as written in TOML (docs/scene-format.md).
//! Every table denies unknown keys; semantic checks live in `scene::build`.
//!
//! Units are metres, angles in the file are degrees, the frame is right-handed
//! with y up. Directions (normals, axes) need not be unit length: the builder
//! normalises them and rejects zero vectors. Relative file names are resolved
//! against the scene file's directory.
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

/// `[camera]`: a pinhole or thin-lens camera looking from `position` at
/// `target`. Conventions: `forward = normalize(target − position)`,
/// `right = normalize(forward × up)`, row 0 at the top of the image.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDesc {
    /// Eye point (the lens centre), world space, metres.
    pub position: Vec3,
    /// Point the view axis passes through, world space, metres.
    pub target: Vec3,
    /// Up hint, need not be perpendicular to the view axis (default +y).
    #[serde(default = "default_up")]
    pub up: Vec3,
    /// Full vertical field of view, degrees, in (0, 180).
    pub fov: f64,
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

/// One `[[lights]]` entry; the TOML key `type` selects the variant.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum LightDesc {
    /// `type = "point"`: an invisible point emitting equally in all directions.
    Point(PointLightDesc),
    /// `type = "directional"`: parallel light from infinitely far away.
    Directional(DirectionalLightDesc),
    /// `type = "rect"`: a visible one-sided rectangle.
    Rect(RectLightDesc),
    /// `type = "sphere"`: a visible emitting sphere.
    Sphere(SphereLightDesc),
    /// `type = "spot"`: an invisible point emitting in a cone (Mitsuba 3's `spot`).
    Spot(SpotLightDesc),
}

/// A spot light: a point whose intensity is `intensity` out to
/// `beam_width` from its axis, falls linearly in the angle to zero at
/// `cutoff_angle`, and is zero beyond (Mitsuba 3's `spot` falloff).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SpotLightDesc {
    /// Name for `--set lights.NAME.…` (default: `lights[i]`).
    #[serde(default)]
    pub name: Option<String>,
    /// Position, world space, metres.
    pub position: Vec3,
    /// The direction of the cone's axis (non-zero); give it or `target`.
    #[serde(default)]
    pub direction: Option<Vec3>,
    /// A point the axis passes through (not `position`); give it or `direction`.
    #[serde(default)]
    pub target: Option<Vec3>,
    /// Radiant intensity on the axis, W/sr per channel.
    pub intensity: Vec3,
    /// The cone's half-angle, degrees, in (0, 90] (default 20, as Mitsuba).
    #[serde(default = "default_cutoff")]
    pub cutoff_angle: f64,
    /// Where the falloff begins, degrees from the axis, in [0, cutoff_angle]
    /// (default: 3/4 of `cutoff_angle`, as Mitsuba).
    #[serde(default)]
    pub beam_width: Option<f64>,
}

fn default_cutoff() -> f64 {
    20.0
}

/// A point light.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointLightDesc {
    /// Name for `--set lights.NAME.…` (default: `lights[i]`).
    #[serde(default)]
    pub name: Option<String>,
    /// Position, world space, metres.
    pub position: Vec3,
    /// Radiant intensity, W/sr per channel.
    pub intensity: Vec3,
}

/// A directional light.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DirectionalLightDesc {
    /// Name for `--set lights.NAME.…` (default: `lights[i]`).
    #[serde(default)]
    pub name: Option<String>,
    /// Direction the light travels in (from the light towards the scene).
    pub direction: Vec3,
    /// Irradiance on a surface facing the light, W/m² per channel.
    pub irradiance: Vec3,
}

/// A rectangular area light: also geometry (a black-bodied emitter).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RectLightDesc {
    /// Name of the light and of its geometry (default: `lights[i]`).
    #[serde(default)]
    pub name: Option<String>,
    /// Centre of the rectangle, world space, metres.
    pub center: Vec3,
    /// Emits only to the side this normal points to.
    pub normal: Vec3,
    /// Direction of the first side, perpendicular to `normal`; the second
    /// side runs along `normal × u_axis`.
    pub u_axis: Vec3,
    /// Side lengths `[u, v]`, metres (> 0).
    pub size: [f64; 2],
    /// Emitted radiance, W/(sr·m²) per channel.
    pub radiance: Vec3,
}

/// A spherical area light: also geometry (a black-bodied emitter).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereLightDesc {
    /// Name of the light and of its geometry (default: `lights[i]`).
    #[serde(default)]
    pub name: Option<String>,
    /// Centre, world space, metres.
    pub center: Vec3,
    /// Radius, metres (> 0).
    pub radius: f64,
    /// Emitted radiance (outwards), W/(sr·m²) per channel.
    pub radiance: Vec3,
}

/// One object: a shape with a material, an optional emission and transforms.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObjectDesc {
    /// Unique name, used by `camera.inside`, `--set objects.NAME.…` and in
    /// errors (default: `objects[i]`).
    #[serde(default)]
    pub name: Option<String>,
    /// The geometry, in the object's own space (before `transform`).
    pub shape: ShapeDesc,
    /// How the surface scatters light.
    pub material: MaterialDesc,
    /// Light the surface emits (default: none).
    #[serde(default)]
    pub emission: Option<EmissionDesc>,
    /// Object-to-world steps, applied in order: first element first (default: identity).
    #[serde(default)]
    pub transform: Vec<TransformDesc>,
    /// Flip an inside-out closed mesh (with a warning) instead of rejecting it
    /// (default false).
    #[serde(default)]
    pub flip_inside_out: bool,
}

/// An object's `shape`; the TOML key `type` selects the variant. Coordinates
/// are metres in the object's space.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum ShapeDesc {
    /// `type = "sphere"`: analytic, normal outward.
    Sphere(SphereDesc),
    /// `type = "rect"`: a rectangle (two triangles) facing its `normal`.
    Rect(RectDesc),
    /// `type = "disk"`: analytic disk or annulus.
    Disk(DiskDesc),
    /// `type = "box"`: a closed axis-aligned cuboid mesh, normals outward.
    Box(BoxDesc),
    /// `type = "cylinder"`: analytic, open or capped.
    Cylinder(CylinderDesc),
    /// `type = "tube"`: an analytic closed thick-walled tube.
    Tube(TubeDesc),
    /// `type = "lathe"`: a revolved profile (mesh).
    Lathe(LatheDesc),
    /// `type = "mesh"`: triangles from an OBJ, PLY, `.serialized` or glTF file.
    Mesh(MeshDesc),
    /// `type = "heightfield"`: diamond-square terrain (mesh).
    Heightfield(HeightfieldDesc),
}

/// An analytic sphere, normal pointing out.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SphereDesc {
    /// Centre, metres.
    pub center: Vec3,
    /// Radius, metres (> 0).
    pub radius: f64,
}

/// A rectangle (two triangles), facing `normal`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RectDesc {
    /// Centre, metres.
    pub center: Vec3,
    /// Geometric normal: the front side.
    pub normal: Vec3,
    /// Direction of the first side, perpendicular to `normal`; the second
    /// side runs along `normal × u_axis`.
    pub u_axis: Vec3,
    /// Side lengths `[u, v]`, metres (> 0).
    pub size: [f64; 2],
}

/// An analytic disk, or an annulus when `inner_radius > 0`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiskDesc {
    /// Centre, metres.
    pub center: Vec3,
    /// Geometric normal: the front side, perpendicular to the disk.
    pub normal: Vec3,
    /// Outer radius, metres (> 0).
    pub radius: f64,
    /// Radius of the hole, metres, in [0, radius) (default 0: no hole).
    #[serde(default)]
    pub inner_radius: f64,
}

/// An axis-aligned box (before the transform): a closed mesh, normals outward.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxDesc {
    /// Centre, metres.
    pub center: Vec3,
    /// Edge lengths along x, y, z, metres (> 0).
    pub size: Vec3,
}

/// An analytic cylinder from `p0` to `p1`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CylinderDesc {
    /// Centre of the first end, metres.
    pub p0: Vec3,
    /// Centre of the second end, metres (must differ from `p0`).
    pub p1: Vec3,
    /// Radius, metres (> 0).
    pub radius: f64,
    /// "out" (away from the axis, default) or "in".
    #[serde(default = "default_out")]
    pub normal: String,
    /// Closed with two disks (a solid); requires normal = "out" (default false).
    #[serde(default)]
    pub caps: bool,
}

fn default_out() -> String {
    "out".into()
}

/// A closed thick-walled tube: outer and inner wall plus two annular caps;
/// normals point out of the material (the inner wall faces the axis).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TubeDesc {
    /// Centre of the first end, metres.
    pub p0: Vec3,
    /// Centre of the second end, metres (must differ from `p0`).
    pub p1: Vec3,
    /// Radius of the outer wall, metres (> `inner_radius`).
    pub outer_radius: f64,
    /// Radius of the inner wall, metres (> 0).
    pub inner_radius: f64,
}

/// A profile of (radius, height) points revolved around the y axis.
/// Walked upward on the outside, the surface faces away from the axis; a
/// profile that starts and ends on the axis (r = 0) makes a closed solid.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LatheDesc {
    /// The `[r, y]` points in metres, r >= 0, at least two.
    pub profile: Vec<[f64; 2]>,
    /// Number of steps around the axis, 3..=65536 (default 128).
    #[serde(default = "default_segments")]
    pub segments: u32,
    /// Shading normals smooth around the axis (default true); false shades
    /// every facet flat.
    #[serde(default = "yes")]
    pub smooth: bool,
    /// Profile joints turning by at most this many degrees are smoothed too
    /// (default 30, in 0..=180); sharper ones (rims, base edges) stay sharp.
    #[serde(default = "default_crease")]
    pub crease_angle: f64,
}

fn default_crease() -> f64 {
    30.0
}

fn default_segments() -> u32 {
    128
}

/// A triangle mesh from a file, by extension: Wavefront OBJ, PLY, Mitsuba
/// `.serialized`, or one primitive of a glTF file; counter-clockwise winding
/// faces the normal.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MeshDesc {
    /// Mesh file, relative to the scene file.
    pub file: String,
    /// Use the file's vertex normals for shading (default true).
    #[serde(default = "yes")]
    pub smooth: bool,
    /// Which mesh of a Mitsuba `.serialized` file, counting from 0 (default 0).
    #[serde(default)]
    pub shape_index: Option<u64>,
    /// Which mesh of a glTF file (`.gltf`, `.glb`), by index in its `meshes`
    /// (default 0).
    #[serde(default)]
    pub mesh: Option<u64>,
    /// Which primitive of that glTF mesh, counting from 0 (default 0).
    #[serde(default)]
    pub primitive: Option<u64>,
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
    /// Grid of (2^levels + 1)² vertices, levels in 1..=12.
    pub levels: u32,
    /// Amplitude of the first displacement, metres (>= 0).
    pub height: f64,
    /// Factor applied to the amplitude at each level, in (0, 1).
    pub roughness: f64,
    /// Seed of the random displacements: equal seeds give equal terrain (default 0).
    #[serde(default)]
    pub seed: u64,
}

/// One step of an object's transform: exactly one of the four keys.
/// Analytic shapes (sphere, disk, cylinder, tube) accept only translations,
/// rotations and uniform scales.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TransformDesc {
    /// Translation, metres.
    #[serde(default)]
    pub translate: Option<Vec3>,
    /// Rotation about `axis` by `degrees` (right-handed).
    #[serde(default)]
    pub rotate: Option<RotateDesc>,
    /// Uniform (number) or per-axis (array) scale, factors > 0.
    #[serde(default)]
    pub scale: Option<ScaleDesc>,
    /// A general affine step: four rows of four numbers, the last row
    /// `[0, 0, 0, 1]`, invertible (imported scenes' matrices).
    #[serde(default)]
    pub matrix: Option<[[f64; 4]; 4]>,
}

/// A rotation about an axis through the origin.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RotateDesc {
    /// Axis direction (normalised by the builder).
    pub axis: Vec3,
    /// Angle, degrees, counter-clockwise looking down the axis towards the origin.
    pub degrees: f64,
}

/// A scale factor: `scale = 2.0` or `scale = [1.0, 2.0, 1.0]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum ScaleDesc {
    /// The same factor on every axis.
    Uniform(f64),
    /// One factor per axis, x, y, z.
    PerAxis(Vec3),
}

/// An object's `material`; the TOML key `type` selects the variant.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum MaterialDesc {
    /// `type = "diffuse"`: Lambertian.
    Diffuse(DiffuseDesc),
    /// `type = "mirror"`: perfect specular reflection.
    Mirror(MirrorDesc),
    /// `type = "dielectric"`: smooth glass or liquid, nested solid or interface.
    Dielectric(DielectricDesc),
    /// Black, non-reflecting (e.g. the back of an emitter).
    Black(BlackDesc),
    /// `type = "rough_dielectric"`: frosted glass (microfacet reflection and
    /// transmission), nested solid or interface like `dielectric`.
    RoughDielectric(RoughDielectricDesc),
    /// `type = "conductor"`: a smooth metal.
    Conductor(ConductorDesc),
    /// `type = "rough_conductor"`: a rough metal.
    RoughConductor(RoughConductorDesc),
    /// `type = "plastic"`: a diffuse base under a smooth dielectric coating.
    Plastic(PlasticDesc),
    /// `type = "rough_plastic"`: a diffuse base under a rough coating.
    RoughPlastic(RoughPlasticDesc),
}

/// Which distribution of microfacet normals a rough surface has.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DistributionDesc {
    /// GGX (Trowbridge–Reitz), the default.
    #[default]
    Ggx,
    /// Beckmann.
    Beckmann,
}

/// Mitsuba's default roughness.
fn default_alpha() -> f64 {
    0.1
}

/// A rough dielectric: the keys of [`DielectricDesc`] plus the roughness.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoughDielectricDesc {
    /// Index of refraction of a closed solid (> 0).
    #[serde(default)]
    pub ior: Option<f64>,
    /// Nesting priority of a solid (default 0; solids only).
    #[serde(default)]
    pub priority: Option<i64>,
    /// Interface only: index on the side opposite the normal.
    #[serde(default)]
    pub int_ior: Option<f64>,
    /// Interface only: index on the side the normal points to.
    #[serde(default)]
    pub ext_ior: Option<f64>,
    /// Beer–Lambert absorption inside a solid.
    #[serde(default)]
    pub absorption: Option<AbsorptionDesc>,
    /// `"ggx"` (default) or `"beckmann"`.
    #[serde(default)]
    pub distribution: DistributionDesc,
    /// Isotropic roughness, in (0, 1] (default 0.1).
    #[serde(default = "default_alpha")]
    pub alpha: f64,
}

/// A smooth metal: a named `material` or its complex index `eta` + i`k`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConductorDesc {
    /// A named metal (Mitsuba's names: "Au", "Ag", "Cu", "Al", ...).
    #[serde(default)]
    pub material: Option<String>,
    /// Real part of the index per channel (with `k`, instead of `material`).
    #[serde(default)]
    pub eta: Option<Vec3>,
    /// Imaginary part of the index per channel.
    #[serde(default)]
    pub k: Option<Vec3>,
    /// Factor on the reflection per channel (default `[1, 1, 1]`).
    #[serde(default = "white")]
    pub specular_reflectance: Vec3,
    /// Reflects on both sides (default: one-sided, as Mitsuba).
    #[serde(default)]
    pub two_sided: bool,
}

/// A rough metal: [`ConductorDesc`]'s keys plus the roughness.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoughConductorDesc {
    /// A named metal.
    #[serde(default)]
    pub material: Option<String>,
    /// Real part of the index per channel.
    #[serde(default)]
    pub eta: Option<Vec3>,
    /// Imaginary part of the index per channel.
    #[serde(default)]
    pub k: Option<Vec3>,
    /// Factor on the reflection per channel (default `[1, 1, 1]`).
    #[serde(default = "white")]
    pub specular_reflectance: Vec3,
    /// Reflects on both sides.
    #[serde(default)]
    pub two_sided: bool,
    /// `"ggx"` (default) or `"beckmann"`.
    #[serde(default)]
    pub distribution: DistributionDesc,
    /// Isotropic roughness, in (0, 1] (default 0.1).
    #[serde(default = "default_alpha")]
    pub alpha: f64,
}

fn default_plastic_diffuse() -> Vec3 {
    [0.5, 0.5, 0.5]
}

fn default_plastic_int_ior() -> f64 {
    1.49
}

fn default_plastic_ext_ior() -> f64 {
    1.000277
}

/// A smooth plastic (Mitsuba's keys and defaults).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlasticDesc {
    /// Albedo of the base per channel, in [0, 1] (default 0.5).
    #[serde(default = "default_plastic_diffuse")]
    pub diffuse_reflectance: Vec3,
    /// Factor on the coating's reflection (default `[1, 1, 1]`).
    #[serde(default = "white")]
    pub specular_reflectance: Vec3,
    /// Index of the coating (default 1.49, polypropylene).
    #[serde(default = "default_plastic_int_ior")]
    pub int_ior: f64,
    /// Index outside (default 1.000277, air).
    #[serde(default = "default_plastic_ext_ior")]
    pub ext_ior: f64,
    /// Internal scattering darkens and saturates the base colour.
    #[serde(default)]
    pub nonlinear: bool,
    /// Reflects on both sides.
    #[serde(default)]
    pub two_sided: bool,
}

/// A rough plastic: [`PlasticDesc`]'s keys plus the roughness.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RoughPlasticDesc {
    /// Albedo of the base per channel, in [0, 1] (default 0.5).
    #[serde(default = "default_plastic_diffuse")]
    pub diffuse_reflectance: Vec3,
    /// Factor on the coating's reflection (default `[1, 1, 1]`).
    #[serde(default = "white")]
    pub specular_reflectance: Vec3,
    /// Index of the coating (default 1.49).
    #[serde(default = "default_plastic_int_ior")]
    pub int_ior: f64,
    /// Index outside (default 1.000277).
    #[serde(default = "default_plastic_ext_ior")]
    pub ext_ior: f64,
    /// Internal scattering darkens and saturates the base colour.
    #[serde(default)]
    pub nonlinear: bool,
    /// Reflects on both sides.
    #[serde(default)]
    pub two_sided: bool,
    /// `"ggx"` (default) or `"beckmann"`.
    #[serde(default)]
    pub distribution: DistributionDesc,
    /// Isotropic roughness, in (0, 1] (default 0.1).
    #[serde(default = "default_alpha")]
    pub alpha: f64,
}

/// A Lambertian material.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DiffuseDesc {
    /// Albedo per channel, each in [0, 1]: a colour or a texture.
    pub reflectance: TextureDesc,
    /// Lambertian on both sides (default: one-sided, black from behind, as Mitsuba).
    #[serde(default)]
    pub two_sided: bool,
}

/// A perfect mirror.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct MirrorDesc {
    /// Fraction reflected per channel (default white, `[1, 1, 1]`).
    #[serde(default = "white")]
    pub reflectance: Vec3,
}

fn white() -> Vec3 {
    [1.0, 1.0, 1.0]
}

/// `type = "black"`: no keys.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BlackDesc {}

/// Either `ior` (a closed solid with a `priority`, nested the Schmidt–Budge
/// way) or `int_ior` + `ext_ior` (an interface surface: int is the side
/// opposite the normal).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DielectricDesc {
    /// Index of refraction of a closed solid (> 0).
    #[serde(default)]
    pub ior: Option<f64>,
    /// Nesting priority of a solid: where solids overlap the highest wins,
    /// ties go to the one declared later (default 0; solids only).
    #[serde(default)]
    pub priority: Option<i64>,
    /// Interface only: index on the side opposite the normal.
    #[serde(default)]
    pub int_ior: Option<f64>,
    /// Interface only: index on the side the normal points to.
    #[serde(default)]
    pub ext_ior: Option<f64>,
    /// Beer–Lambert: the colour transmitted after `distance` metres inside.
    #[serde(default)]
    pub absorption: Option<AbsorptionDesc>,
}

/// Beer–Lambert absorption of a solid, given by what survives a distance.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AbsorptionDesc {
    /// Fraction transmitted per channel after `distance`, each in (0, 1].
    pub color: Vec3,
    /// Path length inside the solid, metres (> 0).
    pub distance: f64,
}

/// A colour that may vary over a surface: `[r, g, b]` or a table with `type`.
#[derive(Debug, Clone, Deserialize)]
#[serde(untagged)]
pub enum TextureDesc {
    /// Three numbers: the same colour everywhere.
    Constant(Vec3),
    /// An inline table: a checker or an image.
    Table(TextureTable),
}

/// A texture given as a table; the TOML key `type` selects the variant.
#[derive(Debug, Clone, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case")]
pub enum TextureTable {
    /// `type = "checker"`: world-space squares of two colours.
    Checker(CheckerDesc),
    /// `type = "image"`: an image over the shape's (u, v).
    Image(ImageTextureDesc),
}

/// World-space checker: colour0 where floor(a/size) + floor(b/size) is even.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CheckerDesc {
    /// The two world axes `a`, `b` of the pattern: two different of "x", "y", "z".
    pub axes: [String; 2],
    /// Side of one square, metres (>= 1e-9).
    pub size: f64,
    /// Colour of the squares where the sum is even.
    pub color0: Vec3,
    /// Colour of the squares where the sum is odd.
    pub color1: Vec3,
}

/// An image texture over the shape's (u, v) parametrisation.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ImageTextureDesc {
    /// Image file, relative to the scene file (PNG/JPEG sRGB-decoded, EXR/HDR linear).
    pub file: String,
    /// Repeats of the image over the shape's (u, v) in [0, 1]² (default `[1, 1]`).
    #[serde(default = "default_uv_scale")]
    pub uv_scale: [f64; 2],
}

fn default_uv_scale() -> [f64; 2] {
    [1.0, 1.0]
}

/// An object's `emission`: the object is also a light of next-event
/// estimation.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct EmissionDesc {
    /// Emitted radiance, W/(sr·m²) per channel.
    pub radiance: TextureDesc,
    /// Emit from both sides (default false: only to the side the normal
    /// points to).
    #[serde(default)]
    pub two_sided: bool,
}
