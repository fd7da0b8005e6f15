//! The wall of a cylinder (a cylinder's side, a tube's outer and inner
//! walls): its crossings with a ray, its normal and the projection onto it.
use super::axis::{across_axis, Axis, AxisY};
use super::bounds::cylinder_bounds;
use super::disk::Disk;
use super::normalize::normalize_or_f64;
use super::segment::side_by_side;
use super::segment::{candidate, Roots, Segment};
use crate::embree::{Bounds, Candidates, LaneRay};
use glam::DVec3;

/// The wall of radius `radius` around the axis from `base` for `height`
/// along it; its normal points away from the axis.
#[derive(Debug, Clone, Copy)]
pub(super) struct Wall<A> {
    /// Centre of the base.
    pub(super) base: DVec3,
    /// Unit axis.
    pub(super) axis: A,
    /// Height along the axis.
    pub(super) height: f64,
    /// Radius.
    pub(super) radius: f64,
}

impl Wall<DVec3> {
    /// This wall with the y axis's own arithmetic (when its axis is y).
    #[inline(always)]
    fn about_y(&self) -> Wall<AxisY> {
        Wall {
            base: self.base,
            axis: AxisY,
            height: self.height,
            radius: self.radius,
        }
    }

    /// The crossings of the segment ([`Wall::crossings_about`]), by the y
    /// axis's own code when the axis is y.
    #[inline(always)]
    pub(super) fn crossings(&self, seg: &Segment, emit: impl FnMut(f64, DVec3)) {
        if self.axis == DVec3::Y {
            self.about_y().crossings_about(seg, emit)
        } else {
            self.crossings_about(seg, emit)
        }
    }

    /// The crossings for the lanes of a callback ([`Wall::lanes_about`]),
    /// by the y axis's own code when the axis is y.
    #[inline(always)]
    pub(super) fn intersect_lanes(&self, flip: bool, rays: &[LaneRay], out: &mut [Candidates]) {
        if self.axis == DVec3::Y {
            self.about_y().lanes_about(flip, rays, out)
        } else {
            self.lanes_about(flip, rays, out)
        }
    }

    /// The unit normal at `p`, away from the axis.
    #[inline(always)]
    pub(super) fn normal(&self, p: DVec3) -> DVec3 {
        normalize_or_f64(across_axis(self.base, self.axis, p), DVec3::X)
    }

    /// `p` moved across the axis onto the wall (left alone on the axis).
    #[inline(always)]
    pub(super) fn project(&self, p: DVec3) -> DVec3 {
        if self.axis == DVec3::Y {
            self.about_y().project_about(p)
        } else {
            self.project_about(p)
        }
    }

    /// Embree's bounds.
    pub(super) fn bounds(&self) -> Bounds {
        cylinder_bounds(self.base, self.axis, self.height, self.radius)
    }

    /// The disk (annulus from `inner`) closing the wall at its base or, when
    /// `far`, at its far end; its own normal is the axis.
    #[inline(always)]
    pub(super) fn end(&self, far: bool, inner: f64) -> Disk {
        Disk {
            center: if far {
                self.base + self.axis * self.height
            } else {
                self.base
            },
            normal: self.axis,
            radius: self.radius,
            inner,
        }
    }
}

impl<A: Axis> Wall<A> {
    /// The roots of the ray with the infinite cylinder, in the quadratic's
    /// order.
    #[inline(always)]
    pub(super) fn roots(&self, seg: &Segment) -> Roots {
        let (o, d, axis, r) = (seg.o, seg.d, self.axis, self.radius);
        let op = o - self.base;
        let d_perp = axis.across(d, axis.along(d));
        let o_perp = axis.across(op, axis.along(op));
        let a = d_perp.length_squared();
        let b = o_perp.dot(d_perp);
        let lo = o_perp.length();
        let c = (lo - r) * (lo + r);
        let disc = b * b - a * c;
        let real = !(a == 0.0 || disc < 0.0);
        let s = disc.sqrt();
        let q = if b > 0.0 { -(b + s) } else { -b + s };
        let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (q / a, c / q) };
        Roots { t0, t1, real }
    }

    /// The crossings among the roots ([`Self::roots`]) within [0, height]
    /// along the axis that the segment keeps: `emit(t, radial)` for each,
    /// in root order. Two roots of one tangent touch are no crossing (asked
    /// only when a root counts).
    #[inline(always)]
    fn emit(&self, seg: &Segment, roots: Roots, mut emit: impl FnMut(f64, DVec3)) {
        let Roots { t0, t1, real } = roots;
        if !real {
            return;
        }
        let keep = [seg.keeps(t0), seg.keeps(t1)];
        if !(keep[0] || keep[1]) || seg.is_touch(t0, t1) {
            return;
        }
        let op = seg.o - self.base;
        for (t, k) in [t0, t1].into_iter().zip(keep) {
            if !k {
                continue;
            }
            let p = op + seg.d * t;
            let y = self.axis.along(p);
            if (0.0..=self.height).contains(&y) {
                emit(t, self.axis.across(p, y));
            }
        }
    }

    /// The crossings of the segment: `emit(t, radial)` for each, in root
    /// order.
    #[inline(always)]
    fn crossings_about(&self, seg: &Segment, emit: impl FnMut(f64, DVec3)) {
        self.emit(seg, self.roots(seg), emit);
    }

    /// The crossings for the lanes of a callback, side by side (`flip`:
    /// normals towards the axis).
    #[inline(always)]
    fn lanes_about(&self, flip: bool, rays: &[LaneRay], out: &mut [Candidates]) {
        side_by_side(
            rays,
            out,
            |seg| self.roots(seg),
            |seg, roots, out| {
                self.emit(seg, roots, |t, radial| {
                    out.push(candidate(t, if flip { -radial } else { radial }))
                })
            },
        );
    }

    #[inline(always)]
    fn project_about(&self, p: DVec3) -> DVec3 {
        let q = p - self.base;
        let y = self.axis.along(q);
        let rad = self.axis.across(q, y);
        let l = rad.length();
        if l > 0.0 {
            self.axis.offset(self.base, y) + rad * (self.radius / l)
        } else {
            p
        }
    }
}
