//! Index-of-refraction fields n(p) with analytic gradients, and their bounds.
//!
//! Every kind is a plain serde struct variant tagged by `kind` (snake_case), so the
//! same description is read from grin-trace JSON and from the TOML scene format.
//! Stratified kinds (everything but `plume`) depend on the height
//! `h = p·up − base` only; `up` must be a unit vector for `n`/`grad` (a `Medium` or
//! `IndexField::validated` normalises it).
//!
//! Here the field and its evaluation; `validate` checks a field's
//! parameters, `bounds` bounds its gradient, chords and extremes, `aabb` is
//! the box, `plume` the plume's waves and lanes, `fast_math` the sine,
//! cosine and exponential they run on.
mod aabb;
mod bounds;
mod fast_math;
mod plume;
mod validate;

pub use aabb::Aabb;
pub use bounds::FeatureScale;
pub use plume::WaveTable;

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::profile;
use fast_math::sin_cos;
use plume::wave;

/// The longest flight step in shortest turbulence wavelengths
/// ([`IndexField::flight_step`]).
pub(crate) const FLIGHT_WAVELENGTHS: f64 = 0.9;

fn default_up() -> DVec3 {
    DVec3::Y
}
fn default_base() -> f64 {
    0.0
}
fn default_zero() -> f64 {
    0.0
}
fn default_waves() -> u32 {
    6
}

/// n(p). Parameters are documented per kind; `up`/`base` default to +y and 0.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum IndexField {
    /// n = `n` everywhere.
    Constant {
        /// The index.
        n: f64,
    },
    /// n = n0 + m·h.
    Linear {
        /// Index at h = 0.
        n0: f64,
        /// Gradient dn/dh, per metre (negative: n falls with height).
        m: f64,
        /// Unit "up" direction the height is measured along (default +y;
        /// normalised by [`IndexField::validated`]).
        #[serde(default = "default_up")]
        up: DVec3,
        /// Height of the origin of h along `up`, metres: h = p·up − base (default 0).
        #[serde(default = "default_base")]
        base: f64,
    },
    /// Standard atmosphere: n = 1 + (n0 − 1)·exp(−h/H).
    Exponential {
        /// Index at h = 0.
        n0: f64,
        /// Scale height H (key `H`), metres (> 0): n − 1 falls by 1/e per H.
        #[serde(rename = "H")]
        scale_height: f64,
        /// Unit "up" direction the height is measured along (default +y;
        /// normalised by [`IndexField::validated`]).
        #[serde(default = "default_up")]
        up: DVec3,
        /// Height of the origin of h along `up`, metres: h = p·up − base (default 0).
        #[serde(default = "default_base")]
        base: f64,
    },
    /// Inferior mirage (hot air over a hot surface): n = n_inf − dn·exp(−h/h0).
    HotGround {
        /// Index far above the ground, as h → ∞.
        n_inf: f64,
        /// Index deficit at the ground, h = 0 (> 0 for hot air).
        dn: f64,
        /// Thickness of the hot layer, metres (> 0): the deficit falls by 1/e per h0.
        h0: f64,
        /// Unit "up" direction the height is measured along (default +y;
        /// normalised by [`IndexField::validated`]).
        #[serde(default = "default_up")]
        up: DVec3,
        /// Height of the origin of h along `up`, metres: h = p·up − base (default 0).
        #[serde(default = "default_base")]
        base: f64,
    },
    /// Inversion layer (superior mirage, looming, towering): a smooth step of `dn`
    /// centred at height `height` with half-width `thickness`, over a linear background:
    /// n = n0 + m·h + dn·(1 + tanh((h − height)/thickness))/2.
    /// Warm air over cold water: dn < 0.
    Inversion {
        /// Index of the background at h = 0, below the step.
        n0: f64,
        /// Size of the step across the layer (< 0 for warm air over cold water).
        dn: f64,
        /// Height of the centre of the layer, metres.
        height: f64,
        /// Half-width of the step, metres (> 0).
        thickness: f64,
        /// Gradient of the linear background dn/dh, per metre (default 0).
        #[serde(default = "default_zero")]
        m: f64,
        /// Unit "up" direction the height is measured along (default +y;
        /// normalised by [`IndexField::validated`]).
        #[serde(default = "default_up")]
        up: DVec3,
        /// Height of the origin of h along `up`, metres: h = p·up − base (default 0).
        #[serde(default = "default_base")]
        base: f64,
    },
    /// A tabulated profile: n at `heights` (metres, strictly increasing, at least
    /// two), interpolated by monotone cubic Hermite (no overshoot between nodes,
    /// C¹) and continued by straight lines with the end slopes beyond the table.
    Profile {
        /// Heights of the nodes, metres (strictly increasing).
        heights: Vec<f64>,
        /// The index at each node (as many as `heights`).
        n: Vec<f64>,
        /// Unit "up" direction the height is measured along (default +y;
        /// normalised by [`IndexField::validated`]).
        #[serde(default = "default_up")]
        up: DVec3,
        /// Height of the origin of h along `up`, metres: h = p·up − base (default 0).
        #[serde(default = "default_base")]
        base: f64,
        /// The thinnest layer the table describes, metres (default: the
        /// closest nodes' spacing): chords stay short enough to see it. A
        /// table sampled finer than its features (an `atmosphere`) says here
        /// how thin they are.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        layer: Option<f64>,
    },
    /// A heat plume over a source at `center` with deterministic turbulence:
    /// n = n_amb − dn·G(p)·(1 + amplitude·T(p)), G = exp(−ρ²/(2 radius²) − (h/height)²)
    /// where h is the height above `center` along `up` and ρ the distance from the
    /// plume axis, T = mean of `waves` sinusoids sin(k_i·p + φ_i) (|T| ≤ 1) with
    /// wavelengths around `wavelength`, directions and phases from `seed`.
    Plume {
        /// Ambient index, far from the plume.
        n_amb: f64,
        /// Index deficit at the source (> 0 for hot air).
        dn: f64,
        /// The source: the base of the plume axis, world metres.
        center: DVec3,
        /// Gaussian width across the axis, metres (> 0).
        radius: f64,
        /// Gaussian height scale along `up`, metres (> 0).
        height: f64,
        /// Relative strength of the turbulence, |amplitude| < 1 (default 0: smooth).
        #[serde(default = "default_zero")]
        amplitude: f64,
        /// Typical turbulence wavelength, metres (> 0; default 0.1).
        #[serde(default = "default_wavelength")]
        wavelength: f64,
        /// Number of sinusoids in T, 1..=64 (default 6).
        #[serde(default = "default_waves")]
        waves: u32,
        /// Seed of the waves' directions, phases and wavelengths (default 0).
        #[serde(default)]
        seed: u64,
        /// Unit direction of the plume axis (default +y; normalised by
        /// [`IndexField::validated`]).
        #[serde(default = "default_up")]
        up: DVec3,
        /// The waves of T, derived from `seed`, `waves` and `wavelength`
        /// (filled by [`IndexField::validated`]; derived at every
        /// evaluation while empty).
        #[serde(skip)]
        table: WaveTable,
    },
}

