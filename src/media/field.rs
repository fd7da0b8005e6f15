//! Index-of-refraction fields n(p) with analytic gradients, and their bounds.
//!
//! Every kind is a plain serde struct variant tagged by `kind` (snake_case), so the
//! same description is read from grin-trace JSON and from the TOML scene format.
//! Stratified kinds (everything but `plume`) depend on the height
//! `h = p·up − base` only; `up` must be a unit vector for `n`/`grad` (a `Medium` or
//! `IndexField::validated` normalises it).
use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::{profile, MediumError};

/// An axis-aligned box (world metres).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Aabb {
    /// The corner with the smallest coordinates.
    pub min: DVec3,
    /// The corner with the largest coordinates.
    pub max: DVec3,
}

impl Aabb {
    /// The box from `min` to `max` (not checked: a validated box has min < max).
    pub fn new(min: DVec3, max: DVec3) -> Aabb {
        Aabb { min, max }
    }

    /// Length of the diagonal, metres.
    pub fn diagonal(&self) -> f64 {
        (self.max - self.min).length()
    }

    /// Closed containment test.
    pub fn contains(&self, p: DVec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// The 8 corners.
    pub fn corners(&self) -> [DVec3; 8] {
        let (a, b) = (self.min, self.max);
        [
            DVec3::new(a.x, a.y, a.z),
            DVec3::new(b.x, a.y, a.z),
            DVec3::new(a.x, b.y, a.z),
            DVec3::new(b.x, b.y, a.z),
            DVec3::new(a.x, a.y, b.z),
            DVec3::new(b.x, a.y, b.z),
            DVec3::new(a.x, b.y, b.z),
            DVec3::new(b.x, b.y, b.z),
        ]
    }

    /// Does the line `p + t d` leave the box by `t = tol` through a face it
    /// moves out of (so that, the box being convex, it is outside from there
    /// on)? The slab test's `t1 <= tol` without its divisions, for a ray just
    /// come out through a face.
    pub fn leaves_within(&self, p: DVec3, d: DVec3, tol: f64) -> bool {
        (0..3).any(|k| {
            (d[k] > 0.0 && self.max[k] - p[k] <= tol * d[k])
                || (d[k] < 0.0 && self.min[k] - p[k] >= tol * d[k])
        })
    }

    /// How far the line `p + t d` runs on inside the box from `p`: the slab
    /// test's t1 clamped at 0 (0 when the line misses), the value of
    /// `clip(p, d).map_or(0.0, |(_, t1)| t1.max(0.0))`. From a point inside
    /// the box only the three faces it moves towards are divided by: the
    /// other quotients are ≤ 0 and could not empty the interval. A flight
    /// asks this at every step.
    pub fn exit_distance(&self, p: DVec3, d: DVec3) -> f64 {
        if !self.contains(p) {
            return self.clip(p, d).map_or(0.0, |(_, t1)| t1.max(0.0));
        }
        let far = DVec3::select(d.cmpgt(DVec3::ZERO), self.max, self.min);
        let q = (far - p) / d;
        let mut t1 = f64::INFINITY;
        for k in 0..3 {
            if d[k] != 0.0 {
                t1 = t1.min(q[k]);
            }
        }
        t1.max(0.0)
    }

    /// Slab test: the parameter interval `[t0, t1]` (possibly with t0 < 0) where the
    /// line `p + t d` is inside the box, or None when it misses.
    pub fn clip(&self, p: DVec3, d: DVec3) -> Option<(f64, f64)> {
        // The six quotients as whole-vector divisions (the same values): the
        // divider's throughput, not the instruction count, bounds this test.
        let (qa, qb) = ((self.min - p) / d, (self.max - p) / d);
        let mut t0 = f64::NEG_INFINITY;
        let mut t1 = f64::INFINITY;
        for k in 0..3 {
            let (o, dir, lo, hi) = (p[k], d[k], self.min[k], self.max[k]);
            if dir == 0.0 {
                if o < lo || o > hi {
                    return None;
                }
            } else {
                let (a, b) = (qa[k], qb[k]);
                let (a, b) = if a < b { (a, b) } else { (b, a) };
                t0 = t0.max(a);
                t1 = t1.min(b);
            }
        }
        (t0 <= t1).then_some((t0, t1))
    }
}

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

/// A plume's turbulence waves (wave vector, phase), a cache of what
/// `seed`, `waves` and `wavelength` determine: always equal to another
/// table, so fields compare by their parameters. With the waves in chunks
/// of [`WAVE_LANES`] (kx, ky, kz, phase; the last padded with k = 0, phase 0)
/// and the vector instructions their sines are computed with.
#[derive(Clone, Default)]
pub struct WaveTable(Vec<(DVec3, f64)>, f64, Vec<[[f64; WAVE_LANES]; 4]>, pulp::Arch);

/// The longest flight step in shortest turbulence wavelengths
/// ([`IndexField::flight_step`]).
pub(crate) const FLIGHT_WAVELENGTHS: f64 = 0.9;

/// Waves evaluated side by side: eight f64 lanes are one AVX-512 register,
/// two AVX2 ones.
const WAVE_LANES: usize = 8;

impl WaveTable {
    fn new(seed: u64, waves: u32, wavelength: f64) -> WaveTable {
        let w: Vec<(DVec3, f64)> = (0..waves).map(|i| wave(seed, i, wavelength)).collect();
        let k_mean = w.iter().map(|w| w.0.length()).sum::<f64>() / f64::from(waves.max(1));
        let chunks = w
            .chunks(WAVE_LANES)
            .map(|c| {
                let get = |j: usize| c.get(j).copied().unwrap_or((DVec3::ZERO, 0.0));
                [
                    std::array::from_fn(|j| get(j).0.x),
                    std::array::from_fn(|j| get(j).0.y),
                    std::array::from_fn(|j| get(j).0.z),
                    std::array::from_fn(|j| get(j).1),
                ]
            })
            .collect();
        WaveTable(w, k_mean, chunks, pulp::Arch::new())
    }

