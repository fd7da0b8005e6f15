//! A tabulated index profile n(h): monotone cubic Hermite interpolation
//! (Fritsch–Carlson slopes, the weighted harmonic mean of PCHIP), so n is C¹,
//! has no overshoot between nodes (its extremes are at nodes) and is continued
//! by straight lines with the end slopes beyond the table.
//!
//! Every function takes the node arrays of an `IndexField::Profile` (heights
//! strictly increasing, at least two nodes: checked by `IndexField::validated`).

/// Slope of the interpolant at node `k`.
fn node_slope(h: &[f64], n: &[f64], k: usize) -> f64 {
    let last = h.len() - 1;
    let secant = |i: usize| (n[i + 1] - n[i]) / (h[i + 1] - h[i]);
    if k == 0 {
        return secant(0);
    }
    if k == last {
        return secant(last - 1);
    }
    let (d0, d1) = (secant(k - 1), secant(k));
    if d0 * d1 <= 0.0 {
        // A local extremum of the data: flat there, so the curve stays within it.
        return 0.0;
    }
    let (w0, w1) = (h[k] - h[k - 1], h[k + 1] - h[k]);
    let (a, b) = (2.0 * w1 + w0, w1 + 2.0 * w0);
    (a + b) / (a / d0 + b / d1)
}

/// The segment holding `x`: `i` with h[i] <= x < h[i+1], clamped to the ends.
fn segment(h: &[f64], x: f64) -> usize {
    let i = h.partition_point(|&v| v <= x);
    i.saturating_sub(1).min(h.len() - 2)
}

/// Cubic of segment `i` in the local variable t = x − h[i]: coefficients
/// c0 + c1 t + c2 t² + c3 t³.
fn cubic(h: &[f64], n: &[f64], i: usize) -> [f64; 4] {
    let w = h[i + 1] - h[i];
    let (d0, d1) = (node_slope(h, n, i), node_slope(h, n, i + 1));
    let delta = (n[i + 1] - n[i]) / w;
    let c2 = (3.0 * delta - 2.0 * d0 - d1) / w;
    let c3 = (d0 + d1 - 2.0 * delta) / (w * w);
    [n[i], d0, c2, c3]
}

/// n and dn/dh at height x.
pub fn eval(h: &[f64], n: &[f64], x: f64) -> (f64, f64) {
    let last = h.len() - 1;
    if x < h[0] {
        let d = node_slope(h, n, 0);
        return (n[0] + d * (x - h[0]), d);
    }
    if x > h[last] {
        let d = node_slope(h, n, last);
        return (n[last] + d * (x - h[last]), d);
    }
    let i = segment(h, x);
    let c = cubic(h, n, i);
    let t = x - h[i];
    (
        c[0] + t * (c[1] + t * (c[2] + t * c[3])),
        c[1] + t * (2.0 * c[2] + t * 3.0 * c[3]),
    )
}

/// n(x) − n(y) without cancellation when x and y share a piece: the cubic's
/// difference is (t − u)(c1 + c2(t + u) + c3(t² + tu + u²)).
pub fn diff(h: &[f64], n: &[f64], x: f64, y: f64) -> f64 {
    let last = h.len() - 1;
    let piece = |v: f64| {
        if v < h[0] {
            None
        } else if v > h[last] {
            Some(usize::MAX)
        } else {
            Some(segment(h, v))
        }
    };
    match (piece(x), piece(y)) {
        (None, None) => node_slope(h, n, 0) * (x - y),
        (Some(usize::MAX), Some(usize::MAX)) => node_slope(h, n, last) * (x - y),
        (Some(i), Some(j)) if i == j => {
            let c = cubic(h, n, i);
            let (t, u) = (x - h[i], y - h[i]);
            (t - u) * (c[1] + c[2] * (t + u) + c[3] * (t * t + t * u + u * u))
        }
        _ => eval(h, n, x).0 - eval(h, n, y).0,
    }
}

/// The largest |dn/dh| over [lo, hi] (the derivative of each cubic is a
/// quadratic: its ends and its vertex).
pub fn max_abs_slope(h: &[f64], n: &[f64], lo: f64, hi: f64) -> f64 {
    let mut m = eval(h, n, lo).1.abs().max(eval(h, n, hi).1.abs());
    for i in 0..h.len() - 1 {
        let (a, b) = (h[i].max(lo), h[i + 1].min(hi));
        if a > b {
            continue;
        }
        let c = cubic(h, n, i);
        m = m.max(eval(h, n, a).1.abs()).max(eval(h, n, b).1.abs());
        if c[3] != 0.0 {
            let v = h[i] - c[2] / (3.0 * c[3]);
            if v > a && v < b {
                m = m.max(eval(h, n, v).1.abs());
            }
        }
    }
    m
}

/// The nodes strictly inside (lo, hi): n is a cubic between them.
pub fn nodes_within(h: &[f64], lo: f64, hi: f64) -> impl Iterator<Item = f64> + '_ {
    h.iter().copied().filter(move |&v| v > lo && v < hi)
}

/// The smallest spacing of the nodes, metres.
pub fn min_spacing(h: &[f64]) -> f64 {
    h.windows(2).map(|w| w[1] - w[0]).fold(f64::INFINITY, f64::min)
}
