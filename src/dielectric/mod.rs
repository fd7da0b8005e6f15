//! Nested dielectrics (Schmidt & Budge 2002): priorities, the per-ray
//! [`InteriorList`], and the three ways of finding the first *true* hit:
//!
//! - [`NestedStrategy::Filter`] (default): false hits are skipped inside an
//!   Embree context filter ([`FalseHitFilter`]). The rule (DESIGN.md): with P0
//!   the highest rank in the list at the ray origin, the first true hit is the
//!   nearest hit on any object of rank ≥ P0, so the filter is stateless and
//!   traversal order does not matter. Rejected hits are recorded and applied to
//!   the list after the query, in t order, de-duplicated.
//! - [`NestedStrategy::Recast`]: the paper's method. Nearest hit; if false,
//!   update the list and cast again from just past it.
//! - [`NestedStrategy::Toggle`]: `Recast` with the paper's toggle in place of
//!   the geometric normal for deciding entering vs leaving.
//!
//! Priorities: the higher priority wins, as in the paper, Arnold and RenderMan.
//! Ties are broken by declaration order: of two solids with equal priority the
//! one declared later in the scene file wins, as if its priority were higher by
//! an infinitesimal (`Solid::rank`). This makes true/false a total order.
pub mod audit;

use crate::embree::{FilterHit, HitFilter};
use crate::ray::{crossing_window, window_coefficients, Hit, Ray};
use crate::scene::RenderScene;

/// How false hits are found and skipped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NestedStrategy {
    Filter,
    Recast,
    Toggle,
    /// No nesting at all: every hit is true, lists are ignored. Wrong for
    /// overlapping solids; the "unmodified ray tracer" speed reference.
    Off,
}

impl std::str::FromStr for NestedStrategy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "filter" => Ok(NestedStrategy::Filter),
            "recast" => Ok(NestedStrategy::Recast),
            "toggle" => Ok(NestedStrategy::Toggle),
            "off" => Ok(NestedStrategy::Off),
            o => Err(format!("expected filter, recast, toggle or off, got \"{o}\"")),
        }
    }
}

impl NestedStrategy {
    pub fn name(self) -> &'static str {
        match self {
            NestedStrategy::Filter => "filter",
            NestedStrategy::Recast => "recast",
            NestedStrategy::Toggle => "toggle",
            NestedStrategy::Off => "off",
        }
    }
}

const INLINE: usize = 6;

/// The solids a ray is inside (solid indices), unordered, without a fixed cap:
/// six entries inline, more spill to the heap (counted by the caller).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct InteriorList {
    len: u32,
    inline: [u32; INLINE],
    spill: Vec<u32>,
}

impl InteriorList {
    pub fn new() -> Self {
        Self::default()
    }

    pub fn from_slice(s: &[u32]) -> Self {
        let mut l = Self::new();
        for &x in s {
            l.insert(x);
        }
        l
    }

    pub fn len(&self) -> usize {
        self.len as usize
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Has this list ever needed the heap?
    pub fn spilled(&self) -> bool {
        !self.spill.is_empty()
    }

    fn get(&self, i: usize) -> u32 {
        if i < INLINE {
            self.inline[i]
        } else {
            self.spill[i - INLINE]
        }
    }

    pub fn iter(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.len()).map(|i| self.get(i))
    }

    pub fn contains(&self, s: u32) -> bool {
        self.iter().any(|x| x == s)
    }

    /// Add `s` if absent (idempotent: a duplicate report of an entry is harmless).
    pub fn insert(&mut self, s: u32) {
        if self.contains(s) {
            return;
        }
        let n = self.len();
        if n < INLINE {
            self.inline[n] = s;
        } else {
            self.spill.push(s);
        }
        self.len += 1;
    }

    /// Remove `s` if present (idempotent).
    pub fn remove(&mut self, s: u32) {
        let Some(pos) = self.iter().position(|x| x == s) else {
            return;
        };
        let last = self.len() - 1;
        let lv = self.get(last);
        if pos < INLINE {
            self.inline[pos] = lv;
        } else {
            self.spill[pos - INLINE] = lv;
        }
        if last >= INLINE {
            self.spill.pop();
        }
        self.len -= 1;
    }

