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
