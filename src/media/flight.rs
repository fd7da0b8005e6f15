//! Flights: a ray crosses the medium's bounds without chords while no
//! geometry is near ([`Medium::flies`]), in Bogacki–Shampine steps held to
//! the image tolerances, straight where a bound on ∇n says the field cannot
//! matter (docs/grin.md, "Flights").
//!
//! A flight is a state machine that asks for the field one point at a time
//! ([`FlightAsk::Eval`]). One ray's flight answers each ask at once
//! ([`Flight::run`]); [`fly_side_by_side`] keeps many rays' flights in step
//! and answers their asks together with [`IndexField::eval_many`] (eight
//! points per vector operation), so neighbouring camera rays cost a fraction
//! of their flights one after another, with the same arithmetic and so the
//! same bits.
use glam::DVec3;

use super::field::IndexField;
use super::stepper::{Bs23Next, Bs23Step, State, BS23_B};
use super::Medium;

/// Where a flight stands after an answer: the next point it needs, or how
/// it ended.
#[derive(Debug, Clone)]
pub(crate) enum FlightAsk {
    /// n and ∇n at this point, please.
    Eval(DVec3),
    /// The ray left the bounds (the state is on their boundary).
    Left,
    /// Geometry is too near for a step worth taking: chords from here.
    Near,
    /// The integration failed (n ≤ 0 ahead, step size underflow).
    Failed(String),
}

/// A step under way and the bounds it was started with.
#[derive(Debug, Clone, Copy)]
struct Pending {
    step: Bs23Step,
    h: f64,
    max_h: f64,
    tol_pos: f64,
    tol_ang: f64,
}

/// One ray's flight.
#[derive(Debug, Clone)]
pub(crate) struct Flight {
    /// The ray's state: at the start, then after each accepted step.
    pub(crate) st: State,
    /// The next step's suggested length, metres.
    pub(crate) h_next: f64,
    /// Arc length flown, metres.
    pub(crate) skipped: f64,
    /// Field evaluations answered.
    pub(crate) evals: u64,
    cap: f64,
    /// What the medium's flight tolerances are multiplied by for this ray
    /// (1 for camera rays; see [`Medium::indirect_tolerance_scale`]).
    tol_scale: f64,
    first: bool,
    rounds: u32,
    pending: Option<Pending>,
}

/// The most steps one flight takes before it is called stuck.
const MAX_ROUNDS: u32 = 1_000_000;

impl Flight {
    /// A flight from `st` (inside the bounds) with the suggested step
    /// `h_next` (not finite: the field's flight step), held to the medium's
    /// flight tolerances times `tol_scale`.
    pub(crate) fn new(st: State, h_next: f64, tol_scale: f64, medium: &Medium) -> Flight {
        let h_next = if h_next.is_finite() {
            h_next
        } else {
            medium.flight_step.min(medium.bounds.diagonal())
        };
        Flight {
            st,
            h_next,
            skipped: 0.0,
            evals: 0,
            cap: f64::INFINITY,
            tol_scale,
            first: true,
            rounds: 0,
            pending: None,
        }
    }

    /// One ray alone: each ask answered by [`IndexField::eval`]. The end
    /// ([`FlightAsk::Left`], [`FlightAsk::Near`] or [`FlightAsk::Failed`]).
    pub(crate) fn run(&mut self, medium: &Medium) -> FlightAsk {
        let mut ask = self.resume(medium);
        while let FlightAsk::Eval(p) = ask {
            let (n, g) = medium.field.eval(p);
            ask = self.feed(medium, n, g);
        }
        ask
    }

    /// Straight from p along t over ℓ: with the curvature at most
    /// κ = max|∇n|/n along the way the direction is off by at most κℓ and
    /// the position by κℓ²/2; negligible at half the tolerances.
    fn straight(medium: &Medium, p: DVec3, t: DVec3, l: f64, tol_pos: f64, tol_ang: f64) -> bool {
        let k = medium.straight_scale * medium.field.grad_bound_on_segment(p, p + t * l) / medium.n_floor;
        k * l <= 0.5 * tol_ang && 0.5 * k * l * l <= 0.5 * tol_pos
    }

    /// From the top of a step: straight to the exit, stop near geometry, or
    /// the first point of the next step.
    fn resume(&mut self, medium: &Medium) -> FlightAsk {
        if self.rounds >= MAX_ROUNDS {
            return FlightAsk::Failed(format!(
                "flight: more than {MAX_ROUNDS} steps without leaving the bounds, at {:?}",
                self.st.r
            ));
        }
        self.rounds += 1;
        let b = medium.bounds;
        let st = self.st;
        let (tol_pos, tol_ang) = medium.flight_tolerances(st.r);
        let (tol_pos, tol_ang) = (tol_pos * self.tol_scale, tol_ang * self.tol_scale);
        let gap = b.exit_distance(st.r, st.t);
        // The bound is worth its exponentials where a ray starts (it may
        // miss the plume altogether) and within a few steps of the exit.
        let check = self.first || gap <= 2.0 * medium.flight_step;
        self.first = false;
        if check && Self::straight(medium, st.r, st.t, gap, tol_pos, tol_ang) {
            self.st.r += st.t * gap;
            self.st.s += gap;
            self.skipped += gap;
            return FlightAsk::Left;
        }
        let clear = medium.obstacles.distance(st.r, &b);
        let max_h = gap.min(0.99 * clear).min(self.cap).min(medium.flight_step);
        if clear < 0.5 * gap.min(self.h_next) {
            return FlightAsk::Near;
        }
        self.attempt(max_h, tol_pos, tol_ang)
    }

