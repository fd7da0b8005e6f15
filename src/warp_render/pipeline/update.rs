//! A frame's warp: every vertex's images for the current camera, written
//! straight into the copies' vertex arrays, and the copies' triangle sets
//! and BVHs updated.
use super::cull::Frustum;
use super::{FrameWarp, Pipeline};
use crate::embree::Committed;
use crate::error::Result;
use crate::scene::RenderScene;
use crate::warp::{CopyKey, Family, WarpGlass};
use crate::warp_render::vertex_images::VertexSolver;
use glam::DVec3;
use rayon::prelude::*;
use std::time::Instant;

/// `slabs` (each split into `chunks` runs of `chunk` elements) regrouped by
/// run: row r holds every slab's run r, so one job writes one run of every
/// slab.
fn chunk_rows<T>(slabs: Vec<&mut [T]>, chunks: usize, chunk: usize) -> Vec<Vec<&mut [T]>> {
    let mut rows: Vec<Vec<&mut [T]>> = (0..chunks).map(|_| Vec::with_capacity(slabs.len())).collect();
    for slab in slabs {
        for (row, part) in rows.iter_mut().zip(slab.chunks_mut(chunk)) {
            row.push(part);
        }
    }
    rows
}

impl Pipeline {
    /// Warp every vertex for the scene's current camera and update the
    /// copies. The copies then hold what that camera (its eye, view and
    /// film) can see: render the same camera (`render`, `render_into`)
    /// before the next `warp`. The tube's copies leave out what lies
    /// outside its pyramid of rays (`Frustum`).
    pub fn warp(&mut self, scene: &RenderScene) -> Result<FrameWarp> {
        let eye = DVec3::from(scene.camera.position.to_array().map(|x| x as f64));
        let nv = self.positions.len();
        let t0 = Instant::now();
        let tube = matches!(self.glass, WarpGlass::Cylinder(_));
        let frustum = self
            .cull_margin_px
            .filter(|_| tube)
            .and_then(|m| Frustum::of(scene, m));
        for c in self.copies.iter_mut().filter(|c| !c.fixed) {
            // One slab of nv vertices per member key.
            c.next.resize(c.members.len() * nv, [0.0; 3]);
            c.codes
                .resize(if frustum.is_some() { c.next.len() } else { 0 }, 0);
        }
        let images;
        match (&self.glass, self.method) {
            (WarpGlass::Plate(plate), _) => {
                // One copy (see `groups`): its vertex array holds the
                // unwarped positions (direct), then the warped ones, which the
                // batch writes in place.
                let (dbit, wbit) = (
                    self.key_bit(CopyKey::DIRECT),
                    self.key_bit(CopyKey {
                        family: Family::Wall2,
                        side: 0,
                    }),
                );
                self.plate_class.resize(nv, Ok(false));
                let c = &mut self.copies[0];
                let mut next = std::mem::take(&mut c.next);
                let (mut direct, mut warped) = next.split_at_mut(nv);
                if c.members.first() != Some(&CopyKey::DIRECT) {
                    std::mem::swap(&mut direct, &mut warped);
                }
                direct.copy_from_slice(&self.positions);
                const CHUNK: usize = 4096;
                warped
                    .par_chunks_mut(CHUNK)
                    .zip(self.plate_class.par_chunks_mut(CHUNK))
                    .zip(self.positions.par_chunks(CHUNK))
                    .zip(self.masks.par_chunks_mut(CHUNK))
                    .for_each(|(((out, class), pts), masks)| {
                        plate.warp_batch(eye, pts, out, class);
                        for (m, c) in masks.iter_mut().zip(class.iter()) {
                            *m = match c {
                                Ok(true) => wbit,
                                Ok(false) => dbit,
                                Err(_) => 0,
                            };
                        }
                    });
                self.copies[0].next = next;
                images = self.masks.iter().filter(|&&m| m != 0).count();
            }
            (glass, method) => {
                let all = &self.positions64;
                let solver = VertexSolver::new(*glass, method, eye, all);
                // One pass per chunk of vertices writes their masks and
                // their rows of every slab, straight from the solver's
                // images (no `VertexImages` per vertex, no pass per slab).
                let keys = &self.keys;
                let mut slab_of = [usize::MAX; 8];
                let mut slabs: Vec<&mut [[f32; 3]]> = Vec::new();
                let mut code_slabs: Vec<&mut [u8]> = Vec::new();
                for c in self.copies.iter_mut().filter(|c| !c.fixed) {
                    for (slab, key) in c.next.chunks_mut(nv.max(1)).zip(&c.members) {
                        if let Some(k) = keys.iter().position(|k| k == key) {
                            slab_of[k] = slabs.len();
                        }
                        slabs.push(slab);
                    }
                    code_slabs.extend(c.codes.chunks_mut(nv.max(1)));
                }
                const CHUNK: usize = 256;
                let chunks = nv.div_ceil(CHUNK);
                let rows = chunk_rows(slabs, chunks, CHUNK);
                // Empty rows when nothing is culled.
                let code_rows = chunk_rows(code_slabs, chunks, CHUNK);
                let frustum = &frustum;
                rows.into_par_iter()
                    .zip(code_rows.into_par_iter())
                    .zip(self.masks.par_chunks_mut(CHUNK))
                    .zip(all.par_chunks(CHUNK))
                    .zip(self.positions.par_chunks(CHUNK))
                    .for_each(|((((mut outs, mut codes), masks), pts), unwarped)| {
                        // A vertex without an image in a copy keeps its
                        // unwarped position there (no kept triangle uses it).
                        for o in outs.iter_mut() {
                            o.copy_from_slice(unwarped);
                        }
                        masks.fill(0);
                        solver.each_image(pts, |i, key, q| {
                            let Some(k) = keys.iter().position(|k| *k == key) else {
                                return;
                            };
                            // The first image per copy wins (`VertexImages::push`).
                            if masks[i] & (1 << k) == 0 {
                                masks[i] |= 1 << k;
                                if let Some(o) = outs.get_mut(slab_of[k]) {
                                    o[i] = [q.x as f32, q.y as f32, q.z as f32];
                                }
                                if let (Some(f), Some(code)) = (frustum, codes.get_mut(slab_of[k])) {
                                    code[i] = f.outcode(q);
                                }
                            }
                        });
                    });
                images = self.masks.par_iter().map(|m| m.count_ones() as usize).sum();
            }
        }
        // The keys some vertex has an image for: a copy of none has no
        // triangle (three of the tube's six copies on the bench's view),
        // and its scan of every triangle is skipped.
        let present = self.masks.par_iter().copied().reduce(|| 0, |a, b| a | b);
        let warp_s = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let tris = &self.tris;
        let masks = &self.masks;
        let results: Vec<Result<(Committed, usize)>> = self
            .copies
            .par_iter_mut()
            .filter(|c| !c.fixed)
            .map(|c| {
                let mut culled = 0;
                // Member m's triangles, in order; their vertices index its
                // slab (offset m·nv).
                let mut ids: Vec<u32> = Vec::with_capacity(c.tri_ids.len().max(1024));
                let mut ends = Vec::with_capacity(c.members.len());
                for (m, &b) in c.member_bits.iter().enumerate() {
                    let bit = 1u8 << b;
                    if present & bit != 0 {
                        // The member's outcodes, when the copy is culled.
                        let codes = c.codes.get(m * nv..(m + 1) * nv).filter(|cs| !cs.is_empty());
                        for (i, t) in tris.iter().enumerate() {
                            if !t.iter().all(|&v| masks[v as usize] & bit != 0) {
                                continue;
                            }
                            if codes
                                .is_some_and(|cs| t.iter().fold(!0u8, |all, &v| all & cs[v as usize]) != 0)
                            {
                                culled += 1;
                            } else {
                                ids.push(i as u32);
                            }
                        }
                    }
                    ends.push(ids.len());
                }
                let same = ids == c.tri_ids && ends == c.member_ends;
                c.tri_ids = ids;
                c.member_ends = ends;
                let next = &mut c.next;
                let (ids, ends) = (&c.tri_ids, &c.member_ends);
                let committed = c.mesh.update(|vs, is| {
                    std::mem::swap(vs, next);
                    if same {
                        return false;
                    }
                    is.clear();
                    let mut start = 0;
                    for (m, &end) in ends.iter().enumerate() {
                        let offset = (m * nv) as u32;
                        is.extend(
                            ids[start..end]
                                .iter()
                                .map(|&i| tris[i as usize].map(|v| v + offset)),
                        );
                        start = end;
                    }
                    true
                })?;
                Ok((committed, culled))
            })
            .collect();
        let (mut refits, mut rebuilds, mut culled_triangles) = (0, 0, 0);
        for r in results {
            let (committed, culled) = r?;
            culled_triangles += culled;
            match committed {
                Committed::Refit => refits += 1,
                Committed::Rebuilt => rebuilds += 1,
                Committed::Empty => {}
            }
        }
        let dropped_triangles = self
            .tris
            .par_iter()
            .filter(|t| masks[t[0] as usize] & masks[t[1] as usize] & masks[t[2] as usize] == 0)
            .count();
        Ok(FrameWarp {
            warp_s,
            build_s: t1.elapsed().as_secs_f64(),
            images,
            refits,
            rebuilds,
            dropped_triangles,
            culled_triangles,
        })
    }
}
