//! Analytic shapes (Embree user geometry) and triangle meshes, with what the
//! integrator needs at a hit: shading normal and texture coordinates.
//!
//! Normal conventions: a sphere's and a cylinder's normal point away from the
//! centre/axis (cylinder `normal = "in"` flips it); a disk's and a rect's normal
//! is the given one; for meshes the geometric normal is (v1−v0)×(v2−v0), i.e.
//! the side from which the winding is counter-clockwise.
use crate::embree::{Bounds, Candidate, Candidates, LaneRay, UserShape};
use glam::{DVec3, Vec3A as V3};

/// `v.normalize_or(fallback)`, bit for bit: glam's test of the reciprocal
/// length (`is_finite() && > 0`) done on its bits (positive, finite, not
/// zero), which LLVM otherwise lowers to a dozen integer instructions of
/// float classification per call (once or twice per hit).
#[inline(always)]
pub(crate) fn normalize_or(v: V3, fallback: V3) -> V3 {
    let rcp = v.length_recip();
    if rcp.to_bits().wrapping_sub(1) < 0x7f7f_ffff {
        v * rcp
    } else {
        fallback
    }
}

/// [`normalize_or`] in f64 (`DVec3::normalize_or`, bit for bit).
#[inline(always)]
fn normalize_or_f64(v: DVec3, fallback: DVec3) -> DVec3 {
    let rcp = v.length_recip();
    if rcp.to_bits().wrapping_sub(1) < 0x7fef_ffff_ffff_ffff {
        v * rcp
    } else {
        fallback
    }
}

/// Ray–sphere crossings in f64 (the f32 quadratic loses too much at grazing).
#[cfg(test)]
fn sphere_ts(c: DVec3, r: f64, o: DVec3, d: DVec3) -> Option<(f64, f64)> {
    let (t0, t1, ok) = sphere_roots(c, r, o, d);
    ok.then_some((t0, t1))
}

/// [`sphere_ts`] without a branch: the ordered roots and whether they are
/// crossings (when not, the roots are meaningless). Straight-line code, so
/// that the lanes of a callback ([`Analytic::intersect_lanes`]) overlap.
#[inline(always)]
fn sphere_roots(c: DVec3, r: f64, o: DVec3, d: DVec3) -> (f64, f64, bool) {
    let oc = o - c;
    let a = d.length_squared();
    let b = oc.dot(d);
    // c' = |oc|² − r², computed as (|oc| − r)(|oc| + r) to limit cancellation.
    let l = oc.length();
    let cc = (l - r) * (l + r);
    let disc = b * b - a * cc;
    let ok = !(disc < 0.0 || a == 0.0);
    let s = disc.sqrt();
    // Numerically stable pair.
    let q = if b > 0.0 { -(b + s) } else { -b + s };
    let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (q / a, cc / q) };
    (t0.min(t1), t0.max(t1), ok)
}

/// The candidate of an analytic hit at `t` with normal `n` (u = v = 1/3:
/// analytic hits are never "near a mesh edge", see dielectric).
#[inline(always)]
fn candidate(t: f64, n: DVec3) -> Candidate {
    Candidate {
        t: t as f32,
        ng: n.as_vec3a().into(),
        u: 1.0 / 3.0,
        v: 1.0 / 3.0,
    }
}

/// The sphere's crossings of a ray with its roots `(t0, t1, ok)`
/// ([`sphere_roots`]) within `[tn, tf]`, onto `out`. A tangent touch
/// (double root) is not a crossing: nothing is reported, so
/// silhouette-grazing rays neither enter nor leave. (Asked only when a root
/// counts.)
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn sphere_push(
    center: DVec3,
    (t0, t1, ok): (f64, f64, bool),
    o: DVec3,
    d: DVec3,
    tn: f32,
    tf: f32,
    out: &mut Candidates,
) {
    if !ok {
        return;
    }
    let (k0, k1) = (in_range(t0, tn, tf), in_range(t1, tn, tf));
    if (k0 || k1) && !is_touch(t0, t1, o, d) {
        if k0 {
            out.push(candidate(t0, o + d * t0 - center));
        }
        if k1 {
            out.push(candidate(t1, o + d * t1 - center));
        }
    }
}

/// Lanes [`Analytic::intersect_lanes`] computes side by side (a callback
/// of Embree's 16-wide packet traversal has one to four active lanes).
const LANES: usize = 4;

/// The height of `p` along the unit `axis` from `p0`, and its distance from
/// the axis line.
#[inline]
fn axial(p0: DVec3, axis: DVec3, p: DVec3) -> (f64, f64) {
    let q = p - p0;
    let y = q.dot(axis);
    (y, (q - axis * y).length())
}

/// The axis of a cylinder or tube, for the per-hit arithmetic: the world's
/// y axis (every shipped scene's cylinders), whose components along and
/// across need no products, or any unit vector. Both give the same values
/// for the y axis (up to the sign of a zero component).
trait Axis: Copy {
    /// The component of `v` along the axis.
    fn along(self, v: DVec3) -> f64;
    /// `v` less its component `along` the axis.
    fn across(self, v: DVec3, along: f64) -> DVec3;
    /// `base` moved by `y` along the axis.
    fn offset(self, base: DVec3, y: f64) -> DVec3;
}

/// The component of `p - p0` across the axis through `p0` (the y axis when
/// `axis` is it).
#[inline(always)]
fn across_axis(p0: DVec3, axis: DVec3, p: DVec3) -> DVec3 {
    let q = p - p0;
    if axis == DVec3::Y {
        AxisY.across(q, AxisY.along(q))
    } else {
        axis.across(q, axis.along(q))
    }
}

/// The world's y axis.
#[derive(Clone, Copy)]
struct AxisY;

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

/// Two roots this close are one tangent touch, not an entry and an exit.
/// Two roots closer than the renderer's crossing window (twice the spawn
/// offset, `ray::crossing_window`, in the same units) are a tangent
/// touch, not a crossing: the ray spawned past one of them could not see the
/// other, so reporting only one would leave the solid in the interior list.
/// (The earlier fixed 1e-6 + 4e-7·t left a gap below the window: grazing rays
/// through the circle where two spheres meet kept the second sphere.)
#[inline]
fn is_touch(t0: f64, t1: f64, o: DVec3, d: DVec3) -> bool {
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

/// Is the root `t` one a query keeps: finite, and within `[tn, tf]` as the
/// f32 the callback compares (`Candidate::t`)?
#[inline(always)]
fn in_range(t: f64, tn: f32, tf: f32) -> bool {
    let t32 = t as f32;
    t.is_finite() && t32 >= tn && t32 <= tf
}

/// An analytic primitive set. Closed sets of primitives share one geometry.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Analytic {
    /// A sphere.
    Sphere {
        /// Centre.
        center: DVec3,
        /// Radius.
        radius: f64,
    },
    /// Tube of `radius` from `p0` along unit `axis` for `height`; `inward`
    /// flips the normal; `caps` adds disks at both ends (prims 1 and 2).
    Cylinder {
        /// Centre of the base.
        p0: DVec3,
        /// Unit axis.
        axis: DVec3,
        /// Height along the axis.
        height: f64,
        /// Radius.
        radius: f64,
        /// Normals point to the axis.
        inward: bool,
        /// Closed by two disks (a solid).
        caps: bool,
    },
    /// Closed thick tube: prim 0 outer wall (out), 1 inner wall (in, towards
    /// the axis), 2 and 3 annular caps at p0 (−axis) and p0 + h·axis (+axis).
    Tube {
        /// Centre of the base.
        p0: DVec3,
        /// Unit axis.
        axis: DVec3,
        /// Height along the axis.
        height: f64,
        /// Outer radius.
        outer: f64,
        /// Inner radius.
        inner: f64,
    },
    /// Disk or annulus (inner > 0) with unit `normal`.
    Disk {
        /// Centre.
        center: DVec3,
        /// Unit normal.
        normal: DVec3,
        /// Outer radius.
        radius: f64,
        /// Inner radius (0 for a full disk).
        inner: f64,
    },
}

