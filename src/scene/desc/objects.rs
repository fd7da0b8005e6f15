//! `[[objects]]`: an object's shape and its transform.
use super::materials::{EmissionDesc, MaterialDesc};
use super::Vec3;
use serde::Deserialize;

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
