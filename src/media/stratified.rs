//! Rays in stratified media (n depends on the height h = p·up − base only),
//! traced by their invariants instead of integrating the ray equation.
//!
//! With the optical parameter τ (dτ = ds/n) the ray equation is
//! d²r/dτ² = n∇n = ∇(n²/2). Across `up` the right side vanishes, so the
//! horizontal part of v = n·t is constant: its direction e (the azimuth) and
//! its size b = n·cos θ (θ the elevation; Snell's and Bouguer's invariant).
//! The horizontal distance is x = b·τ. Along `up`, p = dh/dτ = n·sin θ obeys
//! p² = n(h)² − b² =: F(h), so on a stretch where h is monotone
//!
//! ```text
//! τ(h) = ∫ dh / √F(h),      s(h) = ∫ n(h) dh / √F(h)
//! ```
//!
//! a 1-D quadrature. It turns where F = 0 (n(h) = b): there √F vanishes like
//! √|h − h_t| and h as a function of τ is smooth (p changes sign). The
//! quadrature is split into *legs* of monotone h between turning points and
//! the box's height limits, and each leg is integrated in a variable that is
//! regular at its turning ends: h = h_a + (h_b − h_a)·sin φ when it ends at a
//! turn (then dh/dφ ∝ cos φ vanishes like √F), h = h_b − (h_b − h_a)·cos φ
//! when it starts at one, both halves of a cosine when both ends turn, h linear
//! in φ otherwise. The integrands are then bounded and smooth, and
//! Gauss–Kronrod converges fast. F is formed as G(h)·(n + b) with
//! G = n(h) − b = [n(h) − n(h₀)] + n₀w₀²/(1 + cos θ₀), using each field's
//! cancellation-free index difference (`IndexField::n_diff`): G is a small
//! number computed from small numbers, not the difference of two indices near 1.
//!
//! Where the quadrature is elementary it is done in closed form, with τ as the
//! variable (no turning point needs handling: p(τ) just changes sign):
//! - linear n = n₀ + m·h: h'' = n·m, so n'' = m²n: n(τ) = n₀ Ch + m p₀ Sh;
//! - the exponential profiles n = A − D·e^{−h/H} (hot ground, the standard
//!   atmosphere): u = e^{(h−h₀)/H} obeys the *linear* equation
//!   u'' = ((A² − b²)·u − A·D₀)/H² (D₀ = D·e^{−h₀/H}), so
//!   u(τ) = 1 + u'₀ Sh + u''₀ Cm with u'₀ = p₀/H, u''₀ = (p₀² + n₀D₀)/H²;
//!
//! where, with κ² = m² or (A² − b²)/H² (negative: oscillating, a duct),
//! Ch = cosh κτ, Sh = sinh(κτ)/κ, Cm = (cosh κτ − 1)/κ², by series near 0 and
//! from one expm1 otherwise (no cancellation as κ → 0).
//!
//! Where we depart from the paper (CS 348b, "A study in non-linear ray
//! tracing"): its exact formula takes the positive square root (one branch)
//! and is undefined past the turning point; here the branch changes at every
//! turning point. [`Branch::Paper`] keeps the printed behaviour for tests: at
//! the turning height the ray goes on horizontally (Φ = 90° is a fixed point
//! of its Snell iteration).
use glam::DVec3;

use super::field::IndexField;
use super::quadrature::{self, Panel};

/// What happens at a turning point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Branch {
    /// The vertical direction reverses (the physics).
    Turn,
    /// The paper's printed branch: the ray stays at the turning height,
    /// horizontal, for ever (a known-wrong variant for tests).
    Paper,
}

/// How a [`StratifiedRay`] evaluates its path.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Options {
    /// Use the quadrature even where a closed form exists (tests compare them).
    pub quadrature: bool,
    /// What happens at turning points.
    pub branch: Branch,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            quadrature: false,
            branch: Branch::Turn,
        }
    }
}

/// A point of the path: optical parameter, height above the start, vertical
/// part of v (p = dh/dτ = n·sin θ) and the index there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// Optical parameter τ from the start (metres: dτ = ds/n).
    pub tau: f64,
    /// Height above the start, h − h₀, metres.
    pub dh: f64,
    /// p = dh/dτ, the vertical component of v = n·t.
    pub p: f64,
    /// The index of refraction there.
    pub n: f64,
}

#[derive(Debug, Clone)]
enum ClosedKind {
    Linear { m: f64 },
    Exp { a: f64, d0: f64, hs: f64 },
}

/// q(τ) = q₁ Sh + q₂ Cm with q = h − h₀ (linear) or q = u − 1 (exponential).
#[derive(Debug, Clone)]
struct Closed {
    kind: ClosedKind,
    q1: f64,
    q2: f64,
    k2: f64,
    /// For an exponential profile with κ² > 0: u = αE + β + γ/E, E = e^{κτ}
    /// (see `exp_modes`).
    modes: Option<(f64, f64, f64)>,
    /// With modes: the τ of their one turning point (∞ without one), once
    /// asked for. A cast asks for the next turn at every chord and crossing,
    /// and each answer would cost a logarithm.
    mode_turn: Option<f64>,
    /// With modes: κ = √κ², and γ/α ≤ 1 (the turn, if any, at τ ≤ 0),
    /// taken once per ray rather than per question (a cast's questions
    /// queue on the divider).
    kappa: f64,
    turn_behind: bool,
}

/// u = αe^{κτ} + β + γe^{−κτ} for an exponential profile with
/// C = A² − b² > 0, each coefficient free of cancellation (u spans e^{±Δh/H},
/// twenty orders of magnitude over a few metres of a thin hot layer, so
/// 1 + q₁Sh + q₂Cm would lose everything where u decays). β = A·D₀/C is the
/// fixed point; α + γ = 1 − β = (n₀D₀ + p₀²)/C; α − γ = p₀/√C. The smaller of
/// α, γ (γ when p₀ > 0) is (1 − β − |p₀|/√C)/2, which simplifies to
/// D₀²b²(A + n₀) / (2C(√C + |p₀|)(n₀√C + A|p₀|)) (all factors positive).
fn exp_modes(a: f64, d0: f64, n0: f64, b: f64, p0: f64, c: f64) -> (f64, f64, f64) {
    let s = c.sqrt();
    let q = p0.abs();
    let beta = a * d0 / c;
    let sum = (n0 * d0 + p0 * p0) / c;
    let small = d0 * d0 * b * b * (a + n0) / (2.0 * c * (s + q) * (n0 * s + a * q));
    let big = sum - small;
    if p0 > 0.0 {
        (big, beta, small)
    } else {
        (small, beta, big)
    }
}

/// The closed form a field's rays have (None: the quadrature), before a
/// start scales an exponential profile's deficit.
fn closed_kind(field: &IndexField) -> Option<ClosedKind> {
    match *field {
        IndexField::Constant { .. } => Some(ClosedKind::Linear { m: 0.0 }),
        IndexField::Linear { m, .. } => Some(ClosedKind::Linear { m }),
        IndexField::HotGround {
            n_inf, dn, h0: hs, ..
        } => Some(ClosedKind::Exp { a: n_inf, d0: dn, hs }),
        IndexField::Exponential {
            n0: ns, scale_height, ..
        } => Some(ClosedKind::Exp {
            a: 1.0,
            d0: -(ns - 1.0),
            hs: scale_height,
        }),
        _ => None,
    }
}

