//! The closed thick tube: primitive 0 the outer wall (normal out), 1 the
//! inner wall (normal in, towards the axis), 2 and 3 the annular caps at
//! `p0` (normal −axis) and `p0 + height·axis` (normal +axis).
use super::axis::axial;
use super::disk::Disk;
use super::segment::lane_by_lane;
use super::segment::{candidate, Segment};
use super::wall::Wall;
use crate::embree::{Bounds, Candidates, LaneRay};
use glam::DVec3;

/// A tube from `p0` along the unit `axis` for `height`, between the radii
/// `inner` and `outer`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tube {
    /// Centre of the base.
    pub p0: DVec3,
    /// Unit axis.
    pub axis: DVec3,
    /// Height along the axis.
    pub height: f64,
    /// Outer radius.
    pub outer: f64,
    /// Inner radius.
    pub inner: f64,
}

impl Tube {
    /// The wall of radius `radius`.
    #[inline(always)]
    fn wall(&self, radius: f64) -> Wall<DVec3> {
        Wall {
            base: self.p0,
            axis: self.axis,
            height: self.height,
            radius,
        }
    }

    /// Primitive 2 (at `p0`) or 3 (at the far end), whose normal points
    /// out of the solid along ∓`axis`; the annulus's own normal is `axis`.
    #[inline(always)]
    fn cap(&self, prim: u32) -> Disk {
        self.wall(self.outer).end(prim != 2, self.inner)
    }

    /// The crossings of primitive `prim` with the segment, onto `out`.
    #[inline(always)]
    pub(super) fn intersect(&self, prim: u32, seg: &Segment, out: &mut Candidates) {
        match prim {
            0 => self
                .wall(self.outer)
                .crossings(seg, |t, radial| out.push(candidate(t, radial))),
            1 => self
                .wall(self.inner)
                .crossings(seg, |t, radial| out.push(candidate(t, -radial))),
            2 => self.cap(2).push_crossing(seg, -self.axis, out),
            _ => self.cap(3).push_crossing(seg, self.axis, out),
        }
    }

    /// [`Self::intersect`] for the lanes of a callback (the walls' side by
    /// side).
    #[inline(always)]
    pub(super) fn intersect_lanes(&self, prim: u32, rays: &[LaneRay], out: &mut [Candidates]) {
        match prim {
            0 => self.wall(self.outer).intersect_lanes(false, rays, out),
            1 => self.wall(self.inner).intersect_lanes(true, rays, out),
            _ => lane_by_lane(rays, out, |seg, out| self.intersect(prim, seg, out)),
        }
    }

    /// Embree's bounds of primitive `prim` (both walls within the outer's).
    pub(super) fn bounds(&self, prim: u32) -> Bounds {
        match prim {
            0 | 1 => self.wall(self.outer).bounds(),
            _ => self.cap(prim).bounds(),
        }
    }

    /// The unit normal at `p` on primitive `prim`.
    #[inline(always)]
    pub(super) fn normal(&self, prim: u32, p: DVec3) -> DVec3 {
        match prim {
            0 => self.wall(self.outer).normal(p),
            1 => -self.wall(self.inner).normal(p),
            2 => -self.axis,
            _ => self.axis,
        }
    }

    /// `p` moved onto primitive `prim`.
    #[inline(always)]
    pub(super) fn project(&self, prim: u32, p: DVec3) -> DVec3 {
        match prim {
            0 => self.wall(self.outer).project(p),
            1 => self.wall(self.inner).project(p),
            _ => self.cap(prim).project(p),
        }
    }

    /// Is `p` strictly inside the solid?
    #[inline]
    pub(super) fn contains(&self, p: DVec3) -> bool {
        let q = p - self.p0;
        let y = q.dot(self.axis);
        let r2 = (q - self.axis * y).length_squared();
        y > 0.0 && y < self.height && r2 < self.outer * self.outer && r2 > self.inner * self.inner
    }

    /// Might the surface pass within `tol` of `p`?
    #[inline]
    pub(super) fn surface_near(&self, p: DVec3, tol: f64) -> bool {
        let (y, r) = axial(self.p0, self.axis, p);
        let (h, outer, inner) = (self.height, self.outer, self.inner);
        let walls = ((r - outer).abs() <= tol || (r - inner).abs() <= tol) && y >= -tol && y <= h + tol;
        let ends = (y.abs() <= tol || (y - h).abs() <= tol) && r <= outer + tol && r >= inner - tol;
        walls || ends
    }
}

#[cfg(test)]
mod tests {
    use super::super::Analytic;
    use super::*;
    use crate::embree::UserShape;
    use glam::Vec3A as V3;

    #[test]
    fn tube_has_four_crossings_through_the_axis() {
        let t = Analytic::Tube(Tube {
            p0: DVec3::new(0.0, -1.0, 0.0),
            axis: DVec3::Y,
            height: 2.0,
            outer: 1.0,
            inner: 0.8,
        });
        let mut ts = vec![];
        for prim in 0..4 {
            let mut c = Candidates::default();
            t.intersect(prim, V3::new(0.0, 0.0, 4.0), V3::new(0.0, 0.0, -1.0), &mut c);
            ts.extend(c.as_slice().iter().map(|c| c.t));
        }
        ts.sort_by(f32::total_cmp);
        let want = [3.0, 3.2, 4.8, 5.0];
        assert_eq!(ts.len(), 4);
        for (a, b) in ts.iter().zip(want) {
            assert!((a - b).abs() < 1e-5);
        }
        assert_eq!(t.contains(DVec3::new(0.9, 0.0, 0.0)), Some(true));
        assert_eq!(t.contains(DVec3::ZERO), Some(false));
    }
}
