//! The one-shot warp renderer: copies built for one frame as Embree
//! scenes, one single ray per pixel. Slower than the pipeline; kept as the
//! reference the pipeline is tested against (the same pixels).
use super::frame::{Frame, Shown};
use super::prepare::Prepared;
use super::rays::{cast, d3, pixel_ray, run_rows};
use super::shade::shade;
use super::vertex_images::{VertexImages, VertexSolver};
use crate::embree::{BuildQuality, Scene, SceneBuilder, SceneFlags};
use crate::error::{Error, Result};
use crate::scene::RenderScene;
use crate::warp::{CopyKey, WarpGlass, WarpSpec};
use glam::{DVec3, Vec3A as V3};
use rayon::prelude::*;
use std::time::Instant;

/// One warped copy: an Embree scene and, per triangle, its source.
pub struct WarpedCopy {
    /// Which copy.
    pub key: CopyKey,
    /// Its Embree scene.
    pub scene: Scene,
    /// (object index in `Prepared::objects`, triangle index in its mesh).
    pub source: Vec<(u32, u32)>,
}

/// All warped copies of a scene, with timings.
pub struct Warped {
    /// The copies.
    pub copies: Vec<WarpedCopy>,
    /// Seconds spent moving vertices.
    pub warp_s: f64,
    /// Seconds spent building the copies' BVHs.
    pub build_s: f64,
    /// Vertex images found.
    pub images: usize,
    /// Triangles whose vertices have no image copy in common (in different
    /// families, or some without an image); the tube's direct copy holds
    /// every triangle all the same (`pipeline::Pipeline::new`).
    pub dropped_triangles: usize,
}

/// Warp every vertex (in parallel) and build the copies.
pub fn warp_scene(scene: &RenderScene, spec: &WarpSpec, prep: &Prepared) -> Result<Warped> {
    // As in `prepare`: the warp needs one eye.
    if scene.camera.orthographic_view().is_some() {
        return Err(Error::Invalid(
            "the warp renderer needs a perspective camera".into(),
        ));
    }
    let eye = DVec3::from(scene.camera.position.to_array().map(|x| x as f64));
    let t0 = Instant::now();
    let all: Vec<DVec3> = prep
        .objects
        .iter()
        .flat_map(|o| o.mesh.positions.iter().map(|p| d3(*p)))
        .collect();
    let solver = VertexSolver::new(spec.glass, spec.method, eye, &all);
    let per_object: Vec<Vec<VertexImages>> = prep
        .objects
        .iter()
        .map(|o| {
            o.mesh
                .positions
                .par_iter()
                .with_min_len(256)
                .map(|p| solver.images(d3(*p)))
                .collect()
        })
        .collect();
    let warp_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let images = per_object.iter().flatten().map(|v| v.len()).sum();
    // One copy per key, built in parallel (each is its own Embree scene).
    let built: Vec<Option<Result<WarpedCopy>>> = spec
        .glass
        .copy_keys()
        .into_par_iter()
        .map(|key| {
            let mut positions: Vec<[f32; 3]> = Vec::with_capacity(prep.vertices);
            let mut indices: Vec<[u32; 3]> = Vec::new();
            let mut source = Vec::new();
            // The tube's direct copy is the unwarped scene, every triangle
            // (its query stops at the tube: see `pipeline::Pipeline::new`).
            let unwarped = key == CopyKey::DIRECT && matches!(spec.glass, WarpGlass::Cylinder(_));
            for (oi, o) in prep.objects.iter().enumerate() {
                let base = positions.len() as u32;
                let imgs = &per_object[oi];
                if unwarped {
                    positions.extend_from_slice(&o.mesh.positions);
                } else {
                    positions.extend(imgs.iter().map(|vi| vi.get(key).unwrap_or([0.0; 3])));
                }
                let has = |v: u32| unwarped || imgs[v as usize].get(key).is_some();
                for (ti, tri) in o.mesh.indices.iter().enumerate() {
                    if tri.iter().all(|&v| has(v)) {
                        indices.push(tri.map(|v| v + base));
                        source.push((oi as u32, ti as u32));
                    }
                }
            }
            if indices.is_empty() {
                return None;
            }
            Some((|| {
                // Rebuilt every frame (the eye moves): Embree's fast (Morton) builder.
                let mut b =
                    SceneBuilder::new(scene.embree.device(), SceneFlags::default(), BuildQuality::Low)?;
                b.add_triangles(&positions, &indices)?;
                Ok(WarpedCopy {
                    key,
                    scene: b.commit()?,
                    source,
                })
            })())
        })
        .collect();
    let mut copies = Vec::new();
    for c in built.into_iter().flatten() {
        copies.push(c?);
    }
    // Triangles in no copy: no key common to all three vertices.
    let dropped_triangles = prep
        .objects
        .par_iter()
        .enumerate()
        .map(|(oi, o)| {
            let imgs = &per_object[oi];
            o.mesh
                .indices
                .iter()
                .filter(|tri| {
                    let a = &imgs[tri[0] as usize];
                    !a.items().iter().any(|(k, _)| {
                        imgs[tri[1] as usize].get(*k).is_some() && imgs[tri[2] as usize].get(*k).is_some()
                    })
                })
                .count()
        })
        .sum();
    Ok(Warped {
        copies,
        warp_s,
        build_s: t1.elapsed().as_secs_f64(),
        images,
        dropped_triangles,
    })
}

/// Render the warped copies with straight primary rays.
pub fn render_warped(scene: &RenderScene, spec: &WarpSpec, prep: &Prepared, warped: &Warped) -> Frame {
    let t0 = Instant::now();
    let direct = warped.copies.iter().find(|c| c.key == CopyKey::DIRECT);
    let (pixels, shown) = run_rows(scene.width, scene.height, |x, y| {
        let (o, d) = pixel_ray(scene, x, y);
        let class = spec.glass.classify(o, d);
        let mut best: Option<(f32, &WarpedCopy, crate::embree::Hit)> = None;
        if let Some(dc) = direct {
            if let Some(h) = cast(&dc.scene, o, d, class.t_enter) {
                best = Some((h.t, dc, h));
            }
        }
        for key in &class.copies {
            if let Some(c) = warped.copies.iter().find(|c| c.key == *key) {
                if let Some(h) = cast(&c.scene, o, d, f64::INFINITY) {
                    if best.as_ref().is_none_or(|b| h.t < b.0) {
                        best = Some((h.t, c, h));
                    }
                }
            }
        }
        match best {
            None => (V3::ZERO, None),
            Some((_, c, h)) => {
                let (obj, tri) = c.source[h.prim_id as usize];
                let weight = if spec.fresnel && c.key != CopyKey::DIRECT {
                    spec.glass.exact_path(o, d).transmittance
                } else {
                    1.0
                };
                let (col, p) = shade(scene, prep, obj, tri, h.u, h.v, weight);
                (
                    col,
                    Some(Shown {
                        object: obj,
                        point: p,
                        path_length: (p - o).length(),
                    }),
                )
            }
        }
    });
    Frame::finished(scene, pixels, shown, t0)
}
