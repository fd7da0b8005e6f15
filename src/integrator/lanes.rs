//! Paths traced side by side: their plain-query segments and shadow rays go
//! to Embree (or to the scene's analytic set) in packets, and each path is
//! shaded by the same step as a single ray ([`PathState::advance`]), or,
//! where the scene allows it, all of a packet's paths at once in vector
//! registers (`wavefront`).
use super::cast::{cast, intersect_packet, known_segment, packet_surface_point, NO_COINCIDENT};
use super::columns::PathColumns;
use super::light::{resolve_shadows, PendingShadow};
use super::path::{PathStart, PathState};
use super::shade_lanes::ShadeLanes;
use super::wavefront::vector_stream;
use super::Tracer;
use crate::counters::Counters;
use crate::dielectric::{self, InteriorList};
use crate::embree::RayPacket;
use crate::error::Result;
use crate::sampling::Rng;
use crate::scene::shapes::{SetScratch, SurfaceLanes};
use crate::scene::{IntegratorKind, SurfacePoint};
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
/// The default shades in vector registers where the scene allows it.
pub struct LanePackets<P> {
    near: P,
    shadow: P,
    occupancy: Counters,
    /// The live paths of [`path_stream`] and their counters, kept for
    /// their allocations.
    front: Vec<Lane>,
    own: Vec<Counters>,
    /// A step's shadow rays: the place of their path in the front and the
    /// connection (kept apart from the paths, which move as the front
    /// shrinks).
    waiting: Vec<(u32, PendingShadow)>,
    /// The lanes of a packet between the phases of vector shading.
    shade: Box<ShadeLanes>,
    /// The paths of a wavefront shaded in vector registers.
    columns: PathColumns,
    /// Shade in vector registers where [`ShadeLanes::applies`].
    vector_shading: bool,
}

impl<P: Default> Default for LanePackets<P> {
    fn default() -> Self {
        LanePackets::with_vector_shading(true)
    }
}

impl<P: Default> LanePackets<P> {
    /// Packets whose paths are shaded in vector registers (`vector`, where
    /// the scene allows it; their analytic queries in f32 where no solids
    /// overlap) or one by one (the queries in f64: the reference, which
    /// single rays reproduce bit for bit).
    pub fn with_vector_shading(vector: bool) -> Self {
        LanePackets {
            near: P::default(),
            shadow: P::default(),
            occupancy: Counters::default(),
            front: Vec::new(),
            own: Vec::new(),
            waiting: Vec::new(),
            shade: Box::default(),
            columns: Default::default(),
            vector_shading: vector,
        }
    }
}

impl<P> LanePackets<P> {
    /// The packets' slots and the rays they carried since the last call
    /// (the `packet_*` fields of [`Counters`]; the others are zero).
    pub fn take_occupancy(&mut self) -> Counters {
        std::mem::take(&mut self.occupancy)
    }
}

/// A path of [`path_stream`]'s wavefront.
struct Lane {
    path: PathState,
    rng: Rng,
    /// Its place in `starts`: its name for `done`, and
    /// where its own counts are.
    slot: u32,
    /// Its last segment ended it.
    ended: bool,
}

/// Up to `N` paths of the path tracer traced side by side (a fixed set):
/// [`path_stream`] over `cams`, with the radiance of path `i` at `i`.
/// `cams` and `rngs` have one entry per path (at most `N`), `sts` one per
/// path (each path's own counts) or one for all.
///
/// # Errors
/// As [`radiance`](super::radiance).
pub fn path_lanes<const N: usize, P: RayPacket<N>>(
    tr: Tracer<'_>,
    cams: &[(V3, V3)],
    list: &InteriorList,
    rngs: &[Rng],
    sts: &mut [Counters],
    packets: &mut LanePackets<P>,
) -> Result<[V3; N]> {
    let n = cams.len().min(N);
    debug_assert!(rngs.len() >= n && (sts.len() == 1 || sts.len() >= n));
    let per_path = sts.len() > 1;
    let mut out = [V3::ZERO; N];
    let starts: Vec<PathStart> = cams[..n]
        .iter()
        .zip(rngs)
        .map(|(&ray, rng)| PathStart {
            ray,
            rng: rng.clone(),
        })
        .collect();
    let mut total = Counters::default();
    let mut own = [Counters::default(); N];
    path_stream(
        tr,
        list,
        &starts,
        |i, l, st| {
            out[i as usize] = l;
            own[i as usize] = *st;
        },
        per_path,
        &mut total,
        packets,
    )?;
    if per_path {
        for (s, o) in sts.iter_mut().zip(&own) {
            *s += *o;
        }
    } else {
        sts[0] += total;
    }
    Ok(out)
}