    /// Σ sin(k·p + φ), Σ k cos(k·p + φ) over the waves, and the largest
    /// |phase| met. The sines and cosines of a chunk are computed side by
    /// side (the loop compiled for the CPU's widest vectors, chosen at run
    /// time); the sums then run in the waves' order, even and odd waves
    /// apart, as the two-lane code before them did, so the result does not
    /// depend on the vector width.
    fn sums(&self, p: DVec3) -> (f64, DVec3, f64) {
        self.3.dispatch(WaveSums { table: self, p })
    }
}

/// [`WaveTable::sums`] at `p`, compiled for each vector level (a `WithSimd`
/// whose body is inlined into pulp's per-level functions, so the lane loop
/// is vectorised for the level dispatched to).
struct WaveSums<'a> {
    table: &'a WaveTable,
    p: DVec3,
}

impl pulp::WithSimd for WaveSums<'_> {
    type Output = (f64, DVec3, f64);

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> Self::Output {
        let WaveSums { table, p } = self;
        let n = table.0.len();
        let (mut t, mut gx, mut gy, mut gz, mut far) = ([0.0; 2], [0.0; 2], [0.0; 2], [0.0; 2], [0.0f64; 2]);
        for (c, [kx, ky, kz, ph]) in table.2.iter().enumerate() {
            let (mut sin, mut cos, mut abs) = ([0.0; WAVE_LANES], [0.0; WAVE_LANES], [0.0; WAVE_LANES]);
            for l in 0..WAVE_LANES {
                let a = kx[l] * p.x + ky[l] * p.y + kz[l] * p.z + ph[l];
                abs[l] = a.abs();
                (sin[l], cos[l]) = sin_cos_reduced(a);
            }
            for l in 0..WAVE_LANES.min(n - c * WAVE_LANES) {
                let e = l % 2;
                far[e] = far[e].max(abs[l]);
                t[e] += sin[l];
                gx[e] += kx[l] * cos[l];
                gy[e] += ky[l] * cos[l];
                gz[e] += kz[l] * cos[l];
            }
        }
        (
            t[0] + t[1],
            DVec3::new(gx[0] + gx[1], gy[0] + gy[1], gz[0] + gz[1]),
            far[0].max(far[1]),
        )
    }
}