impl Analytic {
    /// Crossings of the ray with the infinite cylinder around (p0, axis),
    /// clipped to [0, h] and to the ray interval `[tn, tf]` ([`in_range`]):
    /// `emit(t, radial)` for each, in root order.
    /// (Handed over one by one rather than as an array of options, which
    /// `intersect` then copied and unpacked: callgrind, cylinder_refraction.)
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn cyl(
        p0: DVec3,
        axis: DVec3,
        h: f64,
        r: f64,
        o: DVec3,
        d: DVec3,
        range: (f32, f32),
        emit: impl FnMut(f64, DVec3),
    ) {
        if axis == DVec3::Y {
            Self::cyl_about(p0, AxisY, h, r, o, d, range, emit)
        } else {
            Self::cyl_about(p0, axis, h, r, o, d, range, emit)
        }
    }

    /// [`cyl`](Self::cyl) about the axis `axis`.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn cyl_about(
        p0: DVec3,
        axis: impl Axis,
        h: f64,
        r: f64,
        o: DVec3,
        d: DVec3,
        range: (f32, f32),
        emit: impl FnMut(f64, DVec3),
    ) {
        let roots = Self::cyl_roots(p0, axis, r, o, d);
        Self::cyl_emit(p0, axis, h, o, d, roots, range, emit);
    }

    /// The roots of the ray with the infinite cylinder of radius `r` around
    /// the axis through `p0`, in the quadratic's order, and whether they are
    /// crossings (when not, the roots are meaningless). Straight-line code,
    /// so that the lanes of a callback ([`Analytic::intersect_lanes`]) overlap.
    #[inline(always)]
    fn cyl_roots(p0: DVec3, axis: impl Axis, r: f64, o: DVec3, d: DVec3) -> (f64, f64, bool) {
        let op = o - p0;
        let d_perp = axis.across(d, axis.along(d));
        let o_perp = axis.across(op, axis.along(op));
        let a = d_perp.length_squared();
        let b = o_perp.dot(d_perp);
        let lo = o_perp.length();
        let c = (lo - r) * (lo + r);
        let disc = b * b - a * c;
        let ok = !(a == 0.0 || disc < 0.0);
        let s = disc.sqrt();
        let q = if b > 0.0 { -(b + s) } else { -b + s };
        let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (q / a, c / q) };
        (t0, t1, ok)
    }

    /// The crossings among the roots `(t0, t1, ok)` ([`cyl_roots`](Self::cyl_roots))
    /// within [0, h] along the axis and within `[tn, tf]` ([`in_range`]):
    /// `emit(t, radial)` for each, in root order. Two roots of one tangent
    /// touch are no crossing (asked only when a root counts).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn cyl_emit(
        p0: DVec3,
        axis: impl Axis,
        h: f64,
        o: DVec3,
        d: DVec3,
        (t0, t1, ok): (f64, f64, bool),
        (tn, tf): (f32, f32),
        mut emit: impl FnMut(f64, DVec3),
    ) {
        if !ok {
            return;
        }
        let keep = [in_range(t0, tn, tf), in_range(t1, tn, tf)];
        if !(keep[0] || keep[1]) || is_touch(t0, t1, o, d) {
            return;
        }
        let op = o - p0;
        for (t, k) in [t0, t1].into_iter().zip(keep) {
            if !k {
                continue;
            }
            let p = op + d * t;
            let y = axis.along(p);
            if (0.0..=h).contains(&y) {
                emit(t, axis.across(p, y));
            }
        }
    }

    /// The walls of a cylinder (`flip`: normals towards the axis) for the
    /// lanes of a callback: every lane's roots first, then each lane's
    /// crossings.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn cyl_lanes(
        p0: DVec3,
        axis: impl Axis,
        h: f64,
        r: f64,
        flip: bool,
        rays: &[LaneRay],
        out: &mut [Candidates],
    ) {
        for (rays, out) in rays.chunks(LANES).zip(out.chunks_mut(LANES)) {
            let mut roots = [(0.0, 0.0, false); LANES];
            for (root, ray) in roots.iter_mut().zip(rays) {
                *root = Self::cyl_roots(p0, axis, r, ray.org.as_dvec3(), ray.dir.as_dvec3());
            }
            for ((ray, out), &root) in rays.iter().zip(out).zip(&roots) {
                let (o, d) = (ray.org.as_dvec3(), ray.dir.as_dvec3());
                Self::cyl_emit(p0, axis, h, o, d, root, (ray.tnear, ray.tfar), |t, radial| {
                    out.push(candidate(t, if flip { -radial } else { radial }))
                });
            }
        }
    }

    /// [`cyl_lanes`](Self::cyl_lanes) about `axis`, the y axis's own code for it.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn cyl_lanes_about(
        p0: DVec3,
        axis: DVec3,
        h: f64,
        r: f64,
        flip: bool,
        rays: &[LaneRay],
        out: &mut [Candidates],
    ) {
        if axis == DVec3::Y {
            Self::cyl_lanes(p0, AxisY, h, r, flip, rays, out)
        } else {
            Self::cyl_lanes(p0, axis, h, r, flip, rays, out)
        }
    }

    /// The crossing of the ray with the disk (annulus when `inner` > 0), if
    /// it lies within `[tn, tf]` ([`in_range`]).
    #[inline]
    fn disk(
        center: DVec3,
        n: DVec3,
        r: f64,
        inner: f64,
        o: DVec3,
        d: DVec3,
        (tn, tf): (f32, f32),
    ) -> Option<f64> {
        let dn = d.dot(n);
        if dn == 0.0 {
            return None;
        }
        let t = (center - o).dot(n) / dn;
        if !in_range(t, tn, tf) {
            return None;
        }
        let p = o + d * t - center;
        let q = p.length_squared();
        (q <= r * r && q >= inner * inner).then_some(t)
    }

    /// Might a surface of this solid pass within `tol` of `p`? A distance
    /// test for spheres, closed cylinders and tubes (never false when the
    /// distance is at most `tol`); `None` for other shapes.
    pub fn surface_near(&self, p: DVec3, tol: f64) -> Option<bool> {
        match *self {
            Analytic::Sphere { center, radius } => Some(((p - center).length() - radius).abs() <= tol),
            Analytic::Cylinder {
                p0,
                axis,
                height,
                radius,
                caps: true,
                inward: false,
            } => {
                let (y, r) = axial(p0, axis, p);
                let side = (r - radius).abs() <= tol && y >= -tol && y <= height + tol;
                let cap = (y.abs() <= tol || (y - height).abs() <= tol) && r <= radius + tol;
                Some(side || cap)
            }
            Analytic::Tube {
                p0,
                axis,
                height,
                outer,
                inner,
            } => {
                let (y, r) = axial(p0, axis, p);
                let walls =
                    ((r - outer).abs() <= tol || (r - inner).abs() <= tol) && y >= -tol && y <= height + tol;
                let ends =
                    (y.abs() <= tol || (y - height).abs() <= tol) && r <= outer + tol && r >= inner - tol;
                Some(walls || ends)
            }
            _ => None,
        }
    }

    /// Is `p` strictly inside the solid this shape bounds (spheres, closed
    /// cylinders, tubes)? `None` for shapes that bound no volume.
    pub fn contains(&self, p: DVec3) -> Option<bool> {
        match *self {
            Analytic::Sphere { center, radius } => Some((p - center).length_squared() < radius * radius),
            Analytic::Cylinder {
                p0,
                axis,
                height,
                radius,
                caps: true,
                inward: false,
            } => {
                let q = p - p0;
                let y = q.dot(axis);
                Some(y > 0.0 && y < height && (q - axis * y).length_squared() < radius * radius)
            }
            Analytic::Tube {
                p0,
                axis,
                height,
                outer,
                inner,
            } => {
                let q = p - p0;
                let y = q.dot(axis);
                let r2 = (q - axis * y).length_squared();
                Some(y > 0.0 && y < height && r2 < outer * outer && r2 > inner * inner)
            }
            _ => None,
        }
    }

    /// Axis-aligned bounds of the whole shape (f64).
    pub fn aabb(&self) -> (DVec3, DVec3) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in 0..self.prims() {
            let b = self.bounds(p);
            lo = lo.min(DVec3::new(
                b.lower[0] as f64,
                b.lower[1] as f64,
                b.lower[2] as f64,
            ));
            hi = hi.max(DVec3::new(
                b.upper[0] as f64,
                b.upper[1] as f64,
                b.upper[2] as f64,
            ));
        }
        (lo, hi)
    }

    fn prims(&self) -> u32 {
        match self {
            Analytic::Sphere { .. } | Analytic::Disk { .. } => 1,
            Analytic::Cylinder { caps, .. } => {
                if *caps {
                    3
                } else {
                    1
                }
            }
            Analytic::Tube { .. } => 4,
        }
    }

    /// Unit outward (per convention) normal at a point `p` on primitive `prim`.
    #[inline]
    pub fn normal(&self, prim: u32, p: DVec3) -> DVec3 {
        match *self {
            Analytic::Sphere { center, .. } => normalize_or_f64(p - center, DVec3::Y),
            Analytic::Cylinder { p0, axis, inward, .. } => match prim {
                0 => {
                    let radial = normalize_or_f64(across_axis(p0, axis, p), DVec3::X);
                    if inward {
                        -radial
                    } else {
                        radial
                    }
                }
                1 => -axis,
                _ => axis,
            },
            Analytic::Tube { p0, axis, .. } => {
                let radial = normalize_or_f64(across_axis(p0, axis, p), DVec3::X);
                match prim {
                    0 => radial,
                    1 => -radial,
                    2 => -axis,
                    _ => axis,
                }
            }
            Analytic::Disk { normal, .. } => normal,
        }
    }

    /// Snap a point near primitive `prim` onto it exactly (f64).
    #[inline]
    pub fn project(&self, prim: u32, p: DVec3) -> DVec3 {
        fn onto(p0: DVec3, axis: impl Axis, r: f64, p: DVec3) -> DVec3 {
            let q = p - p0;
            let y = axis.along(q);
            let rad = axis.across(q, y);
            let l = rad.length();
            if l > 0.0 {
                axis.offset(p0, y) + rad * (r / l)
            } else {
                p
            }
        }
        let radial = |p0: DVec3, axis: DVec3, r: f64| {
            if axis == DVec3::Y {
                onto(p0, AxisY, r, p)
            } else {
                onto(p0, axis, r, p)
            }
        };
        let plane = |c: DVec3, n: DVec3| p - n * (p - c).dot(n);
        match *self {
            Analytic::Sphere { center, radius } => {
                let q = p - center;
                let l = q.length();
                if l > 0.0 {
                    center + q * (radius / l)
                } else {
                    p
                }
            }
            Analytic::Cylinder {
                p0,
                axis,
                height,
                radius,
                ..
            } => match prim {
                0 => radial(p0, axis, radius),
                1 => plane(p0, axis),
                _ => plane(p0 + axis * height, axis),
            },
            Analytic::Tube {
                p0,
                axis,
                height,
                outer,
                inner,
            } => match prim {
                0 => radial(p0, axis, outer),
                1 => radial(p0, axis, inner),
                2 => plane(p0, axis),
                _ => plane(p0 + axis * height, axis),
            },
            Analytic::Disk { center, normal, .. } => plane(center, normal),
        }
    }

    /// Texture coordinates in [0, 1]² at `p` (sphere: longitude/latitude around y).
    pub fn uv(&self, p: DVec3) -> [f32; 2] {
        match *self {
            Analytic::Sphere { center, radius } => {
                let q = (p - center) / radius;
                let u = 0.5 + q.x.atan2(q.z) / std::f64::consts::TAU;
                let v = q.y.clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
                [u as f32, v as f32]
            }
            _ => [0.0, 0.0],
        }
    }
}

