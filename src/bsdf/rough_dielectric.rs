//! Rough glass: microfacet reflection and transmission at the boundary
//! between two dielectrics (Walter, Marschner, Li and Torrance, "Microfacet
//! models for refraction through rough surfaces", EGSR 2007), as Mitsuba 3's
//! `roughdielectric` (visible-normal sampling).
//!
//! Parameters: a [`MicrofacetDistribution`], and the absolute indices of
//! refraction `ext_ior` on the +z side and `int_ior` on the −z side (they
//! must differ: an index-matched boundary is no boundary, and this model
//! degenerates to a delta there). Both sides are handled: `wo` may be on
//! either. A caller that orients the shading normal towards the incoming
//! ray (as snell's integrator does) passes the nested rule's pair as
//! `ext_ior = n1` (the side the ray travels in) and `int_ior = n2`.
//!
//! Let ηo be the index on `wo`'s side and ηi on `wi`'s. For reflection the
//! half vector is m = ±(wo + wi)/|…| and
//! f = F D G / (4 |cos θo| |cos θi|).
//! For transmission Walter's generalized half vector is
//! h_t = −(ηo wo + ηi wi) / |…| (flipped to m.z > 0), which is the normal of
//! the facet that refracts wo into wi (Snell's law in vector form:
//! ηo wo + ηi wi is along the facet normal), and
//! f = (1 − F) D G ηi² |wo·m| |wi·m| / (|cos θo| |cos θi| (ηo wo·m + ηi wi·m)²),
//! times (ηo/ηi)² in radiance mode (see [`TransportMode`]).
//!
//! The Jacobian of the half-vector map, derived for sampling: let
//! h = ηo wo + ηi wi (unnormalised), m = h/|h|. Moving wi over a solid
//! angle dωi moves h over an area ηi² dωi (wi scaled by ηi), of which the
//! part seen along h is ηi² |wi·m| dωi; the direction of h sweeps that area
//! divided by |h|². Since h ∥ m, |h| = |h·m| = |ηo wo·m + ηi wi·m|, so
//! dω_m/dω_i = ηi² |wi·m| / (ηo wo·m + ηi wi·m)²
//! (for reflection, h = wo + wi and the same argument gives 1 / (4 |wi·m|)),
//! and pdf(wi) = pdf_vis(m) · (F or 1 − F) · dω_m/dω_i. Both are implemented
//! with η = ηi/ηo, i.e. divided through by ηo² (Mitsuba's form).
//!
//! Sampling draws m from the normals visible from wo, then chooses
//! reflection with probability F(wo·m) (the Fresnel term at the sampled
//! facet, as Mitsuba does) and refraction otherwise. The weight is then
//! G1(wi, m), times (ηo/ηi)² for a radiance transmission. A sample whose
//! wi lands on the wrong side of the macrosurface for its lobe (G1 = 0) is
//! returned as `None`: this is exactly the set [`RoughDielectric::pdf`]
//! gives 0, so the density of the returned samples is `pdf`.
//!
//! Departures from Mitsuba 3: `f` excludes the cosine (Mitsuba's `eval`
//! includes |cos θi|); no `specular_reflectance`/`specular_transmittance`
//! factors (Mitsuba's docs advise never to set them); zero-weight samples
//! are `None` instead of samples of weight 0.
use super::fresnel::{self, reflect, refract};
use super::microfacet::MicrofacetDistribution;
use super::{positive, BsdfError, BsdfSample, TransportMode};
use glam::{Vec2, Vec3};

/// A rough dielectric boundary (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoughDielectric {
    distribution: MicrofacetDistribution,
    /// int_ior / ext_ior.
    eta: f32,
    mode: TransportMode,
}

/// The microfacet configuration of a pair of directions, in f64: the two
/// evaluations f(wo, wi) and f(wi, wo) then see the same facet, and the
/// cosines with it obey Snell's law to f64 precision, so that F taken from
/// either side agrees even at the critical angle.
struct Config {
    /// The half vector, m.z > 0 (f32, for D and G).
    m: Vec3,
    /// wi is on the other side from wo.
    transmission: bool,
    /// ηi / ηo: the index of wi's side over wo's.
    eta: f64,
    /// wo·m.
    om: f64,
    /// wi·m.
    im: f64,
    /// Fresnel reflectance at the facet.
    fresnel: f64,
}

impl RoughDielectric {
    /// Rough glass between `ext_ior` (+z side) and `int_ior` (−z side), for
    /// radiance transport. Errors name an index that is not finite and > 0,
    /// or `int_ior` when it equals `ext_ior`.
    pub fn try_new(
        distribution: MicrofacetDistribution,
        ext_ior: f32,
        int_ior: f32,
    ) -> Result<RoughDielectric, BsdfError> {
        let ext = positive("ext_ior", ext_ior)?;
        let int = positive("int_ior", int_ior)?;
        if int == ext {
            return Err(BsdfError::InvalidParameter {
                name: "int_ior",
                value: int,
                requirement: "different from ext_ior (an index-matched boundary scatters nothing)",
            });
        }
        Ok(RoughDielectric {
            distribution,
            eta: int / ext,
            mode: TransportMode::Radiance,
        })
    }