/// A plume's parameters as plain numbers, for [`PlumeConsts::at`].
#[derive(Clone, Copy)]
struct PlumeConsts {
    n_amb: f64,
    dn: f64,
    center: DVec3,
    radius: f64,
    height: f64,
    amplitude: f64,
    /// 1 / the number of waves.
    inv: f64,
    up: DVec3,
}

impl PlumeConsts {
    fn of(f: &IndexField) -> Option<PlumeConsts> {
        match *f {
            IndexField::Plume {
                n_amb,
                dn,
                center,
                radius,
                height,
                amplitude,
                waves,
                up,
                ..
            } => Some(PlumeConsts {
                n_amb,
                dn,
                center,
                radius,
                height,
                amplitude,
                inv: 1.0 / f64::from(waves),
                up,
            }),
            _ => None,
        }
    }

    /// n and ∇n at (x, y, z) from the waves' sums (see the field's doc):
    /// scalar arithmetic only, the arithmetic shared by one point at a time
    /// and eight side by side (one vector lane each), so both give the same
    /// bits.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn at(&self, x: f64, y: f64, z: f64, t_sum: f64, sx: f64, sy: f64, sz: f64) -> (f64, f64, f64, f64) {
        let c = self;
        let (qx, qy, qz) = (x - c.center.x, y - c.center.y, z - c.center.z);
        let h = qx * c.up.x + qy * c.up.y + qz * c.up.z;
        let (rx, ry, rz) = (qx - c.up.x * h, qy - c.up.y * h, qz - c.up.z * h);
        let rho2 = rx * rx + ry * ry + rz * rz;
        let hh = h / c.height;
        let g = exp_nonpositive(-rho2 / (2.0 * c.radius * c.radius) - hh * hh);
        let (r2, a) = (c.radius * c.radius, 2.0 * h / (c.height * c.height));
        let (ggx, ggy, ggz) = (
            g * (-rx / r2 - c.up.x * a),
            g * (-ry / r2 - c.up.y * a),
            g * (-rz / r2 - c.up.z * a),
        );
        let (t, tx, ty, tz) = if c.amplitude != 0.0 {
            (t_sum * c.inv, sx * c.inv, sy * c.inv, sz * c.inv)
        } else {
            (0.0, 0.0, 0.0, 0.0)
        };
        let f = 1.0 + c.amplitude * t;
        let n = c.n_amb - c.dn * g * f;
        let (m, ga) = (-c.dn, g * c.amplitude);
        (
            n,
            m * (ggx * f + ga * tx),
            m * (ggy * f + ga * ty),
            m * (ggz * f + ga * tz),
        )
    }
}

/// [`IndexField::eval_many`]'s eight points, each a lane: every wave's
/// phase, sine and cosine for the eight points side by side, summed per
/// point in the waves' order (even and odd apart, as [`WaveSums`]), then
/// [`IndexField::plume_at`] per lane.
struct PointLanes<'a> {
    consts: PlumeConsts,
    table: &'a WaveTable,
    pts: [DVec3; WAVE_LANES],
}

