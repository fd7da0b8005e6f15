//! The GGX microfacet distribution and the shading frame, in vector lanes:
//! what the rough lanes ([`super::rough`], [`super::conductor`]) share of
//! `MicrofacetDistribution` (D, Smith's G1, the density of visible normals,
//! Heitz 2018's sampling of them) and of `Frame::from_normal`, operation
//! for operation as the scalar code computes them in f32, so that a lane's
//! values are the scalar's up to rounding.
//!
//! Beckmann is not here ([`supports`]): its sampling needs error functions
//! in f64, and its lanes go to the scalar step.

use super::lane_math::{normalize, sincos_turns};
use crate::bsdf::{MicrofacetDistribution, MicrofacetKind};
use crate::simd3::{add, dot, scale, select, Vec3s};
use std::f32::consts::PI;

/// Whether the lanes model `distribution` (in radiance transport, as
/// `Bsdf::at` builds it): GGX (either roughness pair) yes; Beckmann no.
pub(super) fn supports(distribution: &MicrofacetDistribution) -> bool {
    distribution.kind() == MicrofacetKind::Ggx
}

#[inline(always)]
pub(super) fn neg<S: pulp::Simd>(simd: S, a: Vec3s<S>) -> Vec3s<S> {
    [simd.neg_f32s(a[0]), simd.neg_f32s(a[1]), simd.neg_f32s(a[2])]
}

/// `x` is neither infinite nor NaN.
#[inline(always)]
pub(super) fn finite<S: pulp::Simd>(simd: S, x: S::f32s) -> S::m32s {
    simd.less_than_f32s(simd.abs_f32s(x), simd.splat_f32s(f32::INFINITY))
}

/// Every component of `v` is finite.
#[inline(always)]
fn finite3<S: pulp::Simd>(simd: S, v: Vec3s<S>) -> S::m32s {
    simd.and_m32s(
        finite(simd, v[0]),
        simd.and_m32s(finite(simd, v[1]), finite(simd, v[2])),
    )
}

/// `Frame::from_normal` per lane: the tangents of `sampling::basis` and
/// the normal.
#[derive(Clone, Copy)]
pub(super) struct Frame<S: pulp::Simd> {
    /// Local x, y and z.
    pub s: Vec3s<S>,
    pub t: Vec3s<S>,
    pub n: Vec3s<S>,
}

impl<S: pulp::Simd> Frame<S> {
    /// The frame about the unit normal `n`.
    #[inline(always)]
    pub fn new(simd: S, n: Vec3s<S>) -> Self {
        let one = simd.splat_f32s(1.0);
        // `1.0f32.copysign(n.z)`: the sign bit of n.z on 1.
        let sign = simd.or_f32s(one, simd.and_f32s(n[2], simd.splat_f32s(-0.0)));
        let a = simd.div_f32s(simd.splat_f32s(-1.0), simd.add_f32s(sign, n[2]));
        let b = simd.mul_f32s(simd.mul_f32s(n[0], n[1]), a);
        let s = [
            simd.add_f32s(
                one,
                simd.mul_f32s(simd.mul_f32s(simd.mul_f32s(sign, n[0]), n[0]), a),
            ),
            simd.mul_f32s(sign, b),
            simd.neg_f32s(simd.mul_f32s(sign, n[0])),
        ];
        let t = [
            b,
            simd.add_f32s(sign, simd.mul_f32s(simd.mul_f32s(n[1], n[1]), a)),
            simd.neg_f32s(n[1]),
        ];
        Frame { s, t, n }
    }

    /// World `v` in local coordinates.
    #[inline(always)]
    pub fn to_local(self, simd: S, v: Vec3s<S>) -> Vec3s<S> {
        [dot(simd, v, self.s), dot(simd, v, self.t), dot(simd, v, self.n)]
    }

    /// Local `v` in world coordinates.
    #[inline(always)]
    pub fn to_world(self, simd: S, v: Vec3s<S>) -> Vec3s<S> {
        add(
            simd,
            add(simd, scale(simd, self.s, v[0]), scale(simd, self.t, v[1])),
            scale(simd, self.n, v[2]),
        )
    }

    /// Local `v` in world coordinates and normalised as `Micro::sample`
    /// does (`normalize_or_zero`: 0 where the length is 0 or not finite).
    #[inline(always)]
    pub fn to_world_unit(self, simd: S, v: Vec3s<S>) -> Vec3s<S> {
        let zero = simd.splat_f32s(0.0);
        let v = self.to_world(simd, v);
        let rcp = simd.div_f32s(simd.splat_f32s(1.0), simd.sqrt_f32s(dot(simd, v, v)));
        let ok = simd.and_m32s(finite(simd, rcp), simd.greater_than_f32s(rcp, zero));
        select(simd, ok, scale(simd, v, rcp), [zero, zero, zero])
    }
}

