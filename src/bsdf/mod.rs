//! Microfacet BSDFs for rough glass, metals and plastics: the models of
//! Mitsuba 3's `roughdielectric`, `conductor`/`roughconductor` and
//! `plastic`/`roughplastic`, as pure math (no scene, no Embree).
//!
//! - [`microfacet`](crate::bsdf::microfacet): the GGX and Beckmann
//!   distributions of microfacet normals, Smith shadowing and visible-normal
//!   sampling.
//! - [`fresnel`](crate::bsdf::fresnel): dielectric and conductor Fresnel
//!   reflectance, the diffuse Fresnel reflectance, reflection and refraction
//!   about a microfacet.
//! - [`rough_dielectric`](crate::bsdf::rough_dielectric): rough glass
//!   (Walter et al. 2007), reflection and transmission.
//! - [`conductor`](crate::bsdf::conductor): smooth and rough metals;
//!   [`metals`](crate::bsdf::metals): named metals' complex indices as
//!   Mitsuba 3's RGB variants use them.
//! - [`plastic`](crate::bsdf::plastic): a smooth or rough dielectric coating
//!   over a diffuse base.
//!
//! # Conventions
//!
//! - Every direction is a unit [`glam::Vec3`] in the local shading frame
//!   ([`Frame`](crate::bsdf::Frame)): z is the shading normal, and
//!   directions point *away* from the surface.
//! - The names are pbrt-v4's: `wo` points back along the path (towards the
//!   camera), `wi` is the direction the BSDF samples (towards the light).
//!   Mitsuba 3 calls them `si.wi` and `wo`.
//! - `f(wo, wi)` is the BSDF *without* the cosine (pbrt's convention;
//!   Mitsuba's `eval` returns f·|cos θ(wi)|). `pdf(wo, wi)` is the
//!   solid-angle density of `sample(wo, ..)` at `wi`. A sample's `weight` is
//!   f·|cos θ(wi)| / pdf, as in both renderers.
//! - Arithmetic is `f32` (like Mitsuba's `scalar_rgb` variant). `f64` is used
//!   where `f32` loses digits: Fresnel factors (near grazing and the critical
//!   angle), the rough dielectric's facet geometry (so that f(wo, wi) and
//!   f(wi, wo) see the same facet), the Beckmann shadowing term and Beckmann
//!   sampling (error functions).
//! - Constructors are `try_new` and reject bad parameters with a
//!   [`BsdfError`](crate::bsdf::BsdfError) naming the parameter; nothing
//!   here panics on parameters.
//!
//! # Example
//!
//! ```
//! use glam::{Vec2, Vec3};
//! use snell::bsdf::{Frame, MicrofacetDistribution, MicrofacetKind, RoughDielectric};
//!
//! // Rough glass (GGX, α = 0.2) under air, its shading normal +y in the world.
//! let ggx = MicrofacetDistribution::isotropic(MicrofacetKind::Ggx, 0.2)?;
//! let glass = RoughDielectric::try_new(ggx, 1.0, 1.5)?;
//! let frame = Frame::from_normal(Vec3::Y);
//! let wo = frame.to_local(Vec3::new(0.3, 1.0, 0.0).normalize());
//! // u_lobe = 0.7 is above the Fresnel reflectance (≈ 0.04): a refraction.
//! let s = glass.sample(wo, 0.7, Vec2::new(0.25, 0.5)).expect("a direction");
//! assert!(s.is_transmission && s.wi.z < 0.0);
//! // Its density and weight are what `pdf` and `f` say.
//! let pdf = glass.pdf(wo, s.wi);
//! assert!((s.pdf - pdf).abs() <= 1e-3 * pdf);
//! let weight = glass.f(wo, s.wi) * s.wi.z.abs() / pdf;
//! assert!((s.weight - weight).abs().max_element() <= 1e-3 * weight.max_element());
//! let into_the_glass = frame.to_world(s.wi);
//! assert!(into_the_glass.y < 0.0);
//! # Ok::<(), snell::bsdf::BsdfError>(())
//! ```
use glam::{Vec3, Vec3A};

