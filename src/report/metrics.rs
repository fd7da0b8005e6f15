//! Numbers the report derives from its measurements: image differences and
//! convergence slopes.
use glam::Vec3A as V3;

/// Root-mean-square difference of two images over pixels and channels, and
/// the same over the means of `k`×`k` blocks (partial blocks at the edges dropped).
pub(crate) fn image_errors(a: &[V3], b: &[V3], w: u32, h: u32, k: u32) -> (f64, f64) {
    let n = a.len().min(b.len()).max(1) as f64;
    let se: f64 = a
        .iter()
        .zip(b)
        .map(|(p, q)| (*p - *q).length_squared() as f64)
        .sum();
    let (bw, bh) = ((w / k).max(1), (h / k).max(1));
    let k = k.min(w).min(h).max(1);
    let mut sums = vec![[0f64; 3]; (bw * bh) as usize];
    for y in 0..bh * k {
        for x in 0..bw * k {
            let i = (y * w + x) as usize;
            let d = a[i] - b[i];
            let cell = &mut sums[((y / k) * bw + x / k) as usize];
            for (c, s) in cell.iter_mut().enumerate() {
                *s += d[c] as f64;
            }
        }
    }
    let kk = (k * k) as f64;
    let bse: f64 = sums
        .iter()
        .flat_map(|c| c.iter())
        .map(|s| (s / kk) * (s / kk))
        .sum();
    ((se / (3.0 * n)).sqrt(), (bse / (3.0 * sums.len() as f64)).sqrt())
}

/// Least-squares slope of log10(y) against log10(x).
pub(crate) fn loglog_slope(points: &[[f64; 2]]) -> f64 {
    let p: Vec<(f64, f64)> = points
        .iter()
        .filter(|p| p[0] > 0.0 && p[1] > 0.0)
        .map(|p| (p[0].log10(), p[1].log10()))
        .collect();
    let n = p.len() as f64;
    let (mx, my) = (
        p.iter().map(|q| q.0).sum::<f64>() / n,
        p.iter().map(|q| q.1).sum::<f64>() / n,
    );
    let sxy: f64 = p.iter().map(|q| (q.0 - mx) * (q.1 - my)).sum();
    let sxx: f64 = p.iter().map(|q| (q.0 - mx) * (q.0 - mx)).sum();
    sxy / sxx
}