fn default_wavelength() -> f64 {
    0.1
}

/// The height-only view of a stratified field.
#[derive(Debug, Clone, Copy)]
pub struct Strata {
    /// Unit direction the height is measured along.
    pub up: DVec3,
    /// The height is h = p·up − base, metres.
    pub base: f64,
}

impl IndexField {
    /// The `kind` tag.
    pub fn kind(&self) -> &'static str {
        match self {
            IndexField::Constant { .. } => "constant",
            IndexField::Linear { .. } => "linear",
            IndexField::Exponential { .. } => "exponential",
            IndexField::HotGround { .. } => "hot_ground",
            IndexField::Inversion { .. } => "inversion",
            IndexField::Profile { .. } => "profile",
            IndexField::Plume { .. } => "plume",
        }
    }

    /// Some(up, base) when n depends on the height `p·up − base` only.
    pub fn strata(&self) -> Option<Strata> {
        match *self {
            IndexField::Constant { .. } => Some(Strata {
                up: DVec3::Y,
                base: 0.0,
            }),
            IndexField::Linear { up, base, .. }
            | IndexField::Exponential { up, base, .. }
            | IndexField::HotGround { up, base, .. }
            | IndexField::Inversion { up, base, .. }
            | IndexField::Profile { up, base, .. } => Some(Strata { up, base }),
            IndexField::Plume { .. } => None,
        }
    }

    /// n and dn/dh of a stratified field at height h (None for a plume).
    pub fn n_h(&self, h: f64) -> Option<(f64, f64)> {
        if let IndexField::Profile { heights, n, .. } = self {
            return Some(profile::eval(heights, n, h));
        }
        Some(match *self {
            IndexField::Constant { n } => (n, 0.0),
            IndexField::Linear { n0, m, .. } => (n0 + m * h, m),
            IndexField::Exponential { n0, scale_height, .. } => {
                let e = (n0 - 1.0) * (-h / scale_height).exp();
                (1.0 + e, -e / scale_height)
            }
            IndexField::HotGround { n_inf, dn, h0, .. } => {
                let e = dn * (-h / h0).exp();
                (n_inf - e, e / h0)
            }
            IndexField::Inversion {
                n0,
                dn,
                height,
                thickness,
                m,
                ..
            } => {
                let th = ((h - height) / thickness).tanh();
                (
                    n0 + m * h + 0.5 * dn * (1.0 + th),
                    m + 0.5 * dn * (1.0 - th * th) / thickness,
                )
            }
            IndexField::Plume { .. } | IndexField::Profile { .. } => return None,
        })
    }

    /// n(h) − n(h_ref) of a stratified field, without the cancellation of
    /// subtracting two indices near 1 (the stratified tracer's turning points
    /// are roots of such differences): expm1 for the exponentials, sinh of the
    /// difference for tanh, the factored cubic for a profile. NaN for a plume.
    pub fn n_diff(&self, h: f64, h_ref: f64) -> f64 {
        let dh = h - h_ref;
        match self {
            IndexField::Constant { .. } => 0.0,
            IndexField::Linear { m, .. } => m * dh,
            IndexField::Exponential { n0, scale_height, .. } => {
                (n0 - 1.0) * (-h_ref / scale_height).exp() * (-dh / scale_height).exp_m1()
            }
            IndexField::HotGround { dn, h0, .. } => -dn * (-h_ref / h0).exp() * (-dh / h0).exp_m1(),
            IndexField::Inversion {
                dn,
                height,
                thickness,
                m,
                ..
            } => {
                // tanh a − tanh c = sinh(a − c)/(cosh a cosh c).
                let (a, c) = ((h - height) / thickness, (h_ref - height) / thickness);
                m * dh + 0.5 * dn * (dh / thickness).sinh() / (a.cosh() * c.cosh())
            }
            IndexField::Profile { heights, n, .. } => profile::diff(heights, n, h, h_ref),
            IndexField::Plume { .. } => f64::NAN,
        }
    }

    /// The largest |dn/dh| of a stratified field over heights [lo, hi] (NaN for
    /// a plume): bounds the curvature of rays there.
    pub fn max_abs_slope(&self, lo: f64, hi: f64) -> f64 {
        let at = |h: f64| self.n_h(h).map_or(f64::NAN, |v| v.1.abs());
        match self {
            IndexField::Inversion { height, .. } if *height > lo && *height < hi => {
                // |m + dn sech²/(2w)| is largest at the centre or at an end.
                at(lo).max(at(hi)).max(at(*height))
            }
            IndexField::Profile { heights, n, .. } => profile::max_abs_slope(heights, n, lo, hi),
            IndexField::Plume { .. } => f64::NAN,
            // Monotone |dn/dh| (constant, linear, exponentials; an inversion
            // away from its centre): largest at an end.
            _ => at(lo).max(at(hi)),
        }
    }

    /// Heights strictly inside (lo, hi) where a stratified n may stop being
    /// monotone or smooth (interior extremes of n, a profile's nodes): between
    /// two consecutive ones n is monotone and smooth.
    pub fn breaks_within(&self, lo: f64, hi: f64) -> Vec<f64> {
        let mut v: Vec<f64> = match self {
            IndexField::Profile { heights, .. } => profile::nodes_within(heights, lo, hi).collect(),
            IndexField::Inversion { .. } => self
                .inversion_critical_heights()
                .into_iter()
                .filter(|h| *h > lo && *h < hi)
                .collect(),
            _ => Vec::new(),
        };
        v.sort_by(f64::total_cmp);
        v
    }

    /// Interior extremes of an inversion's n: dn/dh = m + dn/(2w) sech²u = 0
    /// ⇒ sech²u = −2wm/dn.
    fn inversion_critical_heights(&self) -> Vec<f64> {
        let IndexField::Inversion {
            dn,
            height,
            thickness,
            m,
            ..
        } = *self
        else {
            return Vec::new();
        };
        if dn == 0.0 {
            return Vec::new();
        }
        let c = -2.0 * thickness * m / dn;
        if !(c > 0.0 && c <= 1.0) {
            return Vec::new();
        }
        let u = (1.0 / c.sqrt()).acosh();
        vec![height - thickness * u, height + thickness * u]
    }

    /// n and grad n at p (one "evaluation").
    pub fn eval(&self, p: DVec3) -> (f64, DVec3) {
        if let Some(s) = self.strata() {
            // n_h is Some for every stratified kind.
            let (n, dndh) = self.n_h(p.dot(s.up) - s.base).unwrap_or((f64::NAN, 0.0));
            return (n, s.up * dndh);
        }
        match *self {
            IndexField::Plume {
                amplitude,
                wavelength,
                waves,
                seed,
                ref table,
                ..
            } => {
                let (mut t, mut grad_t) = (0.0, DVec3::ZERO);
                if amplitude != 0.0 {
                    // The table's phases are summed by the branch-free kernel
                    // (checked for range once); libm where they are huge.
                    let mut in_range = table.0.len() == waves as usize;
                    if in_range {
                        let (sum, g, far) = table.sums(p);
                        in_range = far < 1e6;
                        t = sum;
                        grad_t = g;
                    }
                    if !in_range {
                        (t, grad_t) = (0.0, DVec3::ZERO);
                        for i in 0..waves {
                            let (k, phase) = wave(seed, i, wavelength);
                            let (sin, cos) = sin_cos(k.dot(p) + phase);
                            t += sin;
                            grad_t += k * cos;
                        }
                    }
                }
                self.plume_at(p, t, grad_t)
            }
            _ => (f64::NAN, DVec3::ZERO),
        }
    }

    /// n at world point `p` (metres); the first half of [`IndexField::eval`].
    pub fn n(&self, p: DVec3) -> f64 {
        self.eval(p).0
    }

    /// ∇n at world point `p`, per metre; the second half of [`IndexField::eval`].
    pub fn grad(&self, p: DVec3) -> DVec3 {
        self.eval(p).1
    }
}