    /// A step of the suggested length (at most `max_h`) from the state.
    fn attempt(&mut self, max_h: f64, tol_pos: f64, tol_ang: f64) -> FlightAsk {
        let h = self.h_next.min(max_h);
        let (step, p) = Bs23Step::begin(&self.st, h, BS23_B);
        self.pending = Some(Pending {
            step,
            h,
            max_h,
            tol_pos,
            tol_ang,
        });
        FlightAsk::Eval(p)
    }

    /// n and ∇n at the point last asked for.
    pub(crate) fn feed(&mut self, medium: &Medium, n: f64, g: DVec3) -> FlightAsk {
        self.evals += 1;
        let Some(pend) = self.pending.as_mut() else {
            return FlightAsk::Failed("flight: a field value arrived without a step under way".into());
        };
        let next = pend.step.feed(&self.st, n, g);
        let (h, max_h, tol_pos, tol_ang, st) = (pend.h, pend.max_h, pend.tol_pos, pend.tol_ang, &self.st);
        match next {
            Ok(Bs23Next::Eval(p)) => FlightAsk::Eval(p),
            // A stage outside the field's domain (n ≤ 0) rejects the step;
            // only a step too small to shrink further reports it.
            Err(e) => {
                if h > 1e-9 * (1.0 + st.s.abs()) {
                    self.h_next = h * 0.25;
                    self.attempt(max_h, tol_pos, tol_ang)
                } else {
                    self.pending = None;
                    FlightAsk::Failed(e)
                }
            }
            Ok(Bs23Next::Done { end, er, ev }) => {
                let ratio = (er / tol_pos).max(ev / (end.n * tol_ang));
                if ratio > 1.0 {
                    self.h_next = h * (0.9 * ratio.powf(-0.3125)).clamp(0.1, 0.9);
                    if self.h_next.is_nan() || self.h_next <= 1e-13 * (1.0 + self.st.s.abs()) {
                        self.pending = None;
                        return FlightAsk::Failed(format!(
                            "flight: step size underflow at arc length {:e} m (tolerances {tol_pos:e} m, {tol_ang:e} rad)",
                            self.st.s
                        ));
                    }
                    return self.attempt(max_h, tol_pos, tol_ang);
                }
                // A quarter power (two hardware square roots; a software
                // cube root cost 7 % of a plume render), a little cautious
                // for a 3rd-order pair.
                let grow = if ratio == 0.0 {
                    5.0
                } else {
                    (0.9 * ratio.sqrt().sqrt().recip()).clamp(0.2, 5.0)
                };
                self.h_next = if h >= self.h_next || !self.h_next.is_finite() {
                    h * grow
                } else {
                    self.h_next.max(h * grow)
                };
                self.pending = None;
                self.accepted(medium, end, h, tol_pos, tol_ang)
            }
        }
    }

    /// After a step to `next` of length h: on inside the bounds, or out
    /// through a face.
    fn accepted(&mut self, medium: &Medium, next: State, h: f64, tol_pos: f64, tol_ang: f64) -> FlightAsk {
        let b = medium.bounds;
        if b.contains(next.r) {
            self.st = next;
            self.skipped += h;
            self.cap = f64::INFINITY;
            return self.resume(medium);
        }
        // The arc crossed a face before the tangent line did: back along
        // the end tangent to the face when that stretch is short enough to
        // be straight, else the step again, shorter.
        match b.clip(next.r, next.t) {
            Some((_, t1)) if t1 <= 0.0 && Self::straight(medium, next.r, -next.t, -t1, tol_pos, tol_ang) => {
                self.st = next;
                self.st.r += next.t * t1;
                self.st.s += t1;
                self.skipped += h + t1;
                FlightAsk::Left
            }
            Some((_, t1)) if t1 <= 0.0 && h + t1 > 0.0 => {
                self.cap = (h + t1).max(0.1 * h);
                self.resume(medium)
            }
            _ => {
                self.cap = 0.5 * h;
                self.resume(medium)
            }
        }
    }
}

/// Flies every flight of `flights` to its end, in step: each round, the
/// points all of them ask for are evaluated together
/// ([`IndexField::eval_many`]). The ends, in order; each flight as
/// [`Flight::run`] would leave it, bit for bit.
pub(crate) fn fly_side_by_side(medium: &Medium, flights: &mut [Flight]) -> Vec<FlightAsk> {
    let field: &IndexField = &medium.field;
    let mut ends: Vec<FlightAsk> = vec![FlightAsk::Near; flights.len()];
    // The flights still under way and the points they ask for.
    let mut who = Vec::with_capacity(flights.len());
    let mut points = Vec::with_capacity(flights.len());
    for (i, f) in flights.iter_mut().enumerate() {
        match f.resume(medium) {
            FlightAsk::Eval(p) => {
                who.push(i);
                points.push(p);
            }
            end => ends[i] = end,
        }
    }
    let mut values = vec![(0.0, DVec3::ZERO); points.len()];
    while !who.is_empty() {
        values.truncate(points.len());
        field.eval_many(&points, &mut values);
        let mut kept = 0;
        for k in 0..who.len() {
            let (i, (n, g)) = (who[k], values[k]);
            match flights[i].feed(medium, n, g) {
                FlightAsk::Eval(p) => {
                    who[kept] = i;
                    points[kept] = p;
                    kept += 1;
                }
                end => ends[i] = end,
            }
        }
        who.truncate(kept);
        points.truncate(kept);
    }
    ends
}
