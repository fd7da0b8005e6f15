//! Plastics: a diffuse base under a dielectric coating, smooth ([`Plastic`],
//! Mitsuba 3's `plastic`) or rough ([`RoughPlastic`], `roughplastic`), with
//! the light trapped between base and coating summed in closed form.
//!
//! Parameters ([`PlasticParams`], Mitsuba's names and defaults):
//! `int_ior` (1.49, polypropylene) and `ext_ior` (1.000277, air): the
//! coating's and the outer medium's indices; `diffuse_reflectance` (0.5):
//! the base's albedo per RGB channel, in [0, 1]; `specular_reflectance` (1):
//! a factor on the coating's reflection (1 is physical); `nonlinear`
//! (false): whether the internal scattering darkens and saturates the base
//! colour (true: ρ / (1 − ρ F_dr,int)) or is a constant factor that keeps
//! texture colours (false: ρ / (1 − F_dr,int)). The rough one adds an
//! isotropic [`MicrofacetDistribution`] for the coating.
//!
//! Both are one-sided (+z), as in Mitsuba. With η = int/ext and F the
//! dielectric Fresnel reflectance:
//!
//! - Smooth: a delta reflection of weight spec · F(cos θo), and a diffuse
//!   lobe f = ρ' (1 − F(cos θo)) (1 − F(cos θi)) / (π η²) with
//!   ρ' the base albedo after internal scattering. The 1/η² is the
//!   radiance compression of light leaving the denser coating.
//! - Rough: the rough-conductor-like coating lobe F D G / (4 cos θo cos θi)
//!   (dielectric F), plus the diffuse lobe with 1 − F replaced by the rough
//!   coating's transmittance T(cos θ): a 64-entry table of
//!   E_m[(1 − F(wi·m)) G1(wt, m)] over visible normals (Gauss–Legendre
//!   quadrature), and F_dr,int by the coating's internal rough reflectance,
//!   as Mitsuba tabulates them.
//!
//! Sampling chooses the coating lobe with Mitsuba's probability
//! p = F·s / (F·s + (1 − F)(1 − s)), where s = mean(spec) / (mean(ρ) +
//! mean(spec)) and F = F(cos θo) (smooth) or 1 − T(cos θo) (rough); else
//! the diffuse lobe by cosine-weighted sampling. The smooth plastic's `pdf`
//! is its diffuse lobe's density times 1 − p (the delta lobe has none); the
//! rough one's is the mixture of both lobes' densities.
//!
//! Departures from Mitsuba 3: `f` excludes the cosine; samples are drawn on
//! the disk by the polar map where Mitsuba uses the concentric one (same
//! density); a rough sample below the surface is `None`; a diffuse albedo
//! above 1 is an error (Mitsuba accepts it, and with `nonlinear` the
//! factor 1 / (1 − ρ F_dr) can then blow up); the rough coating's tables
//! are computed in f64 quadrature weights and f32 samples like Mitsuba's,
//! but GGX's visible normals are mapped differently (see
//! [`super::microfacet`]), so they agree with Mitsuba's to the rules'
//! accuracy, not bit for bit.
use super::fresnel::{self, reflect, refract};
use super::microfacet::MicrofacetDistribution;
use super::quadrature::gauss_legendre;
use super::{non_negative_rgb, positive, BsdfError, BsdfSample};
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};
use std::sync::Arc;

/// A plastic's parameters (Mitsuba's names and defaults).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlasticParams {
    /// Index of refraction of the coating.
    pub int_ior: f32,
    /// Index of refraction of the outer medium.
    pub ext_ior: f32,
    /// Albedo of the diffuse base per RGB channel, in [0, 1].
    pub diffuse_reflectance: Vec3,
    /// Factor on the coating's reflection per RGB channel (1 is physical).
    pub specular_reflectance: Vec3,
    /// Internal scattering shifts the base colour (see the module documentation).
    pub nonlinear: bool,
}

