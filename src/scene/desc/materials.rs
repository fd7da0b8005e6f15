//! Materials, textures and emission.
use super::Vec3;
use serde::Deserialize;

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