/// A reflected direction drawn by a model of per-channel weights (metals,
/// plastics), per lane. Only the lanes of `valid` hold one
/// (`Micro::sample` returned `Some`); the others have weight and pdf 0 and
/// a meaningless direction.
pub(super) struct ReflectionSample<S: pulp::Simd> {
    /// The direction, world space, unit.
    pub wi: Vec3s<S>,
    /// f·cos θi / pdf per RGB channel (a delta lobe: its reflectance over
    /// its probability).
    pub weight: Vec3s<S>,
    /// The solid-angle density of `wi` (a delta lobe: as the model reports it).
    pub pdf: S::f32s,
    /// The lanes whose lobe is a delta (`MicroSample::is_delta`), valid or not.
    pub delta: S::m32s,
    pub valid: S::m32s,
}

impl<S: pulp::Simd> ReflectionSample<S> {
    /// `Micro::sample`'s end: the local direction `wi` in the world, unit,
    /// kept where `valid`, the weight finite and the direction above the
    /// geometric surface (`side`, on the incident side).
    #[inline(always)]
    pub fn in_world(self, simd: S, frame: Frame<S>, side: Vec3s<S>) -> Self {
        let zero = simd.splat_f32s(0.0);
        let wi = frame.to_world_unit(simd, self.wi);
        let valid = simd.and_m32s(
            simd.and_m32s(self.valid, finite3(simd, self.weight)),
            simd.greater_than_f32s(dot(simd, wi, side), zero),
        );
        let keep = |x: S::f32s| simd.select_f32s(valid, x, zero);
        ReflectionSample {
            wi,
            weight: [keep(self.weight[0]), keep(self.weight[1]), keep(self.weight[2])],
            pdf: keep(self.pdf),
            delta: self.delta,
            valid,
        }
    }
}

/// A GGX distribution per lane, its roughnesses along the frame's first
/// and second tangents (as `MicrofacetDistribution` keeps them, raised to
/// its minimum).
#[derive(Clone, Copy)]
pub(super) struct Ggx<S: pulp::Simd> {
    pub alpha_u: S::f32s,
    pub alpha_v: S::f32s,
}

impl<S: pulp::Simd> Ggx<S> {
    /// D(m) of `MicrofacetDistribution::d` (0 for m.z ≤ 0 and where
    /// D cos θm ≤ 1e-20).
    #[inline(always)]
    pub fn d(&self, simd: S, m: Vec3s<S>) -> S::f32s {
        let zero = simd.splat_f32s(0.0);
        let z = m[2];
        let x = simd.div_f32s(m[0], self.alpha_u);
        let y = simd.div_f32s(m[1], self.alpha_v);
        let z2 = simd.mul_f32s(z, z);
        let t = simd.add_f32s(simd.add_f32s(simd.mul_f32s(x, x), simd.mul_f32s(y, y)), z2);
        let k = simd.mul_f32s(simd.mul_f32s(simd.splat_f32s(PI), self.alpha_u), self.alpha_v);
        let d = simd.div_f32s(simd.splat_f32s(1.0), simd.mul_f32s(simd.mul_f32s(k, t), t));
        let keep = simd.and_m32s(
            simd.and_m32s(simd.greater_than_f32s(z, zero), finite(simd, d)),
            simd.greater_than_f32s(simd.mul_f32s(d, z), simd.splat_f32s(1e-20)),
        );
        simd.select_f32s(keep, d, zero)
    }

