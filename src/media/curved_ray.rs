//! A ray traced through a [`Medium`] chord by chord, the chords it gives,
//! and flights flown for many camera rays at once.
use super::flight::{self, Flight, FlightAsk};
use super::invariant_cast::{InvariantCast, Step};
use super::medium::Medium;
use super::mirage_study;
use super::stepper::{State, Stepper};
use super::stratified::{KeptScale, StratifiedRay};
use glam::DVec3;

impl Medium {
    /// Can the straight chord meet geometry? (False only when it misses
    /// every padded box of the scene's geometry: Embree would find nothing.)
    pub fn chord_may_hit(&self, c: &Chord) -> bool {
        match c.start {
            ChordStart::InBox => true,
            ChordStart::LeftBounds => self.obstacles_outside.segment_meets(c.origin, c.dir, c.length),
            ChordStart::Elsewhere => self.obstacles.segment_meets(c.origin, c.dir, c.length),
        }
    }

    /// Start a curved ray at p (world, metres) with direction d (normalised here).
    pub fn start_ray(&self, p: DVec3, d: DVec3) -> CurvedRay {
        let idle = State {
            r: DVec3::ZERO,
            t: DVec3::X,
            v: DVec3::X,
            n: f64::NAN,
            g: DVec3::ZERO,
            s: 0.0,
        };
        let mut ray = CurvedRay {
            st: idle,
            prev: idle,
            last_arc: 0.0,
            last_curved: false,
            mode: Mode::Outside,
            failure: None,
            h_next: f64::INFINITY,
            ell_prev: f64::INFINITY,
            evals: 0,
            chords: 0,
            entered: false,
            started_inside: false,
            inv: None,
            inv_live: false,
            flown: None,
            tol_scale: 1.0,
        };
        self.restart_ray(&mut ray, p, d);
        ray
    }

    /// Start `ray` afresh at p with direction d, as [`Medium::start_ray`]
    /// would, in its own storage: a render starts one curved ray per path
    /// segment, and a new one is a copy of several hundred bytes each time.
    pub fn restart_ray(&self, ray: &mut CurvedRay, p: DVec3, d: DVec3) {
        let dl = d.length();
        let bad = !(p.is_finite() && d.is_finite() && dl > 0.0);
        let t = if bad { DVec3::X } else { d / dl };
        let st = State {
            r: p,
            t,
            v: t,
            n: f64::NAN,
            g: DVec3::ZERO,
            s: 0.0,
        };
        ray.st = st;
        ray.prev = st;
        ray.last_arc = 0.0;
        ray.last_curved = false;
        ray.mode = if bad { Mode::Failed } else { Mode::Outside };
        ray.failure = bad.then(|| format!("invalid ray: origin {p:?}, direction {d:?}"));
        ray.h_next = f64::INFINITY;
        ray.ell_prev = f64::INFINITY;
        ray.evals = 0;
        ray.chords = 0;
        ray.entered = false;
        ray.started_inside = false;
        ray.inv_live = false;
        ray.flown = None;
        ray.tol_scale = 1.0;
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Mode {
    /// Straight (outside the bounds, or just left them).
    Outside,
    /// Integrating inside the bounds.
    Inside,
    /// The method failed (message in `failure`): chords of length 0 from here on.
    Failed,
}

/// A flight flown before its ray got there: the start it was flown from
/// (state, suggested step), the flight at its end, and how it ended.
#[derive(Debug, Clone)]
pub(super) struct Flown {
    pub(super) start: (State, f64),
    pub(super) flight: Flight,
    pub(super) end: FlightAsk,
}

/// A straight piece of a curved ray, to cast through Embree.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chord {
    /// Start of the chord, world metres.
    pub origin: DVec3,
    /// Unit direction of the chord.
    pub dir: DVec3,
    /// Length in metres: infinite for a ray that never enters the bounds, 0
    /// after a failure or when the ray leaves the box where it stands.
    pub length: f64,
    /// Straight length of the stretch before the chord that needed no chord
    /// (it could meet no geometry), metres: the path's length to the chord's
    /// start grows by it.
    pub skipped: f64,
    /// What is known of the boxes the chord may meet.
    pub start: ChordStart,
}

/// Where a [`Chord`] starts, as far as it decides the boxes it may meet.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChordStart {
    /// Where the ray reaches a geometry's (padded) box, as the invariant cast
    /// finds it: it may hit, no box test needed.
    InBox,
    /// Just out of the medium's bounds through a face, moving away: the box
    /// being convex, the chord meets none of the geometry well inside it.
    LeftBounds,
    /// Anywhere else: every box is tested.
    Elsewhere,
}

