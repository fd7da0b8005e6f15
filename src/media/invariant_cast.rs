//! Chords of a ray in a stratified field evaluated from its invariant
//! (`stratified/`), for method `invariant`.
//!
//! The arc lies in the vertical plane of its azimuth: x = b·τ along the
//! horizontal direction e, h(τ) along up. A box of geometry is met only on
//! the τ-interval where x is within the box's horizontal extent *and* the
//! height within its vertical extent; elsewhere nothing can be hit and no
//! chord is needed: the ray skips ahead to the next such contact (or to the
//! medium's exit). In contact, chords follow the tolerance: a chord over
//! [τ₁, τ₂] deviates from the arc by at most max|n·n'|·(τ₂ − τ₁)²/8 (the
//! interpolation error of h(τ) with h'' = n·n', measured vertically at equal
//! x, which bounds the distance), with the maximum over the heights the chord
//! spans (its ends and turning points).
use glam::DVec3;

use super::field::{Aabb, IndexField};
use super::footprint::ChordTolerance;
use super::stratified::{KeptScale, LaneStart, Options, Point, StratifiedRay};

/// How far (metres) the start must be from a height limit for a ray moving
/// away from it to skip the search for its crossing: far beyond the rounding
/// of heights near the start, so the search could not have found one either.
const LEVEL_MARGIN: f64 = 1e-6;

/// What the cast does next.
#[derive(Debug, Clone, Copy)]
pub enum Step {
    /// A chord to cast from `origin` to `end` (`skipped`: straight length of
    /// the stretch skipped before it).
    Chord {
        /// Start of the chord.
        origin: DVec3,
        /// End of the chord.
        end: DVec3,
        /// Unit tangent of the arc at `end`.
        tangent: DVec3,
        /// Straight length skipped before the chord.
        skipped: f64,
    },
    /// The ray left the medium at `at` with unit tangent `tangent`.
    Exit {
        /// The exit point (on the box's boundary, to rounding).
        at: DVec3,
        /// Unit tangent there.
        tangent: DVec3,
        /// Straight length skipped before it.
        skipped: f64,
    },
}

/// The coordinate axis `up` lies on, and its sign (None when oblique).
pub fn up_axis(up: DVec3) -> Option<(usize, f64)> {
    (0..3).find_map(|k| {
        let others = (0..3).filter(|&j| j != k).all(|j| up[j] == 0.0);
        (others && up[k] != 0.0).then(|| (k, up[k].signum()))
    })
}

/// A box in the frame of the stratification: extents along the two
/// horizontal axes and in height, and e^{h/H} of its heights for an
/// exponential profile of scale H (a ray scales them by its own e^{−h₀/H}
/// instead of taking an exponential per crossing).
#[derive(Debug, Clone, Copy, PartialEq)]
struct FrameBox {
    lo: [f64; 2],
    hi: [f64; 2],
    h: (f64, f64),
    u: Option<(f64, f64)>,
}

/// What every ray of a medium shares: the frame of the stratification (up
/// on a coordinate axis), the box's height limits and the geometry's boxes
/// in that frame.
#[derive(Debug, Clone, PartialEq)]
pub struct InvariantSetup {
    /// The coordinate axis along up and up's sign on it.
    axis: usize,
    sign: f64,
    base: f64,
    /// The horizontal coordinate axes.
    horizontal: [usize; 2],
    /// The medium's box in the frame.
    limits: FrameBox,
    /// The geometry's boxes in the frame (None: not known, everything may be hit).
    boxes: Option<Vec<FrameBox>>,
    /// The smallest index in the box.
    n_min: f64,
}

