//! Rust hit filters run as Embree *context filters*: the [`HitFilter`] trait,
//! the hit it sees ([`FilterHit`]), the extended intersect context that carries
//! it through Embree ([`FilterContext`]) and the `extern "C"` trampoline Embree
//! calls. Also the helpers every query uses: [`init_context`] (Embree's inline
//! `rtcInitIntersectContext`) and [`soa`] (lane addressing in `RTCRayN`/`RTCHitN`).

use super::device::{panic_message, EmbreeError};
use super::INVALID_ID;
use embree_sys as sys;
use glam::Vec3A as V3;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Float index of field `k` of lane `i` in an SoA ray/hit block of width `n`.
#[inline(always)]
pub(super) fn soa(k: usize, i: usize, n: usize) -> usize {
    k * n + i
}

/// A hit as a filter sees it, before it is accepted. Same conventions as
/// [`Hit`](super::Hit): t in units of `|dir|`, the geometric normal unnormalised
/// and as the geometry reports it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterHit {
    /// Embree's geometry id.
    pub geom_id: u32,
    /// Primitive within the geometry.
    pub prim_id: u32,
    /// Ray parameter of the potential hit, in units of `|dir|`.
    pub t: f32,
    /// Unnormalised geometric normal (triangles: `(v1-v0)×(v2-v0)`; user
    /// geometry: the shape's [`Candidate::ng`](super::Candidate::ng)).
    pub ng: V3,
    /// The query ray's origin.
    pub org: V3,
    /// The query ray's direction (as given, not normalised).
    pub dir: V3,
    /// First barycentric coordinate (triangles) or the shape's own parameter
    /// (user geometry).
    pub u: f32,
    /// Second barycentric coordinate (triangles) or the shape's own parameter
    /// (user geometry).
    pub v: f32,
}

/// A Rust intersection filter, run as an Embree context filter. Embree calls it
/// in traversal order (not nearest first), possibly for hits beyond the final
/// nearest one, and possibly more than once for the same surface crossing.
pub trait HitFilter {
    /// Return `false` to reject the hit (Embree then continues the traversal).
    /// A panic here is caught: the query rejects every later hit and returns
    /// [`EmbreeError::FilterPanicked`].
    fn accept(&mut self, hit: &FilterHit) -> bool;
}

/// Which geometries a filtered query's filter need not see
/// ([`Scene::intersect_filtered_skipping`](super::Scene::intersect_filtered_skipping)):
/// a hit on geometry `g` is
/// accepted without a call when `ranges[g].0 <= key <= ranges[g].1`
/// (geometries past the end of `ranges` are always passed to the filter).
/// Analytic shapes then skip the call altogether, triangles leave the
/// trampoline before reading the hit: most of a call's cost.
#[derive(Debug, Clone, Copy)]
pub struct SkipRanges<'a> {
    /// Per geometry id: the inclusive range of `key` for which its hits are accepted unseen.
    pub ranges: &'a [(u32, u32)],
    /// This query's key (e.g. the ray's top rank).
    pub key: u32,
}

impl SkipRanges<'_> {
    /// Skip nothing.
    pub const NONE: SkipRanges<'static> = SkipRanges { ranges: &[], key: 0 };
}

/// The part of every [`FilterContext`] that does not depend on the filter's
/// type: Embree's context, then the skip ranges. `#[repr(C)]` and first in
/// `FilterContext`, so code that only knows the raw context (the analytic
/// shapes' intersect callback) can read the ranges of any filtered query.
#[repr(C)]
pub(super) struct FilterHead {
    base: sys::RTCIntersectContext,
    ranges: *const (u32, u32),
    len: usize,
    key: u32,
}

impl FilterHead {
    /// Accept hits on `geom` without calling the filter?
    #[inline(always)]
    fn skips(&self, geom: u32) -> bool {
        let g = geom as usize;
        if g >= self.len {
            return false;
        }
        // SAFETY: `ranges` points at `len` entries borrowed for the life of
        // the context (`FilterContext::new`), and g < len.
        let (lo, hi) = unsafe { *self.ranges.add(g) };
        lo <= self.key && self.key <= hi
    }
}

