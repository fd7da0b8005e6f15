//! The analytic shapes as Embree user geometry: bounds and intersection per
//! primitive, one ray or the active lanes of a packet callback at a time.
use super::segment::{lane_by_lane, Segment};
use super::Analytic;
use crate::embree::{Bounds, Candidates, LaneRay, UserShape};
use glam::Vec3A as V3;

impl UserShape for Analytic {
    fn prim_count(&self) -> u32 {
        self.prims()
    }

    fn bounds(&self, prim: u32) -> Bounds {
        match self {
            Analytic::Sphere(s) => s.bounds(),
            Analytic::Cylinder(c) => c.bounds(prim),
            Analytic::Tube(t) => t.bounds(prim),
            Analytic::Disk(k) => k.bounds(),
            Analytic::Rect(r) => r.bounds(),
        }
    }

    fn intersect(&self, prim: u32, org: V3, dir: V3, out: &mut Candidates) {
        self.intersect_in(prim, org, dir, f32::NEG_INFINITY, f32::INFINITY, out);
    }

    #[inline]
    fn intersect_in(&self, prim: u32, org: V3, dir: V3, tn: f32, tf: f32, out: &mut Candidates) {
        let seg = Segment::new(org, dir, tn, tf);
        match self {
            Analytic::Sphere(s) => s.intersect(&seg, out),
            Analytic::Cylinder(c) => c.intersect(prim, &seg, out),
            Analytic::Tube(t) => t.intersect(prim, &seg, out),
            Analytic::Disk(k) => k.intersect(&seg, out),
            Analytic::Rect(r) => r.intersect(&seg, out),
        }
    }

    fn intersect_lanes(&self, prim: u32, rays: &[LaneRay], out: &mut [Candidates]) {
        match self {
            Analytic::Sphere(s) => s.intersect_lanes(rays, out),
            Analytic::Cylinder(c) => c.intersect_lanes(prim, rays, out),
            Analytic::Tube(t) => t.intersect_lanes(prim, rays, out),
            Analytic::Disk(k) => lane_by_lane(rays, out, |seg, out| k.intersect(seg, out)),
            Analytic::Rect(r) => lane_by_lane(rays, out, |seg, out| r.intersect(seg, out)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::{Cylinder, Sphere, Tube};
    use super::*;
    use crate::embree::Candidate;
    use glam::DVec3;

    /// `intersect_lanes` (lanes side by side) gives every lane what
    /// `intersect_in` gives it alone, bit for bit: spheres, cylinders and
    /// tubes about the y axis and a tilted one, rays aimed near them
    /// (grazing ones included), any ray interval, one to seven lanes.
    #[test]
    fn lanes_side_by_side_equal_lanes_alone() {
        let tilted = DVec3::new(1.0, 2.0, 0.5).normalize();
        let shapes = [
            Analytic::Sphere(Sphere {
                center: DVec3::new(0.3, 0.6, -0.2),
                radius: 0.6,
            }),
            Analytic::Cylinder(Cylinder {
                p0: DVec3::new(0.0, -1.0, 0.0),
                axis: DVec3::Y,
                height: 2.0,
                radius: 1.0,
                inward: true,
                caps: false,
            }),
            Analytic::Cylinder(Cylinder {
                p0: DVec3::new(0.1, -1.0, 0.2),
                axis: tilted,
                height: 2.0,
                radius: 0.7,
                inward: false,
                caps: true,
            }),
            Analytic::Tube(Tube {
                p0: DVec3::new(0.0, -1.0, 0.0),
                axis: DVec3::Y,
                height: 2.0,
                outer: 1.0,
                inner: 0.8,
            }),
            Analytic::Tube(Tube {
                p0: DVec3::new(0.0, -1.0, 0.0),
                axis: tilted,
                height: 2.0,
                outer: 1.0,
                inner: 0.8,
            }),
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
}
