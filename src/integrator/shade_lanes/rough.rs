//! Rough glass with a GGX distribution in vector lanes: the sampling and
//! the evaluation of [`RoughDielectric`](crate::bsdf::RoughDielectric) as
//! the path tracer uses it through `scatter::Micro` (its frame about the
//! oriented shading normal, its geometric-side checks), for every lane at
//! once, in f32.
//!
//! Each lane is one hit: the incident direction, the shading normal
//! oriented to the incident side, the geometric normal on that side, the
//! nested rule's index pair and the roughnesses (isotropic or not). The
//! steps are `Micro::new`, `Micro::sample` and `Micro::eval` operation for
//! operation (Heitz 2018's visible normals, the Fresnel choice at the
//! sampled facet, Walter et al.'s densities), so a lane's direction, weight
//! and density are the scalar's up to rounding, given the same three
//! uniform numbers. Beckmann lanes are not handled here ([`supports`]): its
//! sampling needs error functions in f64.
//!
//! Where the scalar model works in f64 (the facet of a pair of directions
//! in `eval`, every Fresnel factor) this is f32: where a lobe's uniform
//! number falls within rounding of the Fresnel reflectance, or a facet
//! within rounding of the critical angle, the two choose different lobes
//! (the tests bound how often). The transmittance 1 − F is computed as
//! such (not subtracted from F), so that it keeps its relative precision
//! as F approaches 1 near the critical angle.
//!

use super::ggx::{finite, neg, Frame, Ggx};
use super::lane_math::normalize;
use crate::simd3::{add, dot, scale, select, sub, Vec3s};

/// Whether [`RoughLanes`] models a distribution: GGX yes, Beckmann no (its
/// lanes go to the scalar step).
pub(super) use super::ggx::supports;

/// Rough glass at one hit per lane (`scatter::Micro` of a
/// `RoughDielectric`), in the shading frame `Frame::from_normal` builds.
pub(super) struct RoughLanes<S: pulp::Simd> {
    frame: Frame<S>,
    /// The direction back along the incident ray, local.
    wo: Vec3s<S>,
    /// The geometric normal on the incident side.
    side: Vec3s<S>,
    /// n2 / n1: the index of the −z side over the +z side's
    /// (`RoughDielectric::eta` with ext_ior = n1 and int_ior = n2).
    eta: S::f32s,
    ggx: Ggx<S>,
}

/// A direction drawn by [`RoughLanes::sample`], per lane. Only the lanes
/// of `valid` hold one (`Micro::sample` returned `Some`); the others have
/// weight and pdf 0 and a meaningless direction.
pub(super) struct RoughSample<S: pulp::Simd> {
    /// The direction, world space, unit.
    pub wi: Vec3s<S>,
    /// f·|cos θi| / pdf, the same in every colour channel; a transmission's
    /// includes the radiance factor (n1/n2)².
    pub weight: S::f32s,
    /// The solid-angle density of `wi`.
    pub pdf: S::f32s,
    /// `wi` crosses the boundary.
    pub transmission: S::m32s,
    pub valid: S::m32s,
}

/// The model, or one of the known-wrong variants that show the tests'
/// power.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
#[cfg_attr(not(test), allow(dead_code))]
pub(super) enum Variant {
    Right,
    /// The Fresnel reflectance halved (the transmittance 1 − F/2).
    HalfFresnel,
    /// The transmission's Jacobian without its factor η².
    NoEta2,
    /// Sampled transmissions weighed with the reflection's Jacobian of the
    /// half vector, 1 / (4 |wi·m|), in place of refraction's (the scalar
    /// path's `BsdfVariant::WrongJacobian`).
    ReflectionJacobian,
}

/// Fresnel at a facet whose cosine with the direction is `c` (sign: the
/// side it arrives from), `eta` = index of the −z side over the +z side's.
/// As `bsdf::fresnel::dielectric`, with the transmittance beside.
pub(super) struct Fresnel<S: pulp::Simd> {
    /// Reflectance (1 under total internal reflection).
    pub r: S::f32s,
    /// Transmittance 1 − r, from its own closed form.
    pub t: S::f32s,
    /// The transmitted cosine, of the sign opposite to `c`.
    cos_t: S::f32s,
    /// The index beyond the facet over the incident side's, and its inverse.
    eta_it: S::f32s,
    eta_ti: S::f32s,
}

