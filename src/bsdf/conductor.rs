//! Metals: a smooth conductor (a mirror with Fresnel reflectance) and a
//! rough conductor (microfacet reflection), Mitsuba 3's `conductor` and
//! `roughconductor`.
//!
//! Parameters: the complex index η + iκ per RGB channel relative to the
//! outer medium (from [`super::metals`] by name, or given), and
//! `specular_reflectance`, an RGB factor on the reflection (1 is physical).
//! The rough conductor adds a [`MicrofacetDistribution`].
//!
//! Both are one-sided, as in Mitsuba: light is reflected only on the +z side
//! (cos θo > 0 and cos θi > 0); seen from below they are black.
//!
//! - Smooth: a delta reflection into (−x, −y, z) with weight
//!   `specular_reflectance` · F(cos θo), F = [`fresnel::conductor`].
//! - Rough: f = spec · F(wo·m) D(m) G(wo, wi, m) / (4 cos θo cos θi) with
//!   m = (wo + wi)/|wo + wi|; sampling draws m from the normals visible from
//!   wo and reflects, pdf = D_vis(m) / (4 wo·m), weight = spec · F · G1(wi, m).
//!
//! Departures from Mitsuba 3: `f` excludes the cosine; a sampled direction
//! below the surface is `None` (Mitsuba returns it with weight 0).
use super::fresnel::{self, reflect};
use super::metals;
use super::microfacet::MicrofacetDistribution;
use super::{non_negative_rgb, BsdfError, BsdfSample};
use glam::{Vec2, Vec3};

/// A complex index and a reflectance factor, checked.
fn checked(eta: Vec3, k: Vec3, specular_reflectance: Vec3) -> Result<(Vec3, Vec3, Vec3), BsdfError> {
    Ok((
        non_negative_rgb(["eta.r", "eta.g", "eta.b"], eta)?,
        non_negative_rgb(["k.r", "k.g", "k.b"], k)?,
        non_negative_rgb(
            [
                "specular_reflectance.r",
                "specular_reflectance.g",
                "specular_reflectance.b",
            ],
            specular_reflectance,
        )?,
    ))
}

/// A metal's complex index by name.
fn named(name: &str) -> Result<&'static metals::Metal, BsdfError> {
    metals::find(name).ok_or_else(|| BsdfError::UnknownMetal(name.to_string()))
}

/// A smooth metal: a perfect mirror with the conductor's Fresnel reflectance.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Conductor {
    eta: Vec3,
    k: Vec3,
    specular_reflectance: Vec3,
}

impl Conductor {
    /// A smooth conductor of complex index `eta` + i`k` (every channel
    /// finite and >= 0; errors name the channel).
    pub fn try_new(eta: Vec3, k: Vec3, specular_reflectance: Vec3) -> Result<Conductor, BsdfError> {
        let (eta, k, specular_reflectance) = checked(eta, k, specular_reflectance)?;
        Ok(Conductor {
            eta,
            k,
            specular_reflectance,
        })
    }

    /// The smooth conductor of Mitsuba's material `name` ([`metals::METALS`]).
    pub fn from_metal(name: &str, specular_reflectance: Vec3) -> Result<Conductor, BsdfError> {
        let m = named(name)?;
        Conductor::try_new(m.eta, m.k, specular_reflectance)
    }

    /// The real part η of the complex index, per RGB channel.
    pub fn eta(&self) -> Vec3 {
        self.eta
    }

    /// The extinction coefficient κ, per RGB channel.
    pub fn k(&self) -> Vec3 {
        self.k
    }

    /// The RGB factor on the reflection.
    pub fn specular_reflectance(&self) -> Vec3 {
        self.specular_reflectance
    }

    /// The reflectance at cosine of incidence `cos_theta` (> 0).
    pub fn reflectance(&self, cos_theta: f32) -> Vec3 {
        self.specular_reflectance * fresnel::conductor(cos_theta, self.eta, self.k)
    }

