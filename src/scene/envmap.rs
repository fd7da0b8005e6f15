//! Importance sampling of lat-long environment maps (Mitsuba 3's `envmap`):
//! a piecewise-constant density over the map's (u, v) square, one cell per
//! texel, proportional to the cell's mean luminance × sin θ; a row is drawn
//! from the marginal, a column from that row's conditional.
//!
//! A map direction with polar angle θ = πv and azimuth φ = 2π(u − ½) has
//! dω = sin θ dθ dφ = 2π² sin θ du dv, so the solid-angle density is
//! p(u, v) / (2π² sin θ).
use super::texture::{ImageData, Rows};
use glam::{Mat3A, Vec3A as V3};
use std::f64::consts::PI;

/// Known-wrong densities, for the tests' power.
#[cfg(test)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EnvSampling {
    /// The sampler as it should be.
    Right,
    /// The solid-angle density without the 1/sin θ of the lat-long map.
    WrongNoSinJacobian,
}

/// The sampling distribution of one map.
pub struct EnvSampler {
    width: usize,
    height: usize,
    /// Cumulative row weights, `height + 1` values from 0 to 1.
    marginal: Vec<f64>,
    /// Per row, cumulative column weights (`width + 1` values from 0 to 1;
    /// all 0 for a row of weight 0).
    conditional: Vec<f64>,
    /// Density over the (u, v) square, per cell (row-major).
    density: Vec<f32>,
    /// Known-wrong variants for the tests.
    #[cfg(test)]
    pub sampling: EnvSampling,
}

impl std::fmt::Debug for EnvSampler {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "EnvSampler({}×{} cells)", self.width, self.height)
    }
}

/// Luminance of linear RGB (Rec. 709 weights, as Mitsuba's `luminance`);
/// negative and non-finite values count as 0.
fn luminance(c: V3) -> f64 {
    let y = 0.2126 * c.x as f64 + 0.7152 * c.y as f64 + 0.0722 * c.z as f64;
    if y.is_finite() && y > 0.0 {
        y
    } else {
        0.0
    }
}

/// `i` with `cdf[i] <= x < cdf[i + 1]` (the last such among equal values,
/// so never a bin of width 0 when `x` < the last value), and `x`'s place
/// inside that bin in [0, 1).
fn pick(cdf: &[f64], x: f64) -> (usize, f64) {
    let n = cdf.len() - 1;
    let i = cdf.partition_point(|&c| c <= x).saturating_sub(1).min(n - 1);
    let w = cdf[i + 1] - cdf[i];
    let t = if w > 0.0 {
        ((x - cdf[i]) / w).clamp(0.0, 1.0)
    } else {
        0.5
    };
    (i, t.min(1.0 - f64::EPSILON))
}

/// Cumulative sums of `w` over their total, from 0 to exactly 1 (`None`
/// when the total is 0).
fn cdf_of(w: &[f64]) -> Option<Vec<f64>> {
    let total: f64 = w.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let mut c = Vec::with_capacity(w.len() + 1);
    let mut acc = 0.0;
    c.push(0.0);
    for x in w {
        acc += x;
        c.push(acc / total);
    }
    *c.last_mut().expect("non-empty") = 1.0;
    Some(c)
}

