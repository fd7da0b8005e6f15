//! Primary rays: a pixel's ray, one cast, the film's rows in parallel, and
//! the f32/f64 conversions between the meshes and the solvers.
use super::frame::Shown;
use crate::embree::{Ray, Scene};
use crate::scene::RenderScene;
use glam::{DVec3, Vec3A as V3};
use rayon::prelude::*;

pub(crate) fn d3(p: [f32; 3]) -> DVec3 {
    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
}

/// The primary ray through the centre of pixel (`x`, `y`): origin and unit
/// direction. Inlined: returned through memory from a call, the ray's 48
/// bytes would be read back right after being written (a store-forwarding
/// stall).
#[inline]
pub(crate) fn pixel_ray(scene: &RenderScene, x: u32, y: u32) -> (DVec3, DVec3) {
    let (o, d) = scene.camera.ray(x as f32 + 0.5, y as f32 + 0.5, (0.0, 0.0));
    let o = DVec3::new(o.x as f64, o.y as f64, o.z as f64);
    let d = DVec3::new(d.x as f64, d.y as f64, d.z as f64).normalize();
    (o, d)
}

pub(crate) fn f3(v: DVec3) -> V3 {
    V3::new(v.x as f32, v.y as f32, v.z as f32)
}

pub(crate) fn cast(s: &Scene, o: DVec3, d: DVec3, tfar: f64) -> Option<crate::embree::Hit> {
    let ray = Ray {
        org: f3(o),
        dir: f3(d),
        tnear: 0.0,
        tfar: tfar.min(f32::MAX as f64) as f32,
    };
    s.intersect(&ray)
}

pub(crate) fn run_rows<F>(width: u32, height: u32, f: F) -> (Vec<V3>, Vec<Option<Shown>>)
where
    F: Fn(u32, u32) -> (V3, Option<Shown>) + Sync,
{
    let rows: Vec<Vec<(V3, Option<Shown>)>> = (0..height)
        .into_par_iter()
        .map(|y| (0..width).map(|x| f(x, y)).collect())
        .collect();
    rows.into_iter().flatten().unzip()
}