impl Default for PlasticParams {
    /// Mitsuba's defaults: white-ish polypropylene in air.
    fn default() -> Self {
        PlasticParams {
            int_ior: 1.49,
            ext_ior: 1.000277,
            diffuse_reflectance: Vec3::splat(0.5),
            specular_reflectance: Vec3::ONE,
            nonlinear: false,
        }
    }
}

/// What a plastic's `f`, `pdf` and `sample` are made of, for code that
/// evaluates the same model elsewhere (the path tracer's vector lanes).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlasticTerms {
    /// int_ior / ext_ior.
    pub eta: f32,
    /// The base albedo after internal scattering (ρ').
    pub base: Vec3,
    /// The factor on the coating's reflection.
    pub specular: Vec3,
    /// Mitsuba's lobe weight s (see the module documentation).
    pub specular_sampling_weight: f32,
}

/// The checked parameters both plastics share.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Coating {
    /// int_ior / ext_ior.
    eta: f32,
    inv_eta_2: f32,
    diffuse: Vec3,
    specular: Vec3,
    nonlinear: bool,
    /// s = mean(spec) / (mean(ρ) + mean(spec)), Mitsuba's lobe weight.
    specular_sampling_weight: f32,
}

impl Coating {
    fn try_new(p: &PlasticParams) -> Result<Coating, BsdfError> {
        let int = positive("int_ior", p.int_ior)?;
        let ext = positive("ext_ior", p.ext_ior)?;
        let diffuse = non_negative_rgb(
            [
                "diffuse_reflectance.r",
                "diffuse_reflectance.g",
                "diffuse_reflectance.b",
            ],
            p.diffuse_reflectance,
        )?;
        for (name, v) in [
            "diffuse_reflectance.r",
            "diffuse_reflectance.g",
            "diffuse_reflectance.b",
        ]
        .into_iter()
        .zip(diffuse.to_array())
        {
            if v > 1.0 {
                return Err(BsdfError::InvalidParameter {
                    name,
                    value: v,
                    requirement: "<= 1 (an albedo)",
                });
            }
        }
        let specular = non_negative_rgb(
            [
                "specular_reflectance.r",
                "specular_reflectance.g",
                "specular_reflectance.b",
            ],
            p.specular_reflectance,
        )?;
        let (d_mean, s_mean) = (diffuse.element_sum() / 3.0, specular.element_sum() / 3.0);
        if d_mean + s_mean <= 0.0 {
            return Err(BsdfError::InvalidParameter {
                name: "diffuse_reflectance",
                value: d_mean,
                requirement: "> 0 on average when specular_reflectance is 0 (nothing to sample)",
            });
        }
        let eta = int / ext;
        Ok(Coating {
            eta,
            inv_eta_2: 1.0 / (eta * eta),
            diffuse,
            specular,
            nonlinear: p.nonlinear,
            specular_sampling_weight: s_mean / (d_mean + s_mean),
        })
    }

    /// The base albedo after internal scattering, for the coating's internal
    /// diffuse reflectance `fdr_int`.
    fn base(&self, fdr_int: f32) -> Vec3 {
        let trapped = if self.nonlinear {
            self.diffuse * fdr_int
        } else {
            Vec3::splat(fdr_int)
        };
        self.diffuse / (Vec3::ONE - trapped)
    }

    fn terms(&self, fdr_int: f32) -> PlasticTerms {
        PlasticTerms {
            eta: self.eta,
            base: self.base(fdr_int),
            specular: self.specular,
            specular_sampling_weight: self.specular_sampling_weight,
        }
    }

    /// The probability of the coating lobe when it reflects `r` of the
    /// light arriving along wo.
    fn prob_specular(&self, r: f32) -> f32 {
        let s = self.specular_sampling_weight;
        let (ps, pd) = (r * s, (1.0 - r) * (1.0 - s));
        if ps + pd > 0.0 {
            ps / (ps + pd)
        } else {
            0.0
        }
    }
}

