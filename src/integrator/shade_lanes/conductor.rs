//! Metals in vector lanes: the sampling and the evaluation of a smooth
//! [`Conductor`] (a delta reflection) and of a GGX [`RoughConductor`] as
//! the path tracer uses them through `scatter::Micro` (the frame about the
//! oriented shading normal, the geometric-side checks), for every lane at
//! once, in f32, each lane smooth or rough.
//!
//! Each lane is one hit: the incident direction, the shading normal
//! oriented to the incident side, the geometric normal on that side, the
//! metal's complex index η + iκ and reflectance factor per RGB channel, and
//! (rough lanes) the roughnesses. The steps are `Micro::sample` and
//! `Micro::eval` with `Conductor::sample` and `RoughConductor::{sample, f,
//! pdf}` operation for operation, so a lane's direction, weight and
//! density are the scalar's up to rounding, given the same uniform numbers.
//!
//! What the caller does first, per lane, as `Bsdf::at` does: nothing is
//! asked of a one-sided metal seen from behind (it is black there), and
//! [`ConductorParams::of`] says which materials the lanes model (Beckmann
//! roughness stays scalar: its sampling needs error functions in f64).
//!
//! The Fresnel reflectance is `fresnel::conductor_channel`'s closed form,
//! which the scalar code evaluates in f64; here it is f32, rearranged so
//! that no step cancels: a² and b² (the real and imaginary parts of
//! n̂² − sin²θ's root, squared) each from whichever of their two forms
//! adds, and the numerators a² + b² + cos²θ − 2a cosθ as sums of squares.

use super::ggx::{self, finite, neg, Frame, Ggx, ReflectionSample};
use crate::bsdf::{Conductor, RoughConductor};
use crate::scene::Material;
use crate::simd3::{add, dot, scale, select, sub, Vec3s};
use glam::Vec3A as V3;

/// One lane's metal as the caller gathers it from its material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ConductorParams {
    pub eta: V3,
    pub k: V3,
    pub specular_reflectance: V3,
    /// The roughnesses along the frame's two tangents (1 for a smooth
    /// metal, where they are not used).
    pub alpha_u: f32,
    pub alpha_v: f32,
    pub smooth: bool,
    /// Reflects on both sides (else black seen from behind).
    pub two_sided: bool,
}

impl ConductorParams {
    /// The parameters of `material` if it is a metal the lanes model: a
    /// smooth one, or a rough one of a GGX distribution.
    pub fn of(material: &Material) -> Option<ConductorParams> {
        let from = |eta: glam::Vec3, k: glam::Vec3, spec: glam::Vec3| ConductorParams {
            eta: eta.into(),
            k: k.into(),
            specular_reflectance: spec.into(),
            alpha_u: 1.0,
            alpha_v: 1.0,
            smooth: true,
            two_sided: false,
        };
        match material {
            Material::Conductor { bsdf, two_sided } => {
                let c: &Conductor = bsdf;
                Some(ConductorParams {
                    two_sided: *two_sided,
                    ..from(c.eta(), c.k(), c.specular_reflectance())
                })
            }
            Material::RoughConductor { bsdf, two_sided } => {
                let c: &RoughConductor = bsdf;
                let d = c.distribution();
                ggx::supports(d).then(|| ConductorParams {
                    alpha_u: d.alpha_u(),
                    alpha_v: d.alpha_v(),
                    smooth: false,
                    two_sided: *two_sided,
                    ..from(c.eta(), c.k(), c.specular_reflectance())
                })
            }
            _ => None,
        }
    }
}

/// Metals at one hit per lane (`scatter::Micro` of a `Conductor` or a
/// `RoughConductor`), in the shading frame `Frame::from_normal` builds.
pub(super) struct ConductorLanes<S: pulp::Simd> {
    frame: Frame<S>,
    /// The direction back along the incident ray, local.
    wo: Vec3s<S>,
    /// The geometric normal on the incident side.
    side: Vec3s<S>,
    eta: Vec3s<S>,
    k: Vec3s<S>,
    spec: Vec3s<S>,
    ggx: Ggx<S>,
    /// Smooth lanes (a delta reflection); the others are rough.
    smooth: S::m32s,
}