fn cyl_bounds(p0: DVec3, axis: DVec3, h: f64, r: f64) -> Bounds {
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
fn pad(lo: DVec3, hi: DVec3) -> Bounds {
    let m = (lo.abs().max(hi.abs()).max_element() * 1e-6).max(1e-6);
    Bounds {
        lower: (lo - DVec3::splat(m)).as_vec3a().into(),
        upper: (hi + DVec3::splat(m)).as_vec3a().into(),
    }
}

impl UserShape for Analytic {
    fn prim_count(&self) -> u32 {
        self.prims()
    }

    fn bounds(&self, prim: u32) -> Bounds {
        match *self {
            Analytic::Sphere { center, radius } => {
                pad(center - DVec3::splat(radius), center + DVec3::splat(radius))
            }
            Analytic::Cylinder {
                p0,
                axis,
                height,
                radius,
                ..
            } => match prim {
                0 => cyl_bounds(p0, axis, height, radius),
                1 => cyl_bounds(p0, axis, 0.0, radius),
                _ => cyl_bounds(p0 + axis * height, axis, 0.0, radius),
            },
            Analytic::Tube {
                p0,
                axis,
                height,
                outer,
                ..
            } => match prim {
                0 | 1 => cyl_bounds(p0, axis, height, outer),
                2 => cyl_bounds(p0, axis, 0.0, outer),
                _ => cyl_bounds(p0 + axis * height, axis, 0.0, outer),
            },
            Analytic::Disk {
                center,
                normal,
                radius,
                ..
            } => cyl_bounds(center, normal, 0.0, radius),
        }
    }

    fn intersect(&self, prim: u32, org: V3, dir: V3, out: &mut Candidates) {
        self.intersect_in(prim, org, dir, f32::NEG_INFINITY, f32::INFINITY, out);
    }

    #[inline]
    fn intersect_in(&self, prim: u32, org: V3, dir: V3, tn: f32, tf: f32, out: &mut Candidates) {
        let o = org.as_dvec3();
        let d = dir.as_dvec3();
        let range = (tn, tf);
        // Every t pushed is `in_range`.
        let mut push = |t: f64, n: DVec3| out.push(candidate(t, n));
        match *self {
            Analytic::Sphere { center, radius } => {
                sphere_push(center, sphere_roots(center, radius, o, d), o, d, tn, tf, out);
            }
            Analytic::Cylinder {
                p0,
                axis,
                height,
                radius,
                inward,
                ..
            } => match prim {
                0 => Self::cyl(p0, axis, height, radius, o, d, range, |t, radial| {
                    push(t, if inward { -radial } else { radial })
                }),
                1 => {
                    if let Some(t) = Self::disk(p0, axis, radius, 0.0, o, d, range) {
                        push(t, -axis);
                    }
                }
                _ => {
                    if let Some(t) = Self::disk(p0 + axis * height, axis, radius, 0.0, o, d, range) {
                        push(t, axis);
                    }
                }
            },
            Analytic::Tube {
                p0,
                axis,
                height,
                outer,
                inner,
            } => match prim {
                0 => Self::cyl(p0, axis, height, outer, o, d, range, &mut push),
                1 => Self::cyl(p0, axis, height, inner, o, d, range, |t, radial| push(t, -radial)),
                2 => {
                    if let Some(t) = Self::disk(p0, axis, outer, inner, o, d, range) {
                        push(t, -axis);
                    }
                }
                _ => {
                    if let Some(t) = Self::disk(p0 + axis * height, axis, outer, inner, o, d, range) {
                        push(t, axis);
                    }
                }
            },
            Analytic::Disk {
                center,
                normal,
                radius,
                inner,
            } => {
                if let Some(t) = Self::disk(center, normal, radius, inner, o, d, range) {
                    push(t, normal);
                }
            }
        }
    }

    fn intersect_lanes(&self, prim: u32, rays: &[LaneRay], out: &mut [Candidates]) {
        match *self {
            Analytic::Sphere { center, radius } => {
                for (rays, out) in rays.chunks(LANES).zip(out.chunks_mut(LANES)) {
                    let mut roots = [(0.0, 0.0, false); LANES];
                    for (root, ray) in roots.iter_mut().zip(rays) {
                        *root = sphere_roots(center, radius, ray.org.as_dvec3(), ray.dir.as_dvec3());
                    }
                    for ((ray, out), &root) in rays.iter().zip(out).zip(&roots) {
                        let (o, d) = (ray.org.as_dvec3(), ray.dir.as_dvec3());
                        sphere_push(center, root, o, d, ray.tnear, ray.tfar, out);
                    }
                }
            }
            Analytic::Cylinder {
                p0,
                axis,
                height,
                radius,
                inward,
                ..
            } if prim == 0 => Self::cyl_lanes_about(p0, axis, height, radius, inward, rays, out),
            Analytic::Tube {
                p0,
                axis,
                height,
                outer,
                inner,
            } if prim < 2 => {
                let (r, flip) = if prim == 0 { (outer, false) } else { (inner, true) };
                Self::cyl_lanes_about(p0, axis, height, r, flip, rays, out)
            }
            _ => {
                for (r, o) in rays.iter().zip(out) {
                    self.intersect_in(prim, r.org, r.dir, r.tnear, r.tfar, o);
                }
            }
        }
    }
}

/// A triangle mesh in world space.
#[derive(Debug, Clone, Default)]
pub struct Mesh {
    /// Vertex positions, world space.
    pub positions: Vec<[f32; 3]>,
    /// Triangles (counter-clockwise seen from outside, for closed meshes).
    pub indices: Vec<[u32; 3]>,
    /// Per-vertex shading normals (same length as positions) or none (flat).
    pub normals: Option<Vec<[f32; 3]>>,
    /// Per-vertex texture coordinates or none.
    pub uvs: Option<Vec<[f32; 2]>>,
}

impl Mesh {
    /// Shading normal and uv at barycentrics (u, v) of triangle `prim`
    /// (Embree's convention: p = (1−u−v)·v0 + u·v1 + v·v2). Forced inline:
    /// the crate builds in 16 codegen units without LTO, so whether a call
    /// was inlined depended on how unrelated edits partitioned the crate (one
    /// build that did not inline it spent 19 % of the warp's ray pass in it).
    #[inline(always)]
    pub fn shading(&self, prim: u32, u: f32, v: f32) -> (Option<V3>, [f32; 2]) {
        let tri = self.indices[prim as usize];
        let w = 1.0 - u - v;
        let n = self.normals.as_ref().map(|ns| {
            let [a, b, c] = tri.map(|i| V3::from(ns[i as usize]));
            (a * w + b * u + c * v).normalize_or_zero()
        });
        (
            n.filter(|n| n.length_squared() > 0.5),
            self.shading_uv(prim, u, v),
        )
    }

    /// The texture coordinates of [`Self::shading`] alone (without the
    /// normal, whose square root and division are a latency chain).
    #[inline(always)]
    pub fn shading_uv(&self, prim: u32, u: f32, v: f32) -> [f32; 2] {
        let Some(t) = self.uvs.as_ref() else {
            return [u, v];
        };
        let tri = self.indices[prim as usize];
        let w = 1.0 - u - v;
        let [a, b, c] = tri.map(|i| t[i as usize]);
        [a[0] * w + b[0] * u + c[0] * v, a[1] * w + b[1] * u + c[1] * v]
    }

    /// The shading normal of [`Self::shading`] alone (without the texture
    /// coordinates).
    #[inline(always)]
    pub fn shading_normal(&self, prim: u32, u: f32, v: f32) -> Option<V3> {
        let ns = self.normals.as_ref()?;
        let tri = self.indices[prim as usize];
        let w = 1.0 - u - v;
        let [a, b, c] = tri.map(|i| V3::from(ns[i as usize]));
        Some(normalize_or(a * w + b * u + c * v, V3::ZERO)).filter(|n| n.length_squared() > 0.5)
    }

    /// The point at barycentrics (u, v) of triangle `prim`, in f64 then rounded.
    #[inline]
    pub fn point(&self, prim: u32, u: f32, v: f32) -> V3 {
        let tri = self.indices[prim as usize];
        let (u, v) = (u.clamp(0.0, 1.0) as f64, v.clamp(0.0, 1.0) as f64);
        let w = (1.0 - u - v).max(0.0);
        let [a, b, c] = tri.map(|i| {
            let q = self.positions[i as usize];
            DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64)
        });
        let p = a * w + b * u + c * v;
        p.as_vec3a()
    }

    /// Axis-aligned bounds.
    pub fn aabb(&self) -> (DVec3, DVec3) {
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for p in &self.positions {
            let p = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            lo = lo.min(p);
            hi = hi.max(p);
        }
        (lo, hi)
    }

    /// Signed volume (positive for outward-facing closed meshes).
    pub fn signed_volume(&self) -> f64 {
        self.indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| {
                    let p = self.positions[i as usize];
                    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
                });
                a.dot(b.cross(c)) / 6.0
            })
            .sum()
    }

    /// Reverse the winding (and normals) of every triangle.
    pub fn flip(&mut self) {
        for t in &mut self.indices {
            t.swap(1, 2);
        }
        if let Some(ns) = &mut self.normals {
            for n in ns {
                *n = [-n[0], -n[1], -n[2]];
            }
        }
    }

    /// Closed-solid check: after welding equal positions, every edge must be
    /// used by exactly two triangles with opposite winding. Returns a
    /// description of the first violation.
    pub fn check_closed(&self) -> Result<(), String> {
        use std::collections::HashMap;
        let mut weld: HashMap<[u32; 3], u32> = HashMap::new();
        let ids: Vec<u32> = self
            .positions
            .iter()
            .map(|p| {
                let key = p.map(|c| if c == 0.0 { 0 } else { c.to_bits() });
                let n = weld.len() as u32;
                *weld.entry(key).or_insert(n)
            })
            .collect();
        let mut directed: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &self.indices {
            let v = t.map(|i| ids[i as usize]);
            for k in 0..3 {
                *directed.entry((v[k], v[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &count) in &directed {
            if count != 1 {
                return Err(format!(
                    "an edge is used {count} times with the same winding (inconsistent orientation or non-manifold)"
                ));
            }
            if !directed.contains_key(&(b, a)) {
                return Err("it has an open edge (used by one triangle only): the mesh is not closed".into());
            }
        }
        Ok(())
    }

    /// Point-in-solid by ray parity (for closed meshes), with a fixed oblique direction.
    pub fn contains(&self, p: DVec3) -> bool {
        self.crossings(p, 0..self.indices.len() as u32) % 2 == 1
    }

    /// The direction of the point-in-solid parity ray (not axis-aligned, so
    /// it rarely runs along an edge of an axis-aligned mesh).
    fn parity_dir() -> DVec3 {
        DVec3::new(0.5773, 0.5774, 0.5773).normalize()
    }

    /// Crossings of the parity ray from `p` with the triangles `tris`.
    /// Squared distance from `p` to triangle `tri`, exact (closest point by
    /// region, Ericson, *Real-Time Collision Detection* §5.1.5) when it may
    /// be at most `bound`; some value above `bound` (the squared distance to
    /// the triangle's plane) when the plane alone is farther; 0 for a
    /// degenerate triangle.
    pub fn distance_squared(&self, tri: u32, p: DVec3, bound: f64) -> f64 {
        let [a, b, c] = self.indices[tri as usize].map(|i| {
            let q = self.positions[i as usize];
            DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64)
        });
        let ab = b - a;
        let ac = c - a;
        let ap = p - a;
        let n = ab.cross(ac);
        let nn = n.length_squared();
        if nn == 0.0 {
            // A degenerate triangle (a segment or a point): called near, so
            // the answer stays conservative. Its edges are its neighbours'.
            return 0.0;
        }
        let h = ap.dot(n);
        // Most triangles of a cell are far from the point's plane.
        if h * h > bound * nn {
            return h * h / nn;
        }
        let d1 = ab.dot(ap);
        let d2 = ac.dot(ap);
        if d1 <= 0.0 && d2 <= 0.0 {
            return ap.length_squared();
        }
        let bp = p - b;
        let d3 = ab.dot(bp);
        let d4 = ac.dot(bp);
        if d3 >= 0.0 && d4 <= d3 {
            return bp.length_squared();
        }
        let vc = d1 * d4 - d3 * d2;
        if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            let v = d1 / (d1 - d3);
            return (ap - ab * v).length_squared();
        }
        let cp = p - c;
        let d5 = ab.dot(cp);
        let d6 = ac.dot(cp);
        if d6 >= 0.0 && d5 <= d6 {
            return cp.length_squared();
        }
        let vb = d5 * d2 - d1 * d6;
        if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            let w = d2 / (d2 - d6);
            return (ap - ac * w).length_squared();
        }
        let va = d3 * d6 - d5 * d4;
        if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
            return (bp - (c - b) * w).length_squared();
        }
        // va + vb + vc = |ab × ac|² > 0 here.
        let denom = va + vb + vc;
        let v = vb / denom;
        let w = vc / denom;
        (ap - ab * v - ac * w).length_squared()
    }

    fn crossings(&self, p: DVec3, tris: impl IntoIterator<Item = u32>) -> u32 {
        let d = Self::parity_dir();
        let mut crossings = 0;
        for ti in tris {
            let t = &self.indices[ti as usize];
            let [a, b, c] = t.map(|i| {
                let q = self.positions[i as usize];
                DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64)
            });
            // Möller–Trumbore in f64.
            let e1 = b - a;
            let e2 = c - a;
            let pv = d.cross(e2);
            let det = e1.dot(pv);
            if det.abs() < 1e-300 {
                continue;
            }
            let inv = 1.0 / det;
            let tv = p - a;
            let u = tv.dot(pv) * inv;
            if !(0.0..=1.0).contains(&u) {
                continue;
            }
            let qv = tv.cross(e1);
            let v = d.dot(qv) * inv;
            if v < 0.0 || u + v > 1.0 {
                continue;
            }
            if e2.dot(qv) * inv > 0.0 {
                crossings += 1;
            }
        }
        crossings
    }
}