impl InvariantSetup {
    /// The setup of a medium with `bounds` in the stratified `field` (None
    /// unless `up` lies on a coordinate axis), with the geometry's `boxes`.
    pub fn new(field: &IndexField, bounds: &Aabb, boxes: Option<&[Aabb]>) -> Option<InvariantSetup> {
        let s = field.strata()?;
        let (axis, sign) = up_axis(s.up)?;
        let scale = match *field {
            IndexField::HotGround { h0, .. } => Some(h0),
            IndexField::Exponential { scale_height, .. } => Some(scale_height),
            _ => None,
        };
        let horizontal = [(axis + 1) % 3, (axis + 2) % 3];
        let frame = |b: &Aabb| {
            let (x, y) = (sign * b.min[axis] - s.base, sign * b.max[axis] - s.base);
            let h = (x.min(y), x.max(y));
            let u = scale
                .map(|hs| ((h.0 / hs).exp(), (h.1 / hs).exp()))
                .filter(|u| u.0.is_finite() && u.1.is_finite());
            FrameBox {
                lo: horizontal.map(|j| b.min[j]),
                hi: horizontal.map(|j| b.max[j]),
                h,
                u,
            }
        };
        Some(InvariantSetup {
            axis,
            sign,
            base: s.base,
            horizontal,
            limits: frame(bounds),
            boxes: boxes.map(|bs| bs.iter().map(frame).collect()),
            n_min: field.min_n_in(bounds).0,
        })
    }
}

/// A ray being cast through a stratified medium by its invariant.
#[derive(Debug, Clone)]
pub struct InvariantCast {
    ray: StratifiedRay,
    tau: f64,
    here: Point,
    /// Where the arc leaves through a side of the box (x is linear in τ).
    tau_side: f64,
    /// Where it leaves the box (side, top or bottom), once needed: a ray that
    /// meets geometry first never needs its height crossings. With the point
    /// there when a height crossing found it.
    tau_exit: Option<f64>,
    exit_point: Option<Point>,
    /// The start's coordinates on the horizontal axes and 1/(dx/dτ) along
    /// them (x is linear in τ there).
    h_origin: [f64; 2],
    h_inv_rate: [f64; 2],
    /// The start's height h₀, its p = dh/dτ and e^{−h₀/H}.
    h0: f64,
    p_start: f64,
    level_scale: f64,
    /// The ends of the last chord (for `refine`).
    last: (Point, Point),
}

impl InvariantCast {
    /// Starts in `slot` the cast of the ray from `p` (inside the medium's
    /// box) with unit direction `t`. Written into the caller's slot rather
    /// than returned, reusing a cast already there: the cast is large, one
    /// starts per path segment, and a returned value was copied on its way
    /// there.
    ///
    /// # Errors
    ///
    /// A message when n at `p` is not finite and > 0 (`slot` is then left
    /// as it was).
    pub fn start_in(
        slot: &mut Option<InvariantCast>,
        field: &IndexField,
        setup: &InvariantSetup,
        p: DVec3,
        t: DVec3,
    ) -> Result<(), String> {
        let (h_lo, h_hi) = setup.limits.h;
        // Restarted in the slot's storage when it has one (see `StratifiedRay::restart`).
        let cast = match slot {
            Some(c) => {
                c.ray.restart(field, h_lo, h_hi, p, t, Options::default())?;
                c
            }
            None => {
                let ray = StratifiedRay::new(field, h_lo, h_hi, p, t, Options::default())?;
                let here = ray.start_point();
                slot.insert(InvariantCast {
                    tau: 0.0,
                    here,
                    tau_side: f64::INFINITY,
                    tau_exit: None,
                    exit_point: None,
                    h_origin: [0.0; 2],
                    h_inv_rate: [0.0; 2],
                    h0: 0.0,
                    p_start: 0.0,
                    level_scale: 1.0,
                    last: (here, here),
                    ray,
                })
            }
        };
        cast.finish_start(setup);
        Ok(())
    }

    /// Starts this cast (made before) with one lane of
    /// [`StratifiedRay::restart_lanes`]: what [`InvariantCast::start_in`]
    /// does with the ray that lane was computed for.
    pub fn start_from(&mut self, lane: &LaneStart, setup: &InvariantSetup) {
        self.ray.restart_from(lane);
        self.finish_start(setup);
    }

    /// What this cast's ray keeps for its next start.
    pub fn kept_scale(&self) -> KeptScale {
        self.ray.kept_scale()
    }

