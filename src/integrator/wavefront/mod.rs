//! The path tracer's wavefront scheduler ([`trace_paths`]): the live paths
//! held as columns ([`PathColumns`]), one array per component of their state. A step writes
//! `N` consecutive paths' rays into a packet straight from the columns, and
//! shades each lane in one of two ways:
//!
//! - in vector registers ([`ShadeLanes`]): Lambertian surfaces under any
//!   light, smooth interfaces, rough (GGX) glass and the boundaries of
//!   nested solids, black surfaces, emission and misses. A scalar phase per
//!   lane reads the material, resolves a boundary's index pair (the nested
//!   rule), draws the step's random numbers (a light's sample among them,
//!   but for a lone rectangle's) and stages the lane; once the stage holds
//!   several packets' lanes the kernel makes every staged lane's light
//!   weight, bounce or lobe and next ray at once, in full vectors; a scalar
//!   phase then hands back each shadow ray, writes the next ray into the
//!   columns, moves a transmitted path's interior list and plays roulette;
//! - one at a time by the single-ray step ([`PathState::advance`]) for every
//!   other lane (other materials, a hit with coincident solid surfaces, an
//!   observed or BSDF-sampled render), and for every lane with
//!   `--shading scalar`, which is the single-ray path tracer bit for bit.
//!
//! Segments that a plain query answers go to Embree (or the analytic set)
//! in the packet, masked inside overlapping solids where one masked query
//! answers them (`dielectric::packet_query`); the others are traced one by
//! one through [`dielectric::trace`]. Shadow rays follow in packets of
//! their own, then the paths that ended leave by compaction.
//!
//! Each path's radiance is the one the single-ray path tracer gives with its
//! generator up to the rounding of the f32 kernel: the same random numbers
//! in the same order, the same shadow rays.
use super::cast::{cast, intersect_packet, known_segment, packet_surface_point, Segment, NO_COINCIDENT};
use super::columns::{self, PacketPaths, PathColumns, MAX};
use super::light::{resolve_shadows, PendingShadow};
use super::path::{finite_radiance, PathStart, PathState};
use super::shade_lanes::{Prepared, ShadeLanes};
use super::{Tracer, WavefrontMode};
use crate::counters::Counters;
use crate::dielectric::{self, Coincident, InteriorList, NestedStrategy, PacketQuery};
use crate::embree::RayPacket;
use crate::error::Result;
use crate::scene::shapes::{SetScratch, SurfaceLanes};
use crate::scene::SurfacePoint;
use glam::Vec3A as V3;

/// A thread's wavefront storage: the two Embree packets (nearest-hit
/// segments and shadow rays), the path columns and the kernel's stage, made
/// once and kept from call to call (zeroing a packet per call shows in a
/// render's profile), with how full the packets went out.
pub struct Wavefront<P> {
    near: P,
    shadow: P,
    occupancy: Counters,
    /// The counters of the paths, kept for their allocation.
    own: Vec<Counters>,
    /// A step's shadow rays: the place of their path in the front and the
    /// connection (kept apart from the paths, which move as the front
    /// shrinks).
    waiting: Vec<(u32, PendingShadow)>,
    /// The lanes staged for the kernel.
    shade: Box<ShadeLanes>,
    /// The paths of a wavefront.
    columns: PathColumns,
}

impl<P: Default> Default for Wavefront<P> {
    fn default() -> Self {
        Wavefront {
            near: P::default(),
            shadow: P::default(),
            occupancy: Counters::default(),
            own: Vec::new(),
            waiting: Vec::new(),
            shade: Box::default(),
            columns: Default::default(),
        }
    }
}

impl<P> Wavefront<P> {
    /// The packets' slots and the rays they carried since the last call
    /// (the `packet_*` and `shade_*` fields of [`Counters`]; the others are
    /// zero).
    pub fn take_occupancy(&mut self) -> Counters {
        std::mem::take(&mut self.occupancy)
    }
}