/// A ray being traced through a [`Medium`], chord by chord.
#[derive(Debug, Clone)]
pub struct CurvedRay {
    pub(super) st: State,
    pub(super) prev: State,
    pub(super) last_arc: f64,
    pub(super) last_curved: bool,
    pub(super) mode: Mode,
    pub(super) failure: Option<String>,
    pub(super) h_next: f64,
    pub(super) ell_prev: f64,
    pub(super) evals: u64,
    pub(super) chords: u64,
    /// The ray has been inside the bounds.
    pub(super) entered: bool,
    /// It started inside them (its first chord is in the medium).
    pub(super) started_inside: bool,
    /// Method `invariant`: the cast, while inside the bounds (`inv_live`);
    /// kept after it for the next start to reuse its storage.
    pub(super) inv: Option<InvariantCast>,
    pub(super) inv_live: bool,
    /// A flight flown beforehand ([`fly_camera_rays`]).
    pub(super) flown: Option<Box<Flown>>,
    /// What its flights' and invariant chords' tolerances are multiplied by:
    /// 1, or the medium's indirect scale after a diffuse bounce
    /// ([`CurvedRay::after_diffuse`]).
    pub(super) tol_scale: f64,
}

/// Distance from q to the segment a–b.
pub(super) fn dist_to_segment(q: DVec3, a: DVec3, b: DVec3) -> f64 {
    let ab = b - a;
    let l2 = ab.length_squared();
    if l2 == 0.0 {
        return (q - a).length();
    }
    let u = ((q - a).dot(ab) / l2).clamp(0.0, 1.0);
    (q - (a + ab * u)).length()
}

impl CurvedRay {
    /// Current point (the end of the last chord), world metres.
    pub fn position(&self) -> DVec3 {
        self.st.r
    }
    /// Unit tangent.
    pub fn direction(&self) -> DVec3 {
        self.st.t
    }
    /// Arc length travelled inside the medium (straight parts outside not included).
    pub fn arc_length(&self) -> f64 {
        self.st.s
    }
    /// Field evaluations so far (n and ∇n at one point count as one).
    pub fn evaluations(&self) -> u64 {
        self.evals
    }
    /// Chords returned so far.
    pub fn chords(&self) -> u64 {
        self.chords
    }
    /// Why the method failed (e.g. the paper's Euler at a turning point); after a
    /// failure `next_chord` returns chords of length 0.
    pub fn failure(&self) -> Option<&str> {
        self.failure.as_deref()
    }
    /// True once the ray has been inside the bounds.
    pub fn entered(&self) -> bool {
        self.entered
    }
    /// True when the ray started inside the bounds (so its first chord lies
    /// in the medium), known once its first chord is made.
    pub fn started_inside(&self) -> bool {
        self.started_inside
    }
    /// True while the ray is inside the bounds and being integrated.
    pub fn is_inside(&self) -> bool {
        self.mode == Mode::Inside
    }

    pub(super) fn fail(&mut self, msg: String) -> Chord {
        self.mode = Mode::Failed;
        self.failure = Some(msg);
        self.last_curved = false;
        self.inv_live = false;
        Chord {
            origin: self.st.r,
            dir: self.st.t,
            length: 0.0,
            skipped: 0.0,
            start: ChordStart::Elsewhere,
        }
    }