/// What a ray keeps of its last start for the next (see
/// [`StratifiedRay::kept_scale`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KeptScale {
    h0: f64,
    hs: f64,
    u: f64,
}

impl KeptScale {
    /// e^{−h₀/H} at start height `h0` for scale height `hs`: the kept value
    /// when it was taken there, else computed.
    #[inline]
    fn scale_at(self, h0: f64, hs: f64) -> f64 {
        if self.h0 == h0 && self.hs == hs {
            self.u
        } else {
            (-h0 / hs).exp()
        }
    }

    /// Nothing kept: the next start computes its scale.
    pub const NONE: KeptScale = KeptScale {
        h0: f64::NAN,
        hs: f64::NAN,
        u: f64::NAN,
    };
}

/// One ray's start from [`StratifiedRay::restart_lanes`].
#[derive(Debug, Clone, Copy)]
pub struct LaneStart {
    start: ExpStart,
    r: DVec3,
    up: DVec3,
    a: f64,
    hs: f64,
    u_scale: f64,
}

/// What a start gives an exponential profile's closed form (see
/// `StratifiedRay::restart`).
#[derive(Debug, Clone, Copy)]
struct ExpStart {
    h0: f64,
    e: DVec3,
    /// The deficit at the start, D₀ = D·e^{−h₀/H}.
    d0: f64,
    n0: f64,
    b: f64,
    p0: f64,
    g0: f64,
    q1: f64,
    q2: f64,
    k2: f64,
    modes: Option<(f64, f64, f64)>,
    kappa: f64,
    turn_behind: bool,
}

/// The closed-form starts of `N` rays of the profile n = a − d0·e^{−h/H}
/// (`hs` = H): ray `i` along unit `t[i]` from height `h0[i]`, where
/// e^{−h₀/H} = `u_scale[i]`. Each quantity for every ray before the next:
/// one ray's set-up is a chain of roots and divisions, and several rays'
/// chains side by side overlap instead of waiting one after the other.
/// (The same operations in the same order as one ray alone: the results do
/// not depend on N.)
#[inline(always)]
fn exp_starts<const N: usize>(
    a: f64,
    d0: f64,
    hs: f64,
    up: DVec3,
    t: &[DVec3; N],
    h0: &[f64; N],
    u_scale: &[f64; N],
) -> [ExpStart; N] {
    // Plain loops over arrays (`array::from_fn`'s closures were not inlined).
    let (mut w0, mut c0, mut horiz, mut e) = ([0.0; N], [0.0; N], [DVec3::ZERO; N], [DVec3::ZERO; N]);
    for i in 0..N {
        w0[i] = t[i].dot(up);
        horiz[i] = t[i] - up * w0[i];
        c0[i] = horiz[i].length();
    }
    for i in 0..N {
        e[i] = if c0[i] > 0.0 {
            horiz[i] / c0[i]
        } else {
            up.any_orthonormal_vector()
        };
    }
    let (mut d0s, mut n0, mut b, mut p0, mut g0) = ([0.0; N], [0.0; N], [0.0; N], [0.0; N], [0.0; N]);
    for i in 0..N {
        d0s[i] = d0 * u_scale[i];
        // The same formula the closed form uses (u₀ = 1).
        n0[i] = a - d0s[i];
        b[i] = n0[i] * c0[i];
        p0[i] = n0[i] * w0[i];
        g0[i] = n0[i] * w0[i] * w0[i] / (1.0 + c0[i]);
    }
    let (mut c, mut k2, mut q1, mut q2) = ([0.0; N], [0.0; N], [0.0; N], [0.0; N]);
    for i in 0..N {
        c[i] = (d0s[i] + g0[i]) * (a + b[i]);
        k2[i] = c[i] / (hs * hs);
        q1[i] = p0[i] / hs;
        q2[i] = (p0[i] * p0[i] + n0[i] * d0s[i]) / (hs * hs);
    }
    let mut modes = [None; N];
    for i in 0..N {
        if c[i] > 0.0 {
            modes[i] = Some(exp_modes(a, d0s[i], n0[i], b[i], p0[i], c[i]));
        }
    }
    let mut out = [ExpStart {
        h0: 0.0,
        e: DVec3::ZERO,
        d0: 0.0,
        n0: 0.0,
        b: 0.0,
        p0: 0.0,
        g0: 0.0,
        q1: 0.0,
        q2: 0.0,
        k2: 0.0,
        modes: None,
        kappa: f64::NAN,
        turn_behind: false,
    }; N];
    for i in 0..N {
        out[i] = ExpStart {
            h0: h0[i],
            e: e[i],
            d0: d0s[i],
            n0: n0[i],
            b: b[i],
            p0: p0[i],
            g0: g0[i],
            q1: q1[i],
            q2: q2[i],
            k2: k2[i],
            modes: modes[i],
            kappa: if modes[i].is_some() {
                k2[i].sqrt()
            } else {
                f64::NAN
            },
            turn_behind: modes[i].is_some_and(|(alpha, _, gamma)| gamma / alpha <= 1.0),
        };
    }
    out
}

#[derive(Debug, Clone)]
struct Leg {
    /// τ at φ = 0 (negative for a first leg begun at a turning point behind
    /// the start, see `StratifiedRay::new`).
    tau0: f64,
    /// Arc length at φ = 0.
    s0: f64,
    ha: f64,
    hb: f64,
    turn_a: bool,
    turn_b: bool,
    /// Converged panels over φ ∈ [0, π/2], [0, π] or [0, 1] (the leg's
    /// map) with running τ and s.
    panels: Vec<Panel>,
    /// The paper branch's horizontal run after a turning point (infinite).
    straight: bool,
}

impl Leg {
    fn tau_len(&self) -> f64 {
        if self.straight {
            f64::INFINITY
        } else {
            self.panels.last().map_or(0.0, |p| p.i0)
        }
    }
    fn s_len(&self) -> f64 {
        self.panels.last().map_or(0.0, |p| p.i1)
    }
    fn dir(&self) -> f64 {
        if self.hb >= self.ha {
            1.0
        } else {
            -1.0
        }
    }
    /// h(φ) and dh/dφ.
    fn h_of(&self, phi: f64) -> (f64, f64) {
        let span = self.hb - self.ha;
        match (self.turn_a, self.turn_b) {
            (false, false) => (self.ha + span * phi, span),
            (false, true) => (self.ha + span * phi.sin(), span * phi.cos()),
            (true, false) => {
                let s = (0.5 * phi).sin();
                (self.ha + span * 2.0 * s * s, span * phi.sin())
            }
            (true, true) => {
                let s = (0.5 * phi).sin();
                (self.ha + span * s * s, 0.5 * span * phi.sin())
            }
        }
    }
    /// The offset h − end from the turning end nearer φ (None without one),
    /// from the map itself: exact where h = end + offset would round it away.
    fn turn_offset(&self, phi: f64) -> Option<(f64, f64)> {
        let span = self.hb - self.ha;
        match (self.turn_a, self.turn_b) {
            (false, false) => None,
            (false, true) => {
                let s = (0.5 * (std::f64::consts::FRAC_PI_2 - phi)).sin();
                Some((self.hb, -2.0 * span * s * s))
            }
            (true, false) => {
                let s = (0.5 * phi).sin();
                Some((self.ha, 2.0 * span * s * s))
            }
            (true, true) => {
                if phi < std::f64::consts::FRAC_PI_2 {
                    let s = (0.5 * phi).sin();
                    Some((self.ha, span * s * s))
                } else {
                    let c = (0.5 * phi).cos();
                    Some((self.hb, -span * c * c))
                }
            }
        }
    }

