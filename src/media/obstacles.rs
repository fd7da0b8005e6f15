//! The scene's geometry as axis-aligned boxes, for the stretches of a curved
//! ray that can meet nothing: there no chord needs casting (and a chord that
//! is cast anyway needs no query). Only a test against boxes; every box is
//! padded beyond Embree's f32 rounding so that "misses every box" implies
//! "Embree would report no hit".
use glam::DVec3;

use super::field::Aabb;

/// More boxes than this are not scanned per chord (a scene of many objects
/// would pay more for the scan than the queries it saves): every stretch then
/// counts as obstructed.
pub const MAX_BOXES: usize = 64;

/// Boxes around the geometry, padded.
#[derive(Debug, Clone, PartialEq)]
pub struct Obstacles {
    boxes: Vec<Aabb>,
    /// True when the boxes are not known (none given, too many, or one not
    /// finite): everything may be hit.
    unknown: bool,
}

/// The padding of a coordinate: far more than f32 rounding of scene
/// coordinates and of a ray's origin and direction (a relative 1e-6), plus a
/// micrometre.
fn pad(v: f64) -> f64 {
    1e-6 * (1.0 + v.abs())
}

impl Obstacles {
    /// Obstacles that say nothing: every stretch may meet geometry.
    pub fn unknown() -> Obstacles {
        Obstacles {
            boxes: Vec::new(),
            unknown: true,
        }
    }

    /// The boxes (min, max) of the scene's geometries, padded.
    pub fn new(boxes: impl IntoIterator<Item = Aabb>) -> Obstacles {
        let boxes: Vec<Aabb> = boxes
            .into_iter()
            .map(|b| {
                let lo = DVec3::new(
                    b.min.x - pad(b.min.x),
                    b.min.y - pad(b.min.y),
                    b.min.z - pad(b.min.z),
                );
                let hi = DVec3::new(
                    b.max.x + pad(b.max.x),
                    b.max.y + pad(b.max.y),
                    b.max.z + pad(b.max.z),
                );
                Aabb::new(lo, hi)
            })
            .collect();
        let unknown =
            boxes.len() > MAX_BOXES || boxes.iter().any(|b| !(b.min.is_finite() && b.max.is_finite()));
        Obstacles { boxes, unknown }
    }

    /// The boxes (padded), empty when unknown.
    pub fn boxes(&self) -> &[Aabb] {
        if self.unknown {
            &[]
        } else {
            &self.boxes
        }
    }

    /// True when the boxes are not known (every stretch may meet geometry).
    pub fn is_unknown(&self) -> bool {
        self.unknown
    }

    /// The boxes not inside `bounds` shrunk by `margin` on every side (all of
    /// them when unknown).
    pub fn not_inside(&self, bounds: &Aabb, margin: f64) -> Obstacles {
        let (lo, hi) = (bounds.min + margin, bounds.max - margin);
        Obstacles {
            boxes: self
                .boxes
                .iter()
                .filter(|b| !(b.min.cmpgt(lo).all() && b.max.cmplt(hi).all()))
                .copied()
                .collect(),
            unknown: self.unknown,
        }
    }

    /// Does the straight segment from `o` along unit `d` for `len` (may be
    /// infinite) meet a box?
    pub fn segment_meets(&self, o: DVec3, d: DVec3, len: f64) -> bool {
        if self.unknown {
            return true;
        }
        // A box wholly behind the start along an axis the segment moves on
        // is never met: no division for it (rays leaving the bounds upward
        // pass over the ground's box this way).
        let ahead =
            |b: &&Aabb| !(0..3).any(|k| (d[k] > 0.0 && b.max[k] < o[k]) || (d[k] < 0.0 && b.min[k] > o[k]));
        let mut ahead = self.boxes.iter().filter(ahead).peekable();
        if ahead.peek().is_none() {
            return false;
        }
        // Slabs with the inverse direction (±inf on a zero component: the
        // products then give ±inf or NaN, and NaN never narrows the interval).
        let inv = d.recip();
        ahead.any(|b| {
            let t1 = (b.min - o) * inv;
            let t2 = (b.max - o) * inv;
            let lo = t1.min(t2);
            let hi = t1.max(t2);
            let enter = lo.x.max(lo.y).max(lo.z).max(0.0);
            let leave = hi.x.min(hi.y).min(hi.z).min(len);
            enter <= leave
        })
    }

