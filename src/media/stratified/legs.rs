//! The quadrature's legs: stretches of monotone height between turning
//! points and the box's limits, each integrated in a variable regular at
//! its turning ends.
use super::closed::closed_next_turn;
use super::{Branch, Form, Point, StratifiedRay};
use crate::media::field::IndexField;
use crate::media::quadrature::{self, Panel};

#[derive(Debug, Clone)]
pub(super) struct Leg {
    /// τ at φ = 0 (negative for a first leg begun at a turning point behind
    /// the start, see `StratifiedRay::new`).
    pub(super) tau0: f64,
    /// Arc length at φ = 0.
    pub(super) s0: f64,
    pub(super) ha: f64,
    pub(super) hb: f64,
    pub(super) turn_a: bool,
    pub(super) turn_b: bool,
    /// Converged panels over φ ∈ [0, π/2], [0, π] or [0, 1] (the leg's
    /// map) with running τ and s.
    pub(super) panels: Vec<Panel>,
    /// The paper branch's horizontal run after a turning point (infinite).
    pub(super) straight: bool,
}

impl Leg {
    pub(super) fn tau_len(&self) -> f64 {
        if self.straight {
            f64::INFINITY
        } else {
            self.panels.last().map_or(0.0, |p| p.i0)
        }
    }
    pub(super) fn s_len(&self) -> f64 {
        self.panels.last().map_or(0.0, |p| p.i1)
    }
    pub(super) fn dir(&self) -> f64 {
        if self.hb >= self.ha {
            1.0
        } else {
            -1.0
        }
    }
    /// h(φ) and dh/dφ.
    pub(super) fn h_of(&self, phi: f64) -> (f64, f64) {
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
    pub(super) fn turn_offset(&self, phi: f64) -> Option<(f64, f64)> {
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
    pub(super) fn phi_of(&self, h: f64) -> f64 {
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
pub(super) struct Quad {
    pub(super) legs: Vec<Leg>,
    /// Height limits (absolute): the box's lowest and highest heights.
    pub(super) lo: f64,
    pub(super) hi: f64,
    pub(super) branch: Branch,
    /// No leg follows the last one (it ended at a height limit, or runs straight).
    pub(super) done: bool,
}

/// Safeguarded Newton (Numerical Recipes' rtsafe) for a root of f in
/// [lo, hi] where f(lo) has the sign of `flo` and f(hi) the other (or is 0);
/// f returns (value, derivative). Bisects whenever Newton would leave the
/// bracket or shrink it by less than half. Returns the bracket's end on
/// `flo`'s side (for G: the last height still on the ray's side).
pub(super) fn bracketed_root(
    mut lo: f64,
    mut hi: f64,
    flo: f64,
    mut f: impl FnMut(f64) -> (f64, f64),
) -> f64 {
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
    /// G(h) = n(h) − b, accurately (see the module docs), with its derivative.
    pub(super) fn g(&self, field: &IndexField, h: f64) -> (f64, f64) {
        self.evals.set(self.evals.get() + 1);
        let d = field.n_diff(h, self.h0);
        let slope = field.n_h(h).map_or(0.0, |v| v.1);
        (d + self.g0, slope)
    }

    /// The first height strictly past `from` toward `to` where G < 0 changes
    /// sign (a turning point), scanning the field's monotone pieces.
    pub(super) fn root_between(&self, field: &IndexField, from: f64, to: f64) -> Option<f64> {
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

    pub(super) fn make_leg(
        &self,
        field: &IndexField,
        ha: f64,
        dir: f64,
        turn_a: bool,
        tau0: f64,
        s0: f64,
    ) -> Leg {
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
    pub(super) fn leg_state(&self, field: &IndexField, leg: &Leg, phi: f64) -> (f64, f64, f64, f64) {
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
    pub(super) fn integrand(&self, field: &IndexField, leg: &Leg, phi: f64) -> (f64, f64) {
        let (_, d, gg, dhdphi) = self.leg_state(field, leg, phi);
        let n = self.n0 + d;
        let it = dhdphi.abs() / (gg.max(f64::MIN_POSITIVE) * (n + self.b)).sqrt();
        (it, n * it)
    }

    pub(super) fn first_leg(&self, field: &IndexField) -> Leg {
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
    pub(super) fn extend_to(&mut self, field: &IndexField, tau: f64) {
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

    pub(super) fn quad_point(&self, field: &IndexField, tau: f64) -> (Point, f64) {
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

    /// [`StratifiedRay::next_turn`] for the other forms.
    #[inline(never)]
    pub(super) fn next_turn_general(&mut self, field: &IndexField, tau: f64) -> f64 {
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

    pub(super) fn first_height_generic(
        &mut self,
        field: &IndexField,
        dh: f64,
        t0: f64,
        t1: f64,
    ) -> Option<f64> {
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
}