/// Paths of the path tracer traced as one wavefront, `N` side by side
/// (where [`Scheduler::of`](super::Scheduler::of) chose the wavefront, with
/// its `mode`): all the paths of `starts` start together, and each step
/// takes the segment of every live path, in packets of `N` made of the live
/// paths in order (a pixel's camera rays fill packets as before; later the
/// survivors of many pixels, so packets stay full however the paths'
/// lengths differ). The segments that a plain query answers
/// ([`dielectric::plain_query_suffices`], or a masked query:
/// [`dielectric::packet_query`]) go to Embree in those packets (a coherent
/// one while each of its paths has only met smooth surfaces), the others
/// through [`dielectric::trace`]; the step's shadow rays follow, in packets
/// of `N` of their own.
///
/// Each path gives the same radiance, bit for bit, as
/// [`radiance`](super::radiance) with its own generator in the
/// [`WavefrontMode::SCALAR`] mode (the shading is `PathState::advance` in
/// both, each path's random numbers are its own, and a path's shadow ray is
/// resolved before its next segment); with the kernel, up to rounding.
/// Every ended path goes to `done` with its index in `starts`, its radiance
/// and (`per_path`) its own counters, else zeros; all counts also add to
/// `stats`.
///
/// # Errors
/// As [`radiance`](super::radiance).
#[allow(clippy::too_many_arguments)]
pub fn trace_paths<const N: usize, P: RayPacket<N>>(
    tr: Tracer<'_>,
    mode: WavefrontMode,
    list: &InteriorList,
    starts: &[PathStart],
    done: impl FnMut(u32, V3, &Counters),
    per_path: bool,
    stats: &mut Counters,
    w: &mut Wavefront<P>,
) -> Result<()> {
    debug_assert!(matches!(
        super::Scheduler::of(tr, super::Shading::Scalar),
        super::Scheduler::Wavefront(_)
    ));
    let Wavefront {
        near,
        shadow,
        occupancy,
        own,
        waiting,
        shade,
        columns,
    } = w;
    let scratch = &mut if mode.f32_set {
        SetScratch::<N>::f32()
    } else {
        SetScratch::<N>::default()
    };
    let storage = Stream {
        near,
        shadow,
        occupancy,
        cols: columns,
        own,
        waiting,
        shade,
        scratch,
    };
    stream(tr, list, starts, done, per_path, stats, mode.kernel, storage)
}

/// The wavefront's storage, borrowed for one call.
struct Stream<'a, const N: usize, P> {
    near: &'a mut P,
    shadow: &'a mut P,
    occupancy: &'a mut Counters,
    cols: &'a mut PathColumns,
    own: &'a mut Vec<Counters>,
    waiting: &'a mut Vec<(u32, PendingShadow)>,
    shade: &'a mut ShadeLanes,
    scratch: &'a mut SetScratch<N>,
}

