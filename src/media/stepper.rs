//! Integrators of the ray equation d/ds(n dr/ds) = ∇n as the first-order system
//! r' = v/n, v' = ∇n (s = arc length, v = n·t, |v| = n), plus the closed form for
//! linear fields (exact.rs) and the paper's height-stepping methods (mirage_study.rs).
use glam::DVec3;

use super::field::IndexField;
use super::{exact, Method};

// The state and the index check live in state.rs (exact.rs needs them,
// and this file needs exact.rs); re-exported for `media::stepper::State` users.
pub(crate) use super::state::check_n;
pub use super::state::State;

/// Method, tolerance and step, with an evaluation counter.
#[derive(Debug, Clone)]
pub struct Stepper<'a> {
    /// The field n(p) being integrated through.
    pub field: &'a IndexField,
    /// Rk45, Rk4 or Exact (the paper's methods live in `mirage_study.rs`; others step as rk4).
    pub method: Method,
    /// rk45's error target per step, metres.
    pub tolerance: f64,
    /// rk4's arc-length step, metres.
    pub step: f64,
    /// Field evaluations (n and ∇n at one point count as one).
    pub evals: u64,
    /// Accepted and rejected rk45 steps.
    pub rejected: u64,
}

fn deriv_state(field: &IndexField, r: DVec3, v: DVec3, s: f64, evals: &mut u64) -> Result<State, String> {
    let (n, g) = field.eval(r);
    *evals += 1;
    check_n(n, r)?;
    let t = v.normalize();
    Ok(State { r, t, v, n, g, s })
}

/// Bogacki–Shampine's 3rd-order weights (stages at 0, 1/2, 3/4 of the step).
pub(crate) const BS23_B: [f64; 3] = [2.0 / 9.0, 1.0 / 3.0, 4.0 / 9.0];

/// A Bogacki–Shampine 3(2) step in progress, fed the field one point at a
/// time: three new evaluations per step, at 1/2, 3/4 and the end (FSAL: n,
/// ∇n at the end are the next step's first stage). A resumable step lets a
/// flight's rays share vectorised evaluations (flight.rs) with the same
/// arithmetic as one ray alone.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Bs23Step {
    h: f64,
    b: [f64; 3],
    /// (dr/ds, dv/ds) at the stages met so far.
    k: [(DVec3, DVec3); 3],
    /// The stage the next evaluation is for (1, 2: interior; 3: the end).
    stage: usize,
    /// The point and v of that stage.
    r: DVec3,
    v: DVec3,
}

/// What a [`Bs23Step`] needs next.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Bs23Next {
    /// n and ∇n at this point.
    Eval(DVec3),
    /// The 3rd-order end state and the error estimate: position (metres)
    /// and |δv|.
    Done { end: State, er: f64, ev: f64 },
}

impl Bs23Step {
    /// A step of length h from `st`, and the first point to evaluate.
    pub(crate) fn begin(st: &State, h: f64, b: [f64; 3]) -> (Bs23Step, DVec3) {
        let k1 = (st.v * (1.0 / st.n), st.g);
        let r = st.r + k1.0 * (0.5 * h);
        let v = st.v + k1.1 * (0.5 * h);
        let step = Bs23Step {
            h,
            b,
            k: [k1, (DVec3::ZERO, DVec3::ZERO), (DVec3::ZERO, DVec3::ZERO)],
            stage: 1,
            r,
            v,
        };
        (step, r)
    }

