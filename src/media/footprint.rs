//! Chord and integration tolerances bounded in the image: a fraction of the
//! pixel footprint at the distance from the eye, so distant chords grow long
//! while the error they leave stays below a fixed share of a pixel.
//!
//! A point of the ray off by δ at distance d from the eye moves what the pixel
//! sees by δ/d radians; a direction off by δθ moves every later point by δθ per
//! metre, so what it moves in the image is at most δθ. With a pixel subtending
//! α and a fraction f, positions are held to f·α·d and directions to f·α.
use glam::DVec3;

/// The eye, the angle one pixel subtends and the fraction of it allowed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Footprint {
    /// The eye (the camera's position), world metres.
    pub eye: DVec3,
    /// The angle one pixel subtends, radians.
    pub pixel_angle: f64,
    /// The fraction of a pixel a chord or an integration error may move.
    pub fraction: f64,
}

impl Footprint {
    /// The position tolerance at `p`, metres: f·α·|p − eye|, at least `floor`.
    #[inline]
    pub fn at(&self, p: DVec3, floor: f64) -> f64 {
        (self.fraction * self.pixel_angle * (p - self.eye).length()).max(floor)
    }

    /// The direction tolerance f·α, radians.
    #[inline]
    pub fn angle(&self) -> f64 {
        self.fraction * self.pixel_angle
    }
}

/// A chord tolerance in metres at each point: fixed, or a footprint's (with
/// a floor).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ChordTolerance {
    /// The same everywhere.
    Fixed(f64),
    /// [`Footprint::at`] with this floor.
    Footprint(Footprint, f64),
}

impl ChordTolerance {
    /// This tolerance times `k` (a footprint's fraction of a pixel, or the
    /// fixed metres).
    #[inline]
    pub fn scaled(self, k: f64) -> ChordTolerance {
        match self {
            ChordTolerance::Fixed(t) => ChordTolerance::Fixed(t * k),
            ChordTolerance::Footprint(f, floor) => ChordTolerance::Footprint(
                Footprint {
                    fraction: f.fraction * k,
                    ..f
                },
                floor,
            ),
        }
    }

    /// The tolerance at `p`, metres.
    #[inline]
    pub fn at(&self, p: DVec3) -> f64 {
        match self {
            ChordTolerance::Fixed(t) => *t,
            ChordTolerance::Footprint(f, floor) => f.at(p, *floor),
        }
    }

    /// The smaller of the tolerances at `a` and `b`, given `ta` = `at(a)`.
    /// A footprint's grows with the distance from the eye, so where `b` is no
    /// nearer than `a` it is `ta` without `b`'s square root (the same value:
    /// the root and the products round monotonically).
    #[inline]
    pub fn min_of(&self, a: DVec3, ta: f64, b: DVec3) -> f64 {
        match self {
            ChordTolerance::Fixed(t) => *t,
            ChordTolerance::Footprint(f, floor) => {
                if (b - f.eye).length_squared() >= (a - f.eye).length_squared() {
                    ta
                } else {
                    ta.min(f.at(b, *floor))
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `min_of` is the smaller of the two tolerances, bit for bit, with or
    /// without its shortcut; taking `ta` whatever the order (the shortcut
    /// without its test) is not.
    #[test]
    fn the_smaller_end_bit_for_bit() {
        let f = Footprint {
            eye: DVec3::new(0.3, 1.2, -0.5),
            pixel_angle: 1.1e-4,
            fraction: 0.1,
        };
        let tol = ChordTolerance::Footprint(f, 1e-6);
        let mut rng = crate::sampling::Rng::new(3);
        let mut u = || 2.0 * rng.uniform_f64() - 1.0;
        let mut nearer = 0;
        for i in 0..10_000 {
            let s = if i % 3 == 0 { 1e-4 } else { 300.0 };
            let a = f.eye + DVec3::new(u(), u(), u()) * s;
            let b = a + DVec3::new(u(), u(), u()) * s * 0.5;
            let ta = tol.at(a);
            let exact = ta.min(tol.at(b));
            assert_eq!(tol.min_of(a, ta, b).to_bits(), exact.to_bits(), "{a} {b}");
            nearer += usize::from(ta != exact);
        }
        assert!(nearer > 1_000, "{nearer}");
        assert_eq!(
            ChordTolerance::Fixed(0.5).min_of(DVec3::ZERO, 0.5, DVec3::ONE),
            0.5
        );
    }
}