/// A cosine-weighted direction on the upper hemisphere (polar map).
fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let r = u.x.sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), (1.0 - u.x).max(0.0).sqrt())
}

/// A smooth plastic: a delta coating reflection over a diffuse base.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plastic {
    coating: Coating,
    /// F_dr of the coating seen from inside (Mitsuba's fit).
    fdr_int: f32,
}

impl Plastic {
    /// A smooth plastic. Errors name the parameter: indices finite and > 0,
    /// reflectances finite and >= 0, diffuse albedo <= 1.
    pub fn try_new(params: &PlasticParams) -> Result<Plastic, BsdfError> {
        let coating = Coating::try_new(params)?;
        Ok(Plastic {
            fdr_int: fresnel::diffuse_reflectance(1.0 / coating.eta),
            coating,
        })
    }

    fn fresnel(&self, cos: f32) -> f32 {
        fresnel::dielectric(cos, self.coating.eta).r
    }

    /// The terms of its lobes.
    pub fn terms(&self) -> PlasticTerms {
        self.coating.terms(self.fdr_int)
    }

    /// The diffuse lobe (the delta lobe has no `f`), without the cosine.
    pub fn f(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let c = &self.coating;
        c.base(self.fdr_int)
            * (FRAC_1_PI * c.inv_eta_2 * (1.0 - self.fresnel(wo.z)) * (1.0 - self.fresnel(wi.z)))
    }

    /// The density of the diffuse samples: (1 − p) cos θi / π.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        (1.0 - self.coating.prob_specular(self.fresnel(wo.z))) * wi.z * FRAC_1_PI
    }

    /// The delta reflection if `u_lobe` < p, else a cosine-weighted
    /// diffuse direction from `u`; `None` for `wo` at or below the horizon.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let c = &self.coating;
        let f_o = self.fresnel(wo.z);
        let ps = c.prob_specular(f_o);
        if u_lobe < ps {
            return Some(BsdfSample {
                wi: Vec3::new(-wo.x, -wo.y, wo.z),
                weight: c.specular * (f_o / ps),
                pdf: ps,
                is_transmission: false,
                is_delta: true,
            });
        }
        let wi = cosine_hemisphere(u);
        let pd = 1.0 - ps;
        if wi.z <= 0.0 || pd <= 0.0 {
            return None;
        }
        let f_i = self.fresnel(wi.z);
        Some(BsdfSample {
            wi,
            weight: c.base(self.fdr_int) * (c.inv_eta_2 * (1.0 - f_o) * (1.0 - f_i) / pd),
            pdf: pd * wi.z * FRAC_1_PI,
            is_transmission: false,
            is_delta: false,
        })
    }
}

/// Entries of the rough coating's transmittance table (Mitsuba's
/// `MI_ROUGH_TRANSMITTANCE_RES`), over cos θ = 0, 1/63, …, 1.
const TABLE_SIZE: usize = 64;

/// A rough plastic: a microfacet coating over a diffuse base.
#[derive(Debug, Clone, PartialEq)]
pub struct RoughPlastic {
    coating: Coating,
    distribution: MicrofacetDistribution,
    /// T(cos θ) of the coating from outside, at cos θ = i / 63 (shared by
    /// the plastics [`RoughPlastic::with_base`] makes).
    external_transmittance: Arc<[f32]>,
    /// The coating's internal rough diffuse reflectance.
    internal_reflectance: f32,
}

