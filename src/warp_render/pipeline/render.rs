//! The pipeline's primary rays: tiles of sixteen pixels, classified
//! analytically, one packet per copy any lane needs, the nearest hit
//! shaded.
use super::classify::Classifier;
use super::Pipeline;
use crate::embree::Packet16;
use crate::scene::RenderScene;
use crate::warp::{CopyKey, WarpSpec};
use crate::warp_render::frame::{Frame, Shown};
use crate::warp_render::prepare::Prepared;
use crate::warp_render::rays::f3;
use crate::warp_render::shade::shade;
use crate::warp_render::tiles::{tile_rays, Tile, LANES, TILE_H, TILE_W};
use glam::{DVec3, Vec3A as V3};
use rayon::prelude::*;
use std::time::Instant;

/// A lane's nearest hit so far: (t, copy, primitive, u, v).
type LaneHit = (f32, usize, u32, f32, f32);

impl Pipeline {
    /// Render the current copies with straight primary rays in packets of sixteen.
    pub fn render(&self, scene: &RenderScene, spec: &WarpSpec, prep: &Prepared) -> Frame {
        let mut frame = Frame {
            width: 0,
            height: 0,
            pixels: Vec::new(),
            shown: Vec::new(),
            render_s: 0.0,
        };
        self.render_into(scene, spec, prep, &mut frame);
        frame
    }

    /// `render` into a frame kept across frames (an interactive viewer's
    /// frame buffer): every pixel is written, hit or not, so the buffers are
    /// reused without clearing, and a frame does not page in fresh memory
    /// (~120 MB at 1600×1200, whose page faults would cost a tenth of the
    /// tube's frame). `render_s` includes resizing on the first use.
    pub fn render_into(&self, scene: &RenderScene, spec: &WarpSpec, prep: &Prepared, frame: &mut Frame) {
        let t0 = Instant::now();
        let (w, h) = (scene.width as usize, scene.height as usize);
        frame.width = scene.width;
        frame.height = scene.height;
        frame.pixels.resize(w * h, V3::ZERO);
        frame.shown.resize(w * h, None);
        let (pixels, shown) = (&mut frame.pixels, &mut frame.shown);
        // The direct copy queried up to the glass (the plate's direct
        // triangles share the one copy every ray asks).
        let direct = self
            .copies
            .iter()
            .position(|c| c.members[..] == [CopyKey::DIRECT]);
        let eye = DVec3::from(scene.camera.position.to_array().map(|x| x as f64));
        let classifier = Classifier::new(self, eye);
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
                    let rays = tile_rays(scene, &tile);
                    let class = classifier.classify16(&rays);
                    let want = class.iter().fold(0u8, |w, c| w | c.1);
                    // Nearest hit per lane: (t, copy, prim, u, v).
                    let mut best: [Option<LaneHit>; LANES] = [None; LANES];
                    if let Some(di) = direct.filter(|&di| !self.copies[di].tri_ids.is_empty()) {
                        packet.clear();
                        for l in 0..LANES {
                            if lane_px(l).is_some() {
                                let tfar = class[l].0.min(f32::MAX as f64) as f32;
                                packet.set(l, f3(rays[l].0), f3(rays[l].1), tfar);
                            }
                        }
                        self.copies[di].mesh.intersect16(&mut packet);
                        for (l, b) in best.iter_mut().enumerate() {
                            if let Some(hh) = packet.hit(l) {
                                *b = Some((hh.t, di, hh.prim_id, hh.u, hh.v));
                            }
                        }
                    }
                    for (ci, c) in self.copies.iter().enumerate() {
                        if want & (1 << ci) == 0 || c.tri_ids.is_empty() {
                            continue;
                        }
                        packet.clear();
                        for l in 0..LANES {
                            if class[l].1 & (1 << ci) != 0 {
                                // Only a nearer hit can change the lane's
                                // answer: Embree culls beyond the best so far.
                                let tfar = best[l].map_or(f32::INFINITY, |b| b.0);
                                packet.set(l, f3(rays[l].0), f3(rays[l].1), tfar);
                            }
                        }
                        c.mesh.intersect16(&mut packet);
                        for (l, b) in best.iter_mut().enumerate() {
                            if let Some(hh) = packet.hit(l) {
                                if b.is_none_or(|b| hh.t < b.0) {
                                    *b = Some((hh.t, ci, hh.prim_id, hh.u, hh.v));
                                }
                            }
                        }
                    }
                    for l in 0..LANES {
                        let Some(i) = lane_px(l) else {
                            continue;
                        };
                        let Some((_, ci, prim, u, v)) = best[l] else {
                            prow[i] = V3::ZERO;
                            srow[i] = None;
                            continue;
                        };
                        let c = &self.copies[ci];
                        let (obj, tri) = self.tri_src[c.tri_ids[prim as usize] as usize];
                        let weight = if spec.fresnel && c.key_of(prim as usize) != CopyKey::DIRECT {
                            spec.glass.exact_path(rays[l].0, rays[l].1).transmittance
                        } else {
                            1.0
                        };
                        let (col, p) = shade(scene, prep, obj, tri, u, v, weight);
                        prow[i] = col;
                        srow[i] = Some(Shown {
                            object: obj,
                            point: p,
                            path_length: (p - rays[l].0).length(),
                        });
                    }
                }
            });
        frame.render_s = t0.elapsed().as_secs_f64();
    }
}
