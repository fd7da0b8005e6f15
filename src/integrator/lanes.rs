//! Paths traced side by side, the entry points of the wavefront
//! (`wavefront`): their plain-query segments and shadow rays go to Embree (or
//! to the scene's analytic set) in packets, and each lane is shaded in
//! vector registers where the kernel can shade it, else by the same step as
//! a single ray ([`PathState::advance`](super::path::PathState)).
use super::columns::PathColumns;
use super::light::PendingShadow;
use super::path::PathStart;
use super::shade_lanes::ShadeLanes;
use super::wavefront::{stream, Stream};
use super::Tracer;
use crate::counters::Counters;
use crate::dielectric::InteriorList;
use crate::embree::RayPacket;
use crate::error::Result;
use crate::sampling::Rng;
use crate::scene::shapes::SetScratch;
use crate::scene::IntegratorKind;
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
    /// The counters of [`path_stream`]'s paths, kept for their allocation.
    own: Vec<Counters>,
    /// A step's shadow rays: the place of their path in the front and the
    /// connection (kept apart from the paths, which move as the front
    /// shrinks).
    waiting: Vec<(u32, PendingShadow)>,
    /// The lanes of a packet between the phases of vector shading.
    shade: Box<ShadeLanes>,
    /// The paths of a wavefront.
    columns: PathColumns,
    /// Shade lanes in vector registers where [`ShadeLanes::applies`].
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
    done: impl FnMut(u32, V3, &Counters),
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
    stream(tr, list, starts, done, per_path, stats, *vector_shading, storage)
}
