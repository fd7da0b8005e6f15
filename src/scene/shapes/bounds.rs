//! The f32 boxes the analytic shapes hand Embree, padded so that rounding
//! never clips a hit.
use crate::embree::Bounds;
use glam::DVec3;

/// The bounds of the cylinder of radius `r` from `p0` along the unit `axis`
/// for `h` (a disk when `h` is 0).
pub(super) fn cylinder_bounds(p0: DVec3, axis: DVec3, h: f64, r: f64) -> Bounds {
    let p1 = p0 + axis * h;
    // Extent of a disk of radius r with normal `axis` along each world axis.
    let e = DVec3::new(
        r * (1.0 - axis.x * axis.x).max(0.0).sqrt(),
        r * (1.0 - axis.y * axis.y).max(0.0).sqrt(),
        r * (1.0 - axis.z * axis.z).max(0.0).sqrt(),
    );
    let lo = p0.min(p1) - e;
    let hi = p0.max(p1) + e;
    pad(lo, hi)
}

/// f32 bounds padded by a relative ulp-scale margin so rounding never clips a hit.
pub(super) fn pad(lo: DVec3, hi: DVec3) -> Bounds {
    let m = (lo.abs().max(hi.abs()).max_element() * 1e-6).max(1e-6);
    Bounds {
        lower: (lo - DVec3::splat(m)).as_vec3a().into(),
        upper: (hi + DVec3::splat(m)).as_vec3a().into(),
    }
}
