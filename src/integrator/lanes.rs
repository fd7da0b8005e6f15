//! Paths traced side by side: their plain-query segments and shadow rays go
//! to Embree (or to the scene's analytic set) in packets, and each path is
//! shaded by the same step as a single ray ([`PathState::advance`]).
use super::cast::{cast, known_segment, NO_COINCIDENT};
use super::path::PathState;
use super::Tracer;
use crate::counters::Counters;
use crate::dielectric::{self, InteriorList};
use crate::embree::RayPacket;
use crate::error::Result;
use crate::sampling::Rng;
use crate::scene::{IntegratorKind, RenderScene, SurfacePoint};
use glam::Vec3A as V3;

/// Can [`path_lanes`] trace the paths of a render of `tr`? The path tracer
/// without a gradient-index medium (whose curved segments are chains of
/// queries). Segments that a plain query answers go to Embree in packets
/// (every segment without overlapping solids; outside every solid with them),
/// the others through [`dielectric::trace`] one by one.
pub fn path_lanes_apply(tr: Tracer<'_>) -> bool {
    tr.scene.integrator == IntegratorKind::Path && tr.scene.medium.is_none()
}

/// The two Embree packets [`path_lanes`] fills (nearest-hit segments and
/// shadow rays), made once per thread's batch of calls: zeroing a packet
/// per call shows in a render's profile. With how full they went out.
#[derive(Default)]
pub struct LanePackets<P> {
    near: P,
    shadow: P,
    occupancy: Counters,
}

impl<P> LanePackets<P> {
    /// The packets' slots and the rays they carried since the last call
    /// (the `packet_*` fields of [`Counters`]; the others are zero).
    pub fn take_occupancy(&mut self) -> Counters {
        std::mem::take(&mut self.occupancy)
    }
}

