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
