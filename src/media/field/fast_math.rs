//! sin, cos and exp for the plume's lanes: fdlibm's kernels without
//! branches, several times faster than libm's.
/// sin x and cos x to about an ulp for |x| < 1e6 (the turbulence's phases),
/// several times faster than libm's: reduction by π/2 in three parts
/// (Cody–Waite; n·π/2's first part is exact for |n| < 2^20) and fdlibm's
/// kernel polynomials on [−π/4, π/4]. libm beyond.
#[inline]
pub(super) fn sin_cos(x: f64) -> (f64, f64) {
    if x.abs() >= 1e6 {
        return x.sin_cos();
    }
    sin_cos_reduced(x)
}

/// [`sin_cos`] without its range check (|x| < 1e6, or NaN): no branches.
#[inline(always)]
pub(super) fn sin_cos_reduced(x: f64) -> (f64, f64) {
    const P1: f64 = 1.570_796_326_734_125_6;
    const P2: f64 = 6.077_100_506_303_966e-11;
    const P3: f64 = 2.022_266_248_711_166_5e-21;
    const S: [f64; 6] = [
        -1.666_666_666_666_663_2e-1,
        8.333_333_333_322_49e-3,
        -1.984_126_982_985_795e-4,
        2.755_731_370_707_006_8e-6,
        -2.505_076_025_340_686_3e-8,
        1.589_690_995_211_55e-10,
    ];
    const C: [f64; 6] = [
        4.166_666_666_666_66e-2,
        -1.388_888_888_887_411e-3,
        2.480_158_728_947_673e-5,
        -2.755_731_435_139_066_3e-7,
        2.087_572_321_298_175e-9,
        -1.135_964_755_778_819_5e-11,
    ];
    // Round to nearest by the 1.5·2^52 shift (no rounding instruction on
    // baseline x86-64).
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    let shifted = x * std::f64::consts::FRAC_2_PI + SHIFT;
    let n = shifted - SHIFT;
    let r = ((x - n * P1) - n * P2) - n * P3;
    let z = r * r;
    let s = r + r * z * (S[0] + z * (S[1] + z * (S[2] + z * (S[3] + z * (S[4] + z * S[5])))));
    let c = 1.0 - 0.5 * z + z * z * (C[0] + z * (C[1] + z * (C[2] + z * (C[3] + z * (C[4] + z * C[5])))));
    // Quadrants without branches (their order is random along a ray).
    // n's low bits (1.5·2^52 + n is an integer with n mod 4 in its last bits).
    let q = shifted.to_bits();
    let (s, c) = if q & 1 != 0 { (c, -s) } else { (s, c) };
    let sign = if q & 2 != 0 { -1.0 } else { 1.0 };
    (s * sign, c * sign)
}

/// e^x for a plume's Gaussian exponent x ≤ 0 (0 below −700, NaN for NaN),
/// without branches, so that vector lanes compute it as one: fdlibm's exp
/// (reduction by ln 2 in two parts, its rational approximation on
/// [−ln2/2, ln2/2], within 1 ulp), with 2^k put in the exponent bits
/// directly. (A division-free Taylor polynomial to r¹³ measured slower.)
#[inline(always)]
pub(super) fn exp_nonpositive(x: f64) -> f64 {
    // ln 2 in two parts (fdlibm's): k·LN2_HI is exact for |k| < 2^11.
    const LN2_HI: f64 = f64::from_bits(0x3fe6_2e42_fee0_0000);
    const LN2_LO: f64 = f64::from_bits(0x3dea_39ef_3579_3c76);
    // fdlibm's rational approximation's coefficients.
    const P: [f64; 5] = [
        1.666_666_666_666_660_2e-1,
        -2.777_777_777_701_559_3e-3,
        6.613_756_321_437_934e-5,
        -1.653_390_220_546_525_2e-6,
        4.138_136_797_057_238_5e-8,
    ];
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    let xc = x.max(-700.0);
    let shifted = xc * std::f64::consts::LOG2_E + SHIFT;
    let k = shifted - SHIFT;
    let hi = xc - k * LN2_HI;
    let lo = k * LN2_LO;
    let r = hi - lo;
    let z = r * r;
    let c = r - z * (P[0] + z * (P[1] + z * (P[2] + z * (P[3] + z * P[4]))));
    let y = 1.0 - ((lo - (r * c) / (2.0 - c)) - hi);
    // k's two's complement is in the low bits of 1.5·2^52 + k.
    let k_bits = shifted.to_bits().wrapping_sub(SHIFT.to_bits());
    let scale = f64::from_bits(k_bits.wrapping_add(1023) << 52);
    if x.is_nan() {
        x
    } else if x < -700.0 {
        0.0
    } else {
        y * scale
    }
}

#[cfg(test)]
mod sin_cos_tests {
    #[test]
    fn fast_sin_cos_agrees_with_libm() {
        let mut worst: f64 = 0.0;
        for i in 0..200_000 {
            let x = (i as f64 - 100_000.0) * 0.013_7 + 1e-3 * (i as f64).sin();
            let (s, c) = super::sin_cos(x);
            worst = worst.max((s - x.sin()).abs()).max((c - x.cos()).abs());
        }
        for x in [
            0.0,
            1e-300,
            std::f64::consts::FRAC_PI_4,
            1e5 + 0.3,
            -9.99e5,
            2e6,
            f64::NAN,
        ] {
            let (s, c) = super::sin_cos(x);
            assert!(
                x.is_nan() || ((s - x.sin()).abs() < 1e-10 && (c - x.cos()).abs() < 1e-10),
                "{x}"
            );
        }
        assert!(worst < 1e-15, "{worst:e}");
    }
}
