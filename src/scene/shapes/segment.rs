//! What a shape's intersection sees of a query: the ray segment, the roots of
//! a quadratic along it, the candidate it reports for each crossing, and a
//! packet callback's lanes taken side by side or one after the other.
use crate::embree::{Candidate, Candidates, LaneRay};
use glam::{DVec3, Vec3A as V3};

/// A ray `o + t·d` restricted to `[tn, tf]`, in f64 (the ray interval stays
/// the f32 that Embree compares).
#[derive(Debug, Clone, Copy)]
pub(super) struct Segment {
    /// Origin.
    pub(super) o: DVec3,
    /// Direction (any length).
    pub(super) d: DVec3,
    /// Start of the ray interval.
    pub(super) tn: f32,
    /// End of the ray interval.
    pub(super) tf: f32,
}

impl Segment {
    /// The segment of the ray `org + t·dir` over `[tn, tf]`.
    #[inline(always)]
    pub(super) fn new(org: V3, dir: V3, tn: f32, tf: f32) -> Self {
        Segment {
            o: org.as_dvec3(),
            d: dir.as_dvec3(),
            tn,
            tf,
        }
    }

    /// The segment of one lane of a callback.
    #[inline(always)]
    pub(super) fn of(ray: &LaneRay) -> Self {
        Self::new(ray.org, ray.dir, ray.tnear, ray.tfar)
    }

    /// Is the root `t` one the query keeps: finite, and within `[tn, tf]` as
    /// the f32 the callback compares (`Candidate::t`)?
    #[inline(always)]
    pub(super) fn keeps(&self, t: f64) -> bool {
        let t32 = t as f32;
        t.is_finite() && t32 >= self.tn && t32 <= self.tf
    }

    /// Where the segment crosses the plane through `point` with normal `n`
    /// (any length), if it keeps the crossing; never for a segment parallel
    /// to the plane (`d·n == 0`: one lying in it would only graze a surface
    /// there). The arithmetic of the planar shapes (disks, rects) and of the
    /// analytic set's vector lanes for rects, operation for operation.
    #[inline(always)]
    pub(super) fn plane_crossing(&self, point: DVec3, n: DVec3) -> Option<f64> {
        let dn = self.d.dot(n);
        if dn == 0.0 {
            return None;
        }
        let t = (point - self.o).dot(n) / dn;
        self.keeps(t).then_some(t)
    }

    /// Are the roots `t0` and `t1` one tangent touch rather than an entry
    /// and an exit? They are when closer than the renderer's crossing window
    /// (twice the spawn offset, `ray::crossing_window`, in the same units):
    /// a ray spawned past one of them could not see the other, so reporting
    /// only one would leave the solid in the interior list. (A fixed
    /// tolerance below the window let grazing rays through the circle where
    /// two spheres meet keep the second sphere.)
    #[inline]
    pub(super) fn is_touch(&self, t0: f64, t1: f64) -> bool {
        let (o, d) = (self.o, self.d);
        let gap = (t1 - t0).abs();
        if gap <= 1e-6 + t0.abs() * 4e-7 {
            return true;
        }
        let tmax = t0.abs().max(t1.abs());
        // The window is k·(|o|max + 0.5)/|d| + k·t; |d| >= its largest
        // component, so a gap beyond k·t + k·(|o|max + 0.5)/|d|max (with a
        // margin far above the rounding of either side) is beyond the window,
        // without the window's square root and division. Near it, the window.
        const K: f64 = 2.0 * crate::ray::OFFSET_ULPS as f64 * f32::EPSILON as f64;
        const MARGIN: f64 = 1.0 + 1e-9;
        let beyond =
            (gap - K * MARGIN * tmax) * d.abs().max_element() > K * MARGIN * (o.abs().max_element() + 0.5);
        !beyond && gap <= crate::ray::crossing_window_f64(o, d, tmax)
    }
}

/// The two roots of a ray's quadratic with a quadric surface, and whether
/// they are crossings (when not, the roots are meaningless). Computed
/// without a branch, so that the lanes of a callback overlap.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Roots {
    pub(super) t0: f64,
    pub(super) t1: f64,
    pub(super) real: bool,
}

/// The candidate of an analytic hit at `t` with normal `n` (u = v = 1/3:
/// analytic hits are never "near a mesh edge", see dielectric).
#[inline(always)]
pub(super) fn candidate(t: f64, n: DVec3) -> Candidate {
    Candidate {
        t: t as f32,
        ng: n.as_vec3a().into(),
        u: 1.0 / 3.0,
        v: 1.0 / 3.0,
    }
}

/// Lanes whose roots [`side_by_side`] computes together (a callback of
/// Embree's 16-wide packet traversal has one to four active lanes).
const LANES_SIDE_BY_SIDE: usize = 4;

/// The crossings of the lanes of a callback with a quadric: every lane's
/// `roots` first, then each lane's `push` of its crossings, so that the
/// lanes' square roots and divisions overlap instead of waiting one on the
/// other.
#[inline(always)]
pub(super) fn side_by_side(
    rays: &[LaneRay],
    out: &mut [Candidates],
    roots: impl Fn(&Segment) -> Roots,
    mut push: impl FnMut(&Segment, Roots, &mut Candidates),
) {
    for (rays, out) in rays
        .chunks(LANES_SIDE_BY_SIDE)
        .zip(out.chunks_mut(LANES_SIDE_BY_SIDE))
    {
        let mut lane_roots = [Roots::default(); LANES_SIDE_BY_SIDE];
        for (root, ray) in lane_roots.iter_mut().zip(rays) {
            *root = roots(&Segment::of(ray));
        }
        for ((ray, out), &root) in rays.iter().zip(out).zip(&lane_roots) {
            push(&Segment::of(ray), root, out);
        }
    }
}

/// The crossings of the lanes of a callback, one lane after the other.
#[inline(always)]
pub(super) fn lane_by_lane(
    rays: &[LaneRay],
    out: &mut [Candidates],
    mut intersect: impl FnMut(&Segment, &mut Candidates),
) {
    for (r, o) in rays.iter().zip(out) {
        intersect(&Segment::of(r), o);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shortcut in `is_touch` (no window root when the gap is clearly
    /// beyond it) decides as the window itself does, also for gaps right at
    /// the window's edge.
    #[test]
    fn touch_shortcut_agrees_with_the_window() {
        let mut rng = crate::sampling::Rng::new(11);
        let mut u = || rng.uniform_f64() * 2.0 - 1.0;
        for k in 0..200_000 {
            let o = DVec3::new(u(), u(), u()) * 10f64.powf(3.0 * u());
            let d = DVec3::new(u(), u(), u()) * 10f64.powf(u());
            let t0 = 10f64.powf(3.0 * u()) * u();
            let tmax = t0.abs();
            let win = crate::ray::crossing_window_f64(o, d, tmax);
            // Gaps around the window, down to a few ulps of it.
            let gap = win * (1.0 + u() * 10f64.powf(-15.0 * u().abs()));
            let t1 = if t0 >= 0.0 { t0 - gap } else { t0 + gap };
            let want = (t1 - t0).abs() <= 1e-6 + t0.abs() * 4e-7
                || (t1 - t0).abs() <= crate::ray::crossing_window_f64(o, d, t0.abs().max(t1.abs()));
            let seg = Segment {
                o,
                d,
                tn: f32::NEG_INFINITY,
                tf: f32::INFINITY,
            };
            assert_eq!(seg.is_touch(t0, t1), want, "case {k}: {t0} {t1} {o} {d}");
        }
    }
}
