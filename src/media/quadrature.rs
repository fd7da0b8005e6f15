//! Gauss–Kronrod 7–15 quadrature of a pair of integrands, plain and adaptive
//! (the stratified tracer integrates the optical parameter and the arc length
//! together: they share the expensive part, the index at the node).

/// Kronrod nodes on [−1, 1] (positive half; the middle node is 0).
const XK: [f64; 8] = [
    0.991_455_371_120_812_6,
    0.949_107_912_342_758_5,
    0.864_864_423_359_769_1,
    0.741_531_185_599_394_4,
    0.586_087_235_467_691_1,
    0.405_845_151_377_397_2,
    0.207_784_955_007_898_5,
    0.0,
];
/// Kronrod weights for XK.
const WK: [f64; 8] = [
    0.022_935_322_010_529_22,
    0.063_092_092_629_978_55,
    0.104_790_010_322_250_2,
    0.140_653_259_715_525_9,
    0.169_004_726_639_267_9,
    0.190_350_578_064_785_4,
    0.204_432_940_075_298_9,
    0.209_482_141_084_727_8,
];
/// Gauss weights of the 7-point rule, on XK[1], XK[3], XK[5], XK[7].
const WG: [f64; 4] = [
    0.129_484_966_168_869_7,
    0.279_705_391_489_276_7,
    0.381_830_050_505_118_9,
    0.417_959_183_673_469_4,
];

/// ∫ f over [a, b] for both components of f by the 15-point Kronrod rule, with
/// the difference from the embedded 7-point Gauss rule (an error estimate,
/// pessimistic for smooth integrands).
pub fn gk15(a: f64, b: f64, f: &mut impl FnMut(f64) -> (f64, f64)) -> ((f64, f64), f64) {
    let c = 0.5 * (a + b);
    let r = 0.5 * (b - a);
    let (mut k0, mut k1, mut g0) = (0.0, 0.0, 0.0);
    for i in 0..8 {
        let pts: &[f64] = if i == 7 { &[0.0] } else { &[1.0, -1.0] };
        for &sgn in pts {
            let (y0, y1) = f(c + sgn * r * XK[i]);
            k0 += WK[i] * y0;
            k1 += WK[i] * y1;
            if i % 2 == 1 {
                g0 += WG[i / 2] * y0;
            }
        }
    }
    ((k0 * r, k1 * r), ((k0 - g0) * r).abs())
}

/// One converged panel of [`adaptive`]: its end and the integrals from the
/// start of the whole interval to that end.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Panel {
    /// Right end of the panel.
    pub x: f64,
    /// Running integral of the first component up to `x`.
    pub i0: f64,
    /// Running integral of the second component up to `x`.
    pub i1: f64,
}

/// ∫ f over [a, b] (both components), splitting in halves until the first
/// component's error estimate is below `rel`·|its integral so far| (plus an
/// absolute floor `abs`), at most `max_depth` halvings deep. Returns the panels
/// left to right with running integrals (the last holds the totals).
pub fn adaptive(
    a: f64,
    b: f64,
    rel: f64,
    abs: f64,
    max_depth: u32,
    f: &mut impl FnMut(f64) -> (f64, f64),
) -> Vec<Panel> {
    let mut out = Vec::new();
    let (mut run0, mut run1) = (0.0f64, 0.0f64);
    // Depth-first, left to right: a stack of pending intervals.
    let mut stack = vec![(a, b, 0u32)];
    let whole = gk15(a, b, f).0 .0.abs();
    while let Some((lo, hi, depth)) = stack.pop() {
        let ((v0, v1), err) = gk15(lo, hi, f);
        let scale = whole.max(run0.abs() + v0.abs());
        if err <= rel * scale + abs || depth >= max_depth {
            run0 += v0;
            run1 += v1;
            out.push(Panel {
                x: hi,
                i0: run0,
                i1: run1,
            });
        } else {
            let mid = 0.5 * (lo + hi);
            stack.push((mid, hi, depth + 1));
            stack.push((lo, mid, depth + 1));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kronrod_integrates_polynomials_and_adaptive_a_square_root_edge() {
        // Degree 22 is exact for 15-point Kronrod (3·7 + 1 = 22 for odd n).
        let ((v, w), _) = gk15(0.0, 2.0, &mut |x| (x.powi(22), 1.0));
        assert!((v - 2f64.powi(23) / 23.0).abs() < 1e-9 * v);
        assert!((w - 2.0).abs() < 1e-15);
        // ∫0^1 √x dx = 2/3: an end singularity in the derivative needs halvings.
        let p = adaptive(0.0, 1.0, 1e-13, 0.0, 50, &mut |x| (x.sqrt(), 0.0));
        let last = p.last().unwrap();
        assert!((last.i0 - 2.0 / 3.0).abs() < 1e-12, "{}", last.i0);
        assert!(p.len() > 3);
        assert!(p.windows(2).all(|w| w[0].x < w[1].x));
    }
}
