//! Gauss–Legendre quadrature on [-1, 1]: the nodes and weights with which
//! the rough plastic tabulates its coating's transmittance and internal
//! reflectance (as Mitsuba 3's `quad::gauss_legendre` does for
//! `roughplastic`). An n-point rule integrates polynomials of degree
//! 2n − 1 exactly; nodes are found by Newton's method on the Legendre
//! polynomial P_n from Chebyshev starting points, in `f64`.

/// P_n(x) and its derivative, by the three-term recurrences
/// k P_k = (2k − 1) x P_{k−1} − (k − 1) P_{k−2} and
/// P'_k = P'_{k−2} + (2k − 1) P_{k−1}.
fn legendre_pd(n: usize, x: f64) -> (f64, f64) {
    match n {
        0 => (1.0, 0.0),
        1 => (x, 1.0),
        _ => {
            let (mut l_pp, mut l_p) = (1.0, x);
            let (mut d_pp, mut d_p) = (0.0, 1.0);
            for k in 2..=n {
                let kf = k as f64;
                let l = ((2.0 * kf - 1.0) * x * l_p - (kf - 1.0) * l_pp) / kf;
                let d = d_pp + (2.0 * kf - 1.0) * l_p;
                (l_pp, l_p) = (l_p, l);
                (d_pp, d_p) = (d_p, d);
            }
            (l_p, d_p)
        }
    }
}

/// The `n`-point Gauss–Legendre rule on [-1, 1]: `(nodes, weights)`, nodes
/// increasing, weights summing to 2. `n = 0` gives empty vectors.
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    for i in 0..n.div_ceil(2) {
        // The i-th root of P_n from below, starting at the Chebyshev node.
        let mut x = -(std::f64::consts::PI * (2 * i + 1) as f64 / (2 * n) as f64).cos();
        for _ in 0..100 {
            let (p, dp) = legendre_pd(n, x);
            let step = p / dp;
            x -= step;
            if step.abs() <= 4.0 * x.abs() * f64::EPSILON {
                break;
            }
        }
        if n % 2 == 1 && i == n / 2 {
            x = 0.0; // the middle root of an odd rule is exactly 0
        }
        let (_, dp) = legendre_pd(n, x);
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        nodes[i] = x;
        nodes[n - 1 - i] = -x;
        weights[i] = w;
        weights[n - 1 - i] = w;
    }
    (nodes, weights)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rules_integrate_polynomials_of_degree_2n_minus_1_exactly() {
        for n in [1usize, 2, 3, 7, 32, 128] {
            let (x, w) = gauss_legendre(n);
            assert!(x.windows(2).all(|p| p[0] < p[1]), "n = {n}: nodes increase");
            for degree in 0..2 * n {
                let got: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(degree as i32)).sum();
                // ∫_{-1}^{1} x^d dx = 2 / (d + 1) for even d, 0 for odd d.
                let want = if degree % 2 == 0 {
                    2.0 / (degree as f64 + 1.0)
                } else {
                    0.0
                };
                assert!(
                    (got - want).abs() < 1e-12,
                    "n = {n}, degree {degree}: {got} vs {want}"
                );
            }
            // One degree more is not exact (the rule's order is sharp); the
            // error falls like 4⁻ⁿ, so look where it is visible.
            if n <= 7 {
                let d = 2 * n;
                let got: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(d as i32)).sum();
                assert!((got - 2.0 / (d as f64 + 1.0)).abs() > 1e-8, "n = {n}");
            }
        }
    }
}
