//! The cylinder: an open wall (normals out, or in towards the axis) or a
//! solid closed by two caps (primitives 1 and 2).
use super::axis::axial;
use super::disk::Disk;
use super::segment::lane_by_lane;
use super::segment::{candidate, Segment};
use super::wall::Wall;
use crate::embree::{Bounds, Candidates, LaneRay};
use glam::DVec3;

/// A cylinder of `radius` from `p0` along the unit `axis` for `height`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cylinder {
    /// Centre of the base.
    pub p0: DVec3,
    /// Unit axis.
    pub axis: DVec3,
    /// Height along the axis.
    pub height: f64,
    /// Radius.
    pub radius: f64,
    /// Normals point to the axis.
    pub inward: bool,
    /// Closed by two disks (a solid).
    pub caps: bool,
}

impl Cylinder {
    /// Primitives: the wall, and the caps of a solid.
    pub(super) fn prims(&self) -> u32 {
        if self.caps {
            3
        } else {
            1
        }
    }

    /// Primitive 0.
    #[inline(always)]
    pub(super) fn wall(&self) -> Wall<DVec3> {
        Wall {
            base: self.p0,
            axis: self.axis,
            height: self.height,
            radius: self.radius,
        }
    }

    /// Primitive 1 (at `p0`) or 2 (at the far end), whose normal points
    /// out of the solid along ∓`axis`; the disk's own normal is `axis`.
    #[inline(always)]
    pub(super) fn cap(&self, prim: u32) -> Disk {
        self.wall().end(prim != 1, 0.0)
    }

    /// The crossings of primitive `prim` with the segment, onto `out`.
    #[inline(always)]
    pub(super) fn intersect(&self, prim: u32, seg: &Segment, out: &mut Candidates) {
        match prim {
            0 => self.wall().crossings(seg, |t, radial| {
                out.push(candidate(t, if self.inward { -radial } else { radial }))
            }),
            1 => self.cap(1).push_crossing(seg, -self.axis, out),
            _ => self.cap(2).push_crossing(seg, self.axis, out),
        }
    }

    /// [`Self::intersect`] for the lanes of a callback (the wall's side by
    /// side).
    #[inline(always)]
    pub(super) fn intersect_lanes(&self, prim: u32, rays: &[LaneRay], out: &mut [Candidates]) {
        if prim == 0 {
            self.wall().intersect_lanes(self.inward, rays, out)
        } else {
            lane_by_lane(rays, out, |seg, out| self.intersect(prim, seg, out))
        }
    }

    /// Embree's bounds of primitive `prim`.
    pub(super) fn bounds(&self, prim: u32) -> Bounds {
        match prim {
            0 => self.wall().bounds(),
            _ => self.cap(prim).bounds(),
        }
    }

    /// The unit normal at `p` on primitive `prim`.
    #[inline(always)]
    pub(super) fn normal(&self, prim: u32, p: DVec3) -> DVec3 {
        match prim {
            0 => {
                let radial = self.wall().normal(p);
                if self.inward {
                    -radial
                } else {
                    radial
                }
            }
            1 => -self.axis,
            _ => self.axis,
        }
    }

    /// `p` moved onto primitive `prim`.
    #[inline(always)]
    pub(super) fn project(&self, prim: u32, p: DVec3) -> DVec3 {
        match prim {
            0 => self.wall().project(p),
            _ => self.cap(prim).project(p),
        }
    }

    /// Is `p` strictly inside? `None` unless the cylinder is a solid.
    #[inline]
    pub(super) fn contains(&self, p: DVec3) -> Option<bool> {
        if !self.is_solid() {
            return None;
        }
        let q = p - self.p0;
        let y = q.dot(self.axis);
        Some(y > 0.0 && y < self.height && (q - self.axis * y).length_squared() < self.radius * self.radius)
    }

    /// Might the surface pass within `tol` of `p`? `None` unless the
    /// cylinder is a solid.
    #[inline]
    pub(super) fn surface_near(&self, p: DVec3, tol: f64) -> Option<bool> {
        if !self.is_solid() {
            return None;
        }
        let (y, r) = axial(self.p0, self.axis, p);
        let side = (r - self.radius).abs() <= tol && y >= -tol && y <= self.height + tol;
        let cap = (y.abs() <= tol || (y - self.height).abs() <= tol) && r <= self.radius + tol;
        Some(side || cap)
    }

    /// Closed and facing out: it bounds a volume.
    #[inline(always)]
    fn is_solid(&self) -> bool {
        self.caps && !self.inward
    }
}