/// A point-in-solid accelerator for a closed mesh: the triangles binned by
/// their projection along the parity ray's direction onto a uniform 2-D grid,
/// so a query tests only the triangles whose projected bounds (padded) cover
/// the point's projection. The same Möller–Trumbore test on a superset of the
/// triangles the parity ray can hit: answers equal `Mesh::contains` (test),
/// at O(triangles per cell) instead of O(triangles).
#[derive(Debug)]
pub struct ContainsGrid {
    mesh: std::sync::Arc<Mesh>,
    axes: [DVec3; 2],
    lo: [f64; 2],
    inv_cell: [f64; 2],
    n: [usize; 2],
    /// Cell c's triangles are `tris[start[c]..start[c + 1]]`.
    start: Vec<u32>,
    tris: Vec<u32>,
    /// Each triangle's plane: unit normal and offset (`n·x = d`); zero for
    /// a degenerate triangle. Gates `surface_near`'s exact distances.
    planes: Vec<[f64; 4]>,
    /// The mesh's bounds cut into cells, each classified on first use.
    cells: InOutCells,
}

/// The bounds of a closed mesh cut into at most 64 cells a side, each
/// classified on first use as wholly outside, wholly inside, or mixed (the
/// surface may pass through it). A point in a classified whole cell gets
/// its answer from one load; a point in a mixed cell (or outside the
/// bounds) from the parity test. A cell is whole when no triangle comes
/// within its half-diagonal of its centre (`ContainsGrid::surface_near`,
/// never false when one does), so every point of it lies on the same side
/// as the centre; the side is taken from two parity tests (the centre and
/// a point a quarter cell off it), and a cell where they disagree (a parity
/// ray through an edge) stays mixed. The leaked-entry check of
/// glass_ice_bubbles spent 1.9 M instructions per trace pass in 1,518
/// parity tests of the glass (1,270 each).
#[derive(Debug)]
struct InOutCells {
    lo: DVec3,
    size: DVec3,
    n: [usize; 3],
    /// `UNKNOWN`, `OUTSIDE`, `INSIDE` or `MIXED` per cell, x fastest.
    /// Relaxed loads and stores: a cell's class is a function of the mesh,
    /// so two threads classifying it store the same value.
    state: Vec<std::sync::atomic::AtomicU8>,
}