    /// Enters the bounds `entry` along the straight ray (from outside, or 0
    /// where it starts in them): the state the medium's method starts from.
    #[inline(always)]
    pub(super) fn enter(&mut self, medium: &Medium, entry: f64) -> Result<(), String> {
        let (r, t) = (self.st.r, self.st.t);
        let p = r + t * entry;
        if let Some(setup) = &medium.invariant {
            // The invariant cast keeps its own state; here only position and
            // direction.
            InvariantCast::start_in(&mut self.inv, &medium.field, setup, p, t)?;
            self.inv_live = true;
            self.st.r = p;
        } else {
            let mut s = State::new(&medium.field, p, t, &mut self.evals)?;
            s.s = self.st.s;
            self.st = s;
        }
        self.now_inside(entry);
        Ok(())
    }

    /// The bookkeeping of [`CurvedRay::enter`] once the method's state is set.
    #[inline(always)]
    pub(super) fn now_inside(&mut self, entry: f64) {
        self.prev = self.st;
        self.mode = Mode::Inside;
        self.started_inside |= !self.entered && entry == 0.0;
        self.entered = true;
    }

    /// Sets up now what the first chord of a ray that starts inside the
    /// bounds would (method `invariant`'s start), and nothing for any other:
    /// the same chords follow. Begun for several rays in a row before any is
    /// traced, their setups (chains of dependent roots and divisions) overlap
    /// in the processor instead of waiting one by one.
    pub fn begin(&mut self, medium: &Medium) {
        if medium.invariant.is_none() || self.mode != Mode::Outside || self.entered || self.flown.is_some() {
            return;
        }
        let inside = medium.deep_inside.contains(self.st.r)
            || medium
                .bounds
                .clip(self.st.r, self.st.t)
                .is_some_and(|(t0, t1)| t0 <= 0.0 && t1 > medium.tolerance);
        if inside {
            if let Err(e) = self.enter(medium, 0.0) {
                self.fail(e);
            }
        }
    }

    /// [`CurvedRay::begin`] for `N` rays (a pixel's camera rays): where
    /// every one starts well inside the bounds with an invariant cast made
    /// before, their casts start side by side ([`InvariantCast::start_lanes`]);
    /// otherwise one by one. The same state as `begin` ray by ray.
    pub fn begin_lanes<const N: usize>(rays: &mut [CurvedRay; N], medium: &Medium) {
        let fresh = |c: &CurvedRay| {
            c.mode == Mode::Outside
                && !c.entered
                && c.flown.is_none()
                && c.inv.is_some()
                && medium.deep_inside.contains(c.st.r)
        };
        if let (Some(setup), true) = (&medium.invariant, rays.iter().all(fresh)) {
            // `enter` at 0: the start is r + t·0 (which is r but for the sign of a zero).
            let p = rays.each_ref().map(|c| c.st.r + c.st.t * 0.0);
            let t = rays.each_ref().map(|c| c.st.t);
            let kept = rays
                .each_ref()
                .map(|c| c.inv.as_ref().map_or(KeptScale::NONE, InvariantCast::kept_scale));
            if let Some(lanes) = StratifiedRay::restart_lanes(&medium.field, &p, &t, &kept) {
                for ((c, lane), &p) in rays.iter_mut().zip(&lanes).zip(&p) {
                    match &mut c.inv {
                        Some(cast) => {
                            cast.start_from(lane, setup);
                            c.inv_live = true;
                            c.st.r = p;
                            c.now_inside(0.0);
                        }
                        None => c.begin(medium),
                    }
                }
                return;
            }
        }
        for c in rays.iter_mut() {
            c.begin(medium);
        }
    }