    /// Flip membership (the paper's toggle).
    pub fn toggle(&mut self, s: u32) {
        if self.contains(s) {
            self.remove(s)
        } else {
            self.insert(s)
        }
    }

    /// The entry with the highest rank, by `rank(solid)`.
    #[inline]
    pub fn top(&self, rank: impl Fn(u32) -> u32) -> Option<u32> {
        self.iter().max_by_key(|&s| rank(s))
    }

    /// Sorted copy (for comparisons).
    pub fn sorted(&self) -> Vec<u32> {
        let mut v: Vec<u32> = self.iter().collect();
        v.sort_unstable();
        v
    }
}

/// A false hit the filter rejected: which solid, where, which way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rejected {
    pub solid: u32,
    pub prim: u32,
    pub t: f32,
    pub entering: bool,
    /// Within `EDGE_EPS` (barycentric) of a mesh edge or vertex, where the
    /// normal alone cannot tell a crossing from a touch: verified after the query.
    pub near_edge: bool,
}

/// Barycentric distance to a triangle edge below which a hit is verified by
/// point-in-solid tests (Embree's robust mode closes edge leaks, not vertex ones).
pub const EDGE_EPS: f32 = 2e-4;

#[inline]
fn near_edge(u: f32, v: f32) -> bool {
    u.min(v).min(1.0 - u - v) < EDGE_EPS
}

/// Rejected hits recorded per query before the filter falls back.
pub const REJECT_CAPACITY: usize = 32;

/// The filter's record buffers. They live per thread (`RECORDS`) and are
/// reused: initialising them on every query was ~200 instructions, 40% of the
/// filter's cost over a plain query (callgrind, glass_of_water_nested).
pub struct FilterRecords {
    pub rejected: [Rejected; REJECT_CAPACITY],
    /// Accepted hits on solids within the crossing window of the nearest
    /// accepted t seen so far: after the query these are the true hit and any
    /// solid surfaces coincident with it.
    pub near: [Rejected; NEAR_CAPACITY],
}

impl Default for FilterRecords {
    fn default() -> Self {
        let zero = Rejected {
            solid: 0,
            prim: 0,
            t: 0.0,
            entering: false,
            near_edge: false,
        };
        FilterRecords {
            rejected: [zero; REJECT_CAPACITY],
            near: [zero; NEAR_CAPACITY],
        }
    }
}

thread_local! {
    static RECORDS: std::cell::RefCell<FilterRecords> = std::cell::RefCell::new(FilterRecords::default());
}

/// The Embree context filter: rejects hits on solids ranked below `p0` and
/// records them. Stateless in its decision, so traversal order does not matter.
pub struct FalseHitFilter<'a> {
    pub rank_by_geom: &'a [u32],
    pub solid_by_geom: &'a [Option<u32>],
    pub p0: u32,
    /// `rec.rejected[..len]` and `rec.near[..near_len]` are this query's.
    pub rec: &'a mut FilterRecords,
    pub len: usize,
    pub overflow: bool,
    pub calls: u32,
    pub near_len: usize,
    pub near_t: f32,
    /// `crossing_window` of this query's ray is `win_a + win_b · t`
    /// (precomputed: no square root per callback).
    win_a: f32,
    win_b: f32,
}

/// Coincident accepted crossings tracked per query.
pub const NEAR_CAPACITY: usize = 4;

impl<'a> FalseHitFilter<'a> {
    /// A filter for one query of `ray` by a ray whose list's top rank is `p0`,
    /// recording into `rec` (whose old contents are ignored).
    pub fn new(scene: &'a RenderScene, p0: u32, ray: &Ray, rec: &'a mut FilterRecords) -> Self {
        let (win_a, win_b) = window_coefficients(ray.org, ray.dir);
        FalseHitFilter {
            win_a,
            win_b,
            rank_by_geom: &scene.rank_by_geom,
            solid_by_geom: &scene.solid_by_geom,
            p0,
            rec,
            len: 0,
            overflow: false,
            calls: 0,
            near_len: 0,
            near_t: f32::INFINITY,
        }
    }
}