const CELL_UNKNOWN: u8 = 0;
const CELL_OUTSIDE: u8 = 1;
const CELL_INSIDE: u8 = 2;
const CELL_MIXED: u8 = 3;

impl InOutCells {
    /// Cells over the bounds (`lo`, `hi`), the longest side cut in 64.
    fn new(lo: DVec3, hi: DVec3) -> Self {
        let ext = (hi - lo).max(DVec3::splat(1e-9 * (1.0 + lo.abs().max(hi.abs()).max_element())));
        let cell = ext.max_element() / 64.0;
        let n = ext.to_array().map(|e| ((e / cell).ceil() as usize).clamp(1, 64));
        let size = ext / DVec3::new(n[0] as f64, n[1] as f64, n[2] as f64);
        InOutCells {
            lo,
            size,
            n,
            state: (0..n[0] * n[1] * n[2])
                .map(|_| std::sync::atomic::AtomicU8::new(CELL_UNKNOWN))
                .collect(),
        }
    }

    /// The cell holding `p` (its index and its coordinates); `None` outside
    /// the bounds.
    #[inline]
    fn cell_of(&self, p: DVec3) -> Option<(usize, [usize; 3])> {
        let x = (p - self.lo) / self.size;
        let mut i = [0usize; 3];
        for k in 0..3 {
            // `!(..)` also rejects NaN.
            if !(x[k] >= 0.0 && x[k] < self.n[k] as f64) {
                return None;
            }
            i[k] = x[k] as usize;
        }
        Some(((i[2] * self.n[1] + i[1]) * self.n[0] + i[0], i))
    }