    /// Hold the rest of this ray (started by [`Medium::restart_ray`]) to
    /// the medium's tolerances for rays after a diffuse or glossy bounce
    /// ([`Medium::indirect_tolerance_scale`]): what such a ray brings back
    /// is spread over the bounce's lobe, not seen through one pixel.
    pub fn after_diffuse(&mut self, medium: &Medium) {
        self.tol_scale = medium.indirect_scale;
    }

    /// The next straight chord to cast: outside the bounds one chord to the entry (or
    /// of infinite length); inside, a chord whose deviation from the arc is at most the
    /// tolerance (ray-equation methods) or one native piece (the paper's methods);
    /// method `invariant` skips the stretches that can meet no geometry (their
    /// length in [`Chord::skipped`]). The ray state moves to the chord's end.
    pub fn next_chord(&mut self, medium: &Medium) -> Chord {
        self.chords += 1;
        self.prev = self.st;
        self.last_curved = false;
        self.last_arc = 0.0;
        let tol = medium.tolerance;
        let mut skipped = 0.0;
        let mut exits = 0;
        loop {
            if self.mode == Mode::Failed {
                return Chord {
                    origin: self.st.r,
                    dir: self.st.t,
                    length: 0.0,
                    skipped,
                    start: ChordStart::Elsewhere,
                };
            }
            if self.mode == Mode::Outside {
                let r = self.st.r;
                let t = self.st.t;
                let straight = |length, start| Chord {
                    origin: r,
                    dir: t,
                    length,
                    skipped,
                    start,
                };
                // Just out through a face: no slab test to see it go.
                if exits > 0 && medium.bounds.leaves_within(r, t, tol) {
                    return straight(f64::INFINITY, ChordStart::LeftBounds);
                }
                let clip = if medium.deep_inside.contains(r) {
                    Some((0.0, f64::INFINITY))
                } else {
                    medium.bounds.clip(r, t)
                };
                match clip {
                    Some((t0, t1)) if t1 > tol => {
                        let entry = t0.max(0.0);
                        if let Err(e) = self.enter(medium, entry) {
                            return self.fail(e);
                        }
                        if entry > 0.0 {
                            return straight(entry, ChordStart::Elsewhere);
                        }
                    }
                    _ => return straight(f64::INFINITY, ChordStart::Elsewhere),
                }
            }
            if let (true, Some(cast), Some(setup)) = (self.inv_live, &mut self.inv, &medium.invariant) {
                let before = cast.evaluations();
                // (× 1 is exact: camera rays keep their tolerance bit for bit.)
                let step = cast.next(
                    &medium.field,
                    setup,
                    medium.chord_tolerance().scaled(self.tol_scale),
                );
                self.evals += cast.evaluations() - before;
                match step {
                    Step::Chord {
                        origin,
                        end,
                        tangent,
                        skipped: sk,
                    } => {
                        skipped += sk;
                        let c = end - origin;
                        let len = c.length();
                        // Arc length of a circular arc on the chord, to 4th
                        // order in the turn |Δt| (its square: no square root).
                        let bend2 = (tangent - self.st.t).length_squared();
                        self.st.s += sk + len * (1.0 + bend2 / 24.0);
                        self.st.r = end;
                        self.st.t = tangent;
                        self.last_curved = true;
                        return Chord {
                            origin,
                            dir: if len > 0.0 { c / len } else { tangent },
                            length: len,
                            skipped,
                            start: ChordStart::InBox,
                        };
                    }
                    Step::Exit {
                        at,
                        tangent,
                        skipped: sk,
                    } => {
                        skipped += sk;
                        self.st.s += sk;
                        self.st.r = at;
                        self.st.t = tangent;
                        self.inv_live = false;
                        self.mode = Mode::Outside;
                        // Outside, the ray returns a chord or re-enters where
                        // it stands (on a face); exiting again without a chord
                        // would repeat forever.
                        exits += 1;
                        if exits > 1 {
                            return self.fail(format!(
                                "ray stuck on the medium's boundary at {at:?}, tangent {tangent:?}"
                            ));
                        }
                        continue;
                    }
                }
            }
            if medium.flies() {
                match self.fly(medium, &mut skipped) {
                    Ok(true) => {
                        // Left the bounds: straight from here (a ray that
                        // re-enters where it stands flies again).
                        exits += 1;
                        if exits > 4 {
                            return self.fail(format!(
                                "ray stuck on the medium's boundary at {:?}, tangent {:?}",
                                self.st.r, self.st.t
                            ));
                        }
                        continue;
                    }
                    // Geometry is near: the chord (and a hit's refinement)
                    // starts where the flight stopped.
                    Ok(false) => self.prev = self.st,
                    Err(e) => return self.fail(e),
                }
            }
            let mut stepper = medium.stepper();
            let res = if medium.method.is_paper() {
                self.paper_chord(medium, &mut stepper)
            } else {
                self.arc_chord(medium, &mut stepper)
            };
            self.evals += stepper.evals;
            return match res {
                Ok(c) => Chord { skipped, ..c },
                Err(e) => self.fail(e),
            };
        }
    }