    /// φ of height h on this leg (h between ha and hb).
    fn phi_of(&self, h: f64) -> f64 {
        let span = self.hb - self.ha;
        let f = if span == 0.0 {
            0.0
        } else {
            ((h - self.ha) / span).clamp(0.0, 1.0)
        };
        match (self.turn_a, self.turn_b) {
            (false, false) => f,
            (false, true) => f.asin(),
            (true, false) => 2.0 * (0.5 * f).sqrt().asin(),
            (true, true) => 2.0 * f.sqrt().asin(),
        }
    }
}

#[derive(Debug, Clone)]
struct Quad {
    legs: Vec<Leg>,
    /// Height limits (absolute): the box's lowest and highest heights.
    lo: f64,
    hi: f64,
    branch: Branch,
    /// No leg follows the last one (it ended at a height limit, or runs straight).
    done: bool,
}

#[derive(Debug, Clone)]
enum Form {
    Closed(Closed),
    Quad(Quad),
}

/// A ray in a stratified field: its invariants and a way to evaluate it at
/// any optical parameter τ ≥ 0.
#[derive(Debug, Clone)]
pub struct StratifiedRay {
    r0: DVec3,
    up: DVec3,
    /// Unit horizontal direction (any unit vector ⟂ up for a vertical ray).
    e: DVec3,
    h0: f64,
    n0: f64,
    /// The invariant n·cos θ.
    b: f64,
    p0: f64,
    /// n₀ − b = n₀w₀²/(1 + cos θ₀) ≥ 0.
    g0: f64,
    form: Form,
    /// Index evaluations (quadrature nodes, root-finding steps) and closed-form
    /// points, for the renderer's counters.
    evals: std::cell::Cell<u64>,
    /// e^{−h₀/H} for an exponential profile, 1 otherwise.
    u_scale: f64,
    /// The scale height `u_scale` was taken with (NaN: none): a camera's
    /// rays all start at its height, and restarting one for the next keeps
    /// the exponential.
    u_scale_hs: f64,
}

/// (Ch, Sh, Cm) at τ for κ² = k2: cosh κτ, sinh(κτ)/κ, (cosh κτ − 1)/κ²
/// (their trigonometric counterparts for κ² < 0), cancellation-free.
fn hyp(k2: f64, t: f64) -> (f64, f64, f64) {
    let z2 = k2 * t * t;
    if z2.abs() < 1e-3 {
        // Terms to z2⁵: the next is below 1e-3⁶/12! relative.
        let ch =
            1.0 + z2 / 2.0 * (1.0 + z2 / 12.0 * (1.0 + z2 / 30.0 * (1.0 + z2 / 56.0 * (1.0 + z2 / 90.0))));
        let sh = t
            * (1.0
                + z2 / 6.0 * (1.0 + z2 / 20.0 * (1.0 + z2 / 42.0 * (1.0 + z2 / 72.0 * (1.0 + z2 / 110.0)))));
        let cm = t
            * t
            * 0.5
            * (1.0
                + z2 / 12.0 * (1.0 + z2 / 30.0 * (1.0 + z2 / 56.0 * (1.0 + z2 / 90.0 * (1.0 + z2 / 132.0)))));
        return (ch, sh, cm);
    }
    if k2 > 0.0 {
        let k = k2.sqrt();
        let em = (k * t).exp_m1();
        let ep = 1.0 + em;
        let c1 = em * em / (2.0 * ep); // cosh − 1
        (1.0 + c1, em * (2.0 + em) / (2.0 * ep * k), c1 / k2)
    } else {
        let k = (-k2).sqrt();
        let (s, c) = (k * t).sin_cos();
        let half = (0.5 * k * t).sin();
        (c, s / k, 2.0 * half * half / -k2)
    }
}

/// Safeguarded Newton (Numerical Recipes' rtsafe) for a root of f in
/// [lo, hi] where f(lo) has the sign of `flo` and f(hi) the other (or is 0);
/// f returns (value, derivative). Bisects whenever Newton would leave the
/// bracket or shrink it by less than half. Returns the bracket's end on
/// `flo`'s side (for G: the last height still on the ray's side).
fn bracketed_root(mut lo: f64, mut hi: f64, flo: f64, mut f: impl FnMut(f64) -> (f64, f64)) -> f64 {
    let lo_sign = flo > 0.0;
    let mut x = 0.5 * (lo + hi);
    let mut step_old = (hi - lo).abs();
    let mut step = step_old;
    for _ in 0..400 {
        let (v, d) = f(x);
        if v == 0.0 {
            return x;
        }
        if (v > 0.0) == lo_sign {
            lo = x;
        } else {
            hi = x;
        }
        let width = (hi - lo).abs();
        if width <= 4.0 * f64::EPSILON * lo.abs().max(hi.abs()) || width == 0.0 {
            break;
        }
        let nx = x - v / d;
        let inside = if lo < hi {
            nx > lo && nx < hi
        } else {
            nx < lo && nx > hi
        };
        let slow = (2.0 * v).abs() > (step_old * d).abs();
        step_old = step;
        if nx.is_finite() && inside && !slow {
            step = (nx - x).abs();
            x = nx;
        } else {
            x = 0.5 * (lo + hi);
            step = 0.5 * width;
        }
        if x == lo || x == hi {
            break;
        }
    }
    lo
}

impl StratifiedRay {
    /// The ray from `r` with unit direction `t` in the stratified `field`
    /// (validated, `up` unit), inside heights [lo, hi] (the box's: quadrature
    /// legs end there).
    ///
    /// # Errors
    ///
    /// A message when the field is not stratified, or n at `r` is not finite
    /// and > 0.
    pub fn new(
        field: &IndexField,
        lo: f64,
        hi: f64,
        r: DVec3,
        t: DVec3,
        opts: Options,
    ) -> Result<Self, String> {
        let mut ray = StratifiedRay {
            r0: r,
            up: DVec3::Y,
            e: DVec3::X,
            h0: 0.0,
            n0: 1.0,
            b: 1.0,
            p0: 0.0,
            g0: 0.0,
            evals: std::cell::Cell::new(0),
            u_scale: 1.0,
            u_scale_hs: f64::NAN,
            form: Form::Quad(Quad {
                legs: Vec::new(),
                lo,
                hi,
                branch: opts.branch,
                done: true,
            }),
        };
        ray.restart(field, lo, hi, r, t, opts)?;
        Ok(ray)
    }