impl HitFilter for FalseHitFilter<'_> {
    #[inline]
    fn accept(&mut self, h: &FilterHit) -> bool {
        self.calls += 1;
        let g = h.geom_id as usize;
        if self.rank_by_geom[g] >= self.p0 {
            if let Some(solid) = self.solid_by_geom[g] {
                self.note_accepted(solid, h);
            }
            return true;
        }
        if self.len < REJECT_CAPACITY {
            self.rec.rejected[self.len] = Rejected {
                solid: self.solid_by_geom[g].unwrap_or(u32::MAX),
                prim: h.prim_id,
                t: h.t,
                entering: h.ng.dot(h.dir) < 0.0,
                near_edge: near_edge(h.u, h.v),
            };
            self.len += 1;
        } else {
            self.overflow = true;
        }
        false
    }
}

impl FalseHitFilter<'_> {
    /// Keep accepted solid hits within the window of the nearest one so far.
    #[inline]
    fn note_accepted(&mut self, solid: u32, h: &FilterHit) {
        // = crossing_window(h.org, h.dir, min(near_t, t)) for this query's ray.
        let t = self.near_t.min(h.t);
        let win = self.win_a + self.win_b * if t.is_finite() { t.abs() } else { 0.0 };
        if h.t > self.near_t + win {
            return;
        }
        if h.t < self.near_t {
            self.near_t = h.t;
            let keep = self.near_t + win;
            let mut k = 0;
            for i in 0..self.near_len {
                if self.rec.near[i].t <= keep {
                    self.rec.near[k] = self.rec.near[i];
                    k += 1;
                }
            }
            self.near_len = k;
        }
        let r = Rejected {
            solid,
            prim: h.prim_id,
            t: h.t,
            entering: h.ng.dot(h.dir) < 0.0,
            near_edge: near_edge(h.u, h.v),
        };
        if self.near_len < NEAR_CAPACITY {
            self.rec.near[self.near_len] = r;
            self.near_len += 1;
        } else {
            self.overflow = true;
        }
    }
}

/// Solid crossings at the same point as a true hit (coincident faces), beyond
/// the true hit's own solid: (solid, entering).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Coincident {
    items: [(u32, bool); NEAR_CAPACITY],
    len: usize,
    /// Solids both entered and left at the point (a touch): no crossing.
    touched: [u32; NEAR_CAPACITY],
    touched_len: usize,
}

impl Coincident {
    pub fn as_slice(&self) -> &[(u32, bool)] {
        &self.items[..self.len]
    }
    /// Add a report. A duplicate of one direction counts once; reports of
    /// both directions of one solid cancel, as in `apply_rejected` (a ray
    /// through the circle where two spheres meet can graze the second one:
    /// the entry alone left it in the list after the ray had left it).
    fn push(&mut self, solid: u32, entering: bool) {
        if self.touched[..self.touched_len].contains(&solid) {
            return;
        }
        if let Some(i) = self.as_slice().iter().position(|c| c.0 == solid) {
            if self.items[i].1 != entering {
                self.items[i] = self.items[self.len - 1];
                self.len -= 1;
                if self.touched_len < NEAR_CAPACITY {
                    self.touched[self.touched_len] = solid;
                    self.touched_len += 1;
                }
            }
            return;
        }
        if self.len < NEAR_CAPACITY {
            self.items[self.len] = (solid, entering);
            self.len += 1;
        }
    }
}

/// The first true hit of a query and the solid surfaces coincident with it.
#[derive(Debug, Clone, Copy)]
pub struct TrueHit {
    pub hit: Hit,
    pub coincident: Coincident,
}

#[inline]
fn window(r: &Ray, t: f32) -> f32 {
    crossing_window(r.org, r.dir, t)
}

