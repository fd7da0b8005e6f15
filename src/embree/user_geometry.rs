//! Analytic shapes as Embree user geometry: the [`UserShape`] trait, the
//! `extern "C"` bounds/intersect/occluded callbacks Embree calls for them, and
//! the panics caught inside those callbacks (counted per geometry, so one
//! scene's broken shape is never reported by another scene).
//!
//! The intersect and occluded callbacks share one lane loop, [`lanes`]; what
//! differs between them (the argument struct, what an accepted hit writes)
//! is a [`LaneQuery`].

use super::device::{panic_message, EmbreeError};
use super::filter::{context_skips, soa};
use embree_sys as sys;
use glam::Vec3A as V3;
use std::any::Any;
use std::ffi::c_void;
use std::mem::MaybeUninit;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::OnceLock;

/// Axis-aligned bounds of one user-geometry primitive, in scene units. They
/// must contain every point the primitive reports as a hit (pad them for
/// rounding): Embree only calls `intersect` for rays that reach the box.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    /// Smallest x, y, z.
    pub lower: [f32; 3],
    /// Largest x, y, z.
    pub upper: [f32; 3],
}

/// One candidate crossing of a ray with an analytic primitive.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Candidate {
    /// Ray parameter: the point is `org + t·dir`, so `t` is in units of
    /// `|dir|` (a distance only for a unit direction).
    pub t: f32,
    /// Geometric normal, any length, reported as is in [`Hit::ng`](super::Hit::ng)
    /// and [`FilterHit::ng`](super::FilterHit::ng). Closed solids must point
    /// it out of the solid (snell's nested-dielectric logic relies on it).
    pub ng: [f32; 3],
    /// The shape's first surface parameter (reported as `Hit::u`).
    pub u: f32,
    /// The shape's second surface parameter (reported as `Hit::v`).
    pub v: f32,
}

/// Up to four candidate crossings of one primitive; the callbacks sort them
/// by ascending `t` before use. Only the pushed items are ever written or
/// read: a callback makes one per active lane, and zeroing the four items
/// of each cost more than the pushes.
#[derive(Clone, Copy)]
pub struct Candidates {
    items: [MaybeUninit<Candidate>; 4],
    len: usize,
}

impl Default for Candidates {
    #[inline(always)]
    fn default() -> Self {
        Candidates {
            items: [MaybeUninit::uninit(); 4],
            len: 0,
        }
    }
}

impl std::fmt::Debug for Candidates {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.as_slice()).finish()
    }
}

impl Candidates {
    /// Add a candidate; silently ignores more than four (no analytic shape of
    /// snell has more than two crossings per primitive).
    #[inline(always)]
    pub fn push(&mut self, c: Candidate) {
        if self.len < self.items.len() {
            self.items[self.len].write(c);
            self.len += 1;
        }
    }

    /// The candidates pushed so far (in push order until the callback sorts them).
    #[inline(always)]
    pub fn as_slice(&self) -> &[Candidate] {
        // SAFETY: items[..len] were written by `push` (len never exceeds 4),
        // and MaybeUninit<Candidate> has Candidate's layout.
        unsafe { std::slice::from_raw_parts(self.items.as_ptr() as *const Candidate, self.len) }
    }

    /// Insertion sort by t: at most four items, where a generic slice sort
    /// shows in a nested trace's profile.
    #[inline]
    pub fn sort(&mut self) {
        // SAFETY: as in `as_slice`, mutably.
        let items =
            unsafe { std::slice::from_raw_parts_mut(self.items.as_mut_ptr() as *mut Candidate, self.len) };
        for i in 1..items.len() {
            let mut j = i;
            while j > 0 && items[j - 1].t > items[j].t {
                items.swap(j - 1, j);
                j -= 1;
            }
        }
    }
}

/// One active lane of a callback, as [`UserShape::intersect_lanes`] sees it.
#[derive(Debug, Clone, Copy, Default)]
pub struct LaneRay {
    /// Origin.
    pub org: V3,
    /// Direction (any length).
    pub dir: V3,
    /// Start of the ray interval.
    pub tnear: f32,
    /// End of the ray interval.
    pub tfar: f32,
}