    /// Makes this the ray [`StratifiedRay::new`] would make, in place: a
    /// render starts one per path segment, and a new one moved into its
    /// place would be a copy of a few hundred bytes each time. On an error
    /// the ray is left as it was.
    ///
    /// # Errors
    ///
    /// As [`StratifiedRay::new`].
    pub fn restart(
        &mut self,
        field: &IndexField,
        lo: f64,
        hi: f64,
        r: DVec3,
        t: DVec3,
        opts: Options,
    ) -> Result<(), String> {
        let s = field.strata().ok_or_else(|| {
            format!(
                "the invariant tracer needs a stratified field, not {}",
                field.kind()
            )
        })?;
        let up = s.up;
        let closed = if opts.quadrature || opts.branch == Branch::Paper {
            None
        } else {
            closed_kind(field)
        };
        if let Some(ClosedKind::Exp { a, d0, hs }) = closed {
            let h0 = r.dot(up) - s.base;
            let u_scale = self.u_scale_at(h0, hs);
            let [start] = exp_starts(a, d0, hs, up, &[t], &[h0], &[u_scale]);
            super::state::check_n(start.n0, r)?;
            self.set_exp(&start, r, up, a, hs, u_scale);
            return Ok(());
        }
        let h0 = r.dot(up) - s.base;
        let w0 = t.dot(up);
        let horiz = t - up * w0;
        let c0 = horiz.length();
        let e = if c0 > 0.0 {
            horiz / c0
        } else {
            up.any_orthonormal_vector()
        };
        let u_scale = 1.0;
        let u_scale_hs = f64::NAN;
        let n0 = field.n_h(h0).map_or(f64::NAN, |v| v.0);
        super::state::check_n(n0, r)?;
        let b = n0 * c0;
        let p0 = n0 * w0;
        let g0 = n0 * w0 * w0 / (1.0 + c0);
        // (Exponential profiles returned above.)
        if let Some(ClosedKind::Linear { m }) = closed {
            let (q1, q2, k2) = (p0, n0 * m, m * m);
            *self = StratifiedRay {
                r0: r,
                up,
                e,
                h0,
                n0,
                b,
                p0,
                g0,
                evals: std::cell::Cell::new(1),
                u_scale,
                u_scale_hs,
                form: Form::Closed(Closed {
                    kind: ClosedKind::Linear { m },
                    q1,
                    q2,
                    k2,
                    modes: None,
                    mode_turn: None,
                    kappa: f64::NAN,
                    turn_behind: false,
                }),
            };
            return Ok(());
        }
        let mut ray = StratifiedRay {
            r0: r,
            up,
            e,
            h0,
            n0,
            b,
            p0,
            g0,
            evals: std::cell::Cell::new(1),
            u_scale,
            u_scale_hs,
            form: Form::Quad(Quad {
                legs: Vec::new(),
                lo: lo.min(h0),
                hi: hi.max(h0),
                branch: opts.branch,
                done: false,
            }),
        };
        let first = ray.first_leg(field);
        let Form::Quad(q) = &mut ray.form else {
            unreachable!("set above")
        };
        q.done = first.straight || (!first.turn_b);
        q.legs.push(first);
        *self = ray;
        Ok(())
    }

    /// e^{−h₀/H} at the start height `h0` for scale height `hs`: kept from
    /// the last start when that was at the same height (a camera's rays all
    /// start at its height).
    fn u_scale_at(&self, h0: f64, hs: f64) -> f64 {
        self.kept_scale().scale_at(h0, hs)
    }

    /// Makes this the closed-form ray of an exponential profile (n = a − d0·e^{−h/H}
    /// at the profile's base) that `start` describes, from `r`.
    fn set_exp(&mut self, start: &ExpStart, r: DVec3, up: DVec3, a: f64, hs: f64, u_scale: f64) {
        self.r0 = r;
        self.up = up;
        self.e = start.e;
        self.h0 = start.h0;
        self.n0 = start.n0;
        self.b = start.b;
        self.p0 = start.p0;
        self.g0 = start.g0;
        self.evals.set(1);
        self.u_scale = u_scale;
        self.u_scale_hs = hs;
        let closed = Closed {
            kind: ClosedKind::Exp { a, d0: start.d0, hs },
            q1: start.q1,
            q2: start.q2,
            k2: start.k2,
            modes: start.modes,
            mode_turn: None,
            kappa: start.kappa,
            turn_behind: start.turn_behind,
        };
        match &mut self.form {
            Form::Closed(c) => *c = closed,
            form => *form = Form::Closed(closed),
        }
    }

    /// The start height, scale height and e^{−h₀/H} this ray keeps for the
    /// next start at the same height (see [`StratifiedRay::restart_lanes`]).
    pub fn kept_scale(&self) -> KeptScale {
        KeptScale {
            h0: self.h0,
            hs: self.u_scale_hs,
            u: self.u_scale,
        }
    }

    /// What [`StratifiedRay::restart`] with default options computes for
    /// `N` rays of a field whose rays have the exponential profile's closed
    /// form, ray `i` from `r[i]` along unit `t[i]` (`kept[i]`: what the ray
    /// to restart keeps). Computed lane by lane, so that the rays' chains of
    /// roots and divisions overlap in the processor; each applied with
    /// [`StratifiedRay::restart_from`]. None where that does not apply (no
    /// such form, or a start's index not valid): restart them one by one.
    // Inlined (with `exp_starts`) into its caller: left out of line, its
    // array of starts is returned through a copy, 1 % of a mirage render.
    #[inline(always)]
    pub fn restart_lanes<const N: usize>(
        field: &IndexField,
        r: &[DVec3; N],
        t: &[DVec3; N],
        kept: &[KeptScale; N],
    ) -> Option<[LaneStart; N]> {
        let (Some(s), Some(ClosedKind::Exp { a, d0, hs })) = (field.strata(), closed_kind(field)) else {
            return None;
        };
        let (mut h0, mut u_scale) = ([0.0; N], [0.0; N]);
        for i in 0..N {
            h0[i] = r[i].dot(s.up) - s.base;
            u_scale[i] = kept[i].scale_at(h0[i], hs);
        }
        let starts = exp_starts(a, d0, hs, s.up, t, &h0, &u_scale);
        if starts.iter().any(|st| !(st.n0.is_finite() && st.n0 > 0.0)) {
            return None;
        }
        Some(std::array::from_fn(|i| LaneStart {
            start: starts[i],
            r: r[i],
            up: s.up,
            a,
            hs,
            u_scale: u_scale[i],
        }))
    }

    /// Makes this the ray one lane of [`StratifiedRay::restart_lanes`] describes.
    pub fn restart_from(&mut self, lane: &LaneStart) {
        self.set_exp(&lane.start, lane.r, lane.up, lane.a, lane.hs, lane.u_scale);
    }

    /// Index evaluations so far (a closed-form point counts as one).
    pub fn evaluations(&self) -> u64 {
        self.evals.get()
    }

    /// The invariant n·cos θ.
    pub fn invariant(&self) -> f64 {
        self.b
    }
    /// Height of the start, h₀ = r·up − base.
    pub fn start_height(&self) -> f64 {
        self.h0
    }
    /// Unit up.
    pub fn up(&self) -> DVec3 {
        self.up
    }
    /// True when the path is evaluated in closed form (no quadrature).
    pub fn is_closed_form(&self) -> bool {
        matches!(self.form, Form::Closed(_))
    }

    /// World position of a point of the path.
    pub fn position(&self, pt: &Point) -> DVec3 {
        self.r0 + self.e * (self.b * pt.tau) + self.up * pt.dh
    }
    /// v = n·t at a point (its length is n).
    pub fn velocity(&self, pt: &Point) -> DVec3 {
        self.e * self.b + self.up * pt.p
    }
    /// Unit tangent at a point.
    pub fn direction(&self, pt: &Point) -> DVec3 {
        self.velocity(pt).normalize()
    }
    /// The horizontal distance covered per unit τ (the invariant b):
    /// x = b·τ along `horizontal()`.
    pub fn horizontal(&self) -> DVec3 {
        self.e
    }
    /// The start point.
    pub fn origin(&self) -> DVec3 {
        self.r0
    }

