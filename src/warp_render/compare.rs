//! The warp against the exact trace, pixel by pixel.
use super::frame::Frame;
use crate::scene::RenderScene;
use glam::Vec3A as V3;

/// Warp against exact, pixel by pixel.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Comparison {
    /// Root-mean-square difference of linear RGB over all pixels and channels.
    pub rmse: f64,
    /// Pixels where both show the same object (position errors are over these).
    pub matched: u64,
    /// Pixels where one shows something and the other nothing or another object.
    pub mismatched: u64,
    /// Pixels compared.
    pub pixels: u64,
    /// Distance between the shown surface points (scene units).
    pub pos_mean: f64,
    /// Median distance.
    pub pos_median: f64,
    /// 95th percentile.
    pub pos_p95: f64,
    /// Largest.
    pub pos_max: f64,
    /// The same in pixel footprints (distance / size of a pixel at the exact
    /// point: the spacing of the exact points of neighbouring pixels).
    pub px_mean: f64,
    /// Median, in pixel footprints.
    pub px_median: f64,
    /// 95th percentile, in pixel footprints.
    pub px_p95: f64,
    /// Largest, in pixel footprints.
    pub px_max: f64,
}

fn quantiles(mut v: Vec<f64>) -> (f64, f64, f64, f64) {
    if v.is_empty() {
        return (0.0, 0.0, 0.0, 0.0);
    }
    v.sort_by(f64::total_cmp);
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let q = |f: f64| v[((v.len() - 1) as f64 * f).round() as usize];
    (mean, q(0.5), q(0.95), *v.last().unwrap_or(&0.0))
}

/// Compare and produce a heatmap (position error in pixels: black 0, red 1,
/// yellow ≥ 2; magenta where the two show different things).
pub fn compare(scene: &RenderScene, warp: &Frame, exact: &Frame) -> (Comparison, Vec<V3>) {
    let (w, h) = (warp.width as usize, warp.height as usize);
    let mut se = 0.0;
    for (a, b) in warp.pixels.iter().zip(&exact.pixels) {
        let d = *a - *b;
        se += (d * d).element_sum() as f64;
    }
    let rmse = (se / (3 * w * h).max(1) as f64).sqrt();
    let pixel_angle = scene.camera.pixel_angle() as f64;
    let footprint = |i: usize| -> f64 {
        let Some(s) = exact.shown[i] else { return 0.0 };
        let (x, y) = (i % w, i / w);
        let mut spacing: Vec<f64> = Vec::new();
        for (nx, ny) in [
            (x + 1, y),
            (x.wrapping_sub(1), y),
            (x, y + 1),
            (x, y.wrapping_sub(1)),
        ] {
            if nx < w && ny < h {
                if let Some(n) = exact.shown[ny * w + nx] {
                    if n.object == s.object {
                        spacing.push((n.point - s.point).length());
                    }
                }
            }
        }
        if spacing.is_empty() {
            s.path_length * pixel_angle
        } else {
            spacing.sort_by(f64::total_cmp);
            spacing[0]
        }
    };
    let mut pos = Vec::new();
    let mut px = Vec::new();
    let mut heat = vec![V3::ZERO; w * h];
    let mut mismatched = 0;
    for (i, cell) in heat.iter_mut().enumerate() {
        match (warp.shown[i], exact.shown[i]) {
            (Some(a), Some(b)) if a.object == b.object => {
                let e = (a.point - b.point).length();
                let fp = footprint(i);
                let epx = if fp > 0.0 { e / fp } else { 0.0 };
                pos.push(e);
                px.push(epx);
                let t = (epx as f32).min(2.0);
                *cell = if t <= 1.0 {
                    V3::new(t, 0.0, 0.0)
                } else {
                    V3::new(1.0, t - 1.0, 0.0)
                };
            }
            (None, None) => {}
            _ => {
                mismatched += 1;
                *cell = V3::new(1.0, 0.0, 1.0);
            }
        }
    }
    let matched = pos.len() as u64;
    let (pos_mean, pos_median, pos_p95, pos_max) = quantiles(pos);
    let (px_mean, px_median, px_p95, px_max) = quantiles(px);
    (
        Comparison {
            rmse,
            matched,
            mismatched,
            pixels: (w * h) as u64,
            pos_mean,
            pos_median,
            pos_p95,
            pos_max,
            px_mean,
            px_median,
            px_p95,
            px_max,
        },
        heat,
    )
}
