//! The path tracer's wavefront for scenes in the vector class
//! ([`ShadeLanes::applies`]): the live paths held as columns ([`PathColumns`]),
//! one array per component of their state. A step writes `N` consecutive paths'
//! rays into a packet straight from the columns, the vector kernel reads their
//! directions and throughputs from the same columns and writes the next rays
//! back, and the paths that ended leave by compaction. The scalar phases that
//! remain per lane are the ones that branch on the material
//! (`ShadeLanes::prepare`) and on the path's end (`ShadeLanes::finish`).
//!
//! Each path's radiance is the one the lane-by-lane wavefront
//! ([`path_stream`](super::path_stream) with scalar shading) gives up to the
//! rounding of the f32 kernel: the same random numbers in the same order,
//! the same packets (the live paths in order), the same shadow rays.
use super::cast::{intersect_packet, packet_surface_point};
use super::columns::{PathColumns, MAX};
use super::light::{resolve_shadows, PendingShadow};
use super::path::{finite_radiance, PathStart};
use super::shade_lanes::{Prepared, ShadeLanes};
use super::Tracer;
use crate::counters::Counters;
use crate::embree::RayPacket;
use crate::scene::shapes::{SetScratch, SurfaceLanes};
use glam::Vec3A as V3;

/// [`path_stream`](super::path_stream) for a scene in the vector class, its
/// analytic queries in `scratch`: the same contract.
#[allow(clippy::too_many_arguments)]
pub(super) fn vector_stream<const N: usize, P: RayPacket<N>>(
    tr: Tracer<'_>,
    starts: &[PathStart],
    mut done: impl FnMut(u32, V3, &Counters),
    per_path: bool,
    stats: &mut Counters,
    packets: (&mut P, &mut P),
    occupancy: &mut Counters,
    cols: &mut PathColumns,
    own: &mut Vec<Counters>,
    waiting: &mut Vec<(u32, PendingShadow)>,
    shade: &mut ShadeLanes,
    scratch: &mut SetScratch<N>,
) {
    debug_assert!(ShadeLanes::applies(tr) && N <= MAX);
    let scene = tr.scene;
    let (near, shadow) = packets;
    let surfaces = &mut SurfaceLanes::<N>::default();
    shade.start(scene);
    cols.start(starts);
    let mut shared = Counters::default();
    own.clear();
    if per_path {
        own.resize(cols.len, Counters::default());
    }
    macro_rules! counts {
        ($slot:expr) => {
            if per_path {
                &mut own[$slot as usize]
            } else {
                &mut shared
            }
        };
    }
    while cols.len > 0 {
        waiting.clear();
        for base in (0..cols.len).step_by(N) {
            let n = N.min(cols.len - base);
            let r = base..base + n;
            let (org, dir) = cols.rays::<N>(base);
            near.set_unbounded_rays(org, dir, n);
            // Coherent while every path of the packet has only met smooth
            // surfaces (as `path_stream`).
            let coherent = cols.scalars[r.clone()].iter().all(|s| s.only_specular);
            occupancy.packet_slots += N as u64;
            occupancy.packet_lanes += n as u64;
            let set_points = match (
                &scene.analytic_set,
                intersect_packet(scene, near, coherent, scratch),
            ) {
                (Some(set), true) => {
                    set.surface_points(near, surfaces);
                    true
                }
                _ => false,
            };
            shade.begin();
            let mut kernel = [false; N];
            let lanes = &mut cols.packet::<N>(base);
            for i in 0..n {
                let st = counts!(lanes.s[i].slot);
                st.segments += 1;
                st.queries += 1;
                let hit = near.hit(i);
                let sp = hit.as_ref().map(|h| {
                    let sp = packet_surface_point(scene, (set_points, surfaces), i, h, || lanes.ray(i));
                    (h.geom_id, sp)
                });
                let prep = shade.prepare(i, tr, lanes, sp.as_ref().map(|(g, sp)| (*g, sp)), st);
                kernel[i] = prep == Prepared::Kernel;
                lanes.ended[i] = !kernel[i];
            }
            if kernel.contains(&true) {
                shade.shade(n, cols.io(base));
                occupancy.shade_slots += N as u64;
                occupancy.shade_lanes += kernel.iter().filter(|&&k| k).count() as u64;
                let lanes = &mut cols.packet::<N>(base);
                for i in 0..n {
                    if !kernel[i] {
                        continue;
                    }
                    let st = counts!(lanes.s[i].slot);
                    let (sh, go) = shade.finish(i, scene, lanes, st);
                    if let Some(sh) = sh {
                        waiting.push(((base + i) as u32, sh));
                    }
                    lanes.ended[i] = !go;
                }
            }
        }
        // The step's shadow rays, packed: each path's before its next segment.
        resolve_shadows(scene, shadow, waiting, occupancy, scratch, |at, contrib| {
            cols.scalars[at].l += contrib;
        });
        cols.compact(|slot, l| {
            let st = counts!(slot);
            let l = finite_radiance(l, st);
            if per_path {
                done(slot, l, st);
                *stats += *st;
            } else {
                done(slot, l, &Counters::default());
            }
        });
    }
    occupancy.set_lanes += scratch.answered;
    occupancy.set_replayed_lanes += scratch.replayed;
    *stats += shared;
}
