//! Plastics in vector lanes: the sampling and the evaluation of a smooth
//! [`Plastic`](crate::bsdf::Plastic) and of a GGX [`RoughPlastic`] as the
//! path tracer uses them through `scatter::Micro` (the frame about the
//! oriented shading normal, the geometric-side checks), for every lane at
//! once, in f32, each lane smooth or rough.
//!
//! Each lane is one hit: the incident direction, the shading normal
//! oriented to the incident side, the geometric normal on that side and
//! the plastic's [`PlasticTerms`] (index ratio, base albedo after internal
//! scattering, coating reflectance factor, lobe weight), and at rough
//! lanes the GGX roughness and the coating itself. The steps are
//! `Micro::sample` and `Micro::eval` with `Plastic::{sample, f, pdf}` and
//! `RoughPlastic::{sample, f, pdf}` operation for operation (the same lobe
//! choice from the first number, the same directions from the other two),
//! so a lane's direction, weight and density are the scalar's up to
//! rounding, given the same uniform numbers.
//!
//! The rough coating's transmittance T(cos θ) is the scalar model's own
//! table lookup (`RoughPlastic::transmittance`) lane by lane: pulp has no
//! gather, and a lookup is a few scalar operations. The Fresnel factors are
//! [`super::rough`]'s f32 closed form (the scalar code's are f64), 1 − F
//! from its own closed form. Beckmann coatings stay scalar
//! ([`PlasticLaneParams::of`]).

use super::ggx::{self, finite, neg, Frame, Ggx, ReflectionSample};
use super::lane_math::sincos_turns;
use super::rough::{self, fresnel};
use crate::bsdf::plastic::PlasticTerms;
use crate::bsdf::RoughPlastic;
use crate::scene::Material;
use crate::simd3::{add, dot, scale, select, sub, Vec3s};
use std::f32::consts::FRAC_1_PI;

/// The most f32 lanes of a vector at any level (AVX-512's 16).
pub(super) const WIDEST: usize = 16;

/// One lane's plastic as the caller gathers it from its material.
#[derive(Clone, Copy, Debug)]
pub(super) struct PlasticLaneParams<'a> {
    pub terms: PlasticTerms,
    /// The coating's GGX roughness (1 at a smooth plastic, where it is not
    /// used).
    pub alpha: f32,
    /// A rough plastic's coating (its transmittance table); `None`: smooth.
    pub rough: Option<&'a std::sync::Arc<RoughPlastic>>,
    /// Reflects on both sides (else black seen from behind).
    pub two_sided: bool,
}

impl<'a> PlasticLaneParams<'a> {
    /// The parameters of `material` if it is a plastic the lanes model: a
    /// smooth one, or a rough one with a GGX coating.
    pub fn of(material: &'a Material) -> Option<PlasticLaneParams<'a>> {
        match material {
            Material::Plastic { bsdf, two_sided } => Some(PlasticLaneParams {
                terms: bsdf.terms(),
                alpha: 1.0,
                rough: None,
                two_sided: *two_sided,
            }),
            Material::RoughPlastic { bsdf, two_sided } => {
                let d = bsdf.distribution();
                ggx::supports(d).then(|| PlasticLaneParams {
                    terms: bsdf.terms(),
                    alpha: d.alpha_u(),
                    rough: Some(bsdf),
                    two_sided: *two_sided,
                })
            }
            _ => None,
        }
    }
}

/// Plastics at one hit per lane (`scatter::Micro` of a `Plastic` or a
/// `RoughPlastic`), in the shading frame `Frame::from_normal` builds.
pub(super) struct PlasticLanes<'a, S: pulp::Simd> {
    frame: Frame<S>,
    /// The direction back along the incident ray, local.
    wo: Vec3s<S>,
    /// The geometric normal on the incident side.
    side: Vec3s<S>,
    eta: S::f32s,
    base: Vec3s<S>,
    spec: Vec3s<S>,
    ggx: Ggx<S>,
    /// Smooth lanes; the others are rough.
    smooth: S::m32s,
    /// Each lane's rough coating (`None` at the others), for its table.
    coats: &'a [Option<&'a RoughPlastic>],
    /// What the coating reflects of light along wo, and lets through:
    /// F(cos θo) and 1 − F (smooth), 1 − T(cos θo) and T (rough).
    r_o: S::f32s,
    t_o: S::f32s,
    /// The coating lobe's probability (`Coating::prob_specular`).
    ps: S::f32s,
    variant: Variant,
}