///
/// Where the transmitted direction is already known (`known`: lanes and
/// |cos θt|), its cosine is taken as it is instead of from Snell's law:
/// near the critical angle 1 − sin²θt cancels, and the transmittance,
/// which goes as cos θt there, would lose its digits.
#[inline(always)]
pub(super) fn fresnel<S: pulp::Simd>(
    simd: S,
    c: S::f32s,
    eta: S::f32s,
    known: Option<(S::m32s, S::f32s)>,
    variant: Variant,
) -> Fresnel<S> {
    let zero = simd.splat_f32s(0.0);
    let one = simd.splat_f32s(1.0);
    let c = simd.min_f32s(simd.max_f32s(c, simd.splat_f32s(-1.0)), one);
    let front = simd.greater_than_or_equal_f32s(c, zero);
    let inv = simd.div_f32s(one, eta);
    let eta_it = simd.select_f32s(front, eta, inv);
    let eta_ti = simd.select_f32s(front, inv, eta);
    let ci = simd.abs_f32s(c);
    // 1 − c² as (1 − c)(1 + c): no cancellation near normal incidence.
    let sin2_i = simd.max_f32s(
        simd.mul_f32s(simd.sub_f32s(one, ci), simd.add_f32s(one, ci)),
        zero,
    );
    let sin2_t = simd.mul_f32s(simd.mul_f32s(eta_ti, eta_ti), sin2_i);
    let mut tir = simd.greater_than_or_equal_f32s(sin2_t, one);
    let mut cos_t = simd.sqrt_f32s(simd.max_f32s(simd.sub_f32s(one, sin2_t), zero));
    if let Some((lanes, known)) = known {
        cos_t = simd.select_f32s(lanes, simd.abs_f32s(known), cos_t);
        tir = simd.and_m32s(tir, simd.not_m32s(lanes));
    }
    // The amplitudes with indices 1 (incident) and eta_it (beyond).
    let (a1, a2) = (ci, simd.mul_f32s(eta_it, cos_t));
    let (b1, b2) = (simd.mul_f32s(eta_it, ci), cos_t);
    let (sa, sb) = (simd.add_f32s(a1, a2), simd.add_f32s(b1, b2));
    let rs = simd.div_f32s(simd.sub_f32s(a1, a2), sa);
    let rp = simd.div_f32s(simd.sub_f32s(b1, b2), sb);
    let half = simd.splat_f32s(0.5);
    let r = simd.mul_f32s(half, simd.add_f32s(simd.mul_f32s(rs, rs), simd.mul_f32s(rp, rp)));
    // 1 − ((a−b)/(a+b))² = 4ab/(a+b)², for both polarisations.
    let t = simd.mul_f32s(
        simd.mul_f32s(simd.splat_f32s(2.0), simd.mul_f32s(a1, a2)),
        simd.add_f32s(
            simd.div_f32s(one, simd.mul_f32s(sa, sa)),
            simd.div_f32s(one, simd.mul_f32s(sb, sb)),
        ),
    );
    let (r, t) = (
        simd.min_f32s(simd.max_f32s(r, zero), one),
        simd.min_f32s(simd.max_f32s(t, zero), one),
    );
    let (mut r, mut t) = (simd.select_f32s(tir, one, r), simd.select_f32s(tir, zero, t));
    if variant == Variant::HalfFresnel {
        r = simd.mul_f32s(r, half);
        t = simd.sub_f32s(one, r);
    }
    Fresnel {
        r,
        t,
        cos_t: simd.select_f32s(front, simd.neg_f32s(cos_t), cos_t),
        eta_it,
        eta_ti,
    }
}