/// The model, or one of the known-wrong variants that show the tests'
/// power.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Variant {
    Right,
    /// The Fresnel reflectance with κ = 0 (a dielectric of index η).
    NoAbsorption,
    /// The evaluation's shadowing-masking G1(wo) alone, without G1(wi).
    OneG1,
}

/// One channel of `fresnel::conductor`: the reflectance at |cos θ| = `c`
/// (in [0, 1]) of the complex index `eta` + i`k`.
#[inline(always)]
fn fresnel_channel<S: pulp::Simd>(simd: S, c: S::f32s, eta: S::f32s, k: S::f32s) -> S::f32s {
    let zero = simd.splat_f32s(0.0);
    let one = simd.splat_f32s(1.0);
    let half = simd.splat_f32s(0.5);
    let c2 = simd.mul_f32s(c, c);
    // 1 − c² as (1 − c)(1 + c): no cancellation near normal incidence.
    let s2 = simd.max_f32s(simd.mul_f32s(simd.sub_f32s(one, c), simd.add_f32s(one, c)), zero);
    // η² − κ² as (η − κ)(η + κ): exact-ish where η ≈ κ.
    let t1 = simd.sub_f32s(simd.mul_f32s(simd.sub_f32s(eta, k), simd.add_f32s(eta, k)), s2);
    let ek = simd.mul_f32s(eta, k);
    let ek2 = simd.mul_f32s(ek, ek);
    let a2pb2 =
        simd.sqrt_f32s(simd.add_f32s(simd.mul_f32s(t1, t1), simd.mul_f32s(simd.splat_f32s(4.0), ek2)));
    // a² = (|n̂² − s²| + t1)/2 and b² = (|n̂² − s²| − t1)/2 with a²b² = η²κ²:
    // the one whose terms add is computed as such, the other as η²κ² over it.
    let big = simd.mul_f32s(half, simd.add_f32s(a2pb2, simd.abs_f32s(t1)));
    let small = simd.select_f32s(simd.greater_than_f32s(big, zero), simd.div_f32s(ek2, big), zero);
    let pos = simd.greater_than_or_equal_f32s(t1, zero);
    let a2 = simd.select_f32s(pos, big, small);
    let b2 = simd.select_f32s(pos, small, big);
    let a = simd.sqrt_f32s(a2);
    // (a² + b² + c² ∓ 2ac) = b² + (c ∓ a)².
    let (cma, cpa) = (simd.sub_f32s(c, a), simd.add_f32s(c, a));
    let rs_num = simd.add_f32s(b2, simd.mul_f32s(cma, cma));
    let rs_den = simd.add_f32s(b2, simd.mul_f32s(cpa, cpa));
    // Both vanish only for a zero index at normal incidence (no material):
    // lossless, as the scalar calls it.
    let rs = simd.select_f32s(
        simd.greater_than_f32s(rs_den, zero),
        simd.div_f32s(rs_num, rs_den),
        one,
    );
    // (a² + b²)c² + s⁴ ∓ 2ac s² = (ac ∓ s²)² + b²c².
    let ac = simd.mul_f32s(a, c);
    let (acm, acp) = (simd.sub_f32s(ac, s2), simd.add_f32s(ac, s2));
    let b2c2 = simd.mul_f32s(b2, c2);
    let rp_num = simd.add_f32s(simd.mul_f32s(acm, acm), b2c2);
    let rp_den = simd.add_f32s(simd.mul_f32s(acp, acp), b2c2);
    let rp = simd.select_f32s(
        simd.greater_than_f32s(rp_den, zero),
        simd.mul_f32s(rs, simd.div_f32s(rp_num, rp_den)),
        rs,
    );
    let r = simd.mul_f32s(half, simd.add_f32s(rs, rp));
    simd.min_f32s(simd.max_f32s(r, zero), one)
}