/// Paths of the path tracer traced as one wavefront, `N` side by side: all
/// the paths of `starts` start together, and each step takes the segment
/// of every live path, in packets of `N` made of the live paths in order
/// (a pixel's camera rays fill packets as before; later the survivors of
/// many pixels, so packets stay full however the paths' lengths differ).
/// The segments that a plain query answers
/// ([`dielectric::plain_query_suffices`]) go to Embree in those packets (a
/// coherent one while each of its paths has only met smooth surfaces), the
/// others through [`dielectric::trace`]; the step's shadow rays follow, in
/// packets of `N` of their own. Each path gives the same radiance, bit for
/// bit, as [`radiance`](super::radiance) with its own generator when
/// `packets` shade one lane at a time (the shading is `PathState::advance`
/// in both, each path's random numbers are its own, and a path's shadow ray
/// is resolved before its next segment); with vector shading
/// (`shade_lanes`), up to rounding. Every ended
/// path goes to `done` with its index in `starts`, its
/// radiance and (`per_path`) its own counters, else zeros; all counts also
/// add to `stats`. Only where
/// [`path_lanes_apply`] holds.
///
/// # Errors
/// As [`radiance`](super::radiance).
pub fn path_stream<const N: usize, P: RayPacket<N>>(
    tr: Tracer<'_>,
    list: &InteriorList,
    starts: &[PathStart],
    mut done: impl FnMut(u32, V3, &Counters),
    per_path: bool,
    stats: &mut Counters,
    packets: &mut LanePackets<P>,
) -> Result<()> {
    debug_assert!(path_lanes_apply(tr));
    let scene = tr.scene;
    let LanePackets {
        near,
        shadow,
        occupancy,
        front,
        own,
        waiting,
        shade,
        columns,
        vector_shading,
    } = packets;
    // The vector mode's analytic queries in f32 lanes; the scalar mode, and
    // scenes with overlapping solids (whose nested rule decides coincident
    // surfaces), get Embree's answers bit for bit.
    let scratch = &mut if *vector_shading && !scene.has_overlap {
        SetScratch::<N>::f32()
    } else {
        SetScratch::<N>::default()
    };
    if *vector_shading && ShadeLanes::applies(tr) {
        vector_stream(
            tr,
            starts,
            done,
            per_path,
            stats,
            (near, shadow),
            occupancy,
            columns,
            own,
            waiting,
            shade,
            scratch,
        );
        return Ok(());
    }
    let surfaces = &mut SurfaceLanes::<N>::default();
    front.clear();
    front.extend(starts.iter().enumerate().map(|(slot, s)| Lane {
        path: PathState::new(s.ray.0, s.ray.1, list.clone()),
        rng: s.rng.clone(),
        slot: slot as u32,
        ended: false,
    }));
    // The counters of a path: its own (in the order the paths started),
    // or the shared ones.
    let mut shared = Counters::default();
    own.clear();
    if per_path {
        own.resize(front.len(), Counters::default());
    }
    macro_rules! counts {
        ($lane:expr) => {
            if per_path {
                &mut own[$lane.slot as usize]
            } else {
                &mut shared
            }
        };
    }
    while !front.is_empty() {
        waiting.clear();
        for (c, chunk) in front.chunks_mut(N).enumerate() {
            near.clear();
            let mut plain: [Option<bool>; N] = [None; N];
            for (i, p) in chunk.iter().enumerate() {
                plain[i] = dielectric::plain_query_suffices(scene, tr.strategy, &p.path.list);
                if plain[i].is_some() {
                    near.set_ray(i, &p.path.ray);
                }
            }
            // Embree's coherent mode while every path of the packet has only
            // met smooth surfaces (a pixel's camera rays and their
            // refractions stay nearly parallel), not only for the camera
            // rays: it paid on refractive scenes. Shadow rays go without:
            // they are slower in it (docs/peers.md).
            let coherent = chunk.iter().all(|l| l.path.only_specular);
            // (A packet without a lane is not sent: `RayPacket::intersect`.)
            let sent = plain.iter().flatten().count() as u64;
            occupancy.packet_slots += if sent > 0 { N as u64 } else { 0 };
            occupancy.packet_lanes += sent;
            let set_hits = intersect_packet(scene, near, coherent, scratch);
            // The surface points of hits on the analytic set's primitives,
            // all lanes' side by side in vector registers (when there are any).
            let set_points = match (&scene.analytic_set, set_hits) {
                (Some(set), true) => {
                    set.surface_points(near, surfaces);
                    true
                }
                _ => false,
            };
            // Which lanes the packet answered (the others are cast one by one
            // below), and the surface points of their hits, every lane's
            // before any lane is shaded: independent f64 square roots and
            // divisions (an analytic hit's projection and normal) the
            // processor overlaps, where each lane's shading waited on its own.
            let mut known = [false; N];
            let mut sps: [Option<SurfacePoint>; N] = [None; N];
            let mut geoms = [0u32; N];
            for (i, lane) in chunk.iter_mut().enumerate() {
                let Some(check) = plain[i] else { continue };
                let p = &lane.path;
                let hit = near.hit(i);
                if check && !dielectric::plain_hit_is_true(scene, tr.strategy, &p.ray, hit.as_ref(), &p.list)
                {
                    // A touch at a mesh edge or a leaked entry: the packet's
                    // query was made (counted); `trace` redoes it and
                    // continues past.
                    counts!(lane).queries += 1;
                    continue;
                }
                if let Some(h) = &hit {
                    sps[i] = Some(packet_surface_point(scene, (set_points, surfaces), i, h, || {
                        p.ray
                    }));
                    geoms[i] = h.geom_id;
                }
                known[i] = true;
            }
            for (i, lane) in chunk.iter_mut().enumerate() {
                let st = counts!(lane);
                let p = &mut lane.path;
                st.segments += 1;
                let sigma = tr.medium(&p.list);
                // The segment is built in place and shaded right here (a
                // segment moved out of a `match` was copied twice per lane).
                let (seg, cast_coincident, coincident);
                if known[i] {
                    seg = known_segment(tr, &p.ray, near.hit(i), p.only_specular, st);
                    coincident = &NO_COINCIDENT;
                } else {
                    (seg, cast_coincident) = cast(tr, &p.ray, &mut p.list, st, None)?;
                    coincident = &cast_coincident;
                }
                let (sh, go) = p.advance(tr, sigma, &seg, coincident, sps[i].as_ref(), &mut lane.rng, st);
                if let Some(sh) = sh {
                    waiting.push(((c * N + i) as u32, sh));
                }
                lane.ended = !go;
            }
        }
        // The step's shadow rays, packed: each path's before its next segment.
        resolve_shadows(scene, shadow, waiting, occupancy, scratch, |at, contrib| {
            front[at].path.l += contrib;
        });
        // Ended paths leave the front, the others keep their order (and
        // stay side by side in memory: a step's packets read them in turn).
        front.retain_mut(|lane| {
            if !lane.ended {
                return true;
            }
            let l = lane.path.radiance(counts!(lane));
            if per_path {
                let st = &own[lane.slot as usize];
                done(lane.slot, l, st);
                *stats += *st;
            } else {
                done(lane.slot, l, &Counters::default());
            }
            false
        });
    }
    occupancy.set_lanes += scratch.answered;
    occupancy.set_replayed_lanes += scratch.replayed;
    *stats += shared;
    Ok(())
}