    /// n and ∇n at the point asked for (`st` the step's start).
    ///
    /// # Errors
    ///
    /// A message when n is not finite or not > 0 there.
    pub(crate) fn feed(&mut self, st: &State, n: f64, g: DVec3) -> Result<Bs23Next, String> {
        check_n(n, self.r)?;
        let (h, b) = (self.h, self.b);
        // dr/ds = v/n: one division for the three components.
        let inv_n = 1.0 / n;
        match self.stage {
            1 => {
                self.k[1] = (self.v * inv_n, g);
                self.r = st.r + self.k[1].0 * (0.75 * h);
                self.v = st.v + self.k[1].1 * (0.75 * h);
                self.stage = 2;
                Ok(Bs23Next::Eval(self.r))
            }
            2 => {
                self.k[2] = (self.v * inv_n, g);
                let [k1, k2, k3] = self.k;
                self.r = st.r + (k1.0 * b[0] + k2.0 * b[1] + k3.0 * b[2]) * h;
                self.v = st.v + (k1.1 * b[0] + k2.1 * b[1] + k3.1 * b[2]) * h;
                self.stage = 3;
                Ok(Bs23Next::Eval(self.r))
            }
            _ => {
                let (r, v) = (self.r, self.v);
                let end = State {
                    r,
                    t: v.normalize(),
                    v,
                    n,
                    g,
                    s: st.s + h,
                };
                let k4 = (v * inv_n, g);
                let [k1, k2, k3] = self.k;
                // b − b* of the embedded 2nd-order pair (b* = 7/24, 1/4, 1/3, 1/8).
                const E3: [f64; 4] = [-5.0 / 72.0, 1.0 / 12.0, 1.0 / 9.0, -1.0 / 8.0];
                let er = (k1.0 * E3[0] + k2.0 * E3[1] + k3.0 * E3[2] + k4.0 * E3[3]) * h;
                let ev = (k1.1 * E3[0] + k2.1 * E3[1] + k3.1 * E3[2] + k4.1 * E3[3]) * h;
                Ok(Bs23Next::Done {
                    end,
                    er: er.length(),
                    ev: ev.length(),
                })
            }
        }
    }
}