    /// G(h) = n(h) − b, accurately (see the module docs), with its derivative.
    fn g(&self, field: &IndexField, h: f64) -> (f64, f64) {
        self.evals.set(self.evals.get() + 1);
        let d = field.n_diff(h, self.h0);
        let slope = field.n_h(h).map_or(0.0, |v| v.1);
        (d + self.g0, slope)
    }

    /// The first height strictly past `from` toward `to` where G < 0 changes
    /// sign (a turning point), scanning the field's monotone pieces.
    fn root_between(&self, field: &IndexField, from: f64, to: f64) -> Option<f64> {
        if from == to {
            return None;
        }
        let (lo, hi) = (from.min(to), from.max(to));
        let mut marks = field.breaks_within(lo, hi);
        if to < from {
            marks.reverse();
        }
        marks.push(to);
        let mut prev = from;
        for x in marks {
            let (gx, _) = self.g(field, x);
            if gx < 0.0 {
                // G ≥ 0 at prev (the ray's side), < 0 at x.
                return Some(bracketed_root(prev, x, 1.0, |h| self.g(field, h)));
            }
            prev = x;
        }
        None
    }

    fn make_leg(&self, field: &IndexField, ha: f64, dir: f64, turn_a: bool, tau0: f64, s0: f64) -> Leg {
        let Form::Quad(q) = &self.form else {
            unreachable!("legs belong to the quadrature form")
        };
        let limit = if dir > 0.0 { q.hi.max(ha) } else { q.lo.min(ha) };
        let (hb, turn_b) = match self.root_between(field, ha, limit) {
            Some(h) => (h, true),
            None => (limit, false),
        };
        let phi_max = match (turn_a, turn_b) {
            (false, false) => 1.0,
            (true, true) => std::f64::consts::PI,
            _ => std::f64::consts::FRAC_PI_2,
        };
        let mut leg = Leg {
            tau0,
            s0,
            ha,
            hb,
            turn_a,
            turn_b,
            panels: Vec::new(),
            straight: false,
        };
        if hb != ha {
            // The integrand is smooth between the field's breaks (a profile's
            // nodes, where n'' jumps): integrate piecewise between them.
            let mut cuts: Vec<f64> = field
                .breaks_within(ha.min(hb), ha.max(hb))
                .into_iter()
                .map(|h| leg.phi_of(h))
                .collect();
            cuts.push(phi_max);
            cuts.sort_by(f64::total_cmp);
            let (mut a, mut t, mut s) = (0.0, 0.0, 0.0);
            let mut panels = Vec::new();
            for c in cuts {
                if c <= a {
                    continue;
                }
                for p in
                    quadrature::adaptive(a, c, 1e-14, 0.0, 48, &mut |phi| self.integrand(field, &leg, phi))
                {
                    panels.push(Panel {
                        x: p.x,
                        i0: t + p.i0,
                        i1: s + p.i1,
                    });
                }
                let last = panels.last().copied().unwrap_or(Panel { x: c, i0: t, i1: s });
                (a, t, s) = (c, last.i0, last.i1);
            }
            leg.panels = panels;
        }
        leg
    }

    /// On a leg at φ: (h, n(h) − n₀, G(h), dh/dφ). Near a turning end G is
    /// taken relative to that end, where it is 0 by definition: the end is a
    /// root of G only to rounding, and the time to reach a turning point
    /// depends on the square root of such an error (1e-16 m of height would
    /// cost 1e-7 m of τ). Within 1e-8 (relative) of the end, h = end + offset
    /// would lose the offset: G there is n'(end)·offset (the next term is
    /// smaller by offset/scale of the field).
    fn leg_state(&self, field: &IndexField, leg: &Leg, phi: f64) -> (f64, f64, f64, f64) {
        self.evals.set(self.evals.get() + 1);
        let (h, dhdphi) = leg.h_of(phi);
        match leg.turn_offset(phi) {
            Some((end, off)) if off.abs() <= 1e-8 * (1.0 + end.abs()) => {
                let slope = field.n_h(end).map_or(0.0, |v| v.1);
                let d_end = field.n_diff(end, self.h0);
                (h, d_end + slope * off, slope * off, dhdphi)
            }
            Some((end, _)) => (h, field.n_diff(h, self.h0), field.n_diff(h, end), dhdphi),
            None => {
                let d = field.n_diff(h, self.h0);
                (h, d, d + self.g0, dhdphi)
            }
        }
    }

    /// (dτ/dφ, ds/dφ) on a leg.
    fn integrand(&self, field: &IndexField, leg: &Leg, phi: f64) -> (f64, f64) {
        let (_, d, gg, dhdphi) = self.leg_state(field, leg, phi);
        let n = self.n0 + d;
        let it = dhdphi.abs() / (gg.max(f64::MIN_POSITIVE) * (n + self.b)).sqrt();
        (it, n * it)
    }

    fn first_leg(&self, field: &IndexField) -> Leg {
        let Form::Quad(q) = &self.form else {
            unreachable!("legs belong to the quadrature form")
        };
        let (lo, hi) = (q.lo, q.hi);
        if self.p0 == 0.0 {
            // Launched horizontally: a turning point at the start; the ray
            // goes where n grows (d²h/dτ² = n·n').
            let slope = field.n_h(self.h0).map_or(0.0, |v| v.1);
            if slope == 0.0 {
                return Leg {
                    tau0: 0.0,
                    s0: 0.0,
                    ha: self.h0,
                    hb: self.h0,
                    turn_a: true,
                    turn_b: true,
                    panels: Vec::new(),
                    straight: true,
                };
            }
            let dir = slope.signum();
            return self.make_leg(field, self.h0, dir, true, 0.0, 0.0);
        }
        let dir = self.p0.signum();
        // A grazing start has F(h₀) = p₀² small and a turning point just behind
        // it: begin the leg there (its integrand is then regular at the start
        // too) and start the ray part-way along it.
        let reach = if dir > 0.0 { hi - self.h0 } else { self.h0 - lo }.max(0.0);
        if reach > 0.0 {
            if let Some(hv) = self.root_between(field, self.h0, self.h0 - dir * reach) {
                let mut leg = self.make_leg(field, hv, dir, true, 0.0, 0.0);
                let phi0 = leg.phi_of(self.h0);
                let pre = quadrature::adaptive(0.0, phi0, 1e-14, 0.0, 48, &mut |phi| {
                    self.integrand(field, &leg, phi)
                });
                let (t, s) = pre.last().map_or((0.0, 0.0), |p| (p.i0, p.i1));
                leg.tau0 = -t;
                leg.s0 = -s;
                return leg;
            }
        }
        self.make_leg(field, self.h0, dir, false, 0.0, 0.0)
    }

    /// Build legs until one reaches past τ (or none follows).
    fn extend_to(&mut self, field: &IndexField, tau: f64) {
        loop {
            let Form::Quad(q) = &self.form else { return };
            let last = q.legs.last().expect("a quadrature ray has its first leg");
            if q.done || last.tau0 + last.tau_len() > tau {
                return;
            }
            let next = if q.branch == Branch::Paper && last.turn_b {
                Leg {
                    tau0: last.tau0 + last.tau_len(),
                    s0: last.s0 + last.s_len(),
                    ha: last.hb,
                    hb: last.hb,
                    turn_a: true,
                    turn_b: false,
                    panels: Vec::new(),
                    straight: true,
                }
            } else {
                let (hb, dir, t, s) = (
                    last.hb,
                    -last.dir(),
                    last.tau0 + last.tau_len(),
                    last.s0 + last.s_len(),
                );
                self.make_leg(field, hb, dir, true, t, s)
            };
            let Form::Quad(q) = &mut self.form else { return };
            q.done = next.straight || !next.turn_b || q.legs.len() > 10_000;
            q.legs.push(next);
        }
    }