/// For an analytic shape's intersect callback, given its query's context:
/// is `geom`'s hit accepted without calling the context filter? `false` for a
/// context without a filter (nothing would be called anyway).
///
/// # Safety
/// `ctx` is the context Embree passed to the callback: `init_context`'s or
/// the `base` of a live [`FilterContext`] (the only contexts snell passes,
/// and every one with a filter is a `FilterContext`).
#[inline(always)]
pub(super) unsafe fn context_skips(ctx: *const sys::RTCIntersectContext, geom: u32) -> bool {
    // SAFETY: the caller's contract: `ctx` is valid, and when its filter is
    // set it is the first field of a #[repr(C)] FilterContext, whose first
    // field is a FilterHead.
    unsafe { (*ctx).filter.is_some() && (*(ctx as *const FilterHead)).skips(geom) }
}

/// The extended intersection context: Embree's context first, then our payload.
/// Embree hands the pointer to `base` back to the trampoline, which casts it to
/// the whole struct; `#[repr(C)]` with `base` first makes that cast valid.
/// Built by the filtered queries of [`Scene`](super::Scene); not constructible
/// outside this module tree.
#[repr(C)]
pub struct FilterContext<'a, F: HitFilter> {
    head: FilterHead,
    filter: &'a mut F,
    panic: Option<String>,
    /// The skip ranges' borrow (`head` holds them as a raw pointer).
    _ranges: std::marker::PhantomData<&'a [(u32, u32)]>,
}

impl<'a, F: HitFilter> FilterContext<'a, F> {
    /// A context whose filter function is the trampoline for `F`, which
    /// accepts the hits `skip` names without calling `filter`.
    #[inline]
    pub(super) fn new(filter: &'a mut F, skip: SkipRanges<'a>) -> Self {
        let SkipRanges { ranges, key } = skip;
        let (ranges, len) = (ranges.as_ptr(), ranges.len());
        FilterContext {
            head: FilterHead {
                base: init_context(Some(filter_trampoline::<F>)),
                ranges,
                len,
                key,
            },
            filter,
            panic: None,
            _ranges: std::marker::PhantomData,
        }
    }

    /// The pointer to pass to `rtcIntersect1`/`rtcOccluded1`: derived from the
    /// whole struct (not from `&mut self.base`), so the trampoline may reach
    /// the fields after `base` through it.
    #[inline]
    pub(super) fn as_raw(&mut self) -> *mut sys::RTCIntersectContext {
        (self as *mut Self).cast::<sys::RTCIntersectContext>()
    }

    /// After the query: `Err(FilterPanicked)` if the filter panicked.
    #[inline]
    pub(super) fn finish(self) -> Result<(), EmbreeError> {
        match self.panic {
            Some(p) => Err(EmbreeError::FilterPanicked(p)),
            None => Ok(()),
        }
    }
}

/// `rtcInitIntersectContext` is an inline C function; this is its body for
/// Embree 3.13 (flags incoherent, no filter, instance stack invalid), with
/// `filter` as the context filter.
#[inline]
pub(super) fn init_context(filter: sys::RTCFilterFunctionN) -> sys::RTCIntersectContext {
    let mut ctx = sys::RTCIntersectContext {
        flags: sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
        filter,
        ..Default::default()
    };
    for id in ctx.instID.iter_mut() {
        *id = INVALID_ID;
    }
    ctx
}

/// The context filter function of a [`FilterContext<F>`]: reads each valid
/// lane's potential hit, asks `F`, and clears the lane's valid flag on reject.
/// A one-lane hit on a geometry the context's skip ranges name returns at
/// once (accepted), before anything else is read.
unsafe extern "C" fn filter_trampoline<F: HitFilter>(args: *const sys::RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes valid arguments.
    let a = unsafe { &*args };
    if a.N == 1 {
        // SAFETY: `context` is the `base` field of a live `FilterContext<F>`
        // (only `FilterContext::<F>::new` installs this trampoline, and the
        // queries pass `FilterContext::as_raw`, a pointer to the whole
        // struct), whose first field is a #[repr(C)] `FilterHead`; the hit
        // block has one lane, whose field 6 is geomID.
        let skip = unsafe {
            let head = &*(a.context as *const FilterHead);
            head.skips((*(a.hit as *const f32).add(soa(6, 0, 1))).to_bits())
        };
        if skip {
            return;
        }
    }
    // SAFETY: as above.
    unsafe { filter_lanes::<F>(a) }
}