/// An analytic shape exposed to Embree as user geometry
/// ([`SceneBuilder::add_user`](super::SceneBuilder::add_user)). Its methods run
/// inside Embree callbacks, possibly on several threads at once; a panic in
/// them is caught, makes the query see a miss and is reported by
/// [`Scene::check`](super::Scene::check).
pub trait UserShape: Send + Sync + 'static {
    /// Number of primitives (e.g. a closed cylinder: tube + two caps).
    fn prim_count(&self) -> u32 {
        1
    }
    /// Bounds of primitive `prim` (`prim < prim_count()`).
    fn bounds(&self, prim: u32) -> Bounds;
    /// Push every crossing of the ray `org + t·dir` with primitive `prim` onto
    /// `out`, for any t and in any order (the caller sorts them and clips
    /// to the ray interval). `dir` need not be unit length.
    fn intersect(&self, prim: u32, org: V3, dir: V3, out: &mut Candidates);

    /// [`intersect`](UserShape::intersect) restricted to the ray interval:
    /// push at least every crossing whose `t` lies in `[tnear, tfar]` (the
    /// callbacks clip to it anyway), in the order `intersect` would. A shape
    /// can skip the work of crossings outside it (the analytic shapes build
    /// no normal for them, and test for a tangent touch only when a root is
    /// inside). The default pushes all of them.
    #[inline]
    fn intersect_in(&self, prim: u32, org: V3, dir: V3, tnear: f32, tfar: f32, out: &mut Candidates) {
        let _ = (tnear, tfar);
        self.intersect(prim, org, dir, out);
    }

    /// [`intersect_in`](UserShape::intersect_in) of each of `rays` (the
    /// active lanes of one callback) into `out[k]` for `rays[k]`. A shape
    /// may compute the lanes side by side (independent arithmetic the
    /// processor overlaps, where one lane after the other waits on each
    /// lane's square roots and divisions); the result must be the same.
    /// The default calls `intersect_in` lane by lane.
    #[inline]
    fn intersect_lanes(&self, prim: u32, rays: &[LaneRay], out: &mut [Candidates]) {
        for (r, o) in rays.iter().zip(out) {
            self.intersect_in(prim, r.org, r.dir, r.tnear, r.tfar, o);
        }
    }
}

/// What Embree's `geometryUserPtr` points at for a user geometry: boxed and
/// owned by the builder, then the scene, so the address stays valid for the
/// scene's life.
pub(super) struct UserGeom {
    pub(super) shape: Box<dyn UserShape>,
    /// Panics caught in this geometry's callbacks (each made its query see a miss).
    panics: AtomicU64,
    /// The first such panic's message.
    first_panic: OnceLock<String>,
}

impl UserGeom {
    pub(super) fn new(shape: Box<dyn UserShape>) -> Self {
        UserGeom {
            shape,
            panics: AtomicU64::new(0),
            first_panic: OnceLock::new(),
        }
    }

    fn record_panic(&self, p: &(dyn Any + Send)) {
        self.panics.fetch_add(1, Ordering::Relaxed);
        self.first_panic.get_or_init(|| panic_message(p));
    }
}

/// `Err(UserGeometryPanicked)` when a callback of one of `geoms` has
/// panicked: their count, and the first panicking geometry's message.
pub(super) fn check_user_panics(geoms: &[Box<UserGeom>]) -> Result<(), EmbreeError> {
    let count: u64 = geoms.iter().map(|g| g.panics.load(Ordering::Relaxed)).sum();
    if count > 0 {
        let message = geoms
            .iter()
            .find_map(|g| g.first_panic.get().cloned())
            .unwrap_or_default();
        return Err(EmbreeError::UserGeometryPanicked { count, message });
    }
    Ok(())
}