    /// What a start sets besides the ray: its horizontal rates, where it
    /// leaves through a side, and the cursor at τ = 0.
    fn finish_start(&mut self, setup: &InvariantSetup) {
        let (h_lo, h_hi) = setup.limits.h;
        let cast = self;
        let ray = &cast.ray;
        let here = ray.start_point();
        let r0 = ray.origin();
        let v = ray.horizontal() * ray.invariant();
        let h_origin = setup.horizontal.map(|j| r0[j]);
        let h_inv_rate = setup.horizontal.map(|j| 1.0 / v[j]);
        let mut tau_side = f64::INFINITY;
        for i in 0..2 {
            let inv = h_inv_rate[i];
            let to = if inv > 0.0 {
                setup.limits.hi[i]
            } else {
                setup.limits.lo[i]
            };
            let t = (to - h_origin[i]) * inv;
            if t.is_finite() {
                tau_side = tau_side.min(t.max(0.0));
            }
        }
        if !tau_side.is_finite() {
            // A vertical ray (b = 0) cannot turn: it crosses the height range
            // within τ ≤ range/n.
            tau_side = 2.0 * (h_hi - h_lo) / setup.n_min + 1.0;
        }
        cast.h0 = ray.start_height();
        cast.level_scale = ray.level_scale();
        cast.tau = 0.0;
        cast.here = here;
        cast.tau_side = tau_side;
        cast.tau_exit = None;
        cast.exit_point = None;
        cast.h_origin = h_origin;
        cast.h_inv_rate = h_inv_rate;
        cast.p_start = here.p;
        cast.last = (here, here);
    }

    /// Index evaluations so far.
    pub fn evaluations(&self) -> u64 {
        self.ray.evaluations()
    }

    /// The τ where the arc leaves the box: through a side, or earlier
    /// through the top or bottom (a height crossing).
    #[inline(always)]
    fn exit(&mut self, field: &IndexField, setup: &InvariantSetup) -> f64 {
        if let Some(t) = self.tau_exit {
            return t;
        }
        let mut t = self.tau_side;
        let l = &setup.limits;
        let us = l.u.map(|u| (u.1 * self.level_scale, u.0 * self.level_scale));
        for (level, u, outward) in [
            (l.h.1 - self.h0, us.map(|u| u.0), 1.0),
            (l.h.0 - self.h0, us.map(|u| u.1), -1.0),
        ] {
            // A ray that starts on this face (or past it by rounding) going
            // into the box meets its level at τ = 0 on the way in; it can
            // only leave through it after turning back.
            let from = if level * outward <= 0.0 && self.p_start * outward < 0.0 {
                self.ray.next_turn(field, 0.0)
            } else {
                0.0
            };
            if from >= t {
                continue;
            }
            // From the start, an arc that moves away from the level (it starts
            // clearly on the inner side and does not turn before t) cannot
            // reach it: no search (rays leaving upward would otherwise look
            // for the bottom each time).
            if from == 0.0
                && level * outward > LEVEL_MARGIN
                && self.p_start * outward < 0.0
                && self.ray.next_turn(field, 0.0) >= t
            {
                continue;
            }
            if let Some(x) = self.ray.first_height_point(field, level, u, from, t) {
                if x.tau < t {
                    t = x.tau;
                    self.exit_point = Some(x);
                }
            }
        }
        self.tau_exit = Some(t);
        t
    }

    /// Does the arc stay within the box's heights from the current point to
    /// `to` (at `end`)? Its heights there are the ends' and a turning point's.
    fn stays_in(&mut self, field: &IndexField, setup: &InvariantSetup, to: f64, end: &Point) -> bool {
        let (lo, hi) = (setup.limits.h.0 - self.h0, setup.limits.h.1 - self.h0);
        let inside = |d: f64| d >= lo && d <= hi;
        if !(inside(self.here.dh) && inside(end.dh)) {
            return false;
        }
        let turn = self.ray.next_turn(field, self.tau);
        turn >= to || inside(self.ray.point(field, turn).dh)
    }