    /// The point at optical parameter τ ≥ 0 (past the last leg of a
    /// quadrature ray: its end).
    #[inline]
    pub fn point(&mut self, field: &IndexField, tau: f64) -> Point {
        // The closed forms directly (a cast asks for points all the time).
        match &self.form {
            Form::Closed(c) if tau != 0.0 => self.closed_point(c, tau),
            _ => self.point_and_arc(field, tau, false).0,
        }
    }

    /// The point at τ = 0 (what [`StratifiedRay::point`] gives there,
    /// without needing the ray mutable).
    pub fn start_point(&self) -> Point {
        Point {
            tau: 0.0,
            dh: 0.0,
            p: self.p0,
            n: self.n0,
        }
    }

    /// The arc length from the start to τ.
    pub fn arc_length(&mut self, field: &IndexField, tau: f64) -> f64 {
        self.point_and_arc(field, tau, true).1
    }

    fn point_and_arc(&mut self, field: &IndexField, tau: f64, want_s: bool) -> (Point, f64) {
        if tau == 0.0 {
            return (self.start_point(), 0.0);
        }
        match &self.form {
            Form::Closed(c) => {
                let pt = self.closed_point(c, tau);
                let s = if want_s { self.closed_arc(c, tau) } else { f64::NAN };
                (pt, s)
            }
            Form::Quad(_) => {
                self.extend_to(field, tau);
                self.quad_point(field, tau)
            }
        }
    }

    fn closed_point(&self, c: &Closed, tau: f64) -> Point {
        self.evals.set(self.evals.get() + 1);
        match (&c.kind, c.modes) {
            (ClosedKind::Linear { m }, _) => {
                let (ch, sh, cm) = hyp(c.k2, tau);
                let dh = c.q1 * sh + c.q2 * cm;
                Point {
                    tau,
                    dh,
                    p: c.q1 * ch + c.q2 * sh,
                    n: self.n0 + m * dh,
                }
            }
            (&ClosedKind::Exp { a, d0, hs }, Some((alpha, beta, gamma))) if c.k2 * tau * tau > 1.0 => {
                // u = αE + β + γ/E; u − 1 = α(E − 1) + γ(1/E − 1).
                let k = c.kappa;
                let z = k * tau;
                let (log_u, ratio, u) = if z < 600.0 {
                    // All three modes are well scaled here (E ≥ e): u itself,
                    // not u − 1, keeps its digits where it is tiny.
                    let e = z.exp();
                    let u = alpha * e + beta + gamma / e;
                    (u.ln(), k * (alpha * e - gamma / e) / u, u)
                } else {
                    // Far out only the growing mode is left (u → −∞ where
                    // α < 0: below the field's zero, outside any valid box).
                    let inv = (-z).exp();
                    let rest = alpha + beta * inv + gamma * inv * inv;
                    if rest > 0.0 {
                        (
                            z + rest.ln(),
                            k * (alpha - gamma * inv * inv) / rest,
                            f64::INFINITY,
                        )
                    } else {
                        (f64::NEG_INFINITY, f64::NEG_INFINITY, 0.0)
                    }
                };
                Point {
                    tau,
                    dh: hs * log_u,
                    p: hs * ratio,
                    n: a - d0 / u,
                }
            }
            (&ClosedKind::Exp { a, d0, hs }, _) => {
                let (ch, sh, cm) = hyp(c.k2, tau);
                let du = c.q1 * sh + c.q2 * cm;
                let u = 1.0 + du;
                Point {
                    tau,
                    dh: hs * du.ln_1p(),
                    p: hs * (c.q1 * ch + c.q2 * sh) / u,
                    n: a - d0 / u,
                }
            }
        }
    }

    fn closed_arc(&self, c: &Closed, tau: f64) -> f64 {
        match c.kind {
            ClosedKind::Linear { m } => {
                let (_, sh, cm) = hyp(c.k2, tau);
                self.n0 * sh + m * self.p0 * cm
            }
            ClosedKind::Exp { .. } => {
                // s = ∫ n dτ: smooth in τ, Gauss–Kronrod.
                let p = quadrature::adaptive(0.0, tau, 1e-15, 0.0, 40, &mut |t| {
                    (self.closed_point(c, t).n, 0.0)
                });
                p.last().map_or(0.0, |x| x.i0)
            }
        }
    }

    fn quad_point(&self, field: &IndexField, tau: f64) -> (Point, f64) {
        let Form::Quad(q) = &self.form else {
            unreachable!("quad_point on a quadrature ray")
        };
        let i = q.legs.partition_point(|l| l.tau0 <= tau).saturating_sub(1);
        let leg = &q.legs[i];
        if leg.straight {
            let h = leg.ha;
            let n = self.n0 + field.n_diff(h, self.h0);
            return (
                Point {
                    tau,
                    dh: h - self.h0,
                    p: 0.0,
                    n,
                },
                leg.s0 + n * (tau - leg.tau0),
            );
        }
        let target = (tau - leg.tau0).clamp(0.0, leg.tau_len());
        let at = |phi: f64| {
            let (h, d, gg, _) = self.leg_state(field, leg, phi);
            let n = self.n0 + d;
            let p = leg.dir() * (gg.max(0.0) * (n + self.b)).sqrt();
            (h, p, n)
        };
        if leg.panels.is_empty() {
            let (h, p, n) = at(0.0);
            return (
                Point {
                    tau,
                    dh: h - self.h0,
                    p,
                    n,
                },
                leg.s0,
            );
        }
        let j = leg
            .panels
            .partition_point(|p| p.i0 < target)
            .min(leg.panels.len() - 1);
        let (mut phi_lo, t_lo, s_lo) = if j == 0 {
            (0.0, 0.0, 0.0)
        } else {
            let p = leg.panels[j - 1];
            (p.x, p.i0, p.i1)
        };
        let mut phi_hi = leg.panels[j].x;
        let t_hi = leg.panels[j].i0;
        // Newton on φ within the panel; the running integrals go from its
        // start (a converged panel's sub-intervals are resolved by one rule).
        let mut f = |phi: f64| self.integrand(field, leg, phi);
        let frac = if t_hi > t_lo {
            (target - t_lo) / (t_hi - t_lo)
        } else {
            0.0
        };
        let base = phi_lo;
        let mut phi = phi_lo + (phi_hi - phi_lo) * frac;
        let mut t_s = (t_lo, s_lo);
        let tol = 4.0 * f64::EPSILON * (target.abs() + leg.tau0.abs() + t_hi);
        for _ in 0..60 {
            let ((dt, ds), _) = quadrature::gk15(base, phi, &mut f);
            t_s = (t_lo + dt, s_lo + ds);
            let err = t_s.0 - target;
            if err.abs() <= tol {
                break;
            }
            if err > 0.0 {
                phi_hi = phi;
            } else {
                phi_lo = phi;
            }
            let (it, _) = f(phi);
            let mut next = phi - err / it;
            if !(next > phi_lo && next < phi_hi) {
                next = 0.5 * (phi_lo + phi_hi);
            }
            if next == phi {
                break;
            }
            phi = next;
        }
        let (h, p, n) = at(phi);
        (
            Point {
                tau,
                dh: h - self.h0,
                p,
                n,
            },
            leg.s0 + t_s.1,
        )
    }

