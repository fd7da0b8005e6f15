//! The disk or annulus: a shape of its own, and the caps of cylinders and
//! tubes.
use super::bounds::cylinder_bounds;
use super::segment::{candidate, Segment};
use crate::embree::{Bounds, Candidates};
use glam::DVec3;

/// A disk, or an annulus when `inner` > 0; its normal is the given one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Disk {
    /// Centre.
    pub center: DVec3,
    /// Unit normal.
    pub normal: DVec3,
    /// Outer radius.
    pub radius: f64,
    /// Inner radius (0 for a full disk).
    pub inner: f64,
}

impl Disk {
    /// The crossing of the segment with the disk, if the segment keeps it.
    #[inline]
    pub(super) fn crossing(&self, seg: &Segment) -> Option<f64> {
        let t = seg.plane_crossing(self.center, self.normal)?;
        let p = seg.o + seg.d * t - self.center;
        let q = p.length_squared();
        (q <= self.radius * self.radius && q >= self.inner * self.inner).then_some(t)
    }

    /// The crossing of the segment, onto `out` with the normal `n`.
    #[inline(always)]
    pub(super) fn push_crossing(&self, seg: &Segment, n: DVec3, out: &mut Candidates) {
        if let Some(t) = self.crossing(seg) {
            out.push(candidate(t, n));
        }
    }

    /// The crossing of the segment, onto `out`.
    #[inline(always)]
    pub(super) fn intersect(&self, seg: &Segment, out: &mut Candidates) {
        self.push_crossing(seg, self.normal, out);
    }

    /// `p` moved along the normal onto the disk's plane.
    #[inline(always)]
    pub(super) fn project(&self, p: DVec3) -> DVec3 {
        p - self.normal * (p - self.center).dot(self.normal)
    }

    /// Embree's bounds.
    pub(super) fn bounds(&self) -> Bounds {
        cylinder_bounds(self.center, self.normal, 0.0, self.radius)
    }
}
