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
use crate::embree::{FilterHit, Hit, HitFilter, Ray};
use crate::scene::RenderScene;

/// How false hits are found and skipped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NestedStrategy {
    Filter,
    Recast,
    Toggle,
}

impl std::str::FromStr for NestedStrategy {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "filter" => Ok(NestedStrategy::Filter),
            "recast" => Ok(NestedStrategy::Recast),
            "toggle" => Ok(NestedStrategy::Toggle),
            o => Err(format!("expected filter, recast or toggle, got \"{o}\"")),
        }
    }
}

impl NestedStrategy {
    pub fn name(self) -> &'static str {
        match self {
            NestedStrategy::Filter => "filter",
            NestedStrategy::Recast => "recast",
            NestedStrategy::Toggle => "toggle",
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
}

/// Rejected hits recorded per query before the filter falls back.
pub const REJECT_CAPACITY: usize = 32;

/// The Embree context filter: rejects hits on solids ranked below `p0` and
/// records them. Stateless in its decision, so traversal order does not matter.
pub struct FalseHitFilter<'a> {
    pub rank_by_geom: &'a [u32],
    pub solid_by_geom: &'a [Option<u32>],
    pub p0: u32,
    pub rejected: [Rejected; REJECT_CAPACITY],
    pub len: usize,
    pub overflow: bool,
    pub calls: u32,
}

impl<'a> FalseHitFilter<'a> {
    pub fn new(scene: &'a RenderScene, p0: u32) -> Self {
        FalseHitFilter {
            rank_by_geom: &scene.rank_by_geom,
            solid_by_geom: &scene.solid_by_geom,
            p0,
            rejected: [Rejected {
                solid: 0,
                prim: 0,
                t: 0.0,
                entering: false,
            }; REJECT_CAPACITY],
            len: 0,
            overflow: false,
            calls: 0,
        }
    }
}

impl HitFilter for FalseHitFilter<'_> {
    #[inline]
    fn accept(&mut self, h: &FilterHit) -> bool {
        self.calls += 1;
        let g = h.geom_id as usize;
        if self.rank_by_geom[g] >= self.p0 {
            return true;
        }
        if self.len < REJECT_CAPACITY {
            self.rejected[self.len] = Rejected {
                solid: self.solid_by_geom[g].unwrap_or(u32::MAX),
                prim: h.prim_id,
                t: h.t,
                entering: h.ng.dot(h.dir) < 0.0,
            };
            self.len += 1;
        } else {
            self.overflow = true;
        }
        false
    }
}

/// Two reports of one solid within this distance are the same crossing
/// (Embree reports shared edges twice, with t differing by an ulp or two).
#[inline]
pub fn same_crossing_window(t: f32) -> f32 {
    1e-6 + t.abs() * 8.0 * f32::EPSILON
}

/// Apply recorded false hits with `t < t_hit` to `list`. Events are grouped per
/// solid in t order; within one window a solid's enter and leave cancel (a
/// tangent touch or a silhouette-edge double report), duplicates of one
/// direction count once. Returns the number of distinct false crossings.
pub fn apply_rejected(list: &mut InteriorList, rejected: &mut [Rejected], t_hit: f32) -> u32 {
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
            && rejected[j].t - rejected[j - 1].t <= same_crossing_window(rejected[j].t)
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

/// Offset for re-casting past a false hit (recast strategies).
#[inline]
fn recast_tnear(t: f32) -> f32 {
    t + same_crossing_window(t)
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
) -> crate::error::Result<Option<Hit>> {
    c.queries += 1;
    // Model only what the scene needs: with an empty list every hit is true,
    // and without overlapping solids no hit can be false.
    if list.is_empty() || !scene.has_overlap {
        return Ok(scene.embree.intersect(ray));
    }
    let ranks = &scene.rank_by_geom;
    let solid_rank = |s: u32| scene.solids[s as usize].rank;
    match strategy {
        NestedStrategy::Filter => {
            let p0 = list.top(solid_rank).map(solid_rank).unwrap_or(0);
            let mut filter = FalseHitFilter::new(scene, p0);
            let hit = scene.embree.intersect_filtered(ray, &mut filter)?;
            c.filter_calls += filter.calls as u64;
            if filter.overflow {
                // Too many false hits to record: the correct slow path.
                c.fallbacks += 1;
                return recast(scene, ray, list, c, false);
            }
            let t_hit = hit.map(|h| h.t).unwrap_or(f32::INFINITY);
            let n = filter.len;
            c.false_hits += apply_rejected(list, &mut filter.rejected[..n], t_hit) as u64;
            c.max_list_depth = c.max_list_depth.max(list.len() as u64);
            if list.spilled() {
                c.spills += 1;
            }
            let _ = ranks;
            Ok(hit)
        }
        NestedStrategy::Recast => recast(scene, ray, list, c, false),
        NestedStrategy::Toggle => recast(scene, ray, list, c, true),
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
        let rank = scene.rank_by_geom[h.geom_id as usize];
        let p0 = list.top(solid_rank).map(solid_rank);
        let is_false = p0.is_some_and(|p| rank < p);
        if !is_false {
            return Ok(Some(h));
        }
        c.false_hits += 1;
        let s = scene.solid_by_geom[h.geom_id as usize].expect("ranked geometry is a solid");
        if toggle {
            list.toggle(s);
        } else if h.ng.dot(r.dir) < 0.0 {
            list.insert(s);
        } else {
            list.remove(s);
        }
        c.max_list_depth = c.max_list_depth.max(list.len() as u64);
        if list.spilled() {
            c.spills += 1;
        }
        r.tnear = recast_tnear(h.t);
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
        let n = apply_rejected(&mut l, &mut v, 5.0);
        assert_eq!(l.sorted(), vec![1]);
        assert_eq!(n, 4);
    }
}