    /// The next turning point strictly after τ (p changes sign there), or ∞.
    /// Inline for the exponential profile's modes: a cast asks at every
    /// chord and crossing, and the answer is then a flag or a kept value.
    #[inline(always)]
    pub fn next_turn(&mut self, field: &IndexField, tau: f64) -> f64 {
        if let Form::Closed(Closed {
            modes: Some((alpha, _, gamma)),
            mode_turn,
            kappa,
            turn_behind,
            ..
        }) = &mut self.form
        {
            if tau >= 0.0 && *turn_behind {
                // ln(γ/α) ≤ 0: the turn is at τ ≤ 0 (behind), if any.
                return f64::INFINITY;
            }
            let t = *mode_turn.get_or_insert_with(|| modes_turn(*alpha, *gamma, *kappa));
            return if t > tau { t } else { f64::INFINITY };
        }
        self.next_turn_general(field, tau)
    }

    /// [`StratifiedRay::next_turn`] for the other forms.
    #[inline(never)]
    fn next_turn_general(&mut self, field: &IndexField, tau: f64) -> f64 {
        match &mut self.form {
            Form::Closed(c) => closed_next_turn(c, tau),
            Form::Quad(_) => loop {
                let Form::Quad(q) = &self.form else { unreachable!() };
                for leg in &q.legs {
                    let end = leg.tau0 + leg.tau_len();
                    if leg.turn_b && !leg.straight && end > tau {
                        return end;
                    }
                }
                if q.done {
                    return f64::INFINITY;
                }
                let last = q.legs.last().map_or(0.0, |l| l.tau0 + l.tau_len());
                self.extend_to(field, last);
            },
        }
    }

    /// The first τ in [t0, t1] where the height above the start equals `dh`
    /// (None when it does not get there), root-found on the monotone pieces
    /// between turning points.
    pub fn first_height(&mut self, field: &IndexField, dh: f64, t0: f64, t1: f64) -> Option<f64> {
        self.first_height_point(field, dh, None, t0, t1).map(|p| p.tau)
    }

    /// [`StratifiedRay::first_height`] with the point there. `u_level`, when
    /// known, is e^{dh/H} for an exponential profile (callers that cross the
    /// same absolute heights again and again keep e^{h/H} and scale it with
    /// [`StratifiedRay::level_scale`]).
    pub fn first_height_point(
        &mut self,
        field: &IndexField,
        dh: f64,
        u_level: Option<f64>,
        t0: f64,
        t1: f64,
    ) -> Option<Point> {
        if let Form::Closed(c) = &self.form {
            if let (&ClosedKind::Exp { a, d0, hs }, Some((alpha, beta, gamma))) = (&c.kind, c.modes) {
                if !closed_level_ill_conditioned(c, dh) {
                    // u = αE + β + γ/E = U: a quadratic in E; the point there
                    // needs no more exponentials (u = U, u' = κ(αE − γ/E)).
                    self.evals.set(self.evals.get() + 1);
                    let k = c.kappa;
                    let target = u_level.unwrap_or_else(|| (dh / hs).exp());
                    let e_lo = if t0 == 0.0 { 1.0 } else { (k * t0).exp() };
                    // τ = ln(E)/κ grows with E: only the smallest root past
                    // the start can be the first crossing (one logarithm).
                    let mut first: Option<f64> = None;
                    for e in quadratic_roots(alpha, beta - target, gamma) {
                        if e >= e_lo * (1.0 - 1e-15) && first.is_none_or(|f| e < f) {
                            first = Some(e);
                        }
                    }
                    let best = first.map(|e| ((e.ln() / k).max(t0), e)).filter(|&(t, _)| t <= t1);
                    return best.map(|(tau, e)| Point {
                        tau,
                        dh,
                        p: hs * k * (alpha * e - gamma / e) / target,
                        n: a - d0 / target,
                    });
                }
            }
            if let Some(roots) = closed_level_roots(c, dh) {
                // The quadratic's roots lose digits where κτ is small and the
                // modes large; two Newton steps on the point itself restore them
                // (skipped where the crossing is tangential).
                let c = c.clone();
                let polish = |t: f64| {
                    let mut t = t;
                    for _ in 0..2 {
                        let p = self.closed_point(&c, t);
                        let step = (p.dh - dh) / p.p;
                        if !(step.is_finite() && step.abs() <= 1e-6 * (1.0 + t.abs())) {
                            break;
                        }
                        t -= step;
                    }
                    t
                };
                let tau = roots
                    .into_iter()
                    .filter(|t| *t >= t0 * (1.0 - 1e-12) && *t <= t1 * (1.0 + 1e-12))
                    .map(polish)
                    .map(|t| t.clamp(t0, t1))
                    .min_by(f64::total_cmp)?;
                return Some(self.point(field, tau));
            }
        }
        self.first_height_generic(field, dh, t0, t1)
            .map(|t| self.point(field, t))
    }

    /// e^{−h₀/H} for an exponential profile (1 otherwise): e^{h/H} of an
    /// absolute height h times this is the `u_level` of h − h₀.
    pub fn level_scale(&self) -> f64 {
        self.u_scale
    }

    fn first_height_generic(&mut self, field: &IndexField, dh: f64, t0: f64, t1: f64) -> Option<f64> {
        let mut a = t0;
        let mut pa = self.point(field, a);
        if pa.dh == dh {
            return Some(a);
        }
        while a < t1 {
            let mut b = self.next_turn(field, a).min(t1);
            let mut pb = self.point(field, b);
            // Past where the path can be evaluated (an index gone to 0): back
            // off to where it can; the crossing, if any, is before.
            let mut guard = 0;
            while pb.dh.is_nan() && guard < 200 {
                b = a + 0.5 * (b - a);
                pb = self.point(field, b);
                guard += 1;
            }
            if (pa.dh - dh) * (pb.dh - dh) <= 0.0 {
                let fa = pa.dh - dh;
                return Some(bracketed_root(a, b, fa, |t| {
                    let p = self.point(field, t);
                    (p.dh - dh, p.p)
                }));
            }
            if !b.is_finite() {
                return None;
            }
            a = b;
            pa = pb;
        }
        None
    }

    /// The largest |n·n'| (the bound on |d²h/dτ²|) over the heights above
    /// the start in [lo, hi]. Exponential profiles have n' = (A − n)/H, both
    /// monotone in h: no field evaluation beyond the ends.
    pub fn curvature_bound(&self, field: &IndexField, lo: f64, hi: f64) -> f64 {
        let (a, b) = (self.h0 + lo, self.h0 + hi);
        if let Form::Closed(c) = &self.form {
            match c.kind {
                ClosedKind::Linear { m } => {
                    return m.abs() * (self.n0 + m * lo).max(self.n0 + m * hi);
                }
                ClosedKind::Exp { a: big_a, d0, hs } => {
                    let n_at = |dh: f64| big_a - d0 * (-dh / hs).exp();
                    let (na, nb) = (n_at(lo), n_at(hi));
                    return na.max(nb) * (big_a - na).abs().max((big_a - nb).abs()) / hs;
                }
            }
        }
        let n_at = |h: f64| field.n_h(h).map_or(f64::NAN, |v| v.0);
        let n_max = field
            .breaks_within(a, b)
            .into_iter()
            .map(n_at)
            .fold(n_at(a).max(n_at(b)), f64::max);
        n_max * field.max_abs_slope(a, b)
    }