/// Apply recorded false hits with `t < t_hit` to `list`. Events are grouped per
/// solid in t order; within one window a solid's enter and leave cancel (a
/// tangent touch or a silhouette-edge double report), duplicates of one
/// direction count once. Returns the number of distinct false crossings.
pub fn apply_rejected(list: &mut InteriorList, rejected: &mut [Rejected], t_hit: f32, win: f32) -> u32 {
    rejected.sort_unstable_by(|a, b| a.solid.cmp(&b.solid).then(a.t.total_cmp(&b.t)));
    let mut crossings = 0;
    let mut i = 0;
    while i < rejected.len() {
        let r = rejected[i];
        if r.t >= t_hit {
            i += 1;
            continue;
        }
        // Gather one window of this solid's events.
        let (mut enter, mut leave) = (r.entering, !r.entering);
        let mut j = i + 1;
        while j < rejected.len()
            && rejected[j].solid == r.solid
            && rejected[j].t < t_hit
            && rejected[j].t - rejected[j - 1].t <= win
        {
            enter |= rejected[j].entering;
            leave |= !rejected[j].entering;
            j += 1;
        }
        match (enter, leave) {
            (true, false) => list.insert(r.solid),
            (false, true) => list.remove(r.solid),
            _ => {}
        }
        crossings += 1;
        i = j;
    }
    crossings
}

/// Per-query counters, folded into render statistics.
#[derive(Debug, Clone, Copy, Default)]
pub struct TraceCounters {
    pub queries: u64,
    pub false_hits: u64,
    pub filter_calls: u64,
    pub fallbacks: u64,
    pub max_list_depth: u64,
    pub spills: u64,
}

/// Is the crossing of `solid` at distance `t` along `ray` a real crossing?
/// Point-in-solid tests just before and after: `None` for a touch (no change),
/// `Some(inside_after)` otherwise. Used only near mesh edges and vertices.
fn verify_crossing(scene: &RenderScene, solid: u32, ray: &Ray, t: f32) -> Option<bool> {
    let d = glam::DVec3::new(ray.dir.x as f64, ray.dir.y as f64, ray.dir.z as f64).normalize();
    let o = glam::DVec3::new(ray.org.x as f64, ray.org.y as f64, ray.org.z as f64);
    let len = (ray.dir.length() as f64) * t as f64;
    let p = o + d * len;
    let delta = 2e-5 * (1.0 + p.abs().max_element());
    let before = scene.solid_contains(solid, p - d * delta);
    let after = scene.solid_contains(solid, p + d * delta);
    (before != after).then_some(after)
}

/// Replace near-edge events by their verified meaning (dropping touches).
fn verify_rejected(scene: &RenderScene, ray: &Ray, rejected: &mut [Rejected]) -> usize {
    let mut k = 0;
    for i in 0..rejected.len() {
        let mut r = rejected[i];
        if r.near_edge && (r.solid as usize) < scene.solids.len() {
            match verify_crossing(scene, r.solid, ray, r.t) {
                None => continue,
                Some(inside) => r.entering = inside,
            }
        }
        rejected[k] = r;
        k += 1;
    }
    k
}

/// A true hit near a mesh edge that only touches its solid is no crossing.
fn is_touch(scene: &RenderScene, ray: &Ray, h: &Hit) -> bool {
    match scene.solid_by_geom[h.geom_id as usize] {
        Some(s)
            if near_edge(h.u, h.v)
                && matches!(
                    scene.geoms[h.geom_id as usize].shape,
                    crate::scene::build::Shape::Mesh(_)
                ) =>
        {
            verify_crossing(scene, s, ray, h.t).is_none()
        }
        _ => false,
    }
}

/// Offset for re-casting past a false hit (recast strategies).
#[inline]
fn recast_tnear(r: &Ray, t: f32) -> f32 {
    t + window(r, t)
}