impl<S: pulp::Simd> ConductorLanes<S> {
    /// The metal met along unit `d` (world) with unit shading normal `n`
    /// oriented towards the incident side (against `d`, but where it leans
    /// past the surface), `side` the geometric normal on the incident side,
    /// the complex index `eta` + i`k` and `specular_reflectance` per RGB
    /// channel (relative to the medium outside, as the materials keep
    /// them), the GGX roughnesses along the frame's tangents (rough lanes;
    /// any finite positive value at smooth ones), and which lanes are
    /// `smooth`.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        simd: S,
        d: Vec3s<S>,
        n: Vec3s<S>,
        side: Vec3s<S>,
        eta: Vec3s<S>,
        k: Vec3s<S>,
        specular_reflectance: Vec3s<S>,
        alpha_u: S::f32s,
        alpha_v: S::f32s,
        smooth: S::m32s,
    ) -> Self {
        let frame = Frame::new(simd, n);
        ConductorLanes {
            wo: frame.to_local(simd, neg(simd, d)),
            frame,
            side,
            eta,
            k,
            spec: specular_reflectance,
            ggx: Ggx { alpha_u, alpha_v },
            smooth,
        }
    }

    /// `specular_reflectance` · F(|cos| = `c`) per channel.
    #[inline(always)]
    fn reflectance(&self, simd: S, c: S::f32s, variant: Variant) -> Vec3s<S> {
        let c = simd.min_f32s(simd.abs_f32s(c), simd.splat_f32s(1.0));
        let f = |i: usize| {
            let k = if variant == Variant::NoAbsorption {
                simd.splat_f32s(0.0)
            } else {
                self.k[i]
            };
            simd.mul_f32s(self.spec[i], fresnel_channel(simd, c, self.eta[i], k))
        };
        [f(0), f(1), f(2)]
    }

    /// `RoughConductor::half_vector`: the unit half vector of `wo` and
    /// local `wi`, and the lanes where both are above the surface and see
    /// its front.
    #[inline(always)]
    fn half_vector(&self, simd: S, wi: Vec3s<S>) -> (Vec3s<S>, S::m32s) {
        let zero = simd.splat_f32s(0.0);
        let wo = self.wo;
        let h = add(simd, wo, wi);
        // `try_normalize`: a finite, positive reciprocal length.
        let rcp = simd.div_f32s(simd.splat_f32s(1.0), simd.sqrt_f32s(dot(simd, h, h)));
        let m = scale(simd, h, rcp);
        let ok = simd.and_m32s(
            simd.and_m32s(
                simd.greater_than_f32s(wo[2], zero),
                simd.greater_than_f32s(wi[2], zero),
            ),
            simd.and_m32s(finite(simd, rcp), simd.greater_than_f32s(rcp, zero)),
        );
        let ok = simd.and_m32s(
            ok,
            simd.and_m32s(
                simd.greater_than_f32s(dot(simd, wo, m), zero),
                simd.greater_than_f32s(dot(simd, wi, m), zero),
            ),
        );
        (m, ok)
    }

    /// `Micro::sample` given the two uniform numbers that draw the facet
    /// (`u1`, `u2`: its second and third; its first, the lobe's, is drawn
    /// and not used by metals). A smooth lane reflects about the shading
    /// normal with the Fresnel reflectance as weight.
    #[cfg(test)]
    #[inline(always)]
    pub fn sample(&self, simd: S, u1: S::f32s, u2: S::f32s) -> ReflectionSample<S> {
        self.sample_variant(simd, u1, u2, Variant::Right)
    }

    #[inline(always)]
    pub(super) fn sample_variant(
        &self,
        simd: S,
        u1: S::f32s,
        u2: S::f32s,
        variant: Variant,
    ) -> ReflectionSample<S> {
        let zero = simd.splat_f32s(0.0);
        let one = simd.splat_f32s(1.0);
        let wo = self.wo;
        let up = simd.greater_than_f32s(wo[2], zero);

        // Rough: a visible normal, reflected (`RoughConductor::sample`).
        let m = self.ggx.sample_visible(simd, wo, u1, u2);
        let om = dot(simd, wo, m);
        let wr = sub(simd, scale(simd, m, simd.mul_f32s(simd.splat_f32s(2.0), om)), wo);
        // Its density, from the pair's half vector (`RoughConductor::pdf`).
        let (h, ok) = self.half_vector(simd, wr);
        let pdf_r = simd.div_f32s(
            simd.mul_f32s(self.ggx.d(simd, h), self.ggx.g1(simd, wo, h)),
            simd.mul_f32s(simd.splat_f32s(4.0), wo[2]),
        );
        let pdf_r = simd.select_f32s(simd.and_m32s(ok, finite(simd, pdf_r)), pdf_r, zero);
        let g1 = self.ggx.g1(simd, wr, m);
        let rough_ok = simd.and_m32s(
            simd.greater_than_f32s(wr[2], zero),
            simd.and_m32s(
                simd.greater_than_f32s(pdf_r, zero),
                simd.greater_than_f32s(g1, zero),
            ),
        );

        // Smooth: the mirror direction (`Conductor::sample`).
        let smooth = self.smooth;
        let wm = [simd.neg_f32s(wo[0]), simd.neg_f32s(wo[1]), wo[2]];

        let wi = select(simd, smooth, wm, wr);
        let pdf = simd.select_f32s(smooth, one, pdf_r);
        let fr = self.reflectance(simd, simd.select_f32s(smooth, wo[2], om), variant);
        let g = simd.select_f32s(smooth, one, g1);
        let weight = [
            simd.mul_f32s(fr[0], g),
            simd.mul_f32s(fr[1], g),
            simd.mul_f32s(fr[2], g),
        ];
        ReflectionSample {
            wi,
            weight,
            pdf,
            delta: smooth,
            valid: simd.and_m32s(up, simd.or_m32s(smooth, rough_ok)),
        }
        .in_world(simd, self.frame, self.side)
    }

    /// `Micro::eval`: f(wo, wi)·|cos θi| per RGB channel and the density of
    /// [`ConductorLanes::sample`] at the unit world direction `wi`; all 0
    /// at smooth lanes (a delta), where the geometric normal puts `wi` on
    /// the other side from the shading frame's, and where `wo` or `wi` is
    /// below the shading frame (one-sided).
    #[cfg(test)]
    #[inline(always)]
    pub fn eval(&self, simd: S, wi: Vec3s<S>) -> (Vec3s<S>, S::f32s) {
        self.eval_variant(simd, wi, Variant::Right)
    }

    #[inline(always)]
    pub(super) fn eval_variant(&self, simd: S, wi: Vec3s<S>, variant: Variant) -> (Vec3s<S>, S::f32s) {
        let zero = simd.splat_f32s(0.0);
        let four = simd.splat_f32s(4.0);
        let wo = self.wo;
        let local = self.frame.to_local(simd, wi);
        let geometric_reflection = simd.greater_than_f32s(dot(simd, wi, self.side), zero);
        let shading_reflection = simd.greater_than_f32s(simd.mul_f32s(local[2], wo[2]), zero);
        let mut ok = simd.not_m32s(simd.xor_m32s(geometric_reflection, shading_reflection));
        ok = simd.and_m32s(ok, simd.not_m32s(self.smooth));
        let (m, okh) = self.half_vector(simd, local);
        ok = simd.and_m32s(ok, okh);

        let d = self.ggx.d(simd, m);
        let g1o = self.ggx.g1(simd, wo, m);
        let g = if variant == Variant::OneG1 {
            g1o
        } else {
            simd.mul_f32s(g1o, self.ggx.g1(simd, local, m))
        };
        let dg = simd.div_f32s(
            simd.mul_f32s(d, g),
            simd.mul_f32s(simd.mul_f32s(four, wo[2]), local[2]),
        );
        let f_ok = simd.and_m32s(ok, finite(simd, dg));
        let fr = self.reflectance(simd, dot(simd, wo, m), variant);
        let cos = simd.abs_f32s(local[2]);
        let fc = |i: usize| {
            let v = simd.mul_f32s(simd.mul_f32s(fr[i], dg), cos);
            simd.select_f32s(f_ok, v, zero)
        };
        let pdf = simd.div_f32s(simd.mul_f32s(d, g1o), simd.mul_f32s(four, wo[2]));
        let pdf_ok = simd.and_m32s(ok, finite(simd, pdf));
        ([fc(0), fc(1), fc(2)], simd.select_f32s(pdf_ok, pdf, zero))
    }
}

#[cfg(test)]
mod tests;