/// Record the panic `p` caught in a callback of the geometry `user` points at.
///
/// # Safety
/// `user` must be the `geometryUserPtr` Embree passed to the callback: a
/// `UserGeom` of `add_user`, alive for the scene's life.
unsafe fn record_user_panic(user: *mut c_void, p: &(dyn Any + Send)) {
    // SAFETY: guaranteed by the caller.
    let g = unsafe { &*(user as *const UserGeom) };
    g.record_panic(p);
}

/// The bounds callback (`RTCBoundsFunction`) of every user geometry.
pub(super) unsafe extern "C" fn user_bounds(args: *const sys::RTCBoundsFunctionArguments) {
    let r = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: Embree passes valid arguments; geometryUserPtr is our UserGeom
        // (see `add_user`), bounds_o is writable.
        unsafe {
            let a = &*args;
            let g = &*(a.geometryUserPtr as *const UserGeom);
            let b = g.shape.bounds(a.primID);
            let o = &mut *a.bounds_o;
            o.lower_x = b.lower[0];
            o.lower_y = b.lower[1];
            o.lower_z = b.lower[2];
            o.upper_x = b.upper[0];
            o.upper_y = b.upper[1];
            o.upper_z = b.upper[2];
        }
    }));
    if let Err(p) = r {
        // SAFETY: Embree passes valid arguments whose geometryUserPtr is our UserGeom.
        unsafe { record_user_panic((*args).geometryUserPtr, &*p) };
    }
}

/// The intersect callback (`RTCIntersectFunctionN`) of every user geometry.
pub(super) unsafe extern "C" fn user_intersect(args: *const sys::RTCIntersectFunctionNArguments) {
    let r = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: Embree calls this callback only for geometries made by
        // `add_user`, with the arguments of its intersect contract.
        unsafe { lanes::<Intersect>(args) }
    }));
    if let Err(p) = r {
        // SAFETY: as in `user_bounds`.
        unsafe { record_user_panic((*args).geometryUserPtr, &*p) };
    }
}

/// The occluded callback (`RTCOccludedFunctionN`) of every user geometry.
pub(super) unsafe extern "C" fn user_occluded(args: *const sys::RTCOccludedFunctionNArguments) {
    let r = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: Embree calls this callback only for geometries made by
        // `add_user`, with the arguments of its occluded contract.
        unsafe { lanes::<Occluded>(args) }
    }));
    if let Err(p) = r {
        // SAFETY: as in `user_bounds`.
        unsafe { record_user_panic((*args).geometryUserPtr, &*p) };
    }
}

/// The accessors of the fields that Embree's intersect and occluded callback
/// arguments share (same names, but distinct structs; the ray block is
/// `rayhit` in one and `ray` in the other).
macro_rules! lane_fields {
    ($ray:ident) => {
        #[inline(always)]
        fn valid(a: &Self::Args) -> *const i32 {
            a.valid
        }
        #[inline(always)]
        fn user(a: &Self::Args) -> *mut c_void {
            a.geometryUserPtr
        }
        #[inline(always)]
        fn prim_id(a: &Self::Args) -> u32 {
            a.primID
        }
        #[inline(always)]
        fn geom_id(a: &Self::Args) -> u32 {
            a.geomID
        }
        #[inline(always)]
        fn context(a: &Self::Args) -> *mut sys::RTCIntersectContext {
            a.context
        }
        #[inline(always)]
        fn n(a: &Self::Args) -> usize {
            a.N as usize
        }
        #[inline(always)]
        fn ray(a: &Self::Args) -> *mut f32 {
            a.$ray as *mut f32
        }
    };
}

/// What differs between the intersect and the occluded callback. The field
/// accessors are read where the loop needs them, not copied up front (a
/// copy per callback is work the loop does not need).
trait LaneQuery {
    /// Embree's argument struct for the callback.
    type Args;
    /// Valid mask, `n` ints (0 = inactive lane).
    fn valid(a: &Self::Args) -> *const i32;
    /// `geometryUserPtr`: our `UserGeom`.
    fn user(a: &Self::Args) -> *mut c_void;
    /// The primitive to intersect.
    fn prim_id(a: &Self::Args) -> u32;
    /// The geometry's id.
    fn geom_id(a: &Self::Args) -> u32;
    /// The query's intersect context (ours, or a `FilterContext`'s).
    fn context(a: &Self::Args) -> *mut sys::RTCIntersectContext;
    /// Number of lanes.
    fn n(a: &Self::Args) -> usize;
    /// The SoA ray block (`RTCRayN`, or the ray part of `RTCRayHitN`), `n` lanes.
    fn ray(a: &Self::Args) -> *mut f32;