impl pulp::WithSimd for PointLanes<'_> {
    type Output = ([(f64, DVec3); WAVE_LANES], [f64; WAVE_LANES]);

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> Self::Output {
        let PointLanes { consts, table, pts } = self;
        let px: [f64; WAVE_LANES] = std::array::from_fn(|l| pts[l].x);
        let py: [f64; WAVE_LANES] = std::array::from_fn(|l| pts[l].y);
        let pz: [f64; WAVE_LANES] = std::array::from_fn(|l| pts[l].z);
        let mut t = [[0.0; WAVE_LANES]; 2];
        let mut gx = [[0.0; WAVE_LANES]; 2];
        let mut gy = [[0.0; WAVE_LANES]; 2];
        let mut gz = [[0.0; WAVE_LANES]; 2];
        let mut far = [[0.0f64; WAVE_LANES]; 2];
        for (w, &(k, ph)) in table.0.iter().enumerate() {
            let e = w % 2;
            for l in 0..WAVE_LANES {
                let a = k.x * px[l] + k.y * py[l] + k.z * pz[l] + ph;
                let (sin, cos) = sin_cos_reduced(a);
                far[e][l] = far[e][l].max(a.abs());
                t[e][l] += sin;
                gx[e][l] += k.x * cos;
                gy[e][l] += k.y * cos;
                gz[e][l] += k.z * cos;
            }
        }
        let (mut n, mut ox, mut oy, mut oz, mut far_out) = (
            [0.0; WAVE_LANES],
            [0.0; WAVE_LANES],
            [0.0; WAVE_LANES],
            [0.0; WAVE_LANES],
            [0.0; WAVE_LANES],
        );
        for l in 0..WAVE_LANES {
            (n[l], ox[l], oy[l], oz[l]) = consts.at(
                px[l],
                py[l],
                pz[l],
                t[0][l] + t[1][l],
                gx[0][l] + gx[1][l],
                gy[0][l] + gy[1][l],
                gz[0][l] + gz[1][l],
            );
            far_out[l] = far[0][l].max(far[1][l]);
        }
        (
            std::array::from_fn(|l| (n[l], DVec3::new(ox[l], oy[l], oz[l]))),
            far_out,
        )
    }
}

impl PartialEq for WaveTable {
    fn eq(&self, _: &WaveTable) -> bool {
        true
    }
}

impl std::fmt::Debug for WaveTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "WaveTable({} waves)", self.0.len())
    }
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

fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

fn unit01(state: &mut u64) -> f64 {
    (splitmix(state) >> 11) as f64 / (1u64 << 53) as f64
}

/// The i-th turbulence wave: wave vector and phase (deterministic in seed).
fn wave(seed: u64, i: u32, wavelength: f64) -> (DVec3, f64) {
    let mut st = seed ^ (u64::from(i) + 1).wrapping_mul(0xD1B5_4A32_D192_ED03);
    let z = 2.0 * unit01(&mut st) - 1.0;
    let phi = std::f64::consts::TAU * unit01(&mut st);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let dir = DVec3::new(r * phi.cos(), z, r * phi.sin());
    // Wavelengths spread over [0.5, 2] × wavelength.
    let lambda = wavelength * 2f64.powf(2.0 * unit01(&mut st) - 1.0);
    let phase = std::f64::consts::TAU * unit01(&mut st);
    (dir * (std::f64::consts::TAU / lambda), phase)
}

/// sin x and cos x to about an ulp for |x| < 1e6 (the turbulence's phases),
/// several times faster than libm's: reduction by π/2 in three parts
/// (Cody–Waite; n·π/2's first part is exact for |n| < 2^20) and fdlibm's
/// kernel polynomials on [−π/4, π/4]. libm beyond.
#[inline]
fn sin_cos(x: f64) -> (f64, f64) {
    if x.abs() >= 1e6 {
        return x.sin_cos();
    }
    sin_cos_reduced(x)
}