/// Find the first true hit along `ray` for a ray inside `list`, updating the
/// list with every false crossing before it. `None` when nothing true is hit
/// (the list then reflects all false crossings to infinity).
pub fn trace(
    scene: &RenderScene,
    strategy: NestedStrategy,
    ray: &Ray,
    list: &mut InteriorList,
    c: &mut TraceCounters,
) -> crate::error::Result<Option<TrueHit>> {
    c.queries += 1;
    let plain = |h: Option<Hit>| {
        h.map(|hit| TrueHit {
            hit,
            coincident: Coincident::default(),
        })
    };
    // Model only what the scene needs: without overlapping solids no hit can
    // be false and no two solid surfaces coincide.
    if !scene.has_overlap || strategy == NestedStrategy::Off {
        return Ok(plain(scene.embree.intersect(ray)));
    }
    let solid_rank = |s: u32| scene.solids[s as usize].rank;
    match strategy {
        NestedStrategy::Filter if list.is_empty() => {
            // Outside every solid nothing is false: a plain query, as cheap as
            // the re-cast baseline's. (Entering two solids through coincident
            // faces at once from outside is therefore resolved when the ray
            // leaves them, not on entry; inside a solid the filter sees them.)
            let mut r = *ray;
            loop {
                match scene.embree.intersect(&r) {
                    Some(h) if is_touch(scene, &r, &h) => {
                        r.tnear = recast_tnear(&r, h.t);
                        c.queries += 1;
                    }
                    h => return Ok(plain(h)),
                }
            }
        }
        NestedStrategy::Filter => RECORDS.with_borrow_mut(|rec| {
            let p0 = list.top(solid_rank).map(solid_rank).unwrap_or(0);
            let mut filter;
            let mut r = *ray;
            let hit = loop {
                filter = FalseHitFilter::new(scene, p0, &r, &mut *rec);
                let hit = scene.embree.intersect_filtered(&r, &mut filter)?;
                c.filter_calls += filter.calls as u64;
                if filter.overflow {
                    break None;
                }
                match hit {
                    Some(h) if is_touch(scene, &r, &h) => {
                        // Touching a mesh solid at an edge or vertex: not a crossing.
                        // Apply the false hits before it and continue past it.
                        let n = verify_rejected(scene, &r, &mut filter.rec.rejected[..filter.len]);
                        let win = window(&r, h.t);
                        let limit = h.t + win;
                        c.false_hits +=
                            apply_rejected(list, &mut filter.rec.rejected[..n], limit, win) as u64;
                        // Other solids' surfaces at the touch point are crossed there.
                        let touched = scene.solid_by_geom[h.geom_id as usize];
                        let mut near = filter.rec.near;
                        let m = verify_rejected(scene, &r, &mut near[..filter.near_len]);
                        let mut others = [near[0]; NEAR_CAPACITY];
                        let mut k = 0;
                        for e in &near[..m] {
                            if Some(e.solid) != touched && (e.t - h.t).abs() <= win {
                                others[k] = *e;
                                k += 1;
                            }
                        }
                        apply_rejected(list, &mut others[..k], limit, win);
                        r.tnear = recast_tnear(&r, h.t);
                        c.queries += 1;
                    }
                    h => break Some(h),
                }
            };
            let Some(hit) = hit else {
                // Too many false hits to record: the correct slow path.
                c.fallbacks += 1;
                return Ok(plain(recast(scene, &r, list, c, false)?));
            };
            let t_hit = hit.map(|h| h.t).unwrap_or(f32::INFINITY);
            let n = verify_rejected(scene, &r, &mut filter.rec.rejected[..filter.len]);
            // False crossings up to and including those coincident with the true hit.
            let win = window(&r, if t_hit.is_finite() { t_hit } else { 0.0 });
            let limit = t_hit + win;
            c.false_hits += apply_rejected(list, &mut filter.rec.rejected[..n], limit, win) as u64;
            c.max_list_depth = c.max_list_depth.max(list.len() as u64);
            if list.spilled() {
                c.spills += 1;
            }
            Ok(hit.map(|hit| {
                let mut coincident = Coincident::default();
                let own = scene.solid_by_geom[hit.geom_id as usize];
                for r in &filter.rec.near[..filter.near_len] {
                    if Some(r.solid) != own && (r.t - hit.t).abs() <= win {
                        coincident.push(r.solid, r.entering);
                    }
                }
                TrueHit { hit, coincident }
            }))
        }),
        NestedStrategy::Recast => Ok(plain(recast(scene, ray, list, c, false)?)),
        NestedStrategy::Toggle => Ok(plain(recast(scene, ray, list, c, true)?)),
        NestedStrategy::Off => unreachable!("handled above"),
    }
}