/// The model, or one of the known-wrong variants that show the tests'
/// power.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Variant {
    Right,
    /// The coating's Fresnel reflectance halved (its transmittance 1 − F/2)
    /// wherever it is computed (the rough coating's tables are not).
    HalfFresnel,
    /// The diffuse lobe without the radiance compression 1/η².
    NoEta2,
}

impl<'a, S: pulp::Simd> PlasticLanes<'a, S> {
    /// The plastic met along unit `d` (world) with unit shading normal `n`
    /// oriented towards the incident side (against `d`, but where it leans
    /// past the surface), `side` the geometric normal on the incident side,
    /// the lanes' [`PlasticTerms`] (`eta`, `base`, `spec`, `weight`: the
    /// specular sampling weight), the GGX roughness (rough lanes; any
    /// finite positive value at smooth ones), which lanes are `smooth`, and
    /// each lane's rough coating (`coats`, one entry per lane of the
    /// vector; `None` at smooth lanes and lanes of other kinds).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        simd: S,
        d: Vec3s<S>,
        n: Vec3s<S>,
        side: Vec3s<S>,
        eta: S::f32s,
        base: Vec3s<S>,
        spec: Vec3s<S>,
        weight: S::f32s,
        alpha: S::f32s,
        smooth: S::m32s,
        coats: &'a [Option<&'a RoughPlastic>],
        variant: Variant,
    ) -> Self {
        let zero = simd.splat_f32s(0.0);
        let one = simd.splat_f32s(1.0);
        let frame = Frame::new(simd, n);
        let mut lanes = PlasticLanes {
            wo: frame.to_local(simd, neg(simd, d)),
            frame,
            side,
            eta,
            base,
            spec,
            ggx: Ggx {
                alpha_u: alpha,
                alpha_v: alpha,
            },
            smooth,
            coats,
            r_o: zero,
            t_o: zero,
            ps: zero,
            variant,
        };
        let cos_o = lanes.wo[2];
        let f = lanes.fresnel(simd, cos_o);
        let t = lanes.transmittance(simd, cos_o);
        lanes.r_o = simd.select_f32s(smooth, f.r, simd.sub_f32s(one, t));
        lanes.t_o = simd.select_f32s(smooth, f.t, t);
        // Mitsuba's p = F s / (F s + (1 − F)(1 − s)), 0 where both vanish.
        let a = simd.mul_f32s(lanes.r_o, weight);
        let b = simd.mul_f32s(lanes.t_o, simd.sub_f32s(one, weight));
        let sum = simd.add_f32s(a, b);
        lanes.ps = simd.select_f32s(simd.greater_than_f32s(sum, zero), simd.div_f32s(a, sum), zero);
        lanes
    }

    /// The coating's Fresnel factors at the cosine `c` (`fresnel::dielectric`).
    #[inline(always)]
    fn fresnel(&self, simd: S, c: S::f32s) -> rough::Fresnel<S> {
        let v = if self.variant == Variant::HalfFresnel {
            rough::Variant::HalfFresnel
        } else {
            rough::Variant::Right
        };
        fresnel(simd, c, self.eta, None, v)
    }

    /// The rough lanes' T(`cos`) (0 at the others), looked up lane by lane.
    #[inline(always)]
    fn transmittance(&self, simd: S, cos: S::f32s) -> S::f32s {
        if self.coats.iter().all(Option::is_none) {
            return simd.splat_f32s(0.0);
        }
        let mut c = [0.0f32; WIDEST];
        let c = &mut c[..S::F32_LANES];
        simd.partial_store_f32s(c, cos);
        for (x, coat) in c.iter_mut().zip(self.coats) {
            *x = coat.map_or(0.0, |p| p.transmittance(*x));
        }
        simd.partial_load_f32s(c)
    }

    /// f(wo, `wi`) per RGB channel, without the cosine, and the density of
    /// the lobes' mixture at local `wi`: `Plastic::{f, pdf}` at smooth
    /// lanes, `RoughPlastic::{f, pdf}` at rough ones; 0 unless both
    /// directions are above the surface.
    #[inline(always)]
    fn f_pdf(&self, simd: S, wi: Vec3s<S>) -> (Vec3s<S>, S::f32s) {
        let zero = simd.splat_f32s(0.0);
        let one = simd.splat_f32s(1.0);
        let four = simd.splat_f32s(4.0);
        let wo = self.wo;
        let up = simd.and_m32s(
            simd.greater_than_f32s(wo[2], zero),
            simd.greater_than_f32s(wi[2], zero),
        );
        let smooth = self.smooth;

        // The diffuse lobe: ρ' (1/π)(1/η²) t(wo) t(wi).
        let t_i = simd.select_f32s(
            smooth,
            self.fresnel(simd, wi[2]).t,
            self.transmittance(simd, wi[2]),
        );
        let k = if self.variant == Variant::NoEta2 {
            simd.splat_f32s(FRAC_1_PI)
        } else {
            let inv_eta_2 = simd.div_f32s(one, simd.mul_f32s(self.eta, self.eta));
            simd.mul_f32s(simd.splat_f32s(FRAC_1_PI), inv_eta_2)
        };
        let k = simd.mul_f32s(simd.mul_f32s(k, self.t_o), t_i);
        let diffuse = scale(simd, self.base, k);
        let pdf_d = simd.mul_f32s(
            simd.mul_f32s(simd.sub_f32s(one, self.ps), wi[2]),
            simd.splat_f32s(FRAC_1_PI),
        );

        // The rough coating: F D G / (4 cos θo cos θi) at the half vector,
        // and its density D G1(wo) / (4 cos θo) where it is finite.
        let h = add(simd, wo, wi);
        // `try_normalize`: a finite, positive reciprocal length.
        let rcp = simd.div_f32s(one, simd.sqrt_f32s(dot(simd, h, h)));
        let hok = simd.and_m32s(finite(simd, rcp), simd.greater_than_f32s(rcp, zero));
        let h = scale(simd, h, rcp);
        let d = self.ggx.d(simd, h);
        let g1o = self.ggx.g1(simd, wo, h);
        let g = simd.mul_f32s(g1o, self.ggx.g1(simd, wi, h));
        let fr = self.fresnel(simd, dot(simd, wo, h)).r;
        let coat = simd.div_f32s(
            simd.mul_f32s(simd.mul_f32s(fr, d), g),
            simd.mul_f32s(simd.mul_f32s(four, wo[2]), wi[2]),
        );
        let rough = simd.and_m32s(simd.not_m32s(smooth), hok);
        let coat = simd.select_f32s(simd.and_m32s(rough, finite(simd, coat)), coat, zero);
        let pdf_c = simd.div_f32s(simd.mul_f32s(d, g1o), simd.mul_f32s(four, wo[2]));
        let pdf_c = simd.select_f32s(simd.and_m32s(rough, finite(simd, pdf_c)), pdf_c, zero);

        let f = add(simd, scale(simd, self.spec, coat), diffuse);
        let pdf = simd.add_f32s(simd.mul_f32s(self.ps, pdf_c), pdf_d);
        let keep = |x: S::f32s| simd.select_f32s(up, x, zero);
        ([keep(f[0]), keep(f[1]), keep(f[2])], keep(pdf))
    }

    /// `Micro::sample` given its three uniform numbers in its order: the
    /// coating lobe where `u_lobe` < p (the mirror direction at a smooth
    /// lane, a visible normal from `u1`, `u2` reflected at a rough one),
    /// else a cosine-weighted direction from `u1`, `u2` (the polar map).
    #[inline(always)]
    pub fn sample(&self, simd: S, u_lobe: S::f32s, u1: S::f32s, u2: S::f32s) -> ReflectionSample<S> {
        let zero = simd.splat_f32s(0.0);
        let one = simd.splat_f32s(1.0);
        let wo = self.wo;
        let coat = simd.less_than_f32s(u_lobe, self.ps);
        let delta = simd.and_m32s(coat, self.smooth);

        // The smooth coating: the mirror direction.
        let wm = [simd.neg_f32s(wo[0]), simd.neg_f32s(wo[1]), wo[2]];
        // The rough coating: a visible normal, reflected (`fresnel::reflect`).
        let m = self.ggx.sample_visible(simd, wo, u1, u2);
        let om = dot(simd, wo, m);
        let wr = sub(simd, scale(simd, m, simd.mul_f32s(simd.splat_f32s(2.0), om)), wo);
        // The diffuse lobe (`plastic::cosine_hemisphere`).
        let r = simd.sqrt_f32s(u1);
        let (sin, cos) = sincos_turns(simd, u2);
        let wd = [
            simd.mul_f32s(r, cos),
            simd.mul_f32s(r, sin),
            simd.sqrt_f32s(simd.max_f32s(simd.sub_f32s(one, u1), zero)),
        ];
        let wi = select(simd, coat, select(simd, self.smooth, wm, wr), wd);

        // f cos θi / pdf from the lobes' mixture; the delta reflection's
        // spec F / p, its probability as density.
        let (f, pdf) = self.f_pdf(simd, wi);
        let drawn = simd.and_m32s(
            simd.greater_than_f32s(wi[2], zero),
            simd.greater_than_f32s(pdf, zero),
        );
        let kd = simd.div_f32s(self.r_o, self.ps);
        ReflectionSample {
            wi,
            weight: select(
                simd,
                delta,
                scale(simd, self.spec, kd),
                scale(simd, f, simd.div_f32s(wi[2], pdf)),
            ),
            pdf: simd.select_f32s(delta, self.ps, pdf),
            delta,
            valid: simd.and_m32s(simd.or_m32s(delta, drawn), simd.greater_than_f32s(wo[2], zero)),
        }
        .in_world(simd, self.frame, self.side)
    }

    /// `Micro::eval`: f(wo, wi)·|cos θi| per RGB channel and the density
    /// of [`PlasticLanes::sample`] at the unit world direction `wi` (the
    /// smooth coating's delta lobe has none); 0 where the geometric normal
    /// puts `wi` on the other side from the shading frame's, and where
    /// `wo` or `wi` is below the shading frame (one-sided).
    #[inline(always)]
    pub fn eval(&self, simd: S, wi: Vec3s<S>) -> (Vec3s<S>, S::f32s) {
        let zero = simd.splat_f32s(0.0);
        let local = self.frame.to_local(simd, wi);
        let geometric_reflection = simd.greater_than_f32s(dot(simd, wi, self.side), zero);
        let shading_reflection = simd.greater_than_f32s(simd.mul_f32s(local[2], self.wo[2]), zero);
        let ok = simd.not_m32s(simd.xor_m32s(geometric_reflection, shading_reflection));
        let (f, pdf) = self.f_pdf(simd, local);
        let cos = simd.abs_f32s(local[2]);
        let fc = scale(simd, f, cos);
        let keep = |x: S::f32s| simd.select_f32s(ok, x, zero);
        ([keep(fc[0]), keep(fc[1]), keep(fc[2])], keep(pdf))
    }
}

#[cfg(test)]
mod tests;
