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
//!
//! Here the ray and what it is asked (points, arc lengths, turns, level
//! crossings, curvature bounds); `start` makes and restarts it, `closed`
//! holds the closed forms, `legs` the quadrature's legs.
mod closed;
mod legs;
mod start;

pub use start::{KeptScale, LaneStart};

use glam::DVec3;

use super::field::IndexField;
use closed::{
    closed_level_ill_conditioned, closed_level_roots, modes_turn, quadratic_roots, Closed, ClosedKind,
};
use legs::Quad;

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

impl StratifiedRay {
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
