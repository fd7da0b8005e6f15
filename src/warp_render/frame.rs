//! A primary-ray image and what each of its pixels shows.
use crate::scene::RenderScene;
use glam::{DVec3, Vec3A as V3};
use std::time::Instant;

/// What a pixel shows: the surface point on the unwarped mesh.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Shown {
    /// Index into `Prepared::objects`.
    pub object: u32,
    /// The point on the unwarped mesh (world space).
    pub point: DVec3,
    /// Length of the (possibly refracted) path from the eye to the point.
    pub path_length: f64,
}

/// A primary-ray image.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// Linear RGB, row-major, row 0 at the top.
    pub pixels: Vec<V3>,
    /// What each pixel shows (`None`: the environment).
    pub shown: Vec<Option<Shown>>,
    /// Seconds spent on the primary rays and shading.
    pub render_s: f64,
}

impl Frame {
    /// The frame of `scene`'s film rendered into `pixels` and `shown`, timed
    /// from `t0`.
    pub(crate) fn finished(
        scene: &RenderScene,
        pixels: Vec<V3>,
        shown: Vec<Option<Shown>>,
        t0: Instant,
    ) -> Frame {
        Frame {
            width: scene.width,
            height: scene.height,
            pixels,
            shown,
            render_s: t0.elapsed().as_secs_f64(),
        }
    }
}