    /// Record the accepted hit `hit` of lane `i` whose t is already in tfar.
    ///
    /// # Safety
    /// `ray` is the callback's SoA block of `n` lanes, `i < n`.
    unsafe fn accept(ray: *mut f32, i: usize, n: usize, hit: &sys::RTCHit);
}

/// `rtcIntersect*`: the nearest accepted candidate becomes the lane's hit.
enum Intersect {}

impl LaneQuery for Intersect {
    type Args = sys::RTCIntersectFunctionNArguments;
    lane_fields!(rayhit);

    #[inline(always)]
    unsafe fn accept(ray: *mut f32, i: usize, n: usize, hit: &sys::RTCHit) {
        let h = [
            hit.Ng_x,
            hit.Ng_y,
            hit.Ng_z,
            hit.u,
            hit.v,
            f32::from_bits(hit.primID),
            f32::from_bits(hit.geomID),
            f32::from_bits(hit.instID[0]),
        ];
        // SAFETY: in an RTCRayHitN of n lanes, the RTCHitN block of 8 fields
        // follows the 12 ray fields; lane i < n of each field is in bounds.
        unsafe {
            let hit_base = ray.add(12 * n);
            for (k, v) in h.iter().enumerate() {
                *hit_base.add(soa(k, i, n)) = *v;
            }
        }
    }
}

/// `rtcOccluded*`: any accepted candidate marks the lane occluded.
enum Occluded {}

impl LaneQuery for Occluded {
    type Args = sys::RTCOccludedFunctionNArguments;
    lane_fields!(ray);

    #[inline(always)]
    unsafe fn accept(ray: *mut f32, i: usize, n: usize, _hit: &sys::RTCHit) {
        // SAFETY: tfar (field 8) of lane i < n of the n-lane RTCRayN.
        unsafe { *ray.add(soa(8, i, n)) = f32::NEG_INFINITY }; // Embree's "occluded"
    }
}

/// Embree's widest packet (`rtcIntersect16`): the most lanes one callback
/// has, and the rays it hands to [`UserShape::intersect_lanes`] at once.
const MAX_CALLBACK_LANES: usize = 16;

