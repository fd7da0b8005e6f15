//! The sphere: its crossings in f64, normal, texture coordinates, point in
//! solid, and the distance tests the nested rule's tables use (a sphere's
//! surface against a point, a box and another sphere).
use super::bounds::pad;
use super::normalize::normalize_or_f64;
use super::segment::side_by_side;
use super::segment::{candidate, Roots, Segment};
use crate::embree::{Bounds, Candidates, LaneRay};
use glam::DVec3;

/// A box as (low corner, high corner).
type Box3 = (DVec3, DVec3);

/// A sphere; its normal points away from the centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: DVec3,
    /// Radius.
    pub radius: f64,
}

impl Sphere {
    /// The ordered roots of the ray with the sphere, in f64 (the f32
    /// quadratic loses too much at grazing).
    #[inline(always)]
    pub(super) fn roots(&self, seg: &Segment) -> Roots {
        let (o, d) = (seg.o, seg.d);
        let oc = o - self.center;
        let a = d.length_squared();
        let b = oc.dot(d);
        // c' = |oc|² − r², computed as (|oc| − r)(|oc| + r) to limit cancellation.
        let l = oc.length();
        let r = self.radius;
        let cc = (l - r) * (l + r);
        let disc = b * b - a * cc;
        let real = !(disc < 0.0 || a == 0.0);
        let s = disc.sqrt();
        // Numerically stable pair.
        let q = if b > 0.0 { -(b + s) } else { -b + s };
        let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (q / a, cc / q) };
        Roots {
            t0: t0.min(t1),
            t1: t0.max(t1),
            real,
        }
    }

    /// The crossings among the roots ([`Self::roots`]) that the segment
    /// keeps, onto `out`. A tangent touch (double root) is not a crossing:
    /// nothing is reported, so silhouette-grazing rays neither enter nor
    /// leave. (Asked only when a root counts.)
    #[inline(always)]
    pub(super) fn push_crossings(&self, seg: &Segment, roots: Roots, out: &mut Candidates) {
        let Roots { t0, t1, real } = roots;
        if !real {
            return;
        }
        let (o, d) = (seg.o, seg.d);
        let (k0, k1) = (seg.keeps(t0), seg.keeps(t1));
        if (k0 || k1) && !seg.is_touch(t0, t1) {
            if k0 {
                out.push(candidate(t0, o + d * t0 - self.center));
            }
            if k1 {
                out.push(candidate(t1, o + d * t1 - self.center));
            }
        }
    }

    /// The crossings of the segment, onto `out`.
    #[inline(always)]
    pub(super) fn intersect(&self, seg: &Segment, out: &mut Candidates) {
        self.push_crossings(seg, self.roots(seg), out);
    }

    /// [`Self::intersect`] for the lanes of a callback, side by side.
    #[inline(always)]
    pub(super) fn intersect_lanes(&self, rays: &[LaneRay], out: &mut [Candidates]) {
        side_by_side(
            rays,
            out,
            |seg| self.roots(seg),
            |seg, roots, out| self.push_crossings(seg, roots, out),
        );
    }

    /// Embree's bounds.
    pub(super) fn bounds(&self) -> Bounds {
        pad(
            self.center - DVec3::splat(self.radius),
            self.center + DVec3::splat(self.radius),
        )
    }

    /// The unit outward normal at `p`.
    #[inline(always)]
    pub(super) fn normal(&self, p: DVec3) -> DVec3 {
        normalize_or_f64(p - self.center, DVec3::Y)
    }

    /// `p` moved radially onto the surface.
    #[inline(always)]
    pub(super) fn project(&self, p: DVec3) -> DVec3 {
        let q = p - self.center;
        let l = q.length();
        if l > 0.0 {
            self.center + q * (self.radius / l)
        } else {
            p
        }
    }

    /// Longitude and latitude around y, in [0, 1]².
    pub(super) fn uv(&self, p: DVec3) -> [f32; 2] {
        let q = (p - self.center) / self.radius;
        let u = 0.5 + q.x.atan2(q.z) / std::f64::consts::TAU;
        let v = q.y.clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
        [u as f32, v as f32]
    }

    /// Is `p` strictly inside the ball?
    #[inline]
    pub(super) fn contains(&self, p: DVec3) -> bool {
        (p - self.center).length_squared() < self.radius * self.radius
    }

    /// Is the surface within `tol` of `p`?
    #[inline]
    pub(super) fn surface_near(&self, p: DVec3, tol: f64) -> bool {
        ((p - self.center).length() - self.radius).abs() <= tol
    }

    /// May the surface come within `tol` of some point of the box `bx`? Not
    /// when the box lies wholly inside the ball (its farthest corner nearer
    /// than r − tol) or wholly outside it (its nearest point farther than
    /// r + tol).
    pub(super) fn surface_may_come_within_box(&self, bx: Box3, tol: f64) -> bool {
        let (c, r) = (self.center, self.radius);
        let far = (bx.0 - c).abs().max((bx.1 - c).abs()).length();
        let near = (c.clamp(bx.0, bx.1) - c).length();
        !(far < r - tol || near > r + tol)
    }

    /// May the surfaces of two spheres come within `tol` of each other? They
    /// meet iff |ra − rb| <= |ca − cb| <= ra + rb.
    pub(super) fn surface_may_come_within_sphere(&self, other: &Sphere, tol: f64) -> bool {
        let (ra, rb) = (self.radius, other.radius);
        let d = (self.center - other.center).length();
        (ra - rb).abs() - tol <= d && d <= ra + rb + tol
    }

    /// The box `b` cut down to the bounds of its part inside the ball
    /// widened by `tol` (which holds every point within `tol` of the
    /// surface); `None` when they do not meet.
    pub(super) fn clip_to_ball(&self, tol: f64, b: Box3) -> Option<Box3> {
        let (c, r) = (self.center, self.radius + tol);
        // Per axis, the distance from `c` to the box's extent (0 inside).
        let gap = (b.0 - c).max(c - b.1).max(DVec3::ZERO);
        let (mut lo, mut hi) = b;
        for k in 0..3 {
            let rest = gap.length_squared() - gap[k] * gap[k];
            if rest > r * r {
                return None;
            }
            let e = (r * r - rest).sqrt();
            lo[k] = lo[k].max(c[k] - e);
            hi[k] = hi[k].min(c[k] + e);
        }
        lo.cmple(hi).all().then_some((lo, hi))
    }

    /// The box `b` cut down to the band of this sphere (`cg`, `rg`) whose
    /// points lie within `tol` of the sphere `other` (`cs`, `rs`): along the
    /// axis a from `cg` to `cs` (d apart), a point x of the first sphere has
    /// |x − cs|² = rg² + d² − 2d·h with h = (x − cg)·a, so the band is a range
    /// of h, and x = cg + h·a + w with w ⊥ a, |w|² = rg² − h². `None` when
    /// the band misses the box.
    pub(super) fn clip_to_band(&self, other: &Sphere, tol: f64, b: Box3) -> Option<Box3> {
        let (cg, rg, cs, rs) = (self.center, self.radius, other.center, other.radius);
        let d = (cs - cg).length();
        if d <= tol {
            return Some(b); // (nearly) concentric: the band is all or nothing
        }
        let a = (cs - cg) / d;
        let h_of = |q: f64| (rg * rg + d * d - q * q) / (2.0 * d);
        let h0 = h_of(rs + tol).max(-rg);
        let h1 = h_of((rs - tol).max(0.0)).min(rg);
        if h0 > h1 {
            return None;
        }
        let hmin2 = if h0 <= 0.0 && h1 >= 0.0 {
            0.0
        } else {
            (h0 * h0).min(h1 * h1)
        };
        let w = (rg * rg - hmin2).max(0.0).sqrt();
        let (mut lo, mut hi) = b;
        for k in 0..3 {
            let spread = w * (1.0 - a[k] * a[k]).max(0.0).sqrt();
            lo[k] = lo[k].max(cg[k] + (h0 * a[k]).min(h1 * a[k]) - spread);
            hi[k] = hi[k].min(cg[k] + (h0 * a[k]).max(h1 * a[k]) + spread);
        }
        lo.cmple(hi).all().then_some((lo, hi))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn whole(o: DVec3, d: DVec3) -> Segment {
        Segment {
            o,
            d,
            tn: f32::NEG_INFINITY,
            tf: f32::INFINITY,
        }
    }

    #[test]
    fn sphere_crossings_are_analytic_even_far_away() {
        let s = Sphere {
            center: DVec3::new(0.0, 0.0, -1e4),
            radius: 1.0,
        };
        let Roots { t0, t1, real } = s.roots(&whole(DVec3::ZERO, DVec3::new(0.0, 0.0, -1.0)));
        assert!(real);
        assert!((t0 - (1e4 - 1.0)).abs() < 1e-9 && (t1 - (1e4 + 1.0)).abs() < 1e-9);
    }

    /// Random spheres and boxes around them; a point on the surface (a dense
    /// spiral) within `tol` of the box (or of the other sphere's surface,
    /// for a band) makes each test keep it: the box tests never rule out a
    /// near surface, the clipped boxes hold every near point. Their power:
    /// each rules out a good share of the cases.
    #[test]
    fn box_and_band_tests_keep_every_near_point_and_rule_out_others() {
        let mut rng = crate::sampling::Rng::new(17);
        let mut u = |lo: f64, hi: f64| lo + (hi - lo) * rng.uniform_f64();
        let n = 4000;
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        let spiral: Vec<DVec3> = (0..n)
            .map(|i| {
                let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
                let r = (1.0 - y * y).sqrt();
                let phi = golden * i as f64;
                DVec3::new(r * phi.cos(), y, r * phi.sin())
            })
            .collect();
        let within = |p: DVec3, b: Box3, tol: f64| (p - b.0 + tol).min(b.1 + tol - p).min_element() >= 0.0;
        let (mut box_out, mut ball_out, mut band_out, mut sphere_out) = (0, 0, 0, 0);
        for _ in 0..400 {
            let s = Sphere {
                center: DVec3::new(u(-1.0, 1.0), u(-1.0, 1.0), u(-1.0, 1.0)),
                radius: u(0.2, 1.5),
            };
            let o = Sphere {
                center: s.center + DVec3::new(u(-2.0, 2.0), u(-2.0, 2.0), u(-2.0, 2.0)),
                radius: u(0.2, 1.5),
            };
            let tol = u(1e-3, 0.1);
            let c = DVec3::new(u(-2.5, 2.5), u(-2.5, 2.5), u(-2.5, 2.5));
            let e = DVec3::new(u(0.01, 1.5), u(0.01, 1.5), u(0.01, 1.5));
            let b = (c - e, c + e);
            let on: Vec<DVec3> = spiral.iter().map(|&x| s.center + x * s.radius).collect();
            let may_box = s.surface_may_come_within_box(b, tol);
            let ball = s.clip_to_ball(tol, b);
            let band = s.clip_to_band(&o, tol, b);
            let may_sphere = s.surface_may_come_within_sphere(&o, tol);
            box_out += !may_box as u32;
            ball_out += ball.is_none() as u32;
            band_out += band.is_none() as u32;
            sphere_out += !may_sphere as u32;
            for &p in &on {
                if (p - p.clamp(b.0, b.1)).length() <= tol {
                    assert!(may_box, "{s:?} {b:?} {tol}: {p} is near the box");
                }
                if within(p, b, 0.0) {
                    let clipped = ball.expect("a surface point in the box is in the ball");
                    assert!(within(p, clipped, 1e-12), "{p} not in {clipped:?}");
                }
                let near_other = ((p - o.center).length() - o.radius).abs() <= tol;
                if near_other {
                    assert!(may_sphere, "{s:?} {o:?} {tol}: {p} near both");
                    if within(p, b, 0.0) {
                        let clipped = band.expect("a point of the band in the box");
                        assert!(within(p, clipped, 1e-9), "{p} not in the band's {clipped:?}");
                    }
                }
            }
            // Points inside the ball, within the box: in the clipped box.
            for &x in spiral.iter().step_by(37) {
                let p = s.center + x * (s.radius + tol) * u(0.0, 1.0);
                if within(p, b, 0.0) {
                    assert!(within(p, ball.expect("the box meets the ball"), 1e-12));
                }
            }
        }
        for (name, out) in [
            ("box", box_out),
            ("ball", ball_out),
            ("band", band_out),
            ("sphere", sphere_out),
        ] {
            assert!(out > 20, "the {name} test rules out only {out} of 400 cases");
        }
    }
}