    /// G1(w, m) = 1 / (1 + Λ(w)), 0 where w sees the facet from the wrong
    /// side, and 0 at grazing w (Λ infinite).
    #[inline(always)]
    pub fn g1(&self, simd: S, w: Vec3s<S>, m: Vec3s<S>) -> S::f32s {
        let zero = simd.splat_f32s(0.0);
        let one = simd.splat_f32s(1.0);
        let (ax, ay) = (
            simd.mul_f32s(self.alpha_u, w[0]),
            simd.mul_f32s(self.alpha_v, w[1]),
        );
        let xy = simd.add_f32s(simd.mul_f32s(ax, ax), simd.mul_f32s(ay, ay));
        let t = simd.div_f32s(xy, simd.mul_f32s(w[2], w[2]));
        // (√(1 + t) − 1) / 2 without the cancellation at small t.
        let lambda = simd.div_f32s(
            simd.mul_f32s(simd.splat_f32s(0.5), t),
            simd.add_f32s(one, simd.sqrt_f32s(simd.add_f32s(one, t))),
        );
        let lambda = simd.select_f32s(finite(simd, t), lambda, simd.splat_f32s(f32::INFINITY));
        let lambda = simd.select_f32s(simd.equal_f32s(xy, zero), zero, lambda);
        let g = simd.div_f32s(one, simd.add_f32s(one, lambda));
        let seen = simd.greater_than_f32s(simd.mul_f32s(dot(simd, w, m), w[2]), zero);
        simd.select_f32s(seen, g, zero)
    }

    /// The density of visible normals seen from `w` at `m`
    /// (`MicrofacetDistribution::pdf`, `w` below the surface turned over).
    #[inline(always)]
    pub fn pdf_visible(&self, simd: S, w: Vec3s<S>, m: Vec3s<S>) -> S::f32s {
        let zero = simd.splat_f32s(0.0);
        let below = simd.less_than_f32s(w[2], zero);
        let w = select(simd, below, neg(simd, w), w);
        let p = simd.div_f32s(
            simd.mul_f32s(
                simd.mul_f32s(self.g1(simd, w, m), simd.max_f32s(dot(simd, w, m), zero)),
                self.d(simd, m),
            ),
            w[2],
        );
        simd.select_f32s(simd.equal_f32s(w[2], zero), zero, p)
    }

    /// A normal visible from `w` (`w` below the surface turned over) from
    /// two uniform numbers: Heitz 2018, as `sample_ggx`.
    #[inline(always)]
    pub fn sample_visible(&self, simd: S, w: Vec3s<S>, u1: S::f32s, u2: S::f32s) -> Vec3s<S> {
        let zero = simd.splat_f32s(0.0);
        let one = simd.splat_f32s(1.0);
        let below = simd.less_than_f32s(w[2], zero);
        let w = select(simd, below, neg(simd, w), w);
        let vh = normalize(
            simd,
            [
                simd.mul_f32s(self.alpha_u, w[0]),
                simd.mul_f32s(self.alpha_v, w[1]),
                w[2],
            ],
        );
        let lensq = simd.add_f32s(simd.mul_f32s(vh[0], vh[0]), simd.mul_f32s(vh[1], vh[1]));
        let len = simd.sqrt_f32s(lensq);
        let t1 = select(
            simd,
            simd.greater_than_f32s(lensq, zero),
            [
                simd.div_f32s(simd.neg_f32s(vh[1]), len),
                simd.div_f32s(vh[0], len),
                zero,
            ],
            [one, zero, zero],
        );
        // vh × t1, as glam's `cross`.
        let t2 = [
            simd.sub_f32s(simd.mul_f32s(vh[1], t1[2]), simd.mul_f32s(t1[1], vh[2])),
            simd.sub_f32s(simd.mul_f32s(vh[2], t1[0]), simd.mul_f32s(t1[2], vh[0])),
            simd.sub_f32s(simd.mul_f32s(vh[0], t1[1]), simd.mul_f32s(t1[0], vh[1])),
        ];
        let r = simd.sqrt_f32s(u1);
        let (sin, cos) = sincos_turns(simd, u2);
        let p1 = simd.mul_f32s(r, cos);
        let p2 = simd.mul_f32s(r, sin);
        let s = simd.mul_f32s(simd.splat_f32s(0.5), simd.add_f32s(one, vh[2]));
        let rest1 = simd.sub_f32s(one, simd.mul_f32s(p1, p1));
        let p2 = simd.add_f32s(
            simd.mul_f32s(simd.sub_f32s(one, s), simd.sqrt_f32s(simd.max_f32s(rest1, zero))),
            simd.mul_f32s(s, p2),
        );
        let h = simd.sqrt_f32s(simd.max_f32s(simd.sub_f32s(rest1, simd.mul_f32s(p2, p2)), zero));
        let nh = add(
            simd,
            add(simd, scale(simd, t1, p1), scale(simd, t2, p2)),
            scale(simd, vh, h),
        );
        normalize(
            simd,
            [
                simd.mul_f32s(self.alpha_u, nh[0]),
                simd.mul_f32s(self.alpha_v, nh[1]),
                simd.max_f32s(nh[2], zero),
            ],
        )
    }
}