impl RoughPlastic {
    /// A rough plastic. Errors as [`Plastic::try_new`], and for an
    /// anisotropic distribution (as Mitsuba, which tabulates an isotropic
    /// coating) or equal indices. Tabulates the coating: about 10⁶
    /// visible-normal samples by Mitsuba's quadrature rules, 0.06 s for GGX
    /// and 0.6 s for Beckmann (an iterative sampler) on one core; reuse a
    /// coating over other bases with [`RoughPlastic::with_base`].
    pub fn try_new(
        params: &PlasticParams,
        distribution: MicrofacetDistribution,
    ) -> Result<RoughPlastic, BsdfError> {
        let coating = Coating::try_new(params)?;
        if !distribution.is_isotropic() {
            return Err(BsdfError::InvalidParameter {
                name: "alpha_v",
                value: distribution.alpha_v(),
                requirement: "equal to alpha_u (the rough plastic's coating is isotropic)",
            });
        }
        if coating.eta == 1.0 {
            return Err(BsdfError::InvalidParameter {
                name: "int_ior",
                value: params.int_ior,
                requirement: "different from ext_ior",
            });
        }
        let outer = unit_square_rule(coating.eta > 1.0);
        let inner = unit_square_rule(coating.eta < 1.0);
        let external_transmittance = (0..TABLE_SIZE)
            .map(|i| coating_transmittance(&distribution, table_cos(i), coating.eta, &outer))
            .collect();
        // 2 ∫ R(μ) μ dμ by Mitsuba's rule: the mean over the table's cosines.
        let internal_reflectance = 2.0
            * (0..TABLE_SIZE)
                .map(|i| {
                    let mu = table_cos(i);
                    coating_reflectance(&distribution, mu, 1.0 / coating.eta, &inner) * mu
                })
                .sum::<f32>()
            / TABLE_SIZE as f32;
        Ok(RoughPlastic {
            coating,
            distribution,
            external_transmittance,
            internal_reflectance,
        })
    }

    /// The same coating over another base: its tables depend only on the
    /// roughness and the indices, so they are shared, not recomputed (a
    /// textured plastic needs this per texel). Errors as
    /// [`Plastic::try_new`] for the reflectances.
    pub fn with_base(
        &self,
        diffuse_reflectance: Vec3,
        specular_reflectance: Vec3,
        nonlinear: bool,
    ) -> Result<RoughPlastic, BsdfError> {
        let coating = Coating::try_new(&PlasticParams {
            int_ior: self.coating.eta,
            ext_ior: 1.0,
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
        })?;
        Ok(RoughPlastic {
            coating,
            ..self.clone()
        })
    }

    /// The coating's microfacet distribution.
    pub fn distribution(&self) -> &MicrofacetDistribution {
        &self.distribution
    }

    /// The coating's transmittance T(cos θ) from outside, interpolated.
    pub fn transmittance(&self, cos_theta: f32) -> f32 {
        let x = cos_theta.clamp(0.0, 1.0) * (TABLE_SIZE - 1) as f32;
        let i = (x as usize).min(TABLE_SIZE - 2);
        let t = &self.external_transmittance;
        t[i] + (t[i + 1] - t[i]) * (x - i as f32)
    }

    /// The terms of its lobes (with [`RoughPlastic::distribution`] and
    /// [`RoughPlastic::transmittance`]).
    pub fn terms(&self) -> PlasticTerms {
        self.coating.terms(self.internal_reflectance)
    }

    /// The coating's internal diffuse reflectance (Mitsuba's tabulated value).
    pub fn internal_reflectance(&self) -> f32 {
        self.internal_reflectance
    }