impl EnvSampler {
    /// The distribution of `image` read with `rows`: `None` when the map
    /// is black (nothing to sample).
    pub fn new(image: &ImageData, rows: Rows) -> Option<EnvSampler> {
        let (w, h) = (image.width, image.height);
        if w == 0 || h == 0 || image.pixels.len() < w * h {
            return None;
        }
        let lum = |u: f64, v: f64| luminance(image.lookup_rows(u as f32, v as f32, rows));
        // The bilinear lookup is bilinear between these breaks (texel
        // centres in u; in v the rows' places), so the trapezoid rule over
        // them is the cell's exact mean: positive wherever the map is.
        let row_at = |k: usize| match rows {
            Rows::Centres => (k as f64 + 0.5) / h as f64,
            Rows::Poles => k as f64 / (h - 1).max(1) as f64,
        };
        let mut weights = vec![0.0f64; w * h];
        let mut vs = Vec::new();
        for j in 0..h {
            let (v0, v1) = (j as f64 / h as f64, (j + 1) as f64 / h as f64);
            vs.clear();
            vs.push(v0);
            vs.extend((0..h).map(row_at).filter(|&v| v > v0 && v < v1));
            vs.push(v1);
            // The cell's mean of sin θ: ∫ sin(πv) dv / Δv.
            let sin_mean = ((PI * v0).cos() - (PI * v1).cos()) / PI * h as f64;
            for i in 0..w {
                let us = [i as f64, i as f64 + 0.5, i as f64 + 1.0].map(|x| x / w as f64);
                let mut sum = 0.0;
                for vv in vs.windows(2) {
                    for uu in us.windows(2) {
                        let corners =
                            lum(uu[0], vv[0]) + lum(uu[1], vv[0]) + lum(uu[0], vv[1]) + lum(uu[1], vv[1]);
                        sum += 0.25 * corners * (uu[1] - uu[0]) * (vv[1] - vv[0]);
                    }
                }
                // `sum` is the integral over the cell (area 1/(wh)).
                weights[j * w + i] = sum * (w * h) as f64 * sin_mean;
            }
        }
        let row_weights: Vec<f64> = weights.chunks(w).map(|r| r.iter().sum()).collect();
        let marginal = cdf_of(&row_weights)?;
        let total: f64 = row_weights.iter().sum();
        let mut conditional = Vec::with_capacity(h * (w + 1));
        for r in weights.chunks(w) {
            conditional.extend(cdf_of(r).unwrap_or_else(|| vec![0.0; w + 1]));
        }
        // Mean weight 1 over the square: the density per unit (u, v) area.
        let density = weights
            .iter()
            .map(|&x| (x * (w * h) as f64 / total) as f32)
            .collect();
        Some(EnvSampler {
            width: w,
            height: h,
            marginal,
            conditional,
            density,
            #[cfg(test)]
            sampling: EnvSampling::Right,
        })
    }

    /// The solid-angle density of a (u, v) density `p` at polar angle θ.
    #[inline]
    fn solid_angle(&self, p: f32, sin_theta: f64) -> f32 {
        #[cfg(test)]
        if self.sampling == EnvSampling::WrongNoSinJacobian {
            return (p as f64 / (2.0 * PI * PI)) as f32;
        }
        if sin_theta > 0.0 {
            (p as f64 / (2.0 * PI * PI * sin_theta)) as f32
        } else {
            0.0
        }
    }

    /// A direction in the map's own frame from two uniform numbers in
    /// [0, 1), and its solid-angle density (`None` on a pole, where the
    /// density is infinite, and in cells of weight 0).
    pub fn sample(&self, u1: f64, u2: f64) -> Option<(V3, f32)> {
        let (j, tv) = pick(&self.marginal, u1);
        let row = &self.conditional[j * (self.width + 1)..(j + 1) * (self.width + 1)];
        let (i, tu) = pick(row, u2);
        let p = self.density[j * self.width + i];
        let u = (i as f64 + tu) / self.width as f64;
        let v = (j as f64 + tv) / self.height as f64;
        let theta = PI * v;
        let phi = 2.0 * PI * (u - 0.5);
        let (st, ct) = theta.sin_cos();
        let (sp, cp) = phi.sin_cos();
        let pdf = self.solid_angle(p, st);
        let d = V3::new((sp * st) as f32, ct as f32, (-cp * st) as f32);
        (pdf > 0.0 && pdf.is_finite()).then_some((d, pdf))
    }

    /// The solid-angle density of [`Self::sample`] at the unit direction
    /// `d` in the map's frame.
    pub fn pdf(&self, d: V3) -> f32 {
        let (x, y, z) = (d.x as f64, (d.y as f64).clamp(-1.0, 1.0), d.z as f64);
        let u = 0.5 + x.atan2(-z) / (2.0 * PI);
        let v = y.acos() / PI;
        let i = ((u * self.width as f64) as usize).min(self.width - 1);
        let j = ((v * self.height as f64) as usize).min(self.height - 1);
        let sin_theta = (x * x + z * z).sqrt();
        self.solid_angle(self.density[j * self.width + i], sin_theta)
    }

    /// A world direction and its density from two uniform numbers, for a
    /// map whose world-to-map rotation is `to_local`.
    #[inline]
    pub fn sample_world(&self, to_local: Option<&Mat3A>, u1: f64, u2: f64) -> Option<(V3, f32)> {
        let (d, pdf) = self.sample(u1, u2)?;
        // The inverse of a rotation is its transpose.
        Some((to_local.map_or(d, |m| m.transpose() * d), pdf))
    }

    /// [`Self::pdf`] of the world direction `d`.
    #[inline]
    pub fn pdf_world(&self, to_local: Option<&Mat3A>, d: V3) -> f32 {
        self.pdf(to_local.map_or(d, |m| *m * d))
    }
}

#[cfg(test)]
mod tests;
