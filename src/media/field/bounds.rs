//! What bounds a field: its gradient along a segment, the longest chord
//! and flight step, n's extremes over a box.
use super::aabb::Aabb;
use super::plume::wave;
use super::{IndexField, Strata, FLIGHT_WAVELENGTHS};
use crate::media::profile;
use glam::DVec3;

/// The longest chord a field allows ([`IndexField::feature_scale`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FeatureScale {
    /// The same length in every direction (infinite: no limit).
    Length(f64),
    /// A layer `thickness` thick across `up`, rays in it curving at most
    /// `curvature` (max|∇n|/n, per metre).
    Layer {
        /// Thickness of the thinnest layer, metres.
        thickness: f64,
        /// Bound on the rays' curvature, per metre.
        curvature: f64,
        /// Unit normal of the layers.
        up: DVec3,
    },
}

impl FeatureScale {
    /// The longest chord (arc length) for a ray with unit tangent `t` that
    /// cannot step over a feature. For a layer of one `thickness`: with the
    /// path's curvature bounded by a, a run ℓ climbs at most ℓ·|t·up| + aℓ²/2,
    /// so ℓ = 2·thickness/(|t·up| + √((t·up)² + 2a·thickness)). A nearly
    /// horizontal ray may then take chords of kilometres where the thickness
    /// along the path would force metres.
    pub fn along(&self, t: DVec3) -> f64 {
        match *self {
            FeatureScale::Length(l) => l,
            FeatureScale::Layer {
                thickness,
                curvature,
                up,
            } => {
                let tu = t.dot(up).abs();
                2.0 * thickness / (tu + (tu * tu + 2.0 * curvature * thickness).sqrt())
            }
        }
    }
}