    fn centre(&self, i: [usize; 3]) -> DVec3 {
        self.lo + (DVec3::new(i[0] as f64, i[1] as f64, i[2] as f64) + 0.5) * self.size
    }
}

impl ContainsGrid {
    /// Bin `mesh`'s triangles.
    pub fn new(mesh: std::sync::Arc<Mesh>) -> Self {
        let d = Mesh::parity_dir();
        let u = d.any_orthonormal_vector();
        let axes = [u, d.cross(u)];
        let proj = |i: u32| -> [f64; 2] {
            let q = mesh.positions[i as usize];
            let q = DVec3::new(q[0] as f64, q[1] as f64, q[2] as f64);
            [q.dot(axes[0]), q.dot(axes[1])]
        };
        let boxes: Vec<([f64; 2], [f64; 2])> = mesh
            .indices
            .iter()
            .map(|t| {
                let p = t.map(proj);
                let lo = [0, 1].map(|k| p[0][k].min(p[1][k]).min(p[2][k]));
                let hi = [0, 1].map(|k| p[0][k].max(p[1][k]).max(p[2][k]));
                (lo, hi)
            })
            .collect();
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        for (a, b) in &boxes {
            for k in 0..2 {
                lo[k] = lo[k].min(a[k]);
                hi[k] = hi[k].max(b[k]);
            }
        }
        // Pad every box by far more than the rounding of the projection and
        // of Möller–Trumbore's barycentrics, so no triangle the exact test
        // could accept is missed.
        let ext = (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1e-30);
        let pad = 1e-7 * ext + 1e-30;
        // Four cells per triangle's worth of side: the cells are binned by the
        // triangle's own extent in each row (below), so a long thin triangle
        // (a lathe's wall, seen along the diagonal) covers a strip of cells,
        // not its whole bounding box.
        let side = ((4.0 * mesh.indices.len() as f64).sqrt().ceil() as usize).clamp(1, 2048);
        let n = [side, side];
        let span = [0, 1].map(|k| (hi[k] - lo[k]) + 2.0 * pad);
        let lo = [lo[0] - pad, lo[1] - pad];
        let inv_cell = [0, 1].map(|k| n[k] as f64 / span[k].max(1e-300));
        let cell_of = |x: f64, k: usize| -> usize {
            (((x - lo[k]) * inv_cell[k]).floor().max(0.0) as usize).min(n[k] - 1)
        };
        // Per triangle: its rows, and in each row the columns its projection
        // (padded) covers: the x extent of the triangle clipped to the row's
        // band, widened by the pad. Convex, so the extent is reached at the
        // corners inside the band or where the edges cross its two lines.
        let cell_h = span[1] / n[1] as f64;
        let ranges: Vec<Vec<(usize, usize, usize)>> = mesh
            .indices
            .iter()
            .zip(&boxes)
            .map(|(t, (a, b))| {
                let p = t.map(proj);
                let (y0, y1) = (cell_of(a[1] - pad, 1), cell_of(b[1] + pad, 1));
                (y0..=y1)
                    .filter_map(|y| {
                        let ya = lo[1] + y as f64 * cell_h - pad;
                        let yb = lo[1] + (y + 1) as f64 * cell_h + pad;
                        let (mut x0, mut x1) = (f64::INFINITY, f64::NEG_INFINITY);
                        for i in 0..3 {
                            let (u, w) = (p[i], p[(i + 1) % 3]);
                            if u[1] >= ya && u[1] <= yb {
                                x0 = x0.min(u[0]);
                                x1 = x1.max(u[0]);
                            }
                            for c in [ya, yb] {
                                if (u[1] - c) * (w[1] - c) < 0.0 {
                                    let x = u[0] + (c - u[1]) / (w[1] - u[1]) * (w[0] - u[0]);
                                    x0 = x0.min(x);
                                    x1 = x1.max(x);
                                }
                            }
                        }
                        // Rounding in the crossings is far below the pad; clamp to the box.
                        (x0 <= x1)
                            .then(|| (y, cell_of(x0.max(a[0]) - pad, 0), cell_of(x1.min(b[0]) + pad, 0)))
                    })
                    .collect()
            })
            .collect();
        let mut count = vec![0u32; n[0] * n[1] + 1];
        for r in &ranges {
            for &(y, x0, x1) in r {
                for x in x0..=x1 {
                    count[y * n[0] + x + 1] += 1;
                }
            }
        }
        for c in 1..count.len() {
            count[c] += count[c - 1];
        }
        let start = count.clone();
        let mut fill = count;
        let mut tris = vec![0u32; *start.last().unwrap_or(&0) as usize];
        for (t, r) in ranges.iter().enumerate() {
            for &(y, x0, x1) in r {
                for x in x0..=x1 {
                    let c = y * n[0] + x;
                    tris[fill[c] as usize] = t as u32;
                    fill[c] += 1;
                }
            }
        }
        let planes = mesh
            .indices
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| DVec3::from_array(mesh.positions[i as usize].map(f64::from)));
                let n = (b - a).cross(c - a).normalize_or_zero();
                [n.x, n.y, n.z, n.dot(a)]
            })
            .collect();
        let (blo, bhi) = mesh.aabb();
        Self {
            mesh,
            axes,
            lo,
            inv_cell,
            n,
            start,
            tris,
            planes,
            cells: InOutCells::new(blo, bhi),
        }
    }

    /// Is `p` inside the mesh? From its cell's class where the cell is whole
    /// ([`InOutCells`]), else [`Self::parity_contains`].
    #[inline]
    pub fn contains(&self, p: DVec3) -> bool {
        use std::sync::atomic::Ordering::Relaxed;
        let Some((c, i)) = self.cells.cell_of(p) else {
            return self.parity_contains(p);
        };
        let mut class = self.cells.state[c].load(Relaxed);
        if class == CELL_UNKNOWN {
            class = self.classify(i);
            self.cells.state[c].store(class, Relaxed);
        }
        match class {
            CELL_OUTSIDE => false,
            CELL_INSIDE => true,
            _ => self.parity_contains(p),
        }
    }

    /// The class of cell `i` (see [`InOutCells`]).
    #[cold]
    fn classify(&self, i: [usize; 3]) -> u8 {
        let c = self.cells.centre(i);
        let half = 0.5 * self.cells.size.length();
        // Widened far beyond the rounding of the distance tests.
        if self.surface_near(c, half * (1.0 + 1e-6) + 1e-9 * (1.0 + c.abs().max_element())) {
            return CELL_MIXED;
        }
        let a = self.parity_contains(c);
        let b = self.parity_contains(c + 0.25 * self.cells.size * DVec3::new(1.0, -0.7, 0.4));
        match (a, b) {
            (true, true) => CELL_INSIDE,
            (false, false) => CELL_OUTSIDE,
            _ => CELL_MIXED,
        }
    }

    /// Is `p` inside the mesh? (Parity of the parity ray's crossings.)
    pub fn parity_contains(&self, p: DVec3) -> bool {
        let q = [p.dot(self.axes[0]), p.dot(self.axes[1])];
        let mut cell = [0usize; 2];
        for k in 0..2 {
            let x = (q[k] - self.lo[k]) * self.inv_cell[k];
            if !(x >= 0.0 && x < self.n[k] as f64) {
                // Outside every padded projected triangle: no crossing.
                return false;
            }
            cell[k] = x as usize;
        }
        let c = cell[1] * self.n[0] + cell[0];
        let tris = &self.tris[self.start[c] as usize..self.start[c + 1] as usize];
        self.mesh.crossings(p, tris.iter().copied()) % 2 == 1
    }

    /// Might the mesh's surface pass within `tol` of `p`? Never false when
    /// some triangle is within `tol` (the triangles of every cell the
    /// projected disc of radius `tol` overlaps are tested by exact
    /// point–triangle distance); O(triangles per cell), like [`Self::contains`].
    pub fn surface_near(&self, p: DVec3, tol: f64) -> bool {
        let q = [p.dot(self.axes[0]), p.dot(self.axes[1])];
        let mut range = [(0usize, 0usize); 2];
        for k in 0..2 {
            let a = (q[k] - tol - self.lo[k]) * self.inv_cell[k];
            let b = (q[k] + tol - self.lo[k]) * self.inv_cell[k];
            // `!(..)` also rejects NaN.
            if !(b >= 0.0 && a < self.n[k] as f64) {
                return false;
            }
            range[k] = (a.max(0.0) as usize, (b as usize).min(self.n[k] - 1));
        }
        let tol2 = tol * tol;
        for y in range[1].0..=range[1].1 {
            for x in range[0].0..=range[0].1 {
                let c = y * self.n[0] + x;
                let tris = &self.tris[self.start[c] as usize..self.start[c + 1] as usize];
                let near = |&t: &u32| {
                    let [nx, ny, nz, d] = self.planes[t as usize];
                    // Most triangles of a cell are far from the point's plane.
                    (nx * p.x + ny * p.y + nz * p.z - d).abs() <= tol
                        && self.mesh.distance_squared(t, p, tol2) <= tol2
                };
                if tris.iter().any(near) {
                    return true;
                }
            }
        }
        false
    }

    /// Triangles a query at `p` tests (0 outside the grid).
    #[cfg(test)]
    fn tested(&self, p: DVec3) -> usize {
        let q = [p.dot(self.axes[0]), p.dot(self.axes[1])];
        let x = [0, 1].map(|k| (q[k] - self.lo[k]) * self.inv_cell[k]);
        if (0..2).any(|k| !(x[k] >= 0.0 && x[k] < self.n[k] as f64)) {
            return 0;
        }
        let c = x[1] as usize * self.n[0] + x[0] as usize;
        (self.start[c + 1] - self.start[c]) as usize
    }

    /// The mesh.
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
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
            assert_eq!(is_touch(t0, t1, o, d), want, "case {k}: {t0} {t1} {o} {d}");
        }
    }

    /// `intersect_lanes` (lanes side by side) gives every lane what
    /// `intersect_in` gives it alone, bit for bit: spheres, cylinders and
    /// tubes about the y axis and a tilted one, rays aimed near them
    /// (grazing ones included), any ray interval, one to seven lanes.
    #[test]
    fn lanes_side_by_side_equal_lanes_alone() {
        let tilted = DVec3::new(1.0, 2.0, 0.5).normalize();
        let shapes = [
            Analytic::Sphere {
                center: DVec3::new(0.3, 0.6, -0.2),
                radius: 0.6,
            },
            Analytic::Cylinder {
                p0: DVec3::new(0.0, -1.0, 0.0),
                axis: DVec3::Y,
                height: 2.0,
                radius: 1.0,
                inward: true,
                caps: false,
            },
            Analytic::Cylinder {
                p0: DVec3::new(0.1, -1.0, 0.2),
                axis: tilted,
                height: 2.0,
                radius: 0.7,
                inward: false,
                caps: true,
            },
            Analytic::Tube {
                p0: DVec3::new(0.0, -1.0, 0.0),
                axis: DVec3::Y,
                height: 2.0,
                outer: 1.0,
                inner: 0.8,
            },
            Analytic::Tube {
                p0: DVec3::new(0.0, -1.0, 0.0),
                axis: tilted,
                height: 2.0,
                outer: 1.0,
                inner: 0.8,
            },
        ];
        let mut rng = crate::sampling::Rng::new(5);
        let mut hits = 0;
        for shape in shapes {
            for prim in 0..shape.prims() {
                for round in 0..2000 {
                    let m = 1 + round % 7;
                    let rays: Vec<LaneRay> = (0..m)
                        .map(|_| {
                            let org =
                                V3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 6.0 - V3::splat(3.0);
                            let aim =
                                V3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.4 - V3::splat(1.2);
                            let mut dir = aim - org;
                            if rng.uniform() < 0.2 {
                                // Perpendicular to the way to the centre: grazing.
                                dir = dir.cross(V3::new(0.3, 1.0, -0.2));
                            }
                            let tnear = if rng.uniform() < 0.5 { 0.0 } else { rng.uniform() };
                            let tfar = if rng.uniform() < 0.5 {
                                f32::INFINITY
                            } else {
                                tnear + 4.0 * rng.uniform()
                            };
                            LaneRay {
                                org,
                                dir,
                                tnear,
                                tfar,
                            }
                        })
                        .collect();
                    let mut side = vec![Candidates::default(); m];
                    shape.intersect_lanes(prim, &rays, &mut side);
                    for (r, got) in rays.iter().zip(&side) {
                        let mut alone = Candidates::default();
                        shape.intersect_in(prim, r.org, r.dir, r.tnear, r.tfar, &mut alone);
                        assert_eq!(got.as_slice(), alone.as_slice(), "{shape:?} prim {prim}: {r:?}");
                        let mut all = Candidates::default();
                        shape.intersect(prim, r.org, r.dir, &mut all);
                        let clipped: Vec<Candidate> = all
                            .as_slice()
                            .iter()
                            .copied()
                            .filter(|c| c.t >= r.tnear && c.t <= r.tfar)
                            .collect();
                        assert_eq!(alone.as_slice(), &clipped[..], "{shape:?} prim {prim}: {r:?}");
                        hits += alone.as_slice().len();
                    }
                }
            }
        }
        assert!(hits > 10_000, "{hits} crossings: the rays should meet the shapes");
    }

    #[test]
    fn sphere_crossings_are_analytic_even_far_away() {
        let (t0, t1) = sphere_ts(
            DVec3::new(0.0, 0.0, -1e4),
            1.0,
            DVec3::ZERO,
            DVec3::new(0.0, 0.0, -1.0),
        )
        .unwrap();
        assert!((t0 - (1e4 - 1.0)).abs() < 1e-9 && (t1 - (1e4 + 1.0)).abs() < 1e-9);
    }

    #[test]
    fn tube_has_four_crossings_through_the_axis() {
        let t = Analytic::Tube {
            p0: DVec3::new(0.0, -1.0, 0.0),
            axis: DVec3::Y,
            height: 2.0,
            outer: 1.0,
            inner: 0.8,
        };
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

    #[test]
    fn triangle_distance_is_exact_and_the_grid_finds_every_near_surface() {
        use crate::scene::meshgen::{lathe, LatheShading};
        let p = crate::scene::meshgen::GLASS_PROFILE;
        let m = std::sync::Arc::new(lathe(&p, 48, LatheShading::Flat));
        let mut rng = crate::sampling::Rng::new(11);
        // The closed form against a dense barycentric sampling of one triangle
        // (an independent upper bound, within the sampling's spacing).
        for _ in 0..200 {
            let t = (rng.uniform_f64() * m.indices.len() as f64) as u32;
            let q = DVec3::new(
                rng.uniform_f64() * 3.0 - 1.5,
                rng.uniform_f64() * 3.0 - 0.25,
                rng.uniform_f64() * 3.0 - 1.5,
            );
            let [a, b, c] =
                m.indices[t as usize].map(|i| DVec3::from_array(m.positions[i as usize].map(f64::from)));
            let k = 200;
            let mut best = f64::INFINITY;
            for i in 0..=k {
                for j in 0..=(k - i) {
                    let (u, v) = (i as f64 / k as f64, j as f64 / k as f64);
                    best = best.min((a + (b - a) * u + (c - a) * v - q).length());
                }
            }
            let exact = m.distance_squared(t, q, f64::INFINITY).sqrt();
            let spacing = (b - a).length().max((c - a).length()) / k as f64;
            assert!(
                exact <= best + 1e-12 && best - exact <= spacing,
                "{exact} vs sampled {best}"
            );
        }
        // The grid's answer equals brute force over every triangle, for points
        // scattered near the surface at distances around the tolerance.
        let g = ContainsGrid::new(m.clone());
        let tol = 1e-5;
        let (mut near, mut far) = (0, 0);
        for _ in 0..20000 {
            let t = (rng.uniform_f64() * m.indices.len() as f64) as usize;
            let [a, b, c] = m.indices[t].map(|i| DVec3::from_array(m.positions[i as usize].map(f64::from)));
            let (u, v) = (rng.uniform_f64(), rng.uniform_f64());
            let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
            let on = a + (b - a) * u + (c - a) * v;
            let dir = DVec3::new(
                rng.uniform_f64() - 0.5,
                rng.uniform_f64() - 0.5,
                rng.uniform_f64() - 0.5,
            )
            .normalize();
            let q = on + dir * (rng.uniform_f64() * 3.0 * tol);
            let brute = (0..m.indices.len() as u32)
                .map(|t| m.distance_squared(t, q, f64::INFINITY))
                .fold(f64::INFINITY, f64::min);
            let expect = brute <= tol * tol;
            assert_eq!(g.surface_near(q, tol), expect, "{q}: brute {}", brute.sqrt());
            if expect {
                near += 1;
            } else {
                far += 1;
            }
        }
        assert!(
            near > 3000 && far > 3000,
            "both answers sampled: {near} near, {far} far"
        );
        // Far outside the grid: nothing near.
        assert!(!g.surface_near(DVec3::new(5.0, 1.0, 5.0), tol));
    }

    /// The cell cache answers as the parity test does, at points scattered
    /// through the bounds and a hair off the surface, on the glass lathe
    /// and a rotated box; most points are answered from whole cells. Its
    /// power: classifying each cell by its centre alone (no surface gate)
    /// gets points wrong.
    #[test]
    fn cell_cache_agrees_with_parity() {
        use crate::scene::meshgen::{lathe, LatheShading};
        let glass = lathe(
            &crate::scene::meshgen::GLASS_PROFILE,
            96,
            LatheShading::Smooth { crease_deg: 30.0 },
        );
        let mut cube = lathe(
            &[[0.0, -0.35], [0.5, -0.35], [0.5, 0.35], [0.0, 0.35]],
            4,
            LatheShading::Flat,
        );
        let rot = glam::DQuat::from_axis_angle(DVec3::new(1.0, 0.3, 0.2).normalize(), 0.44);
        for v in &mut cube.positions {
            let q = rot * DVec3::from_array(v.map(f64::from)) + DVec3::new(-0.25, 1.75, 0.1);
            *v = q.to_array().map(|c| c as f32);
        }
        let mut rng = crate::sampling::Rng::new(9);
        for m in [glass, cube] {
            let m = std::sync::Arc::new(m);
            let g = ContainsGrid::new(m.clone());
            let (lo, hi) = m.aabb();
            let mut pts: Vec<DVec3> = (0..40000)
                .map(|_| {
                    let u = DVec3::new(rng.uniform_f64(), rng.uniform_f64(), rng.uniform_f64());
                    lo - 0.05 + (hi - lo + 0.1) * u
                })
                .collect();
            for t in m.indices.iter() {
                let [a, b, c] = t.map(|i| DVec3::from_array(m.positions[i as usize].map(f64::from)));
                let n = (b - a).cross(c - a).normalize();
                let on = (a + b + c) / 3.0;
                pts.extend([on + n * 1e-6, on - n * 1e-6, on + n * 1e-3, on - n * 1e-3]);
            }
            let (mut whole, mut naive_wrong) = (0, 0);
            for &q in &pts {
                let exact = g.parity_contains(q);
                assert_eq!(g.contains(q), exact, "{q}");
                if let Some((c, i)) = g.cells.cell_of(q) {
                    let class = g.cells.state[c].load(std::sync::atomic::Ordering::Relaxed);
                    whole += (class == CELL_INSIDE || class == CELL_OUTSIDE) as u32;
                    naive_wrong += (g.parity_contains(g.cells.centre(i)) != exact) as u32;
                }
            }
            assert!(
                whole as usize > pts.len() / 2,
                "{whole} of {} from whole cells",
                pts.len()
            );
            assert!(
                naive_wrong > 50,
                "centre-only classes get {naive_wrong} points wrong"
            );
        }
    }

    #[test]
    fn contains_grid_agrees_with_brute_force_parity() {
        use crate::scene::meshgen::{lathe, LatheShading};
        let p = crate::scene::meshgen::GLASS_PROFILE;
        let m = std::sync::Arc::new(lathe(&p, 96, LatheShading::Smooth { crease_deg: 30.0 }));
        let g = ContainsGrid::new(m.clone());
        let mut rng = crate::sampling::Rng::new(5);
        let mut inside = 0;
        let mut pts: Vec<DVec3> = (0..20000)
            .map(|_| {
                DVec3::new(
                    rng.uniform_f64() * 2.4 - 1.2,
                    rng.uniform_f64() * 2.8 - 0.1,
                    rng.uniform_f64() * 2.4 - 1.2,
                )
            })
            .collect();
        // Points at and a hair off vertices and edge midpoints: the hard cases.
        for t in m.indices.iter().step_by(7) {
            let a = DVec3::from_array(m.positions[t[0] as usize].map(|c| c as f64));
            let b = DVec3::from_array(m.positions[t[1] as usize].map(|c| c as f64));
            for q in [a, (a + b) * 0.5] {
                pts.extend([q, q + DVec3::splat(1e-9), q - DVec3::splat(1e-7)]);
            }
        }
        let mut tested = 0;
        for &q in &pts {
            let (fast, slow) = (g.contains(q), m.contains(q));
            assert_eq!(fast, slow, "{q}");
            inside += fast as u32;
            tested += g.tested(q);
        }
        assert!(inside > 500, "the sample must include inside points: {inside}");
        // The binning follows each triangle's extent per row, not its bounds:
        // a query tests a few triangles of the 1152 (bounds binning: 74.9).
        let mean = tested as f64 / pts.len() as f64;
        assert!(mean < 20.0, "mean triangles tested per query: {mean:.1}");
    }
}