/// [`sin_cos`] without its range check (|x| < 1e6, or NaN): no branches.
#[inline(always)]
fn sin_cos_reduced(x: f64) -> (f64, f64) {
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
fn exp_nonpositive(x: f64) -> f64 {
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

fn check(key: &str, ok: bool, expected: &str, value: impl std::fmt::Debug) -> Result<(), MediumError> {
    if ok {
        Ok(())
    } else {
        Err(MediumError::invalid(
            key,
            format!("expected {expected}, got {value:?}"),
        ))
    }
}

fn finite(key: &str, v: f64) -> Result<(), MediumError> {
    check(key, v.is_finite(), "a finite number", v)
}

fn unit_up(key: &str, up: DVec3) -> Result<DVec3, MediumError> {
    check(
        key,
        up.is_finite() && up.length() > 1e-12,
        "a finite non-zero vector",
        up,
    )?;
    Ok(up.normalize())
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

    /// Checks the parameters (finite, positive scales, non-zero `up`) and returns a copy
    /// with `up` normalised. `key` prefixes error keys (e.g. "medium.field").
    ///
    /// # Errors
    ///
    /// [`MediumError::Invalid`] at `key.param` for the first parameter that is
    /// not finite or out of range (H, h0, thickness, radius, height, wavelength
    /// ≤ 0, |amplitude| ≥ 1, waves outside 1..=64, a zero `up`).
    pub fn validated(&self, key: &str) -> Result<IndexField, MediumError> {
        let k = |s: &str| format!("{key}.{s}");
        let mut f = self.clone();
        match &mut f {
            IndexField::Constant { n } => finite(&k("n"), *n)?,
            IndexField::Linear { n0, m, up, base } => {
                finite(&k("n0"), *n0)?;
                finite(&k("m"), *m)?;
                finite(&k("base"), *base)?;
                *up = unit_up(&k("up"), *up)?;
            }
            IndexField::Exponential {
                n0,
                scale_height,
                up,
                base,
            } => {
                finite(&k("n0"), *n0)?;
                check(
                    &k("H"),
                    scale_height.is_finite() && *scale_height > 0.0,
                    "H > 0",
                    *scale_height,
                )?;
                finite(&k("base"), *base)?;
                *up = unit_up(&k("up"), *up)?;
            }
            IndexField::HotGround {
                n_inf,
                dn,
                h0,
                up,
                base,
            } => {
                finite(&k("n_inf"), *n_inf)?;
                finite(&k("dn"), *dn)?;
                check(&k("h0"), h0.is_finite() && *h0 > 0.0, "h0 > 0", *h0)?;
                finite(&k("base"), *base)?;
                *up = unit_up(&k("up"), *up)?;
            }
            IndexField::Inversion {
                n0,
                dn,
                height,
                thickness,
                m,
                up,
                base,
            } => {
                finite(&k("n0"), *n0)?;
                finite(&k("dn"), *dn)?;
                finite(&k("height"), *height)?;
                finite(&k("m"), *m)?;
                finite(&k("base"), *base)?;
                check(
                    &k("thickness"),
                    thickness.is_finite() && *thickness > 0.0,
                    "thickness > 0",
                    *thickness,
                )?;
                *up = unit_up(&k("up"), *up)?;
            }
            IndexField::Profile {
                heights,
                n,
                up,
                base,
                layer,
            } => {
                if let Some(l) = layer {
                    check(
                        &k("layer"),
                        l.is_finite() && *l > 0.0,
                        "a finite layer > 0 (metres)",
                        *l,
                    )?;
                }
                check(
                    &k("heights"),
                    heights.len() >= 2,
                    "at least two nodes",
                    heights.len(),
                )?;
                check(
                    &k("n"),
                    n.len() == heights.len(),
                    &format!("as many values as heights ({})", heights.len()),
                    n.len(),
                )?;
                for (i, h) in heights.iter().enumerate() {
                    finite(&k(&format!("heights[{i}]")), *h)?;
                    if i > 0 {
                        check(
                            &k(&format!("heights[{i}]")),
                            *h > heights[i - 1],
                            &format!("heights strictly increasing (above {})", heights[i - 1]),
                            *h,
                        )?;
                    }
                }
                for (i, v) in n.iter().enumerate() {
                    check(
                        &k(&format!("n[{i}]")),
                        v.is_finite() && *v > 0.0,
                        "a finite n > 0",
                        *v,
                    )?;
                }
                finite(&k("base"), *base)?;
                *up = unit_up(&k("up"), *up)?;
            }
            IndexField::Plume {
                n_amb,
                dn,
                center,
                radius,
                height,
                amplitude,
                wavelength,
                waves,
                seed,
                up,
                table,
            } => {
                finite(&k("n_amb"), *n_amb)?;
                finite(&k("dn"), *dn)?;
                check(&k("center"), center.is_finite(), "a finite point", *center)?;
                check(
                    &k("radius"),
                    radius.is_finite() && *radius > 0.0,
                    "radius > 0",
                    *radius,
                )?;
                check(
                    &k("height"),
                    height.is_finite() && *height > 0.0,
                    "height > 0",
                    *height,
                )?;
                check(
                    &k("amplitude"),
                    amplitude.is_finite() && amplitude.abs() < 1.0,
                    "|amplitude| < 1",
                    *amplitude,
                )?;
                check(
                    &k("wavelength"),
                    wavelength.is_finite() && *wavelength > 0.0,
                    "wavelength > 0",
                    *wavelength,
                )?;
                check(&k("waves"), (1..=64).contains(waves), "1 to 64 waves", *waves)?;
                *up = unit_up(&k("up"), *up)?;
                *table = WaveTable::new(*seed, *waves, *wavelength);
            }
        }
        Ok(f)
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

    /// A plume's n and ∇n at `p` from its waves' sums Σ sin and Σ k cos
    /// there (not yet divided by their number), through
    /// [`PlumeConsts::at`].
    #[inline(always)]
    fn plume_at(&self, p: DVec3, t_sum: f64, grad_t_sum: DVec3) -> (f64, DVec3) {
        match PlumeConsts::of(self) {
            Some(c) => {
                let (n, gx, gy, gz) = c.at(p.x, p.y, p.z, t_sum, grad_t_sum.x, grad_t_sum.y, grad_t_sum.z);
                (n, DVec3::new(gx, gy, gz))
            }
            None => (f64::NAN, DVec3::ZERO),
        }
    }

    /// [`IndexField::eval`] at each of `ps` into `out`, the same bits. A
    /// plume's points are taken eight at a time, each a vector lane (the
    /// Gaussian's exponential and each wave's sine and cosine one vector
    /// operation for eight points): what makes several rays' flights side by
    /// side cheaper than one after another.
    pub fn eval_many(&self, ps: &[DVec3], out: &mut [(f64, DVec3)]) {
        debug_assert_eq!(ps.len(), out.len());
        let IndexField::Plume {
            amplitude,
            waves,
            ref table,
            ..
        } = *self
        else {
            for (p, o) in ps.iter().zip(out.iter_mut()) {
                *o = self.eval(*p);
            }
            return;
        };
        let consts = match PlumeConsts::of(self) {
            Some(c) if amplitude != 0.0 && table.0.len() == waves as usize => c,
            _ => {
                for (p, o) in ps.iter().zip(out.iter_mut()) {
                    *o = self.eval(*p);
                }
                return;
            }
        };
        for (pc, oc) in ps.chunks(WAVE_LANES).zip(out.chunks_mut(WAVE_LANES)) {
            let mut pts = [pc[0]; WAVE_LANES];
            pts[..pc.len()].copy_from_slice(pc);
            let (res, far) = table.3.dispatch(PointLanes { consts, table, pts });
            for (l, o) in oc.iter_mut().enumerate() {
                *o = if far[l] < 1e6 { res[l] } else { self.eval(pc[l]) };
            }
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
    fn critical_heights(&self, b: &Aabb, s: Strata) -> Vec<f64> {
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

#[cfg(test)]
mod wave_sum_tests {
    use super::{exp_nonpositive, sin_cos_reduced, IndexField, PlumeConsts, PointLanes, WaveSums, WaveTable};
    use glam::DVec3;

    /// The sums two waves at a time, even and odd apart, in the waves'
    /// order: the arithmetic every vector level must reproduce bit for bit.
    /// `one_sum`: all waves in one running sum instead (a known-wrong order).
    fn reference(t: &WaveTable, p: DVec3, one_sum: bool) -> (f64, DVec3, f64) {
        let (mut s, mut g, mut far) = ([0.0; 2], [DVec3::ZERO; 2], [0.0f64; 2]);
        for (i, (k, ph)) in t.0.iter().enumerate() {
            let e = if one_sum { 0 } else { i % 2 };
            let a = k.x * p.x + k.y * p.y + k.z * p.z + ph;
            far[e] = far[e].max(a.abs());
            let (sin, cos) = sin_cos_reduced(a);
            s[e] += sin;
            g[e] = DVec3::new(g[e].x + k.x * cos, g[e].y + k.y * cos, g[e].z + k.z * cos);
        }
        (s[0] + s[1], g[0] + g[1], far[0].max(far[1]))
    }

    fn bits(v: (f64, DVec3, f64)) -> [u64; 5] {
        [v.0, v.1.x, v.1.y, v.1.z, v.2].map(f64::to_bits)
    }

    #[test]
    fn every_vector_level_sums_the_waves_as_the_reference() {
        let mut levels = vec![("scalar", pulp::Arch::Scalar)];
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(s) = pulp::x86::V3::try_new() {
                levels.push(("avx2", pulp::Arch::V3(s)));
            }
            if let Some(s) = pulp::x86::V4::try_new() {
                levels.push(("avx512", pulp::Arch::V4(s)));
            }
        }
        let (mut points, mut caught) = (0, 0);
        // 1, 6 (the shipped scene's), 8, 9 and 21 waves: partial and whole chunks.
        for (waves, seed) in [(1, 5), (6, 3), (8, 1), (9, 7), (21, 2)] {
            let table = WaveTable::new(seed, waves, 0.2);
            for i in 0..2000 {
                let f = i as f64;
                let p = DVec3::new((f * 0.37).sin() * 0.9, 0.25 + f * 1.3e-3, (f * 0.53).cos() * 0.9);
                let want = bits(reference(&table, p, false));
                for (name, level) in &levels {
                    assert_eq!(
                        bits(level.dispatch(WaveSums { table: &table, p })),
                        want,
                        "{name}, {waves} waves at {p}"
                    );
                }
                points += 1;
                caught += usize::from(waves > 2 && bits(reference(&table, p, true)) != want);
            }
        }
        // Power: summing in another order changes the bits at most points.
        assert!(
            caught > points / 2,
            "a reordered sum differs at only {caught} of {points} points"
        );
    }

    /// The branch-free exponential against libm over the Gaussian's range:
    /// within 1 ulp, 0 below −700, NaN through. Power: the polynomial
    /// stopped at r⁴ misses by more than a thousand.
    #[test]
    fn the_branch_free_exponential_is_libms_within_an_ulp() {
        let ulps = |a: f64, b: f64| (a.to_bits() as i64 - b.to_bits() as i64).unsigned_abs();
        let (mut worst, mut n) = (0, 0);
        for i in 0..200_000 {
            let x = -700.0 * (i as f64 / 200_000.0).powi(3) - 1e-3 * ((i * 7919) % 1000) as f64 / 1000.0;
            worst = worst.max(ulps(exp_nonpositive(x), x.exp()));
            n += 1;
        }
        for x in [
            0.0,
            -0.0,
            -1e-300,
            -0.5 * std::f64::consts::LN_2,
            -std::f64::consts::LN_2,
            -1.0,
            -699.99,
        ] {
            worst = worst.max(ulps(exp_nonpositive(x), x.exp()));
        }
        eprintln!("exp over {n} points: worst {worst} ulp");
        assert!(worst <= 1, "{worst} ulp");
        assert_eq!(exp_nonpositive(-700.5), 0.0);
        assert_eq!(exp_nonpositive(f64::NEG_INFINITY), 0.0);
        assert!(exp_nonpositive(f64::NAN).is_nan());
        // A truncated polynomial (the power check).
        let truncated = |x: f64| {
            let k = (x / std::f64::consts::LN_2).round();
            let r = x - k * std::f64::consts::LN_2;
            (1.0 + r + r * r / 2.0 + r * r * r / 6.0 + r.powi(4) / 24.0) * 2f64.powi(k as i32)
        };
        assert!(ulps(truncated(-0.3), (-0.3f64).exp()) > 1000);
    }

    /// Eight points side by side give each point's own evaluation bit for
    /// bit, at every vector level, for a part chunk and past it, with a
    /// point whose phases are out of the kernel's range among them.
    #[test]
    fn points_side_by_side_evaluate_as_one_at_a_time() {
        let field = IndexField::Plume {
            n_amb: 1.000293,
            dn: 0.012,
            center: DVec3::new(0.0, 0.25, 0.0),
            radius: 0.3,
            height: 2.5,
            amplitude: 0.7,
            wavelength: 0.2,
            waves: 6,
            seed: 3,
            up: DVec3::Y,
            table: Default::default(),
        }
        .validated("medium.field")
        .unwrap();
        let IndexField::Plume { ref table, .. } = field else {
            unreachable!()
        };
        let bits = |v: (f64, DVec3)| [v.0, v.1.x, v.1.y, v.1.z].map(f64::to_bits);
        let mut levels = vec![pulp::Arch::Scalar];
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(s) = pulp::x86::V3::try_new() {
                levels.push(pulp::Arch::V3(s));
            }
            if let Some(s) = pulp::x86::V4::try_new() {
                levels.push(pulp::Arch::V4(s));
            }
        }
        for i in 0..500 {
            let f = i as f64;
            let pts: [DVec3; 8] = std::array::from_fn(|l| {
                let g = f + l as f64 * 0.173;
                DVec3::new((g * 0.37).sin() * 0.9, 0.25 + g * 5e-3, (g * 0.53).cos() * 0.9)
            });
            for level in &levels {
                let (res, _) = level.dispatch(PointLanes {
                    consts: PlumeConsts::of(&field).unwrap(),
                    table,
                    pts,
                });
                for l in 0..8 {
                    assert_eq!(bits(res[l]), bits(field.eval(pts[l])), "lane {l} at {}", pts[l]);
                }
            }
        }
        let mut ps: Vec<DVec3> = (0..11).map(|i| DVec3::new(0.05 * i as f64, 1.0, -0.3)).collect();
        ps[4] = DVec3::new(3e5, 1.0, 0.0);
        let mut out = vec![(0.0, DVec3::ZERO); ps.len()];
        field.eval_many(&ps, &mut out);
        for (p, o) in ps.iter().zip(&out) {
            assert_eq!(bits(*o), bits(field.eval(*p)), "at {p}");
        }
        // Power: the waves summed in one running sum (another order) change
        // the bits at most points.
        let (mut caught, mut points) = (0, 0);
        for i in 0..1000 {
            let f = i as f64;
            let p = DVec3::new((f * 0.37).sin() * 0.9, 0.25 + f * 2e-3, (f * 0.53).cos() * 0.9);
            let (sum, g, _) = reference(table, p, true);
            caught += usize::from(bits(field.plume_at(p, sum, g)) != bits(field.eval(p)));
            points += 1;
        }
        assert!(
            caught > points / 2,
            "another order differs at only {caught} of {points}"
        );
    }
}

#[cfg(test)]
mod exit_distance_tests {
    use super::Aabb;
    use crate::sampling::Rng;
    use glam::DVec3;

    /// `exit_distance` is the slab test's clamped t1 bit for bit, from
    /// inside, on the faces and outside, with axis-parallel directions; the
    /// near faces' quotient in its place (a known-wrong variant) is not.
    #[test]
    fn exit_distance_is_the_slab_tests_far_end() {
        let b = Aabb {
            min: DVec3::new(-0.9, 0.25, -0.9),
            max: DVec3::new(0.9, 3.2, 0.9),
        };
        let mut rng = Rng::for_sample(11, 0, 0);
        let mut u = || rng.uniform_f64();
        let (mut differ_wrong, mut n) = (0, 0);
        for i in 0..200_000 {
            let mut p = DVec3::new(3.0 * u() - 1.5, 4.0 * u() - 0.5, 3.0 * u() - 1.5);
            if i % 7 == 0 {
                // On a face.
                p.x = if u() < 0.5 { b.min.x } else { b.max.x };
            }
            let mut d = DVec3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize();
            if i % 11 == 0 {
                d = [DVec3::X, DVec3::NEG_Y, DVec3::Z][i % 3];
            }
            let want = b.clip(p, d).map_or(0.0, |(_, t1)| t1.max(0.0));
            let got = b.exit_distance(p, d);
            assert_eq!(got.to_bits(), want.to_bits(), "p {p:?} d {d:?}");
            if b.contains(p) {
                n += 1;
                let near = DVec3::select(d.cmpgt(DVec3::ZERO), b.min, b.max);
                let q = (near - p) / d;
                let wrong = (0..3)
                    .filter(|&k| d[k] != 0.0)
                    .map(|k| q[k])
                    .fold(f64::INFINITY, f64::min)
                    .max(0.0);
                differ_wrong += usize::from(wrong.to_bits() != want.to_bits());
            }
        }
        assert!(n > 10_000 && differ_wrong > n / 2, "{differ_wrong} of {n}");
    }
}