// Dormand–Prince 5(4) tableau.
const C: [f64; 7] = [0.0, 1.0 / 5.0, 3.0 / 10.0, 4.0 / 5.0, 8.0 / 9.0, 1.0, 1.0];
const A: [[f64; 6]; 7] = [
    [0.0; 6],
    [1.0 / 5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [3.0 / 40.0, 9.0 / 40.0, 0.0, 0.0, 0.0, 0.0],
    [44.0 / 45.0, -56.0 / 15.0, 32.0 / 9.0, 0.0, 0.0, 0.0],
    [
        19372.0 / 6561.0,
        -25360.0 / 2187.0,
        64448.0 / 6561.0,
        -212.0 / 729.0,
        0.0,
        0.0,
    ],
    [
        9017.0 / 3168.0,
        -355.0 / 33.0,
        46732.0 / 5247.0,
        49.0 / 176.0,
        -5103.0 / 18656.0,
        0.0,
    ],
    [
        35.0 / 384.0,
        0.0,
        500.0 / 1113.0,
        125.0 / 192.0,
        -2187.0 / 6784.0,
        11.0 / 84.0,
    ],
];
const E: [f64; 7] = [
    71.0 / 57600.0,
    0.0,
    -71.0 / 16695.0,
    71.0 / 1920.0,
    -17253.0 / 339200.0,
    22.0 / 525.0,
    -1.0 / 40.0,
];

impl<'a> Stepper<'a> {
    /// A stepper with its counters at 0.
    pub fn new(field: &'a IndexField, method: Method, tolerance: f64, step: f64) -> Stepper<'a> {
        Stepper {
            field,
            method,
            tolerance,
            step,
            evals: 0,
            rejected: 0,
        }
    }

    /// One Dormand–Prince step of length h: the 5th-order state (FSAL: n, ∇n at the end
    /// are the next step's first stage) and the error norm in metres
    /// max(|δr|, h·|δv|/n).
    ///
    /// # Errors
    ///
    /// A message when n is not finite or not > 0 at one of the stages.
    pub fn dp45(&mut self, st: &State, h: f64) -> Result<(State, f64), String> {
        let (end, er, ev) = self.dp45_parts(st, h)?;
        Ok((end, er.max(h.abs() * ev / end.n)))
    }

    /// [`Stepper::dp45`] with the error estimate in two parts: position
    /// (metres) and v (|δv|, so |δv|/n is the direction's in radians).
    ///
    /// # Errors
    ///
    /// As [`Stepper::dp45`].
    pub fn dp45_parts(&mut self, st: &State, h: f64) -> Result<(State, f64, f64), String> {
        let mut kr = [DVec3::ZERO; 7];
        let mut kv = [DVec3::ZERO; 7];
        kr[0] = st.v / st.n;
        kv[0] = st.g;
        for i in 1..6 {
            let mut r = st.r;
            let mut v = st.v;
            for j in 0..i {
                r += kr[j] * (h * A[i][j]);
                v += kv[j] * (h * A[i][j]);
            }
            let (n, g) = self.field.eval(r);
            self.evals += 1;
            check_n(n, r)?;
            kr[i] = v / n;
            kv[i] = g;
        }
        let mut r = st.r;
        let mut v = st.v;
        for j in 0..6 {
            r += kr[j] * (h * A[6][j]);
            v += kv[j] * (h * A[6][j]);
        }
        let end = deriv_state(self.field, r, v, st.s + h, &mut self.evals)?;
        kr[6] = v / end.n;
        kv[6] = end.g;
        let _ = C;
        let mut er = DVec3::ZERO;
        let mut ev = DVec3::ZERO;
        for j in 0..7 {
            er += kr[j] * (h * E[j]);
            ev += kv[j] * (h * E[j]);
        }
        Ok((end, er.length(), ev.length()))
    }

    /// One Bogacki–Shampine 3(2) step of length h with the solution's
    /// weights `b` ([`BS23_B`]; tests give a wrong set): the end state and
    /// the error estimate in two parts as [`Stepper::dp45_parts`], through
    /// [`Bs23Step`] as a flight takes it.
    ///
    /// # Errors
    ///
    /// As [`Stepper::dp45`].
    #[cfg(test)]
    pub(crate) fn bs23_weighted(
        &mut self,
        st: &State,
        h: f64,
        b: [f64; 3],
    ) -> Result<(State, f64, f64), String> {
        let (mut step, mut p) = Bs23Step::begin(st, h, b);
        loop {
            let (n, g) = self.field.eval(p);
            self.evals += 1;
            match step.feed(st, n, g)? {
                Bs23Next::Eval(q) => p = q,
                Bs23Next::Done { end, er, ev } => return Ok((end, er, ev)),
            }
        }
    }

    /// One classical RK4 step of length h (4 evaluations, the last one at the end point).
    ///
    /// # Errors
    ///
    /// A message when n is not finite or not > 0 at one of the stages.
    pub fn rk4(&mut self, st: &State, h: f64) -> Result<State, String> {
        let f = |s: &mut Self, r: DVec3, v: DVec3| -> Result<(DVec3, DVec3), String> {
            let (n, g) = s.field.eval(r);
            s.evals += 1;
            check_n(n, r)?;
            Ok((v / n, g))
        };
        let (k1r, k1v) = (st.v / st.n, st.g);
        let (k2r, k2v) = f(self, st.r + k1r * (h / 2.0), st.v + k1v * (h / 2.0))?;
        let (k3r, k3v) = f(self, st.r + k2r * (h / 2.0), st.v + k2v * (h / 2.0))?;
        let (k4r, k4v) = f(self, st.r + k3r * h, st.v + k3v * h)?;
        let r = st.r + (k1r + k2r * 2.0 + k3r * 2.0 + k4r) * (h / 6.0);
        let v = st.v + (k1v + k2v * 2.0 + k3v * 2.0 + k4v) * (h / 6.0);
        deriv_state(self.field, r, v, st.s + h, &mut self.evals)
    }

    /// One accepted rk45 step of at most `max_h` (starting from the suggestion
    /// `*h_next`, which is updated): the new state and the step taken.
    ///
    /// # Errors
    ///
    /// A message when the step size underflows (the tolerance is too small for
    /// f64, or n ≤ 0 right ahead of the ray).
    pub fn rk45_step(&mut self, st: &State, h_next: &mut f64, max_h: f64) -> Result<(State, f64), String> {
        loop {
            let h = h_next.min(max_h);
            // A trial stage outside the field's domain (n ≤ 0) rejects the step; only a
            // step too small to shrink further reports it.
            let (next, err) = match self.dp45(st, h) {
                Ok(x) => x,
                Err(e) if h > 1e-9 * (1.0 + st.s.abs()) => {
                    self.rejected += 1;
                    *h_next = h * 0.25;
                    let _ = e;
                    continue;
                }
                Err(e) => return Err(e),
            };
            let ratio = err / self.tolerance;
            if ratio <= 1.0 {
                let grow = if ratio == 0.0 {
                    5.0
                } else {
                    (0.9 * ratio.powf(-0.2)).clamp(0.2, 5.0)
                };
                *h_next = if h >= *h_next || !h_next.is_finite() {
                    h * grow
                } else {
                    h_next.max(h * grow)
                };
                return Ok((next, h));
            }
            self.rejected += 1;
            *h_next = h * (0.9 * ratio.powf(-0.25)).clamp(0.1, 0.9);
            if h_next.is_nan() || *h_next <= 1e-13 * (1.0 + st.s.abs()) {
                return Err(format!(
                    "rk45: step size underflow at arc length {:e} m (tolerance {:e} too small for f64?)",
                    st.s, self.tolerance
                ));
            }
        }
    }

    /// One step of length h of a ray-equation method without error control (rk45 uses
    /// the 5th-order solution): used to land on stops and to locate events inside an
    /// accepted step.
    ///
    /// # Errors
    ///
    /// A message when n is not finite or not > 0 along the step, or (exact) when
    /// the field is not linear.
    pub fn single(&mut self, st: &State, h: f64) -> Result<State, String> {
        match self.method {
            // `invariant` traces rays in media by their invariant; steps asked
            // of the stepper itself are rk45's.
            Method::Rk45 | Method::Invariant => self.dp45(st, h).map(|x| x.0),
            Method::Exact => {
                self.evals += 1;
                exact::advance(self.field, st, h)
            }
            _ => self.rk4(st, h),
        }
    }

    /// Advance by exactly `ell` metres of arc (rk45 adaptive from the suggested step
    /// `*h_next`, rk4 in ceil(ell/step) equal steps, exact in one). Intermediate
    /// positions are pushed to `points`.
    ///
    /// # Errors
    ///
    /// The errors of the steps taken, and a message when rk45 would need more than
    /// 1e6 steps or rk4 more than 1e9.
    pub fn advance(
        &mut self,
        st: &State,
        ell: f64,
        h_next: &mut f64,
        points: &mut Vec<DVec3>,
    ) -> Result<State, String> {
        match self.method {
            Method::Exact => {
                self.evals += 1;
                exact::advance(self.field, st, ell)
            }
            Method::Rk45 | Method::Invariant => {
                let mut cur = *st;
                let mut done = 0.0;
                let mut guard = 0u32;
                while done < ell {
                    guard += 1;
                    if guard > 1_000_000 {
                        return Err("rk45: more than 1e6 steps in one advance".into());
                    }
                    let rest = ell - done;
                    let (next, h) = self.rk45_step(&cur, h_next, rest)?;
                    cur = next;
                    if h >= rest {
                        break;
                    }
                    done += h;
                    points.push(cur.r);
                }
                cur.s = st.s + ell;
                Ok(cur)
            }
            _ => {
                let k = (ell / self.step).ceil().max(1.0);
                if k > 1e9 {
                    return Err(format!("rk4: {k} steps of {} m in one advance", self.step));
                }
                let h = ell / k;
                let mut cur = *st;
                for i in 0..k as u64 {
                    cur = self.rk4(&cur, h)?;
                    if (i + 1) < k as u64 {
                        points.push(cur.r);
                    }
                }
                cur.s = st.s + ell;
                Ok(cur)
            }
        }
    }
}