impl IndexField {
    /// An upper bound on |∇n| along the straight segment from `a` to `b`
    /// (infinite for kinds without one). Plume: with ρ the distance from the
    /// axis and h the height, G = Gρ(ρ)·Gh(h) falls with both, and
    /// |∇n| ≤ |dn|·(|∇G|·(1 + |amplitude|) + G·|amplitude|·K) (K the mean
    /// wavenumber, |∇T| ≤ K), |∇G| ≤ max Gh · max(ρGρ)/radius² + max Gρ ·
    /// max(2|h|Gh)/height², each maximum over the ranges of ρ and |h| the
    /// segment spans (ρ·e^(−ρ²/2r²) peaks at ρ = r, h·e^(−h²/H²) at H/√2).
    pub fn grad_bound_on_segment(&self, a: DVec3, b: DVec3) -> f64 {
        let IndexField::Plume {
            dn,
            center,
            radius,
            height,
            amplitude,
            wavelength,
            waves,
            seed,
            up,
            ref table,
            ..
        } = *self
        else {
            return f64::INFINITY;
        };
        let (qa, qb) = (a - center, b - center);
        let (ha, hb) = (qa.dot(up), qb.dot(up));
        let (pa, pb) = (qa - up * ha, qb - up * hb);
        let d = pb - pa;
        let u = if d.length_squared() > 0.0 {
            (-pa.dot(d) / d.length_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let rho_lo = (pa + d * u).length();
        let rho_hi = pa.length().max(pb.length());
        let h_lo = if ha * hb <= 0.0 {
            0.0
        } else {
            ha.abs().min(hb.abs())
        };
        let h_hi = ha.abs().max(hb.abs());
        let g_rho = |x: f64| (-x * x / (2.0 * radius * radius)).exp();
        let g_h = |x: f64| (-(x / height).powi(2)).exp();
        // max of x·g(x) over [lo, hi] for a bump peaking at `peak`.
        let peak_max = |lo: f64, hi: f64, peak: f64, g: &dyn Fn(f64) -> f64| {
            if lo <= peak && peak <= hi {
                peak * g(peak)
            } else {
                (lo * g(lo)).max(hi * g(hi))
            }
        };
        let (gr, gh) = (g_rho(rho_lo), g_h(h_lo));
        let grad_g = gh * peak_max(rho_lo, rho_hi, radius, &g_rho) / (radius * radius)
            + gr * 2.0 * peak_max(h_lo, h_hi, height * std::f64::consts::FRAC_1_SQRT_2, &g_h)
                / (height * height);
        let k_mean = if amplitude == 0.0 {
            0.0
        } else if table.0.len() == waves as usize {
            table.1
        } else {
            (0..waves)
                .map(|i| wave(seed, i, wavelength).0.length())
                .sum::<f64>()
                / f64::from(waves)
        };
        dn.abs() * (grad_g * (1.0 + amplitude.abs()) + gr * gh * amplitude.abs() * k_mean)
    }

    /// What bounds a chord's length so that it cannot step over a feature of
    /// the field, computed once per medium ([`FeatureScale::along`] per
    /// chord: a profile's largest slope is a scan of its table).
    pub fn feature_scale(&self) -> FeatureScale {
        match *self {
            IndexField::Inversion {
                n0,
                dn,
                thickness,
                m,
                up,
                ..
            } => {
                // n is near n0 in any air-like layer; 0.5 keeps the bound finite otherwise.
                let n_min = (n0 - dn.abs()).max(0.5);
                FeatureScale::Layer {
                    thickness,
                    curvature: (dn.abs() / (2.0 * thickness) + m.abs()) / n_min,
                    up: up.normalize_or_zero(),
                }
            }
            IndexField::Profile {
                ref heights,
                ref n,
                up,
                layer,
                ..
            } => {
                // As for the inversion, with the closest nodes as the layer.
                let lo = heights[0];
                let hi = heights[heights.len() - 1];
                let n_min = n.iter().copied().fold(f64::INFINITY, f64::min).max(0.5);
                FeatureScale::Layer {
                    thickness: layer.unwrap_or_else(|| profile::min_spacing(heights)),
                    curvature: profile::max_abs_slope(heights, n, lo, hi) / n_min,
                    up: up.normalize_or_zero(),
                }
            }
            _ => FeatureScale::Length(self.feature_length()),
        }
    }

    /// The longest step of a flight, metres: 0.9 of the shortest turbulence
    /// wavelength of a plume, else the feature length. Longer steps sample
    /// the waves too sparsely for the step's error estimate to see them; a
    /// flight's three evaluations per step (Bogacki–Shampine) then put about
    /// 3.3 on a wavelength (flight_tests.rs measures the cap).
    pub fn flight_step(&self) -> f64 {
        match *self {
            IndexField::Plume {
                amplitude,
                wavelength,
                waves,
                seed,
                ref table,
                ..
            } if amplitude != 0.0 => {
                let k_max = if table.0.len() == waves as usize {
                    table.0.iter().map(|w| w.0.length()).fold(0.0, f64::max)
                } else {
                    (0..waves)
                        .map(|i| wave(seed, i, wavelength).0.length())
                        .fold(0.0, f64::max)
                };
                FLIGHT_WAVELENGTHS * std::f64::consts::TAU / k_max
            }
            _ => self.feature_length(),
        }
    }

    /// A length over which the field's gradient direction may change (used to cap
    /// chords whose bending the end tangents cannot see), metres: for a plume
    /// min(radius, height)/2, and wavelength/8 with turbulence; for an inversion
    /// its `thickness`. Infinite for monotone stratified fields.
    pub fn feature_length(&self) -> f64 {
        match *self {
            IndexField::Plume {
                radius,
                height,
                amplitude,
                wavelength,
                ..
            } => {
                let l = radius.min(height) * 0.5;
                if amplitude != 0.0 {
                    l.min(wavelength * 0.125)
                } else {
                    l
                }
            }
            IndexField::Inversion { thickness, .. } => thickness,
            IndexField::Profile {
                ref heights, layer, ..
            } => layer.unwrap_or_else(|| profile::min_spacing(heights)),
            _ => f64::INFINITY,
        }
    }

    /// The minimum of n over the box, exactly for stratified fields (a function of
    /// height: extremes at corners or at interior critical points), and a guaranteed
    /// lower bound for a plume. Returns (min n, where).
    pub fn min_n_in(&self, b: &Aabb) -> (f64, DVec3) {
        match (self.strata(), self) {
            (Some(s), _) => {
                let cand = self.critical_heights(b, s);
                let mut best = (f64::INFINITY, 0.0);
                for h in cand {
                    let n = self.n_h(h).map_or(f64::NAN, |v| v.0);
                    if n.is_nan() || n < best.0 {
                        best = (n, h);
                    }
                }
                // A representative point at that height (the box centre moved along up).
                let c = (b.min + b.max) * 0.5;
                let p = c + s.up * (best.1 - (c.dot(s.up) - s.base));
                (best.0, p)
            }
            (
                None,
                IndexField::Plume {
                    n_amb, dn, amplitude, ..
                },
            ) => {
                let lower = n_amb - dn.abs() * (1.0 + amplitude.abs());
                (lower, (b.min + b.max) * 0.5)
            }
            _ => (f64::NAN, b.min),
        }
    }

    /// Heights where a stratified n can be extreme over the box: the lowest
    /// and highest heights of its corners and the interior critical points.
    pub(super) fn critical_heights(&self, b: &Aabb, s: Strata) -> Vec<f64> {
        let hs: Vec<f64> = b.corners().iter().map(|c| c.dot(s.up) - s.base).collect();
        let lo = hs.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = hs.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let mut cand = vec![lo, hi];
        // Between breaks n is monotone: its extremes are there or at the ends.
        cand.extend(self.breaks_within(lo, hi));
        cand
    }

    /// The maximum of n over the box (exact for stratified fields, a
    /// guaranteed upper bound for a plume).
    pub fn max_n_in(&self, b: &Aabb) -> f64 {
        match (self.strata(), self) {
            (Some(s), _) => self
                .critical_heights(b, s)
                .into_iter()
                .map(|h| self.n_h(h).map_or(f64::NAN, |v| v.0))
                .fold(
                    f64::NEG_INFINITY,
                    |a, n| if n.is_nan() { f64::NAN } else { a.max(n) },
                ),
            (
                None,
                IndexField::Plume {
                    n_amb, dn, amplitude, ..
                },
            ) => n_amb + dn.abs() * (1.0 + amplitude.abs()),
            _ => f64::NAN,
        }
    }
}