    /// Integrates without chords while no geometry can be met (see
    /// [`Medium::flies`] and flight.rs), or takes the flight flown for this
    /// very start beforehand ([`fly_camera_rays`]). Ok(true) when the ray
    /// has left the bounds (its arc length inside added to `skipped`),
    /// Ok(false) when geometry is too close for a step worth taking: the
    /// caller casts chords from there. Not inlined: in `next_chord` its
    /// set-up was hoisted ahead of the invariant cast, which never flies.
    #[inline(never)]
    pub(super) fn fly(&mut self, medium: &Medium, skipped: &mut f64) -> Result<bool, String> {
        self.last_curved = false;
        let (flight, end) = match self.flown.take() {
            Some(f) if f.start == (self.st, self.h_next) => (f.flight, f.end),
            _ => {
                let mut f = Flight::new(self.st, self.h_next, self.tol_scale, medium);
                let end = f.run(medium);
                (f, end)
            }
        };
        self.st = flight.st;
        self.h_next = flight.h_next;
        *skipped += flight.skipped;
        self.evals += flight.evals;
        match end {
            FlightAsk::Left => {
                self.mode = Mode::Outside;
                Ok(true)
            }
            FlightAsk::Near => Ok(false),
            FlightAsk::Failed(e) => Err(e),
            FlightAsk::Eval(_) => Err("flight: ended while asking for the field".into()),
        }
    }

    /// The flight this ray, not yet cast, would start where it enters the
    /// bounds: what [`CurvedRay::next_chord`] does on its way to
    /// [`CurvedRay::fly`] (None when it would not fly from its entry).
    pub(super) fn flight_at_entry(&self, medium: &Medium) -> Option<Flight> {
        if self.mode != Mode::Outside || self.entered || !medium.flies() {
            return None;
        }
        let st = self.entry_state(medium, &mut 0)?.ok()?;
        Some(Flight::new(st, self.h_next, self.tol_scale, medium))
    }

    /// Where this ray (outside the bounds) enters them and its state there,
    /// as `next_chord` finds them: None when it misses them.
    pub(super) fn entry_state(&self, medium: &Medium, evals: &mut u64) -> Option<Result<State, String>> {
        let (r, t) = (self.st.r, self.st.t);
        match medium.bounds.clip(r, t) {
            Some((t0, t1)) if t1 > medium.tolerance => {
                let p = r + t * t0.max(0.0);
                Some(State::new(&medium.field, p, t, evals).map(|mut s| {
                    s.s = self.st.s;
                    s
                }))
            }
            _ => None,
        }
    }