/// Up to `N` paths of the path tracer traced side by side (renders use 8):
/// the segments of the live paths that a plain query answers
/// ([`dielectric::plain_query_suffices`]) go to Embree as one packet of `N`
/// rays (a coherent one while no path has met a diffuse surface), the others through
/// [`dielectric::trace`]; every batch of shadow rays is one packet. Each path
/// gives the same radiance, bit for bit, as [`radiance`](super::radiance) with its own `rng`:
/// the shading is `PathState::advance` in both, and each path's random
/// numbers are its own. Only where [`path_lanes_apply`] holds; `cams` and
/// `rngs` have one entry per path (at most `N`, the width of the packet
/// type `P`), `sts` one per path (each path's own counts) or one for all.
///
/// # Errors
/// As [`radiance`](super::radiance).
pub fn path_lanes<const N: usize, P: RayPacket<N>>(
    tr: Tracer<'_>,
    cams: &[(V3, V3)],
    list: &InteriorList,
    rngs: &mut [Rng],
    sts: &mut [Counters],
    packets: &mut LanePackets<P>,
) -> Result<[V3; N]> {
    let n = cams.len().min(N);
    let per_lane = sts.len() > 1;
    debug_assert!(path_lanes_apply(tr) && rngs.len() >= n && (sts.len() == 1 || sts.len() >= n));
    // Lane `i < n` indexes these without a bounds check.
    let rngs = &mut rngs[..n];
    let sts = &mut sts[..if per_lane { n } else { 1 }];
    // The counters of lane `i`.
    let lane = |i: usize| if per_lane { i } else { 0 };
    let scene = tr.scene;
    let mut paths: [Option<PathState>; N] = std::array::from_fn(|_| None);
    for (slot, &(o, d)) in paths.iter_mut().zip(cams) {
        *slot = Some(PathState::new(o, d, list.clone()));
    }
    let mut out = [V3::ZERO; N];
    let LanePackets {
        near,
        shadow,
        occupancy,
    } = packets;
    while paths.iter().any(Option::is_some) {
        near.clear();
        let mut plain: [Option<bool>; N] = [None; N];
        for (i, p) in paths.iter().enumerate() {
            if let Some(p) = p {
                plain[i] = dielectric::plain_query_suffices(scene, tr.strategy, &p.list);
                if plain[i].is_some() {
                    near.set_ray(i, &p.ray);
                }
            }
        }
        // Embree's coherent mode while every live path has only met smooth
        // surfaces (a pixel's camera rays and their refractions stay nearly
        // parallel), not only for the camera rays: it paid on refractive
        // scenes. Shadow rays go without: they are slower in it (docs/peers.md).
        let coherent = paths.iter().flatten().all(|p| p.only_specular);
        // (A packet without a lane is not sent: `RayPacket::intersect`.)
        let lanes = plain.iter().flatten().count() as u64;
        occupancy.packet_slots += if lanes > 0 { N as u64 } else { 0 };
        occupancy.packet_lanes += lanes;
        intersect_packet(scene, near, coherent);
        shadow.clear();
        // Which lanes the packet answered (the others are cast one by one
        // below), and the surface points of their hits, every lane's before
        // any lane is shaded: independent f64 square roots and divisions
        // (an analytic hit's projection and normal) the processor overlaps,
        // where each lane's shading waited on its own.
        let mut known = [false; N];
        let mut sps: [Option<SurfacePoint>; N] = [None; N];
        for i in 0..n {
            let Some(p) = &paths[i] else { continue };
            let Some(check) = plain[i] else { continue };
            let hit = near.hit(i);
            if check && !dielectric::plain_hit_is_true(scene, tr.strategy, &p.ray, hit.as_ref(), &p.list) {
                // A touch at a mesh edge or a leaked entry: the packet's
                // query was made (counted); `trace` redoes it and continues
                // past.
                sts[lane(i)].queries += 1;
                continue;
            }
            if let Some(h) = &hit {
                sps[i] = Some(scene.surface_point(&p.ray, h));
            }
            known[i] = true;
        }
        let mut pending: [Option<V3>; N] = [None; N];
        let mut ended = [false; N];
        for i in 0..n {
            let Some(p) = &mut paths[i] else { continue };
            let st = &mut sts[lane(i)];
            st.segments += 1;
            let sigma = tr.medium(&p.list);
            // The segment is built in place and shaded right here (a
            // segment moved out of a `match` was copied twice per lane).
            let (seg, cast_coincident, coincident);
            if known[i] {
                seg = known_segment(tr, &p.ray, near.hit(i), st);
                coincident = &NO_COINCIDENT;
            } else {
                (seg, cast_coincident) = cast(tr, &p.ray, &mut p.list, st, None)?;
                coincident = &cast_coincident;
            }
            let (sh, go) = p.advance(tr, sigma, &seg, coincident, sps[i].as_ref(), &mut rngs[i], st);
            if let Some(sh) = sh {
                shadow.set_ray(i, &sh.ray);
                pending[i] = Some(sh.contrib);
            }
            ended[i] = !go;
        }
        if pending.iter().any(Option::is_some) {
            occupancy.shadow_packet_slots += N as u64;
            occupancy.shadow_packet_lanes += pending.iter().flatten().count() as u64;
            occlude_packet(scene, shadow);
        }
        // In each path's order: its shadow ray before its next segment.
        for i in 0..n {
            let Some(p) = &mut paths[i] else { continue };
            if let Some(c) = pending[i] {
                if !shadow.occluded(i) {
                    p.l += c;
                }
            }
            if ended[i] {
                out[i] = p.radiance(&mut sts[lane(i)]);
                paths[i] = None;
            }
        }
    }
    Ok(out)
}

/// Nearest hits of the active lanes of `packet` in `scene`: Embree's, or
/// with an [`AnalyticSet`](crate::scene::shapes::AnalyticSet), Embree's
/// among the meshes completed by the set's.
#[inline]
fn intersect_packet<const N: usize, P: RayPacket<N>>(scene: &RenderScene, packet: &mut P, coherent: bool) {
    match &scene.analytic_set {
        Some(set) => {
            packet.intersect_meshes(&scene.embree, coherent);
            set.intersect(packet);
        }
        None => packet.intersect(&scene.embree, coherent),
    }
}

/// Occlusion of the active lanes of `packet` (shadow rays: not coherent),
/// as [`intersect_packet`] finds hits.
#[inline]
fn occlude_packet<const N: usize, P: RayPacket<N>>(scene: &RenderScene, packet: &mut P) {
    match &scene.analytic_set {
        Some(set) => {
            packet.occlude_meshes(&scene.embree, false);
            set.occlude(packet);
        }
        None => packet.occlude(&scene.embree, false),
    }
}