/// The trampoline's calls of the filter, out of line so that a skipped hit
/// costs the trampoline no stack frame.
///
/// # Safety
/// `a` is the argument block Embree passed to [`filter_trampoline::<F>`].
#[inline(never)]
unsafe fn filter_lanes<F: HitFilter>(a: &sys::RTCFilterFunctionNArguments) {
    // SAFETY: `context` is the `base` field of a live `FilterContext<F>` (see
    // `filter_trampoline`); `base` is the first field of the #[repr(C)] head,
    // itself first in the #[repr(C)] struct.
    let ctx = unsafe { &mut *(a.context as *mut FilterContext<'_, F>) };
    if ctx.panic.is_some() {
        // A previous call panicked: reject everything, the query result is discarded.
        for i in 0..a.N as usize {
            // SAFETY: `valid` has N entries.
            unsafe { *a.valid.add(i) = 0 };
        }
        return;
    }
    let n = a.N as usize;
    let ray = a.ray as *const f32;
    let hit = a.hit as *const f32;
    if n == 1 {
        // Single-ray queries (every query of `dielectric::trace`): the lane
        // addressing folds to constants, cheaper than the general loop below.
        // SAFETY: lane 0 of the one-lane blocks Embree passed (N = 1).
        unsafe { filter_lane(ctx, a, ray, hit, 0, 1) };
        return;
    }
    for i in 0..n {
        // SAFETY: i < N (Embree contract: valid mask, ray and hit blocks have
        // N lanes); field 6 of the hit block is geomID.
        unsafe {
            if !ctx.head.skips((*hit.add(soa(6, i, n))).to_bits()) {
                filter_lane(ctx, a, ray, hit, i, n);
            }
        }
    }
}

/// Run the filter on lane `i` of `n` and clear the lane's valid flag when it
/// rejects (or panics).
///
/// # Safety
/// `a` is Embree's argument block of this call, `ray`/`hit` its ray and hit
/// blocks, `n` its `N` and `i < n`.
#[inline(always)]
unsafe fn filter_lane<F: HitFilter>(
    ctx: &mut FilterContext<'_, F>,
    a: &sys::RTCFilterFunctionNArguments,
    ray: *const f32,
    hit: *const f32,
    i: usize,
    n: usize,
) {
    // SAFETY: lane i < N of the valid mask, ray and hit blocks (caller's contract).
    let fh = unsafe {
        if *a.valid.add(i) == 0 {
            return;
        }
        FilterHit {
            org: V3::new(
                *ray.add(soa(0, i, n)),
                *ray.add(soa(1, i, n)),
                *ray.add(soa(2, i, n)),
            ),
            dir: V3::new(
                *ray.add(soa(4, i, n)),
                *ray.add(soa(5, i, n)),
                *ray.add(soa(6, i, n)),
            ),
            t: *ray.add(soa(8, i, n)),
            ng: V3::new(
                *hit.add(soa(0, i, n)),
                *hit.add(soa(1, i, n)),
                *hit.add(soa(2, i, n)),
            ),
            prim_id: (*hit.add(soa(5, i, n))).to_bits(),
            u: *hit.add(soa(3, i, n)),
            v: *hit.add(soa(4, i, n)),
            geom_id: (*hit.add(soa(6, i, n))).to_bits(),
        }
    };
    let filter = &mut *ctx.filter;
    match catch_unwind(AssertUnwindSafe(|| filter.accept(&fh))) {
        Ok(true) => {}
        Ok(false) => {
            // SAFETY: lane i of the N-entry valid mask.
            unsafe { *a.valid.add(i) = 0 };
        }
        Err(p) => {
            ctx.panic = Some(panic_message(&*p));
            // SAFETY: lane i of the N-entry valid mask.
            unsafe { *a.valid.add(i) = 0 };
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn init_context_matches_inline_c() {
        let c = init_context(None);
        assert_eq!(c.flags, sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT);
        assert!(c.filter.is_none());
        assert!(c.instID.iter().all(|&i| i == INVALID_ID));
    }
}