    /// The first τ ≥ the current one (and below `bound`) where the arc is
    /// inside a box, with the point there when it is known.
    fn first_contact(&mut self, field: &IndexField, boxes: &[FrameBox], bound: f64) -> (f64, Option<Point>) {
        let mut best = (bound, None);
        // Without a turn before `bound` the height only moves one way from
        // here: a box wholly behind that way (below a rising arc, above a
        // falling one) cannot be met, whatever its horizontal extent.
        let monotone = self.ray.next_turn(field, self.tau) >= bound;
        let (rising, falling) = (monotone && self.here.p >= 0.0, monotone && self.here.p <= 0.0);
        for b in boxes {
            if (rising && b.h.1 - self.h0 < self.here.dh) || (falling && b.h.0 - self.h0 > self.here.dh) {
                continue;
            }
            let (mut ta, mut tb) = (self.tau, best.0);
            for i in 0..2 {
                let (o, inv) = (self.h_origin[i], self.h_inv_rate[i]);
                if inv.is_infinite() {
                    // Not moving along this axis: inside its extent or never.
                    if o < b.lo[i] || o > b.hi[i] {
                        ta = f64::INFINITY;
                    }
                } else {
                    // Plain comparisons rather than f64::min/max: with a
                    // finite, non-zero `inv` no operand is NaN, and this runs
                    // per box per chord.
                    let (t1, t2) = ((b.lo[i] - o) * inv, (b.hi[i] - o) * inv);
                    let (near, far) = if t1 < t2 { (t1, t2) } else { (t2, t1) };
                    if near > ta {
                        ta = near;
                    }
                    if far < tb {
                        tb = far;
                    }
                }
            }
            if ta > tb {
                continue;
            }
            let (lo, hi) = (b.h.0 - self.h0, b.h.1 - self.h0);
            let pa = if ta == self.tau {
                self.here
            } else {
                self.ray.point(field, ta)
            };
            if pa.dh >= lo && pa.dh <= hi {
                best = (ta, Some(pa));
                continue;
            }
            let above = pa.dh > hi;
            let level = if above { hi } else { lo };
            let u = b.u.map(|u| if above { u.1 } else { u.0 } * self.level_scale);
            if let Some(p) = self.ray.first_height_point(field, level, u, ta, tb) {
                if p.tau < best.0 {
                    best = (p.tau, Some(p));
                }
            }
        }
        best
    }

    /// Move to the exit (nothing can be met before it) and report it.
    fn go_to_exit(&mut self, field: &IndexField, setup: &InvariantSetup, from: DVec3) -> Step {
        let exit = self.exit(field, setup);
        self.tau = exit;
        self.here = match self.exit_point {
            Some(p) if p.tau == exit => p,
            _ => self.ray.point(field, exit),
        };
        let at = self.ray.position(&self.here);
        Step::Exit {
            at,
            tangent: self.ray.direction(&self.here),
            skipped: (at - from).length(),
        }
    }

    /// The next chord to cast (skipping what can meet nothing), or the exit;
    /// `tolerance` gives the chord tolerance at a point.
    pub fn next(&mut self, field: &IndexField, setup: &InvariantSetup, tolerance: ChordTolerance) -> Step {
        let from = self.ray.position(&self.here);
        let mut skipped = 0.0;
        if self.tau_exit.is_some_and(|ex| self.tau >= ex) {
            return self.go_to_exit(field, setup, from);
        }
        let bound = self.tau_exit.unwrap_or(self.tau_side);
        let (c, at) = match &setup.boxes {
            Some(b) => self.first_contact(field, b, bound),
            None => (self.tau, None),
        };
        if c >= bound {
            // Nothing before the side (so nothing before the exit).
            return self.go_to_exit(field, setup, from);
        }
        if c > self.tau {
            let pc = at.unwrap_or_else(|| self.ray.point(field, c));
            if self.tau_exit.is_none() && !self.stays_in(field, setup, c, &pc) && c >= self.exit(field, setup)
            {
                return self.go_to_exit(field, setup, from);
            }
            self.tau = c;
            self.here = pc;
            skipped = (self.ray.position(&pc) - from).length();
        }
        let from = self.ray.position(&self.here);
        let tol0 = tolerance.at(from);
        let mut tol = tol0;
        let bound = self.tau_exit.unwrap_or(self.tau_side);
        let rest = bound - self.tau;
        let local = self.ray.curvature_bound_at(field, &[self.here]);
        let mut dtau = if local > 0.0 {
            (8.0 * tol / local).sqrt().min(rest)
        } else {
            rest
        };
        let mut end = self.ray.point(field, self.tau + dtau);
        for _ in 0..8 {
            // The tolerance at the nearer end to the eye (a ray coming back
            // towards the camera, after a bounce, has it at its end).
            tol = tolerance.min_of(from, tol0, self.ray.position(&end));
            if self.tau_exit.is_none() && !self.stays_in(field, setup, self.tau + dtau, &end) {
                let exit = self.exit(field, setup);
                if self.tau + dtau > exit {
                    dtau = exit - self.tau;
                    end = self.ray.point(field, exit);
                }
            }
            // The chord's heights: its ends and a turning point between.
            let turn = self.ray.next_turn(field, self.tau);
            let m = if turn < self.tau + dtau {
                let pt = self.ray.point(field, turn);
                self.ray.curvature_bound_at(field, &[self.here, end, pt])
            } else {
                self.ray.curvature_bound_at(field, &[self.here, end])
            };
            if m * dtau * dtau <= 8.0 * tol {
                break;
            }
            dtau = (8.0 * tol / m).sqrt().min(0.7 * dtau);
            end = self.ray.point(field, self.tau + dtau);
        }
        self.last = (self.here, end);
        self.tau += dtau;
        self.here = end;
        Step::Chord {
            origin: from,
            end: self.ray.position(&end),
            tangent: self.ray.direction(&end),
            skipped,
        }
    }