fn recast(
    scene: &RenderScene,
    ray: &Ray,
    list: &mut InteriorList,
    c: &mut TraceCounters,
    toggle: bool,
) -> crate::error::Result<Option<Hit>> {
    let solid_rank = |s: u32| scene.solids[s as usize].rank;
    let mut r = *ray;
    // Bound the loop: a ray cannot cross more surfaces than this without a bug.
    for _ in 0..100_000 {
        let Some(h) = scene.embree.intersect(&r) else {
            return Ok(None);
        };
        if is_touch(scene, &r, &h) {
            r.tnear = recast_tnear(&r, h.t);
            c.queries += 1;
            continue;
        }
        if list.is_empty() {
            return Ok(Some(h));
        }
        let rank = scene.rank_by_geom[h.geom_id as usize];
        let p0 = list.top(solid_rank).map(solid_rank);
        let is_false = p0.is_some_and(|p| rank < p);
        if !is_false {
            return Ok(Some(h));
        }
        c.false_hits += 1;
        let s = scene.solid_by_geom[h.geom_id as usize].expect("ranked geometry is a solid");
        let entering = if near_edge(h.u, h.v) && !toggle {
            verify_crossing(scene, s, &r, h.t).unwrap_or(h.ng.dot(r.dir) < 0.0)
        } else {
            h.ng.dot(r.dir) < 0.0
        };
        if toggle {
            list.toggle(s);
        } else if entering {
            list.insert(s);
        } else {
            list.remove(s);
        }
        c.max_list_depth = c.max_list_depth.max(list.len() as u64);
        if list.spilled() {
            c.spills += 1;
        }
        r.tnear = recast_tnear(&r, h.t);
        c.queries += 1;
    }
    Err(crate::error::Error::Invalid(
        "a ray crossed more than 100000 false surfaces; the scene geometry is degenerate".into(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn list_spills_without_a_cap_and_stays_a_set() {
        let mut l = InteriorList::new();
        for s in 0..50 {
            l.insert(s);
            l.insert(s);
        }
        assert_eq!(l.len(), 50);
        assert!(l.spilled());
        for s in (0..50).step_by(2) {
            l.remove(s);
        }
        assert_eq!(l.sorted(), (1..50).step_by(2).collect::<Vec<_>>());
        assert_eq!(l.top(|s| s), Some(49));
        l.toggle(49);
        l.toggle(0);
        assert!(!l.contains(49) && l.contains(0));
    }

    #[test]
    fn duplicate_and_tangent_reports_collapse() {
        let mut l = InteriorList::new();
        let r = |solid, t: f32, entering| Rejected {
            solid,
            prim: 0,
            t,
            entering,
            near_edge: false,
        };
        // Solid 1: entered, reported twice (shared edge) at t ≈ 1.
        // Solid 2: tangent touch at t = 2 (enter + leave in one window).
        // Solid 3: entered at 3 and left at 4; solid 4: beyond the hit.
        let mut v = vec![
            r(1, 1.0, true),
            r(2, 2.0, false),
            r(1, 1.0 + f32::EPSILON, true),
            r(2, 2.0, true),
            r(3, 4.0, false),
            r(3, 3.0, true),
            r(4, 9.0, true),
        ];
        let n = apply_rejected(&mut l, &mut v, 5.0, 1e-5);
        assert_eq!(l.sorted(), vec![1]);
        assert_eq!(n, 4);
    }
}