/// The lane loop of both callbacks: for each active lane, intersect the shape,
/// sort the candidates, clip them to `[tnear, tfar]`, and offer them nearest
/// first to the context filter (if any); the first accepted one is recorded
/// by `Q::accept`.
///
/// # Safety
/// `args` must be the arguments Embree passes to the `Q` callback of a
/// geometry created by `add_user`.
#[inline(always)]
unsafe fn lanes<Q: LaneQuery>(args: *const Q::Args) {
    // SAFETY: guaranteed by the caller (Embree's callback contract): `args`, its
    // valid mask of N ints and its SoA ray block of N lanes are valid for this
    // call; geometryUserPtr is our UserGeom (`add_user`), and `context` is a
    // valid intersect context (ours, or `FilterContext`'s base). The slices
    // over the lane arrays cover only their first m entries, each written
    // before (MaybeUninit<T> has T's layout).
    unsafe {
        let a = &*args;
        let n = Q::n(a);
        let g = &*(Q::user(a) as *const UserGeom);
        let r = Q::ray(a);
        // The active lanes, sixteen at a time (Embree's N is at most 16).
        let mut base = 0;
        while base < n {
            let end = (base + MAX_CALLBACK_LANES).min(n);
            let mut idx = [0u8; MAX_CALLBACK_LANES];
            let mut lane_rays = [MaybeUninit::<LaneRay>::uninit(); MAX_CALLBACK_LANES];
            let mut m = 0;
            for i in base..end {
                if *Q::valid(a).add(i) == 0 {
                    continue;
                }
                idx[m] = (i - base) as u8;
                lane_rays[m].write(LaneRay {
                    org: V3::new(*r.add(soa(0, i, n)), *r.add(soa(1, i, n)), *r.add(soa(2, i, n))),
                    dir: V3::new(*r.add(soa(4, i, n)), *r.add(soa(5, i, n)), *r.add(soa(6, i, n))),
                    tnear: *r.add(soa(3, i, n)),
                    tfar: *r.add(soa(8, i, n)),
                });
                m += 1;
            }
            let first = base;
            base = end;
            if m == 0 {
                continue;
            }
            // The first m lanes were written just above (the arrays are not
            // zeroed: a callback usually has one to four active lanes).
            let rays = std::slice::from_raw_parts(lane_rays.as_ptr() as *const LaneRay, m);
            let mut cand_store = [MaybeUninit::<Candidates>::uninit(); MAX_CALLBACK_LANES];
            for c in &mut cand_store[..m] {
                // Only `len` (the items are MaybeUninit, valid uninitialised):
                // writing `Candidates::default()` became a memset of every
                // lane's 104 bytes.
                std::ptr::addr_of_mut!((*c.as_mut_ptr()).len).write(0);
            }
            let cands = std::slice::from_raw_parts_mut(cand_store.as_mut_ptr() as *mut Candidates, m);
            if m == 1 {
                let ray = &rays[0];
                g.shape.intersect_in(
                    Q::prim_id(a),
                    ray.org,
                    ray.dir,
                    ray.tnear,
                    ray.tfar,
                    &mut cands[0],
                );
            } else {
                g.shape.intersect_lanes(Q::prim_id(a), rays, cands);
            }
            for (k, cands) in cands.iter_mut().enumerate() {
                let i = first + idx[k] as usize;
                let (tnear, tfar) = (rays[k].tnear, rays[k].tfar);
                cands.sort();
                for c in cands.as_slice() {
                    if !(c.t >= tnear && c.t <= tfar) {
                        continue;
                    }
                    let tfar_ptr = r.add(soa(8, i, n));
                    // Potential hit in single-lane layout; filters read t from ray.tfar.
                    let mut potential = sys::RTCHit {
                        Ng_x: c.ng[0],
                        Ng_y: c.ng[1],
                        Ng_z: c.ng[2],
                        u: c.u,
                        v: c.v,
                        primID: Q::prim_id(a),
                        geomID: Q::geom_id(a),
                        instID: [(*Q::context(a)).instID[0]],
                    };
                    *tfar_ptr = c.t;
                    // Without a context filter there is nothing to call: user
                    // geometries never get per-geometry filters (`add_user`), so
                    // rtcFilterIntersection/Occlusion would accept the hit anyway;
                    // with one, they would call it and nothing else, so it is
                    // called directly, skipping Embree's dispatch.
                    // Wide queries are not used by snell's filters; their hits
                    // are accepted directly. Nor is it called for a geometry the
                    // filtered query's skip ranges name (`context_skips`: a
                    // context with a filter is a FilterContext's).
                    let filter = (*Q::context(a)).filter;
                    if let Some(filter) =
                        filter.filter(|_| n == 1 && !context_skips(Q::context(a), Q::geom_id(a)))
                    {
                        let mut lane_valid: i32 = -1;
                        let fargs = sys::RTCFilterFunctionNArguments {
                            valid: &mut lane_valid,
                            geometryUserPtr: Q::user(a),
                            context: Q::context(a),
                            ray: r as *mut sys::RTCRayN,
                            hit: &mut potential as *mut sys::RTCHit as *mut sys::RTCHitN,
                            N: 1,
                        };
                        // The context filter with the argument block Embree's
                        // rtcFilter* would pass it (under this block's SAFETY).
                        filter(&fargs);
                        if lane_valid == 0 {
                            *tfar_ptr = tfar;
                            continue;
                        }
                    }
                    Q::accept(r, i, n, &potential);
                    break; // candidates are sorted: the first accepted one is nearest
                }
            }
        }
    }
}