    /// Where the arc of the last chord crosses the plane through `hit` with
    /// normal `ng`, and the unit tangent there (safeguarded Newton on τ from
    /// the root of the chord's cubic Hermite model; None when the chord's arc
    /// does not cross it).
    pub fn refine(&mut self, field: &IndexField, hit: DVec3, ng: DVec3) -> Option<(DVec3, DVec3)> {
        let (pa, pb) = self.last;
        let (a, b) = (pa.tau, pb.tau);
        let g = |ray: &StratifiedRay, p: &Point| (ray.position(p) - hit).dot(ng);
        let (fa, fb) = (g(&self.ray, &pa), g(&self.ray, &pb));
        if fa * fb > 0.0 {
            return None;
        }
        let (mut lo, mut hi, mut flo) = (a, b, fa);
        // The chord's ends give g and g' = v·n there: the cubic through them
        // is within the chord tolerance's square of the arc, so Newton starts
        // next to the root (the secant alone left it ~tolerance away).
        let (da, db) = (self.ray.velocity(&pa).dot(ng), self.ray.velocity(&pb).dot(ng));
        let mut t = a + (b - a) * hermite_root(fa, fb, da * (b - a), db * (b - a));
        let mut best = pa;
        let mut shift = 0.0;
        for _ in 0..8 {
            let p = self.ray.point(field, t);
            best = p;
            let f = g(&self.ray, &p);
            if f == 0.0 || (hi - lo).abs() <= 1e-12 * (1.0 + t.abs()) {
                break;
            }
            if (f > 0.0) == (flo > 0.0) {
                lo = t;
                flo = f;
            } else {
                hi = t;
            }
            let d = self.ray.velocity(&p).dot(ng);
            let mut next = t - f / d;
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            if (next - t).abs() <= 1e-7 * (1.0 + t.abs()) {
                // Converging quadratically: what is left after this step
                // is far below it, so the step is taken along the tangent
                // instead of with one more point of the arc.
                shift = next - t;
                break;
            }
            t = next;
        }
        let v = self.ray.velocity(&best);
        Some((self.ray.position(&best) + v * shift, self.ray.direction(&best)))
    }
}

/// The root in [0, 1] of the cubic Hermite interpolant with values `fa`,
/// `fb` (of opposite signs, or one zero) and slopes `sa`, `sb` (per unit of
/// the interval) at its ends: Newton from the secant's root, which it keeps
/// when the cubic leaves the bracket or is not finite.
fn hermite_root(fa: f64, fb: f64, sa: f64, sb: f64) -> f64 {
    let secant = (fa / (fa - fb)).clamp(0.0, 1.0);
    // H(s) = fa + sa·s + c2·s² + c3·s³.
    let c2 = 3.0 * (fb - fa) - 2.0 * sa - sb;
    let c3 = 2.0 * (fa - fb) + sa + sb;
    let mut s = secant;
    for _ in 0..4 {
        let h = fa + s * (sa + s * (c2 + s * c3));
        let dh = sa + s * (2.0 * c2 + s * 3.0 * c3);
        let next = s - h / dh;
        if !(next.is_finite() && (0.0..=1.0).contains(&next)) {
            return secant;
        }
        s = next;
    }
    s
}