    /// A delta reflection: `f` is zero for every pair of directions.
    pub fn f(&self, _wo: Vec3, _wi: Vec3) -> Vec3 {
        Vec3::ZERO
    }

    /// A delta reflection: no density over directions.
    pub fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
    }

    /// The mirror direction with the Fresnel reflectance as weight (probability 1);
    /// `None` for `wo` at or below the horizon.
    pub fn sample(&self, wo: Vec3) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi: Vec3::new(-wo.x, -wo.y, wo.z),
            weight: self.reflectance(wo.z),
            pdf: 1.0,
            is_transmission: false,
            is_delta: true,
        })
    }
}

/// A rough metal: microfacet reflection with the conductor's Fresnel term.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoughConductor {
    distribution: MicrofacetDistribution,
    eta: Vec3,
    k: Vec3,
    specular_reflectance: Vec3,
}

impl RoughConductor {
    /// A rough conductor of complex index `eta` + i`k`.
    pub fn try_new(
        distribution: MicrofacetDistribution,
        eta: Vec3,
        k: Vec3,
        specular_reflectance: Vec3,
    ) -> Result<RoughConductor, BsdfError> {
        let (eta, k, specular_reflectance) = checked(eta, k, specular_reflectance)?;
        Ok(RoughConductor {
            distribution,
            eta,
            k,
            specular_reflectance,
        })
    }

    /// The rough conductor of Mitsuba's material `name`.
    pub fn from_metal(
        distribution: MicrofacetDistribution,
        name: &str,
        specular_reflectance: Vec3,
    ) -> Result<RoughConductor, BsdfError> {
        let m = named(name)?;
        RoughConductor::try_new(distribution, m.eta, m.k, specular_reflectance)
    }

    /// The microfacet distribution.
    pub fn distribution(&self) -> &MicrofacetDistribution {
        &self.distribution
    }

    /// The real part η of the complex index, per RGB channel.
    pub fn eta(&self) -> Vec3 {
        self.eta
    }

    /// The extinction coefficient κ, per RGB channel.
    pub fn k(&self) -> Vec3 {
        self.k
    }

    /// The RGB factor on the reflection.
    pub fn specular_reflectance(&self) -> Vec3 {
        self.specular_reflectance
    }

    /// The half vector of two directions above the surface that both see
    /// its front (`None` otherwise: f and pdf are 0).
    fn half_vector(wo: Vec3, wi: Vec3) -> Option<Vec3> {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return None;
        }
        let m = (wo + wi).try_normalize()?;
        (wo.dot(m) > 0.0 && wi.dot(m) > 0.0).then_some(m)
    }

    /// The BSDF (without the cosine).
    pub fn f(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let Some(m) = Self::half_vector(wo, wi) else {
            return Vec3::ZERO;
        };
        let dg = self.distribution.d(m) * self.distribution.g(wo, wi, m) / (4.0 * wo.z * wi.z);
        if !dg.is_finite() {
            return Vec3::ZERO;
        }
        self.specular_reflectance * fresnel::conductor(wo.dot(m), self.eta, self.k) * dg
    }

    /// The solid-angle density of [`RoughConductor::sample`]:
    /// D(m) G1(wo, m) / (4 cos θo).
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(m) = Self::half_vector(wo, wi) else {
            return 0.0;
        };
        let pdf = self.distribution.d(m) * self.distribution.g1(wo, m) / (4.0 * wo.z);
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
    }

    /// A visible normal from `u`, reflected; `None` when `wo` is not above
    /// the surface or the reflection goes below it.
    pub fn sample(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let m = self.distribution.sample_visible(wo, u);
        let wi = reflect(wo, m);
        if wi.z <= 0.0 {
            return None;
        }
        let pdf = self.pdf(wo, wi);
        let g1 = self.distribution.g1(wi, m);
        if pdf.is_nan() || pdf <= 0.0 || g1 <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: self.specular_reflectance * fresnel::conductor(wo.dot(m), self.eta, self.k) * g1,
            pdf,
            is_transmission: false,
            is_delta: false,
        })
    }
}