    /// The largest |n·n'| over the path between points whose heights include
    /// the lowest and highest of that stretch: exact from the points' indices
    /// for the closed forms (|n·n'| is monotone in h there: n' = (A − n)/H or
    /// m), from the field over the heights otherwise.
    pub fn curvature_bound_at(&self, field: &IndexField, pts: &[Point]) -> f64 {
        if let Form::Closed(c) = &self.form {
            return match c.kind {
                ClosedKind::Linear { m } => pts.iter().map(|p| m.abs() * p.n).fold(0.0, f64::max),
                // One division after the maximum: dividing by H > 0 rounds
                // monotonically, so the result is the largest quotient's.
                ClosedKind::Exp { a, hs, .. } => {
                    pts.iter().map(|p| p.n * (a - p.n).abs()).fold(0.0, f64::max) / hs
                }
            };
        }
        let lo = pts.iter().map(|p| p.dh).fold(f64::INFINITY, f64::min);
        let hi = pts.iter().map(|p| p.dh).fold(f64::NEG_INFINITY, f64::max);
        self.curvature_bound(field, lo, hi)
    }

    /// The lowest and highest heights above the start over [t0, t1].
    pub fn height_range(&mut self, field: &IndexField, t0: f64, t1: f64) -> (f64, f64) {
        let (a, b) = (self.point(field, t0).dh, self.point(field, t1).dh);
        let (mut lo, mut hi) = (a.min(b), a.max(b));
        let mut t = t0;
        loop {
            t = self.next_turn(field, t);
            if t >= t1 {
                break;
            }
            let d = self.point(field, t).dh;
            lo = lo.min(d);
            hi = hi.max(d);
        }
        (lo, hi)
    }

    /// The optical parameter at arc length s (Newton on s(τ), ds/dτ = n).
    pub fn tau_at_arc(&mut self, field: &IndexField, s: f64) -> f64 {
        let mut tau = s / self.n0;
        let (mut lo, mut hi) = (0.0, f64::INFINITY);
        for _ in 0..100 {
            let (pt, st) = self.point_and_arc(field, tau, true);
            let f = st - s;
            if f > 0.0 {
                hi = hi.min(tau);
            } else {
                lo = f64::max(lo, tau);
            }
            if f.abs() <= 2.0 * f64::EPSILON * s.abs() {
                break;
            }
            let mut next = tau - f / pt.n;
            if !(next > lo && next < hi) {
                next = if hi.is_finite() {
                    0.5 * (lo + hi)
                } else {
                    2.0 * tau.max(1e-300)
                };
            }
            if next == tau {
                break;
            }
            tau = next;
        }
        tau
    }
}

/// Is a ray's path in `field` a closed form in τ (linear and exponential
/// profiles), rather than the quadrature?
pub fn has_closed_form(field: &IndexField) -> bool {
    matches!(
        field,
        IndexField::Constant { .. }
            | IndexField::Linear { .. }
            | IndexField::HotGround { .. }
            | IndexField::Exponential { .. }
    )
}

/// The real roots of a·x² + b·x + c = 0 (stable: no cancellation between b
/// and the root of the discriminant); NaN where there is none.
fn quadratic_roots(a: f64, b: f64, c: f64) -> [f64; 2] {
    if a == 0.0 {
        return [if b != 0.0 { -c / b } else { f64::NAN }, f64::NAN];
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return [f64::NAN; 2];
    }
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    if q == 0.0 {
        return [0.0, f64::NAN];
    }
    [q / a, c / q]
}

/// The optical parameters (any order, τ ≥ 0 not enforced) where the height
/// above the start of a closed-form ray equals `level`, solved exactly: with
/// E = e^{κτ} the height's linearising coordinate is αE + β + γ/E, a
/// quadratic in E (in τ itself when κ = 0). None where that form does not
/// apply (an oscillating exponential profile, κ² < 0).
fn closed_level_roots(c: &Closed, level: f64) -> Option<[f64; 2]> {
    let k2 = c.k2;
    let (alpha, beta, gamma, target) = match (&c.kind, c.modes) {
        (&ClosedKind::Exp { hs, .. }, Some((a, b, g))) => (a, b, g, (level / hs).exp()),
        (ClosedKind::Linear { .. }, _) if k2 == 0.0 => {
            // q₁τ + q₂τ²/2 = level.
            return Some(quadratic_roots(0.5 * c.q2, c.q1, -level));
        }
        (ClosedKind::Linear { .. }, _) if k2 > 0.0 => {
            let k = k2.sqrt();
            (
                c.q1 / (2.0 * k) + c.q2 / (2.0 * k2),
                -c.q2 / k2,
                -c.q1 / (2.0 * k) + c.q2 / (2.0 * k2),
                level,
            )
        }
        _ => return None,
    };
    let k = k2.sqrt();
    // Only positive roots are crossings (ln of the others would be NaN, and
    // slow).
    Some(quadratic_roots(alpha, beta - target, gamma).map(|e| if e > 0.0 { e.ln() / k } else { f64::NAN }))
}

/// Can the quadratic's roots have lost digits? When the modes αE + β + γ/E
/// are far larger than the level they sum to (only for an exponential
/// profile's u near 0, or a linear field's large 1/m modes).
fn closed_level_ill_conditioned(c: &Closed, level: f64) -> bool {
    match (&c.kind, c.modes) {
        (&ClosedKind::Exp { hs, .. }, Some((a, b, g))) => {
            // u = e^{level/H} ≥ e^{−7} unless the level is far below.
            level < -7.0 * hs || a.abs() + b.abs() + g.abs() > 1e3
        }
        _ => true,
    }
}

/// The τ where u = αE + β + γ/E turns (∞ if it does not): u' = κ(αE − γ/E)
/// = 0 at E² = γ/α (accurate where tanh κτ = ratio near 1 would round the
/// turn away).
fn modes_turn(alpha: f64, gamma: f64, kappa: f64) -> f64 {
    let r = gamma / alpha;
    if r > 0.0 {
        r.ln() / (2.0 * kappa)
    } else {
        f64::INFINITY
    }
}

/// Where q' = q₁ Ch + q₂ Sh vanishes after τ (a form without modes; see
/// [`modes_turn`] for those).
fn closed_next_turn(c: &Closed, tau: f64) -> f64 {
    let (q1, q2, k2) = (c.q1, c.q2, c.k2);
    if q2 == 0.0 {
        return f64::INFINITY;
    }
    let cand = if k2 > 0.0 {
        // q₁ cosh κτ + (q₂/κ) sinh κτ = 0: tanh κτ = −κ q₁/q₂.
        let k = k2.sqrt();
        let r = -k * q1 / q2;
        if r.abs() >= 1.0 {
            return f64::INFINITY;
        }
        r.atanh() / k
    } else if k2 == 0.0 {
        -q1 / q2
    } else {
        // tan κτ = −κ q₁/q₂: every π/κ.
        let k = (-k2).sqrt();
        let base = (-k * q1 / q2).atan();
        let step = std::f64::consts::PI / k;
        let n = ((tau - base / k) / step).floor() + 1.0;
        let t = base / k + n * step;
        return if t > tau { t } else { t + step };
    };
    if cand > tau {
        cand
    } else {
        f64::INFINITY
    }
}