impl<S: pulp::Simd> RoughLanes<S> {
    /// The boundary met along unit `d` (world) with unit shading normal
    /// `n` oriented towards the incident side (against `d`, but where it
    /// leans past the surface), `side` the geometric normal on the incident
    /// side, `n1` the index the ray travels in and `n2` the one beyond
    /// (different), and the distribution's roughnesses along the frame's
    /// first and second tangents (as `MicrofacetDistribution` keeps them,
    /// raised to its minimum).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        simd: S,
        d: Vec3s<S>,
        n: Vec3s<S>,
        side: Vec3s<S>,
        n1: S::f32s,
        n2: S::f32s,
        alpha_u: S::f32s,
        alpha_v: S::f32s,
    ) -> Self {
        let frame = Frame::new(simd, n);
        RoughLanes {
            wo: frame.to_local(simd, neg(simd, d)),
            frame,
            side,
            eta: simd.div_f32s(n2, n1),
            ggx: Ggx { alpha_u, alpha_v },
        }
    }

    /// `Micro::sample` with the uniform numbers it draws, in its order:
    /// `u_lobe` picks reflection where it is ≤ F at the sampled facet, `u1`
    /// and `u2` draw the facet.
    #[cfg(test)]
    #[inline(always)]
    pub fn sample(&self, simd: S, u_lobe: S::f32s, u1: S::f32s, u2: S::f32s) -> RoughSample<S> {
        self.sample_variant(simd, u_lobe, u1, u2, Variant::Right)
    }

    #[inline(always)]
    pub(super) fn sample_variant(
        &self,
        simd: S,
        u_lobe: S::f32s,
        u1: S::f32s,
        u2: S::f32s,
        variant: Variant,
    ) -> RoughSample<S> {
        let zero = simd.splat_f32s(0.0);
        let one = simd.splat_f32s(1.0);
        let wo = self.wo;
        let m = self.ggx.sample_visible(simd, wo, u1, u2);
        let pdf_m = self.ggx.pdf_visible(simd, self.wo, m);
        let mut valid = simd.and_m32s(
            simd.not_m32s(simd.equal_f32s(wo[2], zero)),
            simd.and_m32s(simd.greater_than_f32s(pdf_m, zero), finite(simd, pdf_m)),
        );
        let om = dot(simd, wo, m);
        let fr = fresnel(simd, om, self.eta, None, variant);
        let reflect = simd.less_than_or_equal_f32s(u_lobe, fr.r);
        let transmission = simd.not_m32s(reflect);
        let four = simd.splat_f32s(4.0);

        // `fresnel::reflect`: 2(wo·m)m − wo.
        let wr = sub(simd, scale(simd, m, simd.mul_f32s(simd.splat_f32s(2.0), om)), wo);
        let pdf_r = simd.div_f32s(
            simd.mul_f32s(pdf_m, fr.r),
            simd.mul_f32s(four, simd.abs_f32s(dot(simd, wr, m))),
        );
        // `fresnel::refract`: m (wo·m ηti + cos θt) − wo ηti.
        let wt = sub(
            simd,
            scale(simd, m, simd.add_f32s(simd.mul_f32s(om, fr.eta_ti), fr.cos_t)),
            scale(simd, wo, fr.eta_ti),
        );
        let im = dot(simd, wt, m);
        let denom = simd.add_f32s(om, simd.mul_f32s(fr.eta_it, im));
        let jacobian = if variant == Variant::NoEta2 {
            one
        } else {
            simd.mul_f32s(fr.eta_it, fr.eta_it)
        };
        let pdf_t = simd.div_f32s(
            simd.mul_f32s(
                simd.mul_f32s(simd.mul_f32s(pdf_m, fr.t), jacobian),
                simd.abs_f32s(im),
            ),
            simd.mul_f32s(denom, denom),
        );
        // Radiance is compressed by ηi²/ηo² into the denser side.
        let scale_t = simd.div_f32s(one, simd.mul_f32s(fr.eta_it, fr.eta_it));

        let wi = select(simd, reflect, wr, wt);
        let pdf = simd.select_f32s(reflect, pdf_r, pdf_t);
        let weight = simd.mul_f32s(simd.select_f32s(reflect, one, scale_t), self.ggx.g1(simd, wi, m));
        let weight = if variant == Variant::ReflectionJacobian {
            // The weight goes as 1/pdf: the right Jacobian over the wrong one.
            let eta2 = simd.mul_f32s(fr.eta_it, fr.eta_it);
            let k = simd.div_f32s(
                simd.mul_f32s(simd.mul_f32s(four, eta2), simd.mul_f32s(im, im)),
                simd.mul_f32s(denom, denom),
            );
            simd.select_f32s(transmission, simd.mul_f32s(weight, k), weight)
        } else {
            weight
        };
        let crosses = simd.less_than_f32s(simd.mul_f32s(wi[2], wo[2]), zero);
        valid = simd.and_m32s(
            valid,
            simd.and_m32s(
                simd.and_m32s(simd.greater_than_f32s(weight, zero), finite(simd, weight)),
                simd.and_m32s(simd.greater_than_f32s(pdf, zero), finite(simd, pdf)),
            ),
        );
        // The lobe must leave on its own side of the shading frame…
        valid = simd.and_m32s(valid, simd.not_m32s(simd.xor_m32s(crosses, transmission)));

        // …and of the geometric surface (`Micro::sample`).
        let wi = self.frame.to_world_unit(simd, wi);
        let above = simd.greater_than_f32s(dot(simd, wi, self.side), zero);
        valid = simd.and_m32s(valid, simd.xor_m32s(above, transmission));

        RoughSample {
            wi,
            weight: simd.select_f32s(valid, weight, zero),
            pdf: simd.select_f32s(valid, pdf, zero),
            transmission,
            valid,
        }
    }

    /// `Micro::eval`: f(wo, wi)·|cos θi| and the density of
    /// [`RoughLanes::sample`] at the unit world direction `wi`; both 0
    /// where the geometric normal puts `wi` on the other side from the
    /// shading frame's, or where no facet joins the two directions.
    #[cfg(test)]
    #[inline(always)]
    pub fn eval(&self, simd: S, wi: Vec3s<S>) -> (S::f32s, S::f32s) {
        self.eval_variant(simd, wi, Variant::Right)
    }

    #[inline(always)]
    pub(super) fn eval_variant(&self, simd: S, wi: Vec3s<S>, variant: Variant) -> (S::f32s, S::f32s) {
        let zero = simd.splat_f32s(0.0);
        let one = simd.splat_f32s(1.0);
        let four = simd.splat_f32s(4.0);
        let wo = self.wo;
        let local = self.frame.to_local(simd, wi);
        let geometric_reflection = simd.greater_than_f32s(dot(simd, wi, self.side), zero);
        let shading_reflection = simd.greater_than_f32s(simd.mul_f32s(local[2], wo[2]), zero);
        let mut ok = simd.not_m32s(simd.xor_m32s(geometric_reflection, shading_reflection));

        // The facet joining the two (`RoughDielectric::config`).
        let o = normalize(simd, wo);
        let i = normalize(simd, local);
        ok = simd.and_m32s(
            ok,
            simd.and_m32s(
                simd.not_m32s(simd.equal_f32s(o[2], zero)),
                simd.not_m32s(simd.equal_f32s(i[2], zero)),
            ),
        );
        let transmission = simd.less_than_f32s(simd.mul_f32s(o[2], i[2]), zero);
        let eta = simd.select_f32s(
            simd.greater_than_f32s(o[2], zero),
            self.eta,
            simd.div_f32s(one, self.eta),
        );
        let h = add(simd, o, scale(simd, i, simd.select_f32s(transmission, eta, one)));
        let hh = dot(simd, h, h);
        ok = simd.and_m32s(
            ok,
            simd.and_m32s(simd.greater_than_f32s(hh, zero), finite(simd, hh)),
        );
        let m = scale(simd, h, simd.div_f32s(one, simd.sqrt_f32s(hh)));
        let m = select(simd, simd.less_than_f32s(m[2], zero), neg(simd, m), m);
        let (om, im) = (dot(simd, o, m), dot(simd, i, m));
        ok = simd.and_m32s(
            ok,
            simd.and_m32s(
                simd.greater_than_f32s(simd.mul_f32s(om, o[2]), zero),
                simd.greater_than_f32s(simd.mul_f32s(im, i[2]), zero),
            ),
        );
        // The facet refracts o into i: |i·m| is the transmitted cosine.
        let fr = fresnel(simd, om, self.eta, Some((transmission, im)), variant);

        let dg = simd.mul_f32s(
            self.ggx.d(simd, m),
            simd.mul_f32s(self.ggx.g1(simd, local, m), self.ggx.g1(simd, wo, m)),
        );
        let cos = simd.abs_f32s(simd.mul_f32s(wo[2], local[2]));
        let denom = simd.add_f32s(om, simd.mul_f32s(eta, im));
        let denom2 = simd.mul_f32s(denom, denom);
        let eta2 = simd.mul_f32s(eta, eta);
        let jacobian = if variant == Variant::NoEta2 { one } else { eta2 };
        // The radiance factor 1/η² and the Jacobian's η² cancel in f.
        let f_t = simd.div_f32s(
            simd.mul_f32s(simd.mul_f32s(fr.t, dg), simd.abs_f32s(simd.mul_f32s(om, im))),
            simd.mul_f32s(cos, denom2),
        );
        let f_t = if variant == Variant::NoEta2 {
            simd.div_f32s(f_t, eta2)
        } else {
            f_t
        };
        let f_r = simd.div_f32s(simd.mul_f32s(fr.r, dg), simd.mul_f32s(four, cos));
        let f = simd.select_f32s(transmission, f_t, f_r);

        let pdf_m = self.ggx.pdf_visible(simd, self.wo, m);
        let pdf_t = simd.div_f32s(
            simd.mul_f32s(
                simd.mul_f32s(simd.mul_f32s(pdf_m, fr.t), jacobian),
                simd.abs_f32s(im),
            ),
            denom2,
        );
        let pdf_r = simd.div_f32s(simd.mul_f32s(pdf_m, fr.r), simd.mul_f32s(four, simd.abs_f32s(im)));
        let pdf = simd.select_f32s(transmission, pdf_t, pdf_r);

        let fc = simd.mul_f32s(f, simd.abs_f32s(local[2]));
        let f_ok = simd.and_m32s(ok, finite(simd, fc));
        let pdf_ok = simd.and_m32s(ok, finite(simd, pdf));
        (
            simd.select_f32s(f_ok, fc, zero),
            simd.select_f32s(pdf_ok, pdf, zero),
        )
    }
}

#[cfg(test)]
mod tests;
