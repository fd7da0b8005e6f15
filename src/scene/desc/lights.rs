//! `[[lights]]`: point, spot, directional, rect and sphere lights.
use super::Vec3;
use serde::Deserialize;

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