    /// Both lobes, without the cosine.
    pub fn f(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Vec3::ZERO;
        }
        let c = &self.coating;
        let mut value = Vec3::ZERO;
        if let Some(h) = (wo + wi).try_normalize() {
            let dist = &self.distribution;
            let spec =
                fresnel::dielectric(wo.dot(h), c.eta).r * dist.d(h) * dist.g(wo, wi, h) / (4.0 * wo.z * wi.z);
            if spec.is_finite() {
                value += c.specular * spec;
            }
        }
        let t = self.transmittance(wo.z) * self.transmittance(wi.z);
        value + c.base(self.internal_reflectance) * (FRAC_1_PI * c.inv_eta_2 * t)
    }

    /// The probability of the coating lobe for `wo`.
    fn prob_specular(&self, wo: Vec3) -> f32 {
        self.coating.prob_specular(1.0 - self.transmittance(wo.z))
    }

    /// The mixture density p·D(h) G1(wo, h) / (4 cos θo) + (1 − p) cos θi / π.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let ps = self.prob_specular(wo);
        let spec = match (wo + wi).try_normalize() {
            Some(h) => self.distribution.d(h) * self.distribution.g1(wo, h) / (4.0 * wo.z),
            None => 0.0,
        };
        let spec = if spec.is_finite() { spec } else { 0.0 };
        ps * spec + (1.0 - ps) * wi.z * FRAC_1_PI
    }

    /// The coating lobe (a visible normal from `u`, reflected) if `u_lobe`
    /// < p, else a cosine-weighted direction from `u`; weight f cos / pdf
    /// with the mixture pdf. `None` when wo or the sample is not above the surface.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u_lobe < self.prob_specular(wo) {
            reflect(wo, self.distribution.sample_visible(wo, u))
        } else {
            cosine_hemisphere(u)
        };
        let pdf = self.pdf(wo, wi);
        if wi.z <= 0.0 || pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            weight: self.f(wo, wi) * (wi.z / pdf),
            pdf,
            is_transmission: false,
            is_delta: false,
        })
    }
}

/// The table's i-th cosine (Mitsuba keeps it off exact grazing).
fn table_cos(i: usize) -> f32 {
    (i as f32 / (TABLE_SIZE - 1) as f32).max(1e-6)
}

/// A tensor Gauss–Legendre rule on [0, 1]², weights summing to 1: Mitsuba
/// uses 32 nodes per axis when light enters the denser side, 128 otherwise
/// (total internal reflection makes the integrand less smooth).
fn unit_square_rule(denser: bool) -> Vec<(Vec2, f32)> {
    let (x, w) = gauss_legendre(if denser { 32 } else { 128 });
    let mut rule = Vec::with_capacity(x.len() * x.len());
    for (xa, wa) in x.iter().zip(&w) {
        for (xb, wb) in x.iter().zip(&w) {
            let u = Vec2::new((xa * 0.5 + 0.5) as f32, (xb * 0.5 + 0.5) as f32);
            rule.push((u, (wa * wb * 0.25) as f32));
        }
    }
    rule
}

/// The rough coating's transmittance for light arriving at cos θ = `mu`
/// with relative index `eta`: E over visible normals m of (1 − F(wi·m)) G1(wt, m),
/// by `rule`.
fn coating_transmittance(dist: &MicrofacetDistribution, mu: f32, eta: f32, rule: &[(Vec2, f32)]) -> f32 {
    let wi = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    rule.iter()
        .map(|&(u, w)| {
            let m = dist.sample_visible(wi, u);
            let fr = fresnel::dielectric(wi.dot(m), eta);
            let wt = refract(wi, m, fr.cos_theta_t, fr.eta_ti);
            if wt.z * wi.z >= 0.0 {
                0.0
            } else {
                w * (1.0 - fr.r) * dist.g1(wt, m)
            }
        })
        .sum()
}

/// The rough coating's reflectance for light arriving at cos θ = `mu` with
/// relative index `eta`: E over visible normals of F(wi·m) G1(wr, m), by `rule`.
fn coating_reflectance(dist: &MicrofacetDistribution, mu: f32, eta: f32, rule: &[(Vec2, f32)]) -> f32 {
    let wi = Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    rule.iter()
        .map(|&(u, w)| {
            let m = dist.sample_visible(wi, u);
            let wr = reflect(wi, m);
            if wr.z <= 0.0 {
                0.0
            } else {
                w * fresnel::dielectric(wi.dot(m), eta).r * dist.g1(wr, m)
            }
        })
        .sum()
}
