//! Three-component vectors of SIMD lanes (`[S::f32s; 3]`: x, y and z of
//! as many lanes as the vector unit holds) and the arithmetic the vector
//! kernels share, operation for operation as glam's `Vec3A` computes it
//! (unfused, `dot` summed left to right).
//!
//! Plain `#[inline(always)]` functions, not closures: a closure is compiled
//! without the kernel's target features, and out of line its intrinsics
//! are calls.

use glam::Vec3A as V3;

/// x, y and z of the lanes.
pub(crate) type Vec3s<S> = [<S as pulp::Simd>::f32s; 3];

#[inline(always)]
pub(crate) fn dot<S: pulp::Simd>(simd: S, a: Vec3s<S>, b: Vec3s<S>) -> S::f32s {
    simd.add_f32s(
        simd.add_f32s(simd.mul_f32s(a[0], b[0]), simd.mul_f32s(a[1], b[1])),
        simd.mul_f32s(a[2], b[2]),
    )
}

#[inline(always)]
pub(crate) fn scale<S: pulp::Simd>(simd: S, a: Vec3s<S>, k: S::f32s) -> Vec3s<S> {
    [
        simd.mul_f32s(a[0], k),
        simd.mul_f32s(a[1], k),
        simd.mul_f32s(a[2], k),
    ]
}

#[inline(always)]
pub(crate) fn add<S: pulp::Simd>(simd: S, a: Vec3s<S>, b: Vec3s<S>) -> Vec3s<S> {
    [
        simd.add_f32s(a[0], b[0]),
        simd.add_f32s(a[1], b[1]),
        simd.add_f32s(a[2], b[2]),
    ]
}

#[inline(always)]
pub(crate) fn sub<S: pulp::Simd>(simd: S, a: Vec3s<S>, b: Vec3s<S>) -> Vec3s<S> {
    [
        simd.sub_f32s(a[0], b[0]),
        simd.sub_f32s(a[1], b[1]),
        simd.sub_f32s(a[2], b[2]),
    ]
}

#[inline(always)]
pub(crate) fn mul<S: pulp::Simd>(simd: S, a: Vec3s<S>, b: Vec3s<S>) -> Vec3s<S> {
    [
        simd.mul_f32s(a[0], b[0]),
        simd.mul_f32s(a[1], b[1]),
        simd.mul_f32s(a[2], b[2]),
    ]
}

#[inline(always)]
pub(crate) fn select<S: pulp::Simd>(simd: S, m: S::m32s, a: Vec3s<S>, b: Vec3s<S>) -> Vec3s<S> {
    [
        simd.select_f32s(m, a[0], b[0]),
        simd.select_f32s(m, a[1], b[1]),
        simd.select_f32s(m, a[2], b[2]),
    ]
}

#[inline(always)]
pub(crate) fn splat<S: pulp::Simd>(simd: S, v: V3) -> Vec3s<S> {
    [simd.splat_f32s(v.x), simd.splat_f32s(v.y), simd.splat_f32s(v.z)]
}
