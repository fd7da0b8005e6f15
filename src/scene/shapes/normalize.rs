//! Normalisation with a fallback, as glam's `normalize_or` (bit for bit) at
//! a fraction of its cost per hit.
use glam::{DVec3, Vec3A as V3};

/// `v.normalize_or(fallback)`, bit for bit: glam's test of the reciprocal
/// length (`is_finite() && > 0`) done on its bits (positive, finite, not
/// zero), which LLVM otherwise lowers to a dozen integer instructions of
/// float classification per call (once or twice per hit).
#[inline(always)]
pub(crate) fn normalize_or(v: V3, fallback: V3) -> V3 {
    let rcp = v.length_recip();
    if rcp.to_bits().wrapping_sub(1) < 0x7f7f_ffff {
        v * rcp
    } else {
        fallback
    }
}

/// [`normalize_or`] in f64 (`DVec3::normalize_or`, bit for bit).
#[inline(always)]
pub(super) fn normalize_or_f64(v: DVec3, fallback: DVec3) -> DVec3 {
    let rcp = v.length_recip();
    if rcp.to_bits().wrapping_sub(1) < 0x7fef_ffff_ffff_ffff {
        v * rcp
    } else {
        fallback
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both agree with glam's `normalize_or` bit for bit, on vectors from
    /// zero and subnormal lengths to overflowing ones, and on NaN.
    #[test]
    fn agree_with_glam_bit_for_bit() {
        let mut rng = crate::sampling::Rng::new(7);
        let mut fallbacks = 0;
        for k in 0..20_000 {
            let scale = match k % 5 {
                0 => 0.0,
                1 => 1e-40,
                2 => 1e30,
                3 => f64::NAN,
                _ => 10f64.powf(rng.uniform_f64() * 20.0 - 10.0),
            };
            let v = DVec3::new(
                rng.uniform_f64() - 0.5,
                rng.uniform_f64() - 0.5,
                rng.uniform_f64() - 0.5,
            ) * scale;
            let v64 = v * if k % 5 == 2 { 1e280 } else { 1.0 };
            let got = normalize_or_f64(v64, DVec3::Y);
            let want = v64.normalize_or(DVec3::Y);
            assert_eq!(
                got.to_array().map(f64::to_bits),
                want.to_array().map(f64::to_bits),
                "{v64}"
            );
            let v32 = v.as_vec3a();
            let got = normalize_or(v32, V3::Y);
            let want = v32.normalize_or(V3::Y);
            assert_eq!(
                got.to_array().map(f32::to_bits),
                want.to_array().map(f32::to_bits),
                "{v32}"
            );
            fallbacks += (got == V3::Y) as u32;
        }
        assert!(
            fallbacks > 4000,
            "{fallbacks}: the fallback cases must be reached"
        );
    }
}