    /// Euclidean distance from `p` to the nearest box that meets `within`
    /// (0 when unknown or inside one, infinite without any).
    pub fn distance(&self, p: DVec3, within: &Aabb) -> f64 {
        if self.unknown {
            return 0.0;
        }
        self.boxes
            .iter()
            .filter(|b| b.min.cmple(within.max).all() && b.max.cmpge(within.min).all())
            .map(|b| (b.min - p).max(p - b.max).max(DVec3::ZERO).length())
            .fold(f64::INFINITY, f64::min)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_and_distances_against_padded_boxes() {
        let o = Obstacles::new([Aabb::new(DVec3::ZERO, DVec3::ONE)]);
        assert!(o.segment_meets(DVec3::new(-1.0, 0.5, 0.5), DVec3::X, 1.0));
        assert!(!o.segment_meets(DVec3::new(-1.0, 0.5, 0.5), DVec3::X, 0.999));
        assert!(o.segment_meets(DVec3::new(-1.0, 0.5, 0.5), DVec3::X, f64::INFINITY));
        assert!(!o.segment_meets(DVec3::new(-1.0, 1.01, 0.5), DVec3::X, f64::INFINITY));
        assert!(!o.segment_meets(DVec3::new(2.0, 0.5, 0.5), DVec3::X, f64::INFINITY));
        let all = Aabb::new(DVec3::splat(-10.0), DVec3::splat(10.0));
        assert!((o.distance(DVec3::new(3.0, 4.5, 0.5), &all) - (4.0f64 + 3.5 * 3.5).sqrt()).abs() < 1e-5);
        assert_eq!(o.distance(DVec3::splat(0.5), &all), 0.0);
        let far = Aabb::new(DVec3::splat(5.0), DVec3::splat(6.0));
        assert_eq!(o.distance(DVec3::splat(5.5), &far), f64::INFINITY);
        let bad = Obstacles::new([Aabb::new(DVec3::ZERO, DVec3::splat(f64::INFINITY))]);
        assert!(bad.is_unknown() && bad.segment_meets(DVec3::splat(9.0), DVec3::X, 1.0));
    }

    /// The slab test alone (no cull of boxes behind), as `segment_meets`
    /// was: the reference its cull must agree with.
    fn slabs_only(o: &Obstacles, p: DVec3, d: DVec3, len: f64) -> bool {
        let inv = d.recip();
        o.boxes.iter().any(|b| {
            let (t1, t2) = ((b.min - p) * inv, (b.max - p) * inv);
            let (lo, hi) = (t1.min(t2), t1.max(t2));
            lo.x.max(lo.y).max(lo.z).max(0.0) <= hi.x.min(hi.y).min(hi.z).min(len)
        })
    }

    #[test]
    fn culling_boxes_behind_changes_no_answer() {
        let boxes = [
            Aabb::new(DVec3::new(-3.0, -0.1, -3.0), DVec3::new(3.0, 0.0, 3.0)),
            Aabb::new(DVec3::new(1.0, 0.0, -2.0), DVec3::new(2.0, 1.0, -1.0)),
            Aabb::new(DVec3::new(-0.5, 2.0, 0.5), DVec3::new(0.5, 2.5, 1.0)),
        ];
        let o = Obstacles::new(boxes);
        let mut rng = crate::sampling::Rng::new(7);
        let mut u = || 2.0 * rng.uniform_f64() - 1.0;
        let (mut met, mut same) = (0, 0);
        // A cull that also drops boxes the segment starts beside (a wrong
        // comparison) must disagree somewhere.
        let wrong = |p: DVec3, d: DVec3, len: f64| {
            let ahead: Vec<Aabb> = o
                .boxes
                .iter()
                .filter(|b| {
                    !(0..3).any(|k| {
                        (d[k] > 0.0 && b.max[k] <= p[k] + 0.5) || (d[k] < 0.0 && b.min[k] >= p[k] - 0.5)
                    })
                })
                .copied()
                .collect();
            slabs_only(
                &Obstacles {
                    boxes: ahead,
                    unknown: false,
                },
                p,
                d,
                len,
            )
        };
        let mut wrong_differs = 0;
        for i in 0..20_000 {
            let p = DVec3::new(4.0 * u(), 3.0 * u(), 4.0 * u());
            let mut d = DVec3::new(u(), u(), u());
            if i % 5 == 0 {
                d[i % 3] = 0.0;
            }
            let d = d.normalize_or(DVec3::Z);
            let len = if i % 2 == 0 {
                f64::INFINITY
            } else {
                3.0 * u().abs()
            };
            let fast = o.segment_meets(p, d, len);
            same += usize::from(fast == slabs_only(&o, p, d, len));
            met += usize::from(fast);
            wrong_differs += usize::from(wrong(p, d, len) != fast);
        }
        assert_eq!(same, 20_000);
        assert!(met > 2_000 && met < 18_000, "{met}");
        assert!(wrong_differs > 100, "{wrong_differs}");
    }

    #[test]
    fn boxes_well_inside_are_left_out_of_those_outside() {
        let bounds = Aabb::new(DVec3::splat(-10.0), DVec3::splat(10.0));
        let inside = Aabb::new(DVec3::splat(-1.0), DVec3::splat(1.0));
        let near_face = Aabb::new(DVec3::new(-1.0, -1.0, 9.95), DVec3::new(1.0, 1.0, 9.99));
        let across = Aabb::new(DVec3::new(-20.0, -1.0, -1.0), DVec3::new(20.0, 1.0, 1.0));
        let o = Obstacles::new([inside, near_face, across]).not_inside(&bounds, 0.1);
        assert_eq!(o.boxes().len(), 2);
        assert!(o.boxes().iter().all(|b| b.max.z > 9.0 || b.max.x > 10.0));
        assert!(Obstacles::unknown().not_inside(&bounds, 0.1).is_unknown());
    }
}