/// The paths `starts` (camera rays inside `list`) traced to their ends as
/// one wavefront, `N` side by side (the contract of [`trace_paths`]); lanes
/// shaded in vector registers where `kernel`.
#[allow(clippy::too_many_arguments)]
fn stream<const N: usize, P: RayPacket<N>>(
    tr: Tracer<'_>,
    list: &InteriorList,
    starts: &[PathStart],
    mut done: impl FnMut(u32, V3, &Counters),
    per_path: bool,
    stats: &mut Counters,
    kernel_on: bool,
    w: Stream<'_, N, P>,
) -> Result<()> {
    debug_assert!(N <= MAX);
    let scene = tr.scene;
    let Stream {
        near,
        shadow,
        occupancy,
        cols,
        own,
        waiting,
        shade,
        scratch,
    } = w;
    let surfaces = &mut SurfaceLanes::<N>::default();
    shade.start(scene);
    // Only overlapping solids make some segments need more than a plain
    // query, and only absorbing ones attenuate a segment.
    let nested = scene.has_overlap && tr.strategy != NestedStrategy::Off;
    let absorbing = scene.solids.iter().any(|s| s.sigma_a.max_element() > 0.0);
    cols.start(starts, list, !scene.solids.is_empty());
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
    // The kernel over the staged lanes (prepared from any packets of the
    // step), then each one's last phase.
    macro_rules! flush {
        () => {
            occupancy.shade_slots += shade.shade() as u64;
            occupancy.shade_lanes += shade.count as u64;
            // Lanes are staged packet by packet: a packet's view is made
            // once per run of its lanes, not per lane.
            let mut view: Option<(usize, PacketPaths<'_, N>)> = None;
            for j in 0..shade.count {
                let k = shade.at[j] as usize;
                let base = k - k % N;
                if view.as_ref().is_none_or(|v| v.0 != base) {
                    view = Some((base, cols.packet::<N>(base)));
                }
                let lanes = &mut view.as_mut().expect("made above").1;
                let i = k - base;
                let st = counts!(lanes.s[i].slot);
                let (sh, go) = shade.finish(j, i, scene, lanes, st);
                if let Some(sh) = sh {
                    waiting.push((k as u32, sh));
                }
                lanes.ended[i] = !go;
            }
            shade.clear();
        };
    }
    // Some path has continued its line (`PathScalars::tnear`): the packets'
    // rays then need their starts.
    let mut lined = false;
    while cols.len > 0 {
        waiting.clear();
        for base in (0..cols.len).step_by(N) {
            let n = N.min(cols.len - base);
            let lanes = &mut cols.packet::<N>(base);
            // Which lanes a plain query answers (perhaps masked, its hit to be
            // checked: `dielectric::packet_query`); the others are traced one
            // by one.
            const PLAIN: Option<PacketQuery> = Some(PacketQuery {
                check: false,
                mask: u32::MAX,
                below: 0,
            });
            let mut plain = [PLAIN; N];
            let mut masked = false;
            if nested {
                for (i, p) in plain.iter_mut().enumerate().take(n) {
                    *p = dielectric::packet_query(scene, tr.strategy, &lanes.lists[i]);
                    masked |= p.is_some_and(|q| q.mask != u32::MAX);
                }
            }
            let sent = plain[..n].iter().flatten().count();
            if sent == n {
                near.set_unbounded_rays(
                    lanes.org.each_ref().map(|c| &**c),
                    lanes.dir.each_ref().map(|c| &**c),
                    n,
                );
            } else {
                near.clear();
            }
            // A ray continuing its line starts past the hit it left (and the
            // lanes of a mixed packet are set one by one).
            if sent < n || lined {
                for (i, p) in plain.iter().enumerate().take(n) {
                    if p.is_some() && (sent < n || lanes.s[i].tnear != 0.0) {
                        near.set_ray(i, &lanes.ray(i));
                    }
                }
            }
            if masked {
                for (i, p) in plain.iter().enumerate().take(n) {
                    if let Some(q) = p {
                        near.set_mask(i, q.mask);
                    }
                }
            }
            // Coherent while every path of the packet has only met smooth
            // surfaces (a pixel's camera rays and their refractions stay
            // nearly parallel); shadow rays go without (docs/peers.md).
            let coherent = lanes.s[..n].iter().all(|s| s.only_specular);
            // (A packet without a lane is not sent: `RayPacket::intersect`.)
            if sent > 0 {
                occupancy.packet_slots += N as u64;
                occupancy.packet_lanes += sent as u64;
            }
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
            if masked {
                for i in 0..n {
                    near.set_mask(i, u32::MAX);
                }
            }
            for i in 0..n {
                let st = counts!(lanes.s[i].slot);
                st.segments += 1;
                let sigma = if absorbing {
                    tr.medium(&lanes.lists[i])
                } else {
                    None
                };
                let hit = near.hit(i);
                // The packet's answer stands for the trace, or the lane is
                // traced alone: a touch at a mesh edge or a leaked entry (the
                // packet's query was made and is counted; `trace` redoes it and
                // continues past), or a ray inside overlapping solids.
                let known = plain[i].is_some_and(|q| {
                    !q.check || {
                        let ray = lanes.ray(i);
                        let list = &mut lanes.lists[i];
                        if list.is_empty() {
                            dielectric::plain_hit_is_true(scene, tr.strategy, &ray, hit.as_ref(), list)
                        } else {
                            let true_hit = dielectric::masked_hit_is_true(scene, &ray, hit.as_ref(), list);
                            if true_hit {
                                let t = hit.as_ref().map(|h| h.t);
                                dielectric::settle_masked_after(scene, q, &ray, t, list, st);
                            }
                            true_hit
                        }
                    }
                });
                let traced = if known {
                    None
                } else {
                    if plain[i].is_some() {
                        st.queries += 1;
                    }
                    Some(cast(tr, &lanes.ray(i), &mut lanes.lists[i], st, None)?)
                };
                // (Without a medium a segment is straight: its chord is the
                // lane's ray.)
                let (hit, coincident) = match &traced {
                    Some((seg, c)) => (seg.hit, c),
                    None => (hit, &NO_COINCIDENT),
                };
                let sp = hit.as_ref().map(|h| match &traced {
                    None => packet_surface_point(scene, (set_points, surfaces), i, h, || lanes.ray(i)),
                    Some((seg, _)) => scene.surface_point(&seg.chord, h),
                });
                let prepared = if kernel_on {
                    if known {
                        st.queries += 1;
                    }
                    let at = hit.as_ref().zip(sp.as_ref());
                    shade.prepare(i, base + i, tr, lanes, sigma, at, coincident, st)
                } else {
                    Prepared::Alone
                };
                let go = match prepared {
                    Prepared::Ended => false,
                    // (Ended or not once the stage is shaded.)
                    Prepared::Kernel => true,
                    Prepared::Alone => {
                        let ray = lanes.ray(i);
                        let known_seg;
                        let seg = match &traced {
                            Some((seg, _)) => seg,
                            None => {
                                known_seg = if kernel_on {
                                    // Counted already where the kernel was asked.
                                    Segment::straight(&ray, hit)
                                } else {
                                    known_segment(tr, &ray, hit, lanes.s[i].only_specular, st)
                                };
                                &known_seg
                            }
                        };
                        let (sh, go) = advance_lane(tr, lanes, i, sigma, seg, coincident, sp.as_ref(), st);
                        lined |= lanes.s[i].tnear != 0.0;
                        if let Some(sh) = sh {
                            waiting.push(((base + i) as u32, sh));
                        }
                        go
                    }
                };
                lanes.ended[i] = !go;
            }
            if shade.full(N) {
                flush!();
            }
        }
        if shade.count > 0 {
            flush!();
        }
        lined |= shade.lined;
        // The step's shadow rays, packed: each path's before its next
        // segment. (Each path has at most one.)
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
    Ok(())
}

/// Lane `i` shaded by the single-ray step: its path's state taken from the
/// columns, advanced past `seg`, and put back. (Out of line: the step is
/// large, and inlined it slows the lanes the kernel shades.)
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn advance_lane<const N: usize>(
    tr: Tracer<'_>,
    lanes: &mut PacketPaths<'_, N>,
    i: usize,
    sigma: Option<V3>,
    seg: &Segment,
    coincident: &Coincident,
    sp: Option<&SurfacePoint>,
    st: &mut Counters,
) -> (Option<PendingShadow>, bool) {
    let ray = lanes.ray(i);
    let s = &mut lanes.s[i];
    let mut p = PathState {
        l: s.l,
        beta: columns::get3(&lanes.beta, i),
        eta_scale: lanes.eta_scale[i],
        ray,
        specular: s.specular,
        prev_p: s.prev_p,
        prev_pdf: s.prev_pdf,
        // Read only where a segment went through a gradient-index medium,
        // which the wavefront never traces.
        prev_wi: ray.dir,
        prev_lambert: true,
        depth: s.depth,
        list: std::mem::take(&mut lanes.lists[i]),
        only_specular: s.only_specular,
    };
    let out = p.advance(tr, sigma, seg, coincident, sp, &mut s.rng, st);
    s.l = p.l;
    s.specular = p.specular;
    s.prev_p = p.prev_p;
    s.prev_pdf = p.prev_pdf;
    s.depth = p.depth;
    s.only_specular = p.only_specular;
    columns::set3(&mut lanes.beta, i, p.beta);
    lanes.eta_scale[i] = p.eta_scale;
    lanes.set_ray(i, &p.ray);
    lanes.lists[i] = p.list;
    out
}
