//! An axis-aligned box: containment, the slab test, the distance out.
use glam::DVec3;
use serde::{Deserialize, Serialize};

/// An axis-aligned box (world metres).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Aabb {
    /// The corner with the smallest coordinates.
    pub min: DVec3,
    /// The corner with the largest coordinates.
    pub max: DVec3,
}

impl Aabb {
    /// The box from `min` to `max` (not checked: a validated box has min < max).
    pub fn new(min: DVec3, max: DVec3) -> Aabb {
        Aabb { min, max }
    }

    /// Length of the diagonal, metres.
    pub fn diagonal(&self) -> f64 {
        (self.max - self.min).length()
    }

    /// Closed containment test.
    pub fn contains(&self, p: DVec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// The 8 corners.
    pub fn corners(&self) -> [DVec3; 8] {
        let (a, b) = (self.min, self.max);
        [
            DVec3::new(a.x, a.y, a.z),
            DVec3::new(b.x, a.y, a.z),
            DVec3::new(a.x, b.y, a.z),
            DVec3::new(b.x, b.y, a.z),
            DVec3::new(a.x, a.y, b.z),
            DVec3::new(b.x, a.y, b.z),
            DVec3::new(a.x, b.y, b.z),
            DVec3::new(b.x, b.y, b.z),
        ]
    }

    /// Does the line `p + t d` leave the box by `t = tol` through a face it
    /// moves out of (so that, the box being convex, it is outside from there
    /// on)? The slab test's `t1 <= tol` without its divisions, for a ray just
    /// come out through a face.
    pub fn leaves_within(&self, p: DVec3, d: DVec3, tol: f64) -> bool {
        (0..3).any(|k| {
            (d[k] > 0.0 && self.max[k] - p[k] <= tol * d[k])
                || (d[k] < 0.0 && self.min[k] - p[k] >= tol * d[k])
        })
    }

    /// How far the line `p + t d` runs on inside the box from `p`: the slab
    /// test's t1 clamped at 0 (0 when the line misses), the value of
    /// `clip(p, d).map_or(0.0, |(_, t1)| t1.max(0.0))`. From a point inside
    /// the box only the three faces it moves towards are divided by: the
    /// other quotients are ≤ 0 and could not empty the interval. A flight
    /// asks this at every step.
    pub fn exit_distance(&self, p: DVec3, d: DVec3) -> f64 {
        if !self.contains(p) {
            return self.clip(p, d).map_or(0.0, |(_, t1)| t1.max(0.0));
        }
        let far = DVec3::select(d.cmpgt(DVec3::ZERO), self.max, self.min);
        let q = (far - p) / d;
        let mut t1 = f64::INFINITY;
        for k in 0..3 {
            if d[k] != 0.0 {
                t1 = t1.min(q[k]);
            }
        }
        t1.max(0.0)
    }

    /// Slab test: the parameter interval `[t0, t1]` (possibly with t0 < 0) where the
    /// line `p + t d` is inside the box, or None when it misses.
    pub fn clip(&self, p: DVec3, d: DVec3) -> Option<(f64, f64)> {
        // The six quotients as whole-vector divisions (the same values): the
        // divider's throughput, not the instruction count, bounds this test.
        let (qa, qb) = ((self.min - p) / d, (self.max - p) / d);
        let mut t0 = f64::NEG_INFINITY;
        let mut t1 = f64::INFINITY;
        for k in 0..3 {
            let (o, dir, lo, hi) = (p[k], d[k], self.min[k], self.max[k]);
            if dir == 0.0 {
                if o < lo || o > hi {
                    return None;
                }
            } else {
                let (a, b) = (qa[k], qb[k]);
                let (a, b) = if a < b { (a, b) } else { (b, a) };
                t0 = t0.max(a);
                t1 = t1.min(b);
            }
        }
        (t0 <= t1).then_some((t0, t1))
    }
}

#[cfg(test)]
mod exit_distance_tests {
    use super::Aabb;
    use crate::sampling::Rng;
    use glam::DVec3;

    /// `exit_distance` is the slab test's clamped t1 bit for bit, from
    /// inside, on the faces and outside, with axis-parallel directions; the
    /// near faces' quotient in its place (a known-wrong variant) is not.
    #[test]
    fn exit_distance_is_the_slab_tests_far_end() {
        let b = Aabb {
            min: DVec3::new(-0.9, 0.25, -0.9),
            max: DVec3::new(0.9, 3.2, 0.9),
        };
        let mut rng = Rng::for_sample(11, 0, 0);
        let mut u = || rng.uniform_f64();
        let (mut differ_wrong, mut n) = (0, 0);
        for i in 0..200_000 {
            let mut p = DVec3::new(3.0 * u() - 1.5, 4.0 * u() - 0.5, 3.0 * u() - 1.5);
            if i % 7 == 0 {
                // On a face.
                p.x = if u() < 0.5 { b.min.x } else { b.max.x };
            }
            let mut d = DVec3::new(u() - 0.5, u() - 0.5, u() - 0.5).normalize();
            if i % 11 == 0 {
                d = [DVec3::X, DVec3::NEG_Y, DVec3::Z][i % 3];
            }
            let want = b.clip(p, d).map_or(0.0, |(_, t1)| t1.max(0.0));
            let got = b.exit_distance(p, d);
            assert_eq!(got.to_bits(), want.to_bits(), "p {p:?} d {d:?}");
            if b.contains(p) {
                n += 1;
                let near = DVec3::select(d.cmpgt(DVec3::ZERO), b.min, b.max);
                let q = (near - p) / d;
                let wrong = (0..3)
                    .filter(|&k| d[k] != 0.0)
                    .map(|k| q[k])
                    .fold(f64::INFINITY, f64::min)
                    .max(0.0);
                differ_wrong += usize::from(wrong.to_bits() != want.to_bits());
            }
        }
        assert!(n > 10_000 && differ_wrong > n / 2, "{differ_wrong} of {n}");
    }
}