pub mod conductor;
pub mod fresnel;
pub mod metals;
pub mod microfacet;
pub mod plastic;
pub mod quadrature;
pub mod rough_dielectric;

#[cfg(test)]
mod tests;

pub use conductor::{Conductor, RoughConductor};
pub use metals::Metal;
pub use microfacet::{MicrofacetDistribution, MicrofacetKind};
pub use plastic::{Plastic, PlasticParams, RoughPlastic};
pub use rough_dielectric::RoughDielectric;

/// A parameter a BSDF cannot be built with.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BsdfError {
    /// A number out of its range: which parameter, its value and the rule.
    #[error("{name} = {value}: must be {requirement}")]
    InvalidParameter {
        /// The parameter's name (with the colour channel for an RGB value).
        name: &'static str,
        /// The value given.
        value: f32,
        /// What the value must be, such as "finite and > 0".
        requirement: &'static str,
    },
    /// A metal name that is not in [`metals::METALS`].
    #[error("unknown metal {0:?}; known: {known}", known = metals::names())]
    UnknownMetal(String),
}

/// `value` if it is finite and > 0.
pub(crate) fn positive(name: &'static str, value: f32) -> Result<f32, BsdfError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(BsdfError::InvalidParameter {
            name,
            value,
            requirement: "finite and > 0",
        })
    }
}

/// `value` if every channel is finite and >= 0 (`names` are the channels' names).
pub(crate) fn non_negative_rgb(names: [&'static str; 3], value: Vec3) -> Result<Vec3, BsdfError> {
    for (name, v) in names.into_iter().zip(value.to_array()) {
        if !(v.is_finite() && v >= 0.0) {
            return Err(BsdfError::InvalidParameter {
                name,
                value: v,
                requirement: "finite and >= 0",
            });
        }
    }
    Ok(value)
}

/// Which quantity a path carries, as in pbrt and Mitsuba. It matters only
/// for transmission through a dielectric: radiance is compressed into the
/// smaller solid angle of the denser side, so a radiance path's transmission
/// carries the factor (η(wo side) / η(wi side))², as snell's smooth interface
/// (`Interface::radiance_scale`) and Mitsuba's `roughdielectric` do; an
/// importance (light-tracing) path's does not.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TransportMode {
    /// Paths traced from the camera (the default).
    #[default]
    Radiance,
    /// Paths traced from the lights.
    Importance,
}

/// One direction drawn by a BSDF's `sample`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BsdfSample {
    /// The sampled direction (local frame, unit).
    pub wi: Vec3,
    /// f(wo, wi)·|cos θ(wi)| / pdf per colour channel; for a delta lobe, the
    /// lobe's reflectance over the probability of choosing it.
    pub weight: Vec3,
    /// The solid-angle density of `wi` (what `pdf(wo, wi)` returns); for a
    /// delta lobe, the discrete probability of choosing that lobe.
    pub pdf: f32,
    /// `wi` is on the other side of the surface from `wo`.
    pub is_transmission: bool,
    /// `wi` was chosen by a delta lobe (a smooth mirror or coating): `f` and
    /// `pdf` are zero for it, and only this sample carries it.
    pub is_delta: bool,
}

/// An orthonormal frame (s, t, n): the local shading frame around a normal.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// First tangent.
    pub s: Vec3,
    /// Second tangent (s × t = n).
    pub t: Vec3,
    /// The normal: the local z axis.
    pub n: Vec3,
}

impl Frame {
    /// The frame around unit `n`, tangents by [`crate::sampling::basis`]
    /// (Duff et al. 2017: continuous everywhere but on n.z = 0's sign flip).
    pub fn from_normal(n: Vec3) -> Frame {
        let (s, t) = crate::sampling::basis(Vec3A::from(n));
        Frame {
            s: s.into(),
            t: t.into(),
            n,
        }
    }

    /// World direction `v` in this frame's coordinates.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local direction `v` in world coordinates.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}