    pub(super) fn exit_straight(&mut self, medium: &Medium, dir: DVec3) -> Chord {
        let d = medium
            .bounds
            .clip(self.st.r, dir)
            .map_or(0.0, |(_, t1)| t1.max(0.0));
        let origin = self.st.r;
        self.st.r += dir * d;
        self.st.t = dir;
        self.st.s += d;
        self.mode = Mode::Outside;
        Chord {
            origin,
            dir,
            length: d,
            skipped: 0.0,
            start: ChordStart::Elsewhere,
        }
    }

    pub(super) fn paper_chord(
        &mut self,
        medium: &Medium,
        stepper: &mut Stepper<'_>,
    ) -> Result<Chord, String> {
        let seg = mirage_study::segment(
            &medium.field,
            medium.method,
            medium.step,
            &self.st,
            &mut stepper.evals,
        )?;
        match seg {
            mirage_study::Seg::Forever => Ok(self.exit_straight(medium, self.st.t)),
            mirage_study::Seg::To(next) => {
                let d = next.r - self.st.r;
                let len = d.length();
                if !(len > 0.0 && len.is_finite()) {
                    return Err(format!("{}: degenerate step of length {len}", medium.method));
                }
                let dir = d / len;
                if medium.bounds.contains(next.r) {
                    let origin = self.st.r;
                    self.st = next;
                    Ok(Chord {
                        origin,
                        dir,
                        length: len,
                        skipped: 0.0,
                        start: ChordStart::Elsewhere,
                    })
                } else {
                    Ok(self.exit_straight(medium, dir))
                }
            }
        }
    }

    pub(super) fn arc_chord(&mut self, medium: &Medium, stepper: &mut Stepper<'_>) -> Result<Chord, String> {
        let tol = medium.tolerance;
        let st = self.st;
        let exit = medium.bounds.clip(st.r, st.t).map_or(0.0, |(_, t1)| t1);
        if exit <= tol * 1e-3 {
            return Ok(self.exit_straight(medium, st.t));
        }
        let radius = st.radius();
        let mut ell = (8.0 * 0.8 * tol * radius)
            .sqrt()
            .min(medium.feature.along(st.t))
            .min(self.ell_prev * 4.0)
            .min(exit);
        let mut points = Vec::new();
        let mut end;
        let mut h_next;
        let mut tries = 0;
        loop {
            tries += 1;
            points.clear();
            h_next = self.h_next;
            end = stepper.advance(&st, ell, &mut h_next, &mut points)?;
            let c = end.r - st.r;
            let dev_tangent = c.length() * (end.t - st.t).length() / 8.0;
            let dev_points = points
                .iter()
                .map(|&q| dist_to_segment(q, st.r, end.r))
                .fold(0.0, f64::max);
            let dev = dev_tangent.max(dev_points);
            if dev <= tol || tries >= 40 {
                break;
            }
            ell *= (0.8 * tol / dev).sqrt().clamp(0.1, 0.9);
        }
        self.ell_prev = ell;
        let mut leaving = false;
        if !medium.bounds.contains(end.r) {
            // Find where the arc leaves the box: Newton on the arc length from the last
            // inside state along its tangent, safeguarded by bisection.
            leaving = true;
            let (mut lo, mut hi) = (0.0, ell);
            let mut lo_state = st;
            for _ in 0..80 {
                let gap = medium
                    .bounds
                    .clip(lo_state.r, lo_state.t)
                    .map_or(0.0, |(_, t1)| t1);
                if gap <= tol * 0.5 || hi - lo <= tol * 0.5 {
                    break;
                }
                let mut guess = lo + gap;
                if !(guess > lo && guess < hi) {
                    guess = 0.5 * (lo + hi);
                }
                let mut hn = self.h_next;
                let s = stepper.advance(&st, guess, &mut hn, &mut Vec::new())?;
                if medium.bounds.contains(s.r) {
                    lo = guess;
                    lo_state = s;
                } else {
                    hi = guess;
                }
            }
            end = lo_state;
            ell = lo;
            if ell <= 0.0 {
                return Ok(self.exit_straight(medium, st.t));
            }
        }
        if h_next.is_finite() {
            self.h_next = h_next;
        }
        let c = end.r - st.r;
        let len = c.length();
        self.st = end;
        self.last_curved = true;
        self.last_arc = ell;
        if leaving {
            self.mode = Mode::Outside;
        }
        Ok(Chord {
            origin: st.r,
            dir: if len > 0.0 { c / len } else { st.t },
            length: len,
            skipped: 0.0,
            start: ChordStart::Elsewhere,
        })
    }

