//! The exact trace the warp is judged against: each primary ray follows
//! the glass exactly (`exact_path`: refraction, TIR where it happens, no
//! reflection branches), and each straight piece is cast against the
//! unwarped meshes; by single rays and in the packet renderer's tiles.
use super::frame::{Frame, Shown};
use super::prepare::Prepared;
use super::rays::{cast, f3, pixel_ray, run_rows};
use super::shade::shade;
use super::tiles::{Tile, LANES, TILE_H, TILE_W};
use crate::embree::Packet16;
use crate::embree::{BuildQuality, Scene, SceneBuilder, SceneFlags};
use crate::error::Result;
use crate::scene::RenderScene;
use crate::warp::WarpSpec;
use glam::Vec3A as V3;
use rayon::prelude::*;
use std::time::Instant;

/// The unwarped meshes as one Embree scene (for the exact trace).
pub struct Originals {
    /// Their Embree scene.
    pub scene: Scene,
    /// Per triangle: (object index, triangle index).
    pub source: Vec<(u32, u32)>,
    /// Seconds building it.
    pub build_s: f64,
}

/// The unwarped meshes of `prep` as one Embree scene, for the exact trace.
///
/// # Errors
/// An Embree error while building.
pub fn build_originals(scene: &RenderScene, prep: &Prepared) -> Result<Originals> {
    let t0 = Instant::now();
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    let mut source = Vec::new();
    for (oi, o) in prep.objects.iter().enumerate() {
        let base = positions.len() as u32;
        positions.extend_from_slice(&o.mesh.positions);
        for (ti, t) in o.mesh.indices.iter().enumerate() {
            indices.push(t.map(|v| v + base));
            source.push((oi as u32, ti as u32));
        }
    }
    let mut b = SceneBuilder::new(scene.embree.device(), SceneFlags::default(), BuildQuality::Medium)?;
    if !indices.is_empty() {
        b.add_triangles(&positions, &indices)?;
    }
    Ok(Originals {
        scene: b.commit()?,
        source,
        build_s: t0.elapsed().as_secs_f64(),
    })
}

/// The exact trace: each primary ray follows the glass exactly.
pub fn render_exact(scene: &RenderScene, spec: &WarpSpec, prep: &Prepared, orig: &Originals) -> Frame {
    let t0 = Instant::now();
    let (pixels, shown) = run_rows(scene.width, scene.height, |x, y| {
        let (o, d) = pixel_ray(scene, x, y);
        let path = spec.glass.exact_path(o, d);
        let mut travelled = 0.0;
        for (i, s) in path.segments.iter().enumerate() {
            if let Some(h) = cast(&orig.scene, s.origin, s.dir, s.t_end) {
                let (obj, tri) = orig.source[h.prim_id as usize];
                let weight = if spec.fresnel && i > 0 {
                    path.transmittance
                } else {
                    1.0
                };
                let (col, p) = shade(scene, prep, obj, tri, h.u, h.v, weight);
                return (
                    col,
                    Some(Shown {
                        object: obj,
                        point: p,
                        path_length: travelled + (p - s.origin).length(),
                    }),
                );
            }
            travelled += s.t_end;
        }
        (V3::ZERO, None)
    });
    Frame::finished(scene, pixels, shown, t0)
}

/// The exact trace with the same packets: each pixel's exact path through
/// the glass (analytic, per lane), its straight pieces cast sixteen at a time
/// against the unwarped meshes (piece k of every lane still looking). The
/// same image as `render_exact` (tested); the fair reference for the
/// packet renderer's speed.
pub fn render_exact_packets(
    scene: &RenderScene,
    spec: &WarpSpec,
    prep: &Prepared,
    orig: &Originals,
) -> Frame {
    let t0 = Instant::now();
    let (w, h) = (scene.width as usize, scene.height as usize);
    let mut pixels = vec![V3::ZERO; w * h];
    let mut shown: Vec<Option<Shown>> = vec![None; w * h];
    pixels
        .par_chunks_mut(w * TILE_H)
        .zip(shown.par_chunks_mut(w * TILE_H))
        .enumerate()
        .for_each(|(ty, (prow, srow))| {
            let rows = prow.len() / w;
            let mut packet = Packet16::new();
            for x0 in (0..w).step_by(TILE_W) {
                let tile = Tile::new(x0, ty, rows, w);
                let lane_px = |l: usize| tile.lane(l).map(|(i, _, _)| i);
                let paths: Vec<Option<crate::warp::ExactPath>> = (0..LANES)
                    .map(|l| {
                        tile.lane(l).map(|(_, x, y)| {
                            let (o, d) = pixel_ray(scene, x, y);
                            spec.glass.exact_path(o, d)
                        })
                    })
                    .collect();
                let mut done = [false; LANES];
                let mut travelled = [0.0f64; LANES];
                let most = paths
                    .iter()
                    .flatten()
                    .map(|p| p.segments.len())
                    .max()
                    .unwrap_or(0);
                for k in 0..most {
                    packet.clear();
                    let mut any = false;
                    for l in 0..LANES {
                        if !done[l] {
                            if let Some(s) = paths[l].as_ref().and_then(|p| p.segments.get(k)) {
                                packet.set(l, f3(s.origin), f3(s.dir), s.t_end.min(f32::MAX as f64) as f32);
                                any = true;
                            }
                        }
                    }
                    if !any {
                        break;
                    }
                    orig.scene.intersect16(&mut packet);
                    for l in 0..LANES {
                        if done[l] {
                            continue;
                        }
                        let (Some(i), Some(path)) = (lane_px(l), paths[l].as_ref()) else {
                            continue;
                        };
                        let Some(s) = path.segments.get(k) else {
                            continue;
                        };
                        if let Some(hh) = packet.hit(l) {
                            let (obj, tri) = orig.source[hh.prim_id as usize];
                            let weight = if spec.fresnel && k > 0 {
                                path.transmittance
                            } else {
                                1.0
                            };
                            let (col, p) = shade(scene, prep, obj, tri, hh.u, hh.v, weight);
                            prow[i] = col;
                            srow[i] = Some(Shown {
                                object: obj,
                                point: p,
                                path_length: travelled[l] + (p - s.origin).length(),
                            });
                            done[l] = true;
                        } else {
                            travelled[l] += s.t_end;
                        }
                    }
                }
            }
        });
    Frame::finished(scene, pixels, shown, t0)
}