    /// The same boundary for transport `mode`.
    pub fn with_mode(self, mode: TransportMode) -> RoughDielectric {
        RoughDielectric { mode, ..self }
    }

    /// The microfacet distribution.
    pub fn distribution(&self) -> &MicrofacetDistribution {
        &self.distribution
    }

    /// int_ior / ext_ior.
    pub fn eta(&self) -> f32 {
        self.eta
    }

    /// The transport mode.
    pub fn mode(&self) -> TransportMode {
        self.mode
    }

    /// The half vector of (wo, wi) and which lobe they belong to; `None` for
    /// grazing directions, a degenerate half vector, or a facet that one of
    /// the two sees from the wrong side (G1 = 0: f and pdf are 0).
    fn config(&self, wo: Vec3, wi: Vec3) -> Option<Config> {
        let (o, i) = (wo.as_dvec3().try_normalize()?, wi.as_dvec3().try_normalize()?);
        if o.z == 0.0 || i.z == 0.0 {
            return None;
        }
        let transmission = o.z * i.z < 0.0;
        let eta_int = f64::from(self.eta);
        let eta = if o.z > 0.0 { eta_int } else { 1.0 / eta_int };
        let h = if transmission { o + i * eta } else { o + i };
        let m = h.try_normalize()?;
        let m = if m.z < 0.0 { -m } else { m };
        let (om, im) = (o.dot(m), i.dot(m));
        if om * o.z <= 0.0 || im * i.z <= 0.0 {
            return None;
        }
        Some(Config {
            m: m.as_vec3(),
            transmission,
            eta,
            om,
            im,
            fresnel: fresnel::dielectric_reflectance(om, eta_int),
        })
    }

    /// The radiance factor of a transmission into index ratio `eta` = ηi/ηo.
    fn transmission_scale(&self, eta: f64) -> f64 {
        match self.mode {
            TransportMode::Radiance => 1.0 / (eta * eta),
            TransportMode::Importance => 1.0,
        }
    }

    /// The BSDF (without the cosine) for light arriving along `wi` and
    /// leaving along `wo`; the same in all three channels.
    pub fn f(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let Some(c) = self.config(wo, wi) else {
            return Vec3::ZERO;
        };
        let dg = f64::from(self.distribution.d(c.m) * self.distribution.g(wo, wi, c.m));
        let cos = f64::from(wo.z * wi.z).abs();
        let value = if c.transmission {
            let denom = c.om + c.eta * c.im;
            self.transmission_scale(c.eta) * (1.0 - c.fresnel) * dg * c.eta * c.eta * (c.om * c.im).abs()
                / (cos * denom * denom)
        } else {
            c.fresnel * dg / (4.0 * cos)
        };
        Vec3::splat(if value.is_finite() { value as f32 } else { 0.0 })
    }

    /// The solid-angle density with which [`RoughDielectric::sample`]
    /// returns `wi`.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let Some(c) = self.config(wo, wi) else {
            return 0.0;
        };
        let pdf_m = f64::from(self.distribution.pdf(wo, c.m));
        let pdf = if c.transmission {
            let denom = c.om + c.eta * c.im;
            pdf_m * (1.0 - c.fresnel) * c.eta * c.eta * c.im.abs() / (denom * denom)
        } else {
            pdf_m * c.fresnel / (4.0 * c.im.abs())
        };
        if pdf.is_finite() {
            pdf as f32
        } else {
            0.0
        }
    }

    /// Draw `wi` for `wo`: a visible normal from `u`, then reflection if
    /// `u_lobe` ≤ F at that facet, else refraction. `None` for grazing `wo`
    /// and for directions that leave on the wrong side of the macrosurface.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z == 0.0 {
            return None;
        }
        let m = self.distribution.sample_visible(wo, u);
        let pdf_m = self.distribution.pdf(wo, m);
        if pdf_m <= 0.0 || !pdf_m.is_finite() {
            return None;
        }
        let fr = fresnel::dielectric(wo.dot(m), self.eta);
        let (wi, pdf, weight, is_transmission) = if u_lobe <= fr.r {
            let wi = reflect(wo, m);
            let pdf = pdf_m * fr.r / (4.0 * wi.dot(m).abs());
            (wi, pdf, 1.0, false)
        } else {
            let wi = refract(wo, m, fr.cos_theta_t, fr.eta_ti);
            let (om, im) = (wo.dot(m), wi.dot(m));
            let denom = om + fr.eta_it * im;
            let pdf = pdf_m * (1.0 - fr.r) * fr.eta_it * fr.eta_it * im.abs() / (denom * denom);
            (
                wi,
                pdf,
                self.transmission_scale(f64::from(fr.eta_it)) as f32,
                true,
            )
        };
        let g1 = self.distribution.g1(wi, m);
        if g1 <= 0.0 || !(pdf > 0.0 && pdf.is_finite()) || (wi.z * wo.z < 0.0) != is_transmission {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: Vec3::splat(weight * g1),
            pdf,
            is_transmission,
            is_delta: false,
        })
    }
}