    /// Embree hit the last chord at distance `t` on a surface through `hit` with unit
    /// normal `ng`: the point where the true arc crosses the plane (x − hit)·ng = 0
    /// (Newton on arc length, safeguarded by bisection) and the unit tangent there.
    /// Straight chords (outside the bounds, the paper's methods) return the chord
    /// point itself.
    pub fn refine_hit(
        &mut self,
        medium: &Medium,
        chord: &Chord,
        t: f64,
        hit: DVec3,
        ng: DVec3,
    ) -> (DVec3, DVec3) {
        let straight = (chord.origin + chord.dir * t, chord.dir);
        if !self.last_curved || ng.length().is_nan() || ng.length() <= 0.0 {
            return straight;
        }
        if let (true, Some(cast)) = (self.inv_live, &mut self.inv) {
            return cast.refine(&medium.field, hit, ng).unwrap_or(straight);
        }
        if self.last_arc <= 0.0 {
            return straight;
        }
        let mut stepper = medium.stepper();
        let a = self.prev;
        let f = |s: &State| (s.r - hit).dot(ng);
        let (fa, fb) = (f(&a), f(&self.st));
        if fa * fb > 0.0 {
            return straight;
        }
        let (mut lo, mut hi) = (0.0, self.last_arc);
        let (mut flo, mut _fhi) = (fa, fb);
        let mut sig = if chord.length > 0.0 {
            (t / chord.length * self.last_arc).clamp(0.0, self.last_arc)
        } else {
            0.0
        };
        let mut best = straight;
        for _ in 0..60 {
            let mut hn = self.h_next;
            let s = match stepper.advance(&a, sig, &mut hn, &mut Vec::new()) {
                Ok(s) => s,
                Err(_) => return straight,
            };
            let fs = f(&s);
            best = (s.r, s.t);
            if fs.abs() <= medium.tolerance * 1e-6 || hi - lo <= medium.tolerance * 1e-6 {
                break;
            }
            if (fs > 0.0) == (flo > 0.0) {
                lo = sig;
                flo = fs;
            } else {
                hi = sig;
                _fhi = fs;
            }
            let d = s.t.dot(ng);
            let mut next = if d != 0.0 { sig - fs / d } else { f64::NAN };
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            sig = next;
        }
        best
    }
}

/// Flies the flights `rays` (fresh from [`Medium::start_ray`], none cast
/// yet) would start where they enter the bounds, side by side (flight.rs):
/// each ray then takes its flight when it gets there instead of flying
/// alone, with the same result bit for bit. Worth it for many nearly
/// parallel rays (a tile's camera rays); rays that would not fly are left
/// alone.
pub fn fly_camera_rays(medium: &Medium, rays: &mut [CurvedRay]) {
    let mut who = Vec::new();
    let mut flights = Vec::new();
    for (i, r) in rays.iter().enumerate() {
        if let Some(f) = r.flight_at_entry(medium) {
            who.push(i);
            flights.push(f);
        }
    }
    if flights.is_empty() {
        return;
    }
    let starts: Vec<(State, f64)> = who
        .iter()
        .zip(&flights)
        .map(|(&i, f)| (f.st, rays[i].h_next))
        .collect();
    let ends = flight::fly_side_by_side(medium, &mut flights);
    for (((&i, f), end), start) in who.iter().zip(flights).zip(ends).zip(starts) {
        rays[i].flown = Some(Box::new(Flown {
            start,
            flight: f,
            end,
        }));
    }
}
