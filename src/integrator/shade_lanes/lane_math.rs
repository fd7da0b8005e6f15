//! Arithmetic on f32 lanes that the kernel and the microfacet lanes share:
//! normalising, mirror reflection, refraction and the sine and cosine of
//! whole turns.
use crate::simd3::{add, dot, scale, select, sub, Vec3s};
use std::f32::consts::PI;

#[inline(always)]
pub(super) fn normalize<S: pulp::Simd>(simd: S, a: Vec3s<S>) -> Vec3s<S> {
    let inv = simd.div_f32s(simd.splat_f32s(1.0), simd.sqrt_f32s(dot(simd, a, a)));
    scale(simd, a, inv)
}

/// `d` reflected about the plane of normal `n` (either orientation).
#[inline(always)]
pub(super) fn reflect<S: pulp::Simd>(simd: S, d: Vec3s<S>, n: Vec3s<S>) -> Vec3s<S> {
    let k = simd.mul_f32s(simd.splat_f32s(2.0), dot(simd, d, n));
    sub(simd, d, scale(simd, n, k))
}

/// `optics::refract` where it does not totally reflect, unnormalised: the
/// normal oriented against `d`, `eta = n1/n2`.
#[inline(always)]
pub(super) fn refract<S: pulp::Simd>(simd: S, d: Vec3s<S>, n: Vec3s<S>, eta: S::f32s) -> Vec3s<S> {
    let c = simd.neg_f32s(dot(simd, d, n));
    let flip = simd.less_than_f32s(c, simd.splat_f32s(0.0));
    let n = select(simd, flip, scale(simd, n, simd.splat_f32s(-1.0)), n);
    let cos_i = simd.abs_f32s(c);
    let one = simd.splat_f32s(1.0);
    let sin2 = simd.mul_f32s(
        simd.mul_f32s(eta, eta),
        simd.max_f32s(
            simd.sub_f32s(one, simd.mul_f32s(cos_i, cos_i)),
            simd.splat_f32s(0.0),
        ),
    );
    let cos_t = simd.sqrt_f32s(simd.max_f32s(simd.sub_f32s(one, sin2), simd.splat_f32s(0.0)));
    add(
        simd,
        scale(simd, d, eta),
        scale(simd, n, simd.sub_f32s(simd.mul_f32s(eta, cos_i), cos_t)),
    )
}

/// The sine and cosine of 2π`u` for `u` in [0, 1]: the nearest quarter turn
/// taken out, then Taylor polynomials on [−π/4, π/4] (their truncation is
/// below 2·10⁻⁹, under half an f32 ulp of 1).
#[inline(always)]
pub(super) fn sincos_turns<S: pulp::Simd>(simd: S, u: S::f32s) -> (S::f32s, S::f32s) {
    // Round to nearest by adding and removing 1.5·2²³ (|4u| < 2²²).
    let magic = simd.splat_f32s(12_582_912.0);
    let q = simd.sub_f32s(
        simd.add_f32s(simd.mul_f32s(u, simd.splat_f32s(4.0)), magic),
        magic,
    );
    // u − q/4 is exact (Sterbenz), so x carries one rounding.
    let x = simd.mul_f32s(
        simd.sub_f32s(u, simd.mul_f32s(q, simd.splat_f32s(0.25))),
        simd.splat_f32s(2.0 * PI),
    );
    let x2 = simd.mul_f32s(x, x);
    // sin x = x(1 − x²/3! + x⁴/5! − x⁶/7! + x⁸/9!)
    let mut s = simd.splat_f32s(1.0 / 362_880.0);
    s = simd.mul_add_f32s(s, x2, simd.splat_f32s(-1.0 / 5_040.0));
    s = simd.mul_add_f32s(s, x2, simd.splat_f32s(1.0 / 120.0));
    s = simd.mul_add_f32s(s, x2, simd.splat_f32s(-1.0 / 6.0));
    s = simd.mul_add_f32s(s, x2, simd.splat_f32s(1.0));
    let s = simd.mul_f32s(s, x);
    // cos x = 1 − x²/2! + x⁴/4! − x⁶/6! + x⁸/8! − x¹⁰/10!
    let mut k = simd.splat_f32s(-1.0 / 3_628_800.0);
    k = simd.mul_add_f32s(k, x2, simd.splat_f32s(1.0 / 40_320.0));
    k = simd.mul_add_f32s(k, x2, simd.splat_f32s(-1.0 / 720.0));
    k = simd.mul_add_f32s(k, x2, simd.splat_f32s(1.0 / 24.0));
    k = simd.mul_add_f32s(k, x2, simd.splat_f32s(-0.5));
    let k = simd.mul_add_f32s(k, x2, simd.splat_f32s(1.0));
    // Quarter turn q (4 is 0): (sin, cos) of x + qπ/2.
    let q1 = simd.equal_f32s(q, simd.splat_f32s(1.0));
    let q2 = simd.equal_f32s(q, simd.splat_f32s(2.0));
    let q3 = simd.equal_f32s(q, simd.splat_f32s(3.0));
    let swap = simd.or_m32s(q1, q3);
    let (sin, cos) = (simd.select_f32s(swap, k, s), simd.select_f32s(swap, s, k));
    let neg_sin = simd.or_m32s(q2, q3);
    let neg_cos = simd.or_m32s(q1, q2);
    (
        simd.select_f32s(neg_sin, simd.neg_f32s(sin), sin),
        simd.select_f32s(neg_cos, simd.neg_f32s(cos), cos),
    )
}
