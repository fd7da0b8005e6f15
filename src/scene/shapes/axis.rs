//! The axis of a cylinder or tube: components along and across it, with the
//! world's y axis (every shipped scene's cylinders) as its own type.
use glam::DVec3;

/// The axis of a cylinder or tube, for the per-hit arithmetic: the world's
/// y axis ([`AxisY`]), whose components along and across need no products,
/// or any unit vector. Both give the same values for the y axis (up to the
/// sign of a zero component).
pub(super) trait Axis: Copy {
    /// The component of `v` along the axis.
    fn along(self, v: DVec3) -> f64;
    /// `v` less its component `along` the axis.
    fn across(self, v: DVec3, along: f64) -> DVec3;
    /// `base` moved by `y` along the axis.
    fn offset(self, base: DVec3, y: f64) -> DVec3;
}

/// The world's y axis.
#[derive(Clone, Copy)]
pub(super) struct AxisY;

impl Axis for AxisY {
    #[inline(always)]
    fn along(self, v: DVec3) -> f64 {
        v.y
    }
    #[inline(always)]
    fn across(self, v: DVec3, _along: f64) -> DVec3 {
        DVec3::new(v.x, 0.0, v.z)
    }
    #[inline(always)]
    fn offset(self, base: DVec3, y: f64) -> DVec3 {
        DVec3::new(base.x, base.y + y, base.z)
    }
}

impl Axis for DVec3 {
    #[inline(always)]
    fn along(self, v: DVec3) -> f64 {
        v.dot(self)
    }
    #[inline(always)]
    fn across(self, v: DVec3, along: f64) -> DVec3 {
        v - self * along
    }
    #[inline(always)]
    fn offset(self, base: DVec3, y: f64) -> DVec3 {
        base + self * y
    }
}

/// The component of `p - p0` across the axis through `p0` (the y axis when
/// `axis` is it).
#[inline(always)]
pub(super) fn across_axis(p0: DVec3, axis: DVec3, p: DVec3) -> DVec3 {
    let q = p - p0;
    if axis == DVec3::Y {
        AxisY.across(q, AxisY.along(q))
    } else {
        axis.across(q, axis.along(q))
    }
}

/// The height of `p` along the unit `axis` from `p0`, and its distance from
/// the axis line.
#[inline]
pub(super) fn axial(p0: DVec3, axis: DVec3, p: DVec3) -> (f64, f64) {
    let q = p - p0;
    let y = q.dot(axis);
    (y, (q - axis * y).length())
}
