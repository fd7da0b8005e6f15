//! The in-filter skip: [`FalseHitFilter`] rejects hits on solids ranked below
//! the ray's P0 inside the Embree query and records them; [`apply_rejected`]
//! applies the records to the interior list afterwards, in t order.
use super::InteriorList;
use crate::embree::{FilterHit, HitFilter};
use crate::ray::{front_facing, window_coefficients, Hit, Ray};
use crate::scene::RenderScene;

/// A false hit the filter rejected: which solid, where, which way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rejected {
    /// Solid index (`u32::MAX` for a hit on a non-solid, which is never false).
    pub solid: u32,
    /// The solid's rank.
    pub rank: u32,
    /// Primitive hit (triangle or analytic part).
    pub prim: u32,
    /// Ray parameter of the hit, in units of the query ray's |dir|.
    pub t: f32,
    /// The ray enters the solid here (`ray::front_facing` of the hit normal).
    pub entering: bool,
    /// Within `EDGE_EPS` (barycentric) of a mesh edge or vertex, where the
    /// normal alone cannot tell a crossing from a touch: verified after the query.
    pub near_edge: bool,
}

/// Barycentric distance to a triangle edge below which a hit is verified by
/// point-in-solid tests (Embree's robust mode closes edge leaks, not vertex ones).
pub const EDGE_EPS: f32 = 2e-4;

#[inline]
pub(crate) fn near_edge(u: f32, v: f32) -> bool {
    u.min(v).min(1.0 - u - v) < EDGE_EPS
}

/// Rejected hits recorded per query before the filter falls back.
pub const REJECT_CAPACITY: usize = 32;

/// The filter's record buffers: per-query scratch, reused from query to
/// query on each thread (`RECORDS`) because initialising them per query is a
/// large share of the filter's cost over a plain query. Nothing in them
/// outlives a query: each one writes what it reads.
pub struct FilterRecords {
    /// False hits of the current query, in the order Embree reported them.
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
            rank: 0,
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
    /// Scratch only (see [`FilterRecords`]): nothing passes from one query to the next.
    pub(crate) static RECORDS: std::cell::RefCell<FilterRecords> = std::cell::RefCell::new(FilterRecords::default());
}

/// The Embree context filter: rejects hits on solids ranked below `p0` and
/// records them. Stateless in its decision, so traversal order does not matter.
pub struct FalseHitFilter<'a> {
    /// Rank per geometry id (`u32::MAX` for non-solids: never false).
    pub rank_by_geom: &'a [u32],
    /// Solid index per geometry id.
    pub solid_by_geom: &'a [Option<u32>],
    /// The top rank of the ray's interior list (the paper's P0): hits on lower ranks are false.
    pub p0: u32,
    /// `rec.rejected[..len]` and `rec.near[..near_len]` are this query's.
    pub rec: &'a mut FilterRecords,
    /// Number of records in `rec.rejected`.
    pub len: usize,
    /// More false hits than `REJECT_CAPACITY` (or coincident accepted hits than `NEAR_CAPACITY`): the query is redone by re-casting.
    pub overflow: bool,
    /// Filter calls in this query.
    pub calls: u32,
    /// Number of records in `rec.near`.
    pub near_len: usize,
    /// The nearest accepted t so far.
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

impl FalseHitFilter<'_> {
    /// `crossing_window` of this query's ray at `t` (the same arithmetic).
    #[inline]
    pub fn window(&self, t: f32) -> f32 {
        self.win_a + self.win_b * if t.is_finite() { t.abs() } else { 0.0 }
    }
}

impl HitFilter for FalseHitFilter<'_> {
    #[inline]
    fn accept(&mut self, h: &FilterHit) -> bool {
        self.calls += 1;
        let g = h.geom_id as usize;
        let rank = self.rank_by_geom[g];
        if rank >= self.p0 {
            if let Some(solid) = self.solid_by_geom[g] {
                self.note_accepted(solid, rank, h);
            }
            return true;
        }
        if self.len < REJECT_CAPACITY {
            self.rec.rejected[self.len] = Rejected {
                solid: self.solid_by_geom[g].unwrap_or(u32::MAX),
                rank,
                prim: h.prim_id,
                t: h.t,
                entering: front_facing(h.ng, h.dir),
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
    fn note_accepted(&mut self, solid: u32, rank: u32, h: &FilterHit) {
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
            rank,
            prim: h.prim_id,
            t: h.t,
            entering: front_facing(h.ng, h.dir),
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

/// Solids to settle at a true hit's child ray: other solids whose surface
/// passes near the hit, and the hit's own mesh solid when the hit is near an
/// edge (`dielectric::settle_child`). Beyond [`NEAR_CAPACITY`] solids the
/// rest keep the list's claim.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NearSolids {
    ids: [u32; NEAR_CAPACITY],
    len: u8,
    /// The hit's own mesh solid, for a hit near one of its edges.
    pub(crate) own_edge: Option<u32>,
}

impl NearSolids {
    /// Nothing to settle.
    pub const NONE: NearSolids = NearSolids {
        ids: [0; NEAR_CAPACITY],
        len: 0,
        own_edge: None,
    };

    /// Is there nothing to settle?
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0 && self.own_edge.is_none()
    }

    pub(crate) fn push(&mut self, s: u32) {
        if (self.len as usize) < NEAR_CAPACITY {
            self.ids[self.len as usize] = s;
            self.len += 1;
        }
    }

    pub(crate) fn ids(&self) -> &[u32] {
        &self.ids[..self.len as usize]
    }
}

/// The geometries whose hits a query by a ray with top rank P0 need not show
/// [`FalseHitFilter`] ([`crate::embree::SkipRanges`] with key P0), per geometry id:
/// - a non-solid: always (never false, never recorded);
/// - a solid of rank `r` when `lo <= P0 <= r`, `lo` being one more than the
///   highest rank of the other solids whose surfaces may meet its own
///   (`surfaces_may_meet`; 0 when none does): the filter would accept the
///   hit (`r >= P0`), and its only other use, recording it as possibly
///   coincident with another accepted solid's true hit, needs a solid ranked
///   at least P0 whose surface meets this one's, which `P0 >= lo` excludes.
///   (glass_of_water_nested: the glass, for rays inside it; deep_nesting:
///   every shell, whose surfaces are concentric spheres that never meet.)
///
/// Computed once per scene (the table lives in its Embree scene).
pub fn skip_ranges(scene: &RenderScene) -> &[(u32, u32)] {
    scene.embree.filter_table(|| {
        scene
            .solid_by_geom
            .iter()
            .map(|s| match s {
                None => (0, u32::MAX),
                Some(s) => {
                    let me = &scene.solids[*s as usize];
                    let lo = scene
                        .solids
                        .iter()
                        .enumerate()
                        .filter(|&(i, _)| i != *s as usize && surfaces_may_meet(scene, *s, i as u32))
                        .map(|(_, o)| o.rank.saturating_add(1))
                        .max()
                        .unwrap_or(0);
                    (lo, me.rank)
                }
            })
            .collect()
    })
}

/// May the surfaces of solids `a` and `b` come within a small tolerance of
/// each other? Their bounds must meet, and the shapes' own tests must allow
/// it (concentric spheres never meet). `true` when unsure: a wider test only
/// skips less.
fn surfaces_may_meet(scene: &RenderScene, a: u32, b: u32) -> bool {
    let (ba, bb) = (scene.solids[a as usize].aabb, scene.solids[b as usize].aabb);
    let scale =
        ba.0.abs()
            .max(ba.1.abs())
            .max(bb.0.abs())
            .max(bb.1.abs())
            .max_element();
    surfaces_may_come_within(scene, a, b, 1e-4 * (1.0 + scale))
}

/// May the surfaces of solids `a` and `b` come within `tol` of each other?
/// As [`surfaces_may_meet`] with its tolerance given.
pub(crate) fn surfaces_may_come_within(scene: &RenderScene, a: u32, b: u32, tol: f64) -> bool {
    let (sa, sb) = (&scene.solids[a as usize], &scene.solids[b as usize]);
    let exact = match (analytic(scene, sa.geom), analytic(scene, sb.geom)) {
        (Some(x), Some(y)) => x.surfaces_may_come_within(y, tol),
        _ => None,
    };
    match exact {
        Some(may) => boxes_within(sa.aabb, sb.aabb, tol) && may,
        None => {
            surface_may_come_within_box(scene, b, sa.aabb, tol)
                && surface_may_come_within_box(scene, a, sb.aabb, tol)
        }
    }
}

/// The analytic shape of geometry `geom`, if it has one (a mesh has none).
pub(crate) fn analytic(scene: &RenderScene, geom: u32) -> Option<&crate::scene::shapes::Analytic> {
    use crate::scene::Shape;
    match &scene.geoms[geom as usize].shape {
        Shape::Analytic(a) => Some(a),
        Shape::Mesh(_) => None,
    }
}

/// Do boxes `a` and `b` come within `tol` of each other (per axis)?
fn boxes_within(a: (glam::DVec3, glam::DVec3), b: (glam::DVec3, glam::DVec3), tol: f64) -> bool {
    (a.0 - tol).cmple(b.1).all() && (b.0 - tol).cmple(a.1).all()
}

/// May the surface of solid `s` come within `tol` of some point of the box
/// `bx`? Its bounds must, and its shape's own test must allow it (a
/// sphere's surface misses a box wholly inside or outside its ball). `true`
/// when unsure.
pub(crate) fn surface_may_come_within_box(
    scene: &RenderScene,
    s: u32,
    bx: (glam::DVec3, glam::DVec3),
    tol: f64,
) -> bool {
    let solid = &scene.solids[s as usize];
    boxes_within(solid.aabb, bx, tol)
        && analytic(scene, solid.geom).is_none_or(|a| a.surface_may_come_within_box(bx, tol))
}

/// Solid crossings at the same point as a true hit (coincident faces), beyond
/// the true hit's own solid: (solid, rank, entering).
///
/// Compact (80 bytes, a [`TrueHit`] 128) because every hit carries one: at
/// 128 bytes the compiler copies a `TrueHit` inline rather than by `memcpy`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Coincident {
    /// (solid, rank) of each crossing.
    items: [(u32, u32); NEAR_CAPACITY],
    /// Bit i: crossing i enters its solid.
    entering: u8,
    len: u8,
    touched_len: u8,
    /// Solids both entered and left at the point (a touch): no crossing.
    touched: [u32; NEAR_CAPACITY],
    /// Solids whose surface passes near the hit, settled for the child ray
    /// by point-in-solid (`dielectric::settle_child`).
    pub(crate) near: NearSolids,
}

impl Coincident {
    /// No coincident crossings (what a plain query reports). A constant, so a
    /// plain query's hit is copied whole rather than zeroed field by field
    /// (whose small stores would stall the wide loads of the copies after
    /// them).
    pub const NONE: Coincident = Coincident {
        items: [(0, 0); NEAR_CAPACITY],
        entering: 0,
        len: 0,
        touched_len: 0,
        touched: [0; NEAR_CAPACITY],
        near: NearSolids::NONE,
    };

    /// The crossings: (solid, rank, entering).
    pub fn iter(&self) -> impl Iterator<Item = (u32, u32, bool)> + '_ {
        self.items[..self.len as usize]
            .iter()
            .enumerate()
            .map(|(i, &(s, r))| (s, r, self.entering & (1 << i) != 0))
    }

    /// Number of crossings.
    pub fn len(&self) -> usize {
        self.len as usize
    }

    /// No crossings?
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    fn position(&self, solid: u32) -> Option<usize> {
        self.items[..self.len as usize].iter().position(|c| c.0 == solid)
    }

    fn set_entering(&mut self, i: usize, entering: bool) {
        self.entering = (self.entering & !(1 << i)) | ((entering as u8) << i);
    }

    /// Add a report. A duplicate of one direction counts once; reports of
    /// both directions of one solid cancel, as in `apply_rejected` (a ray
    /// through the circle where two spheres meet can graze the second one:
    /// the entry alone left it in the list after the ray had left it).
    pub(crate) fn push(&mut self, solid: u32, rank: u32, entering: bool) {
        if self.touched[..self.touched_len as usize].contains(&solid) {
            return;
        }
        if let Some(i) = self.position(solid) {
            if (self.entering & (1 << i) != 0) != entering {
                let last = self.len as usize - 1;
                self.items[i] = self.items[last];
                let last_entering = self.entering & (1 << last) != 0;
                self.set_entering(i, last_entering);
                self.set_entering(last, false);
                self.len -= 1;
                if (self.touched_len as usize) < NEAR_CAPACITY {
                    self.touched[self.touched_len as usize] = solid;
                    self.touched_len += 1;
                }
            }
            return;
        }
        if (self.len as usize) < NEAR_CAPACITY {
            let i = self.len as usize;
            self.items[i] = (solid, rank);
            self.set_entering(i, entering);
            self.len += 1;
        }
    }

    /// Whether the crossings enter `solid` (`None`: they do not cross it).
    pub(crate) fn entering_of(&self, solid: u32) -> Option<bool> {
        self.position(solid).map(|i| self.entering & (1 << i) != 0)
    }

    /// Make the crossings leave the ray inside `solid` or not, as
    /// point-in-solid decided (`settle::look_ahead`): replaces a report of
    /// the other direction and undoes a touch.
    pub(crate) fn settle(&mut self, solid: u32, rank: u32, entering: bool) {
        let tl = self.touched_len as usize;
        if let Some(i) = self.touched[..tl].iter().position(|&t| t == solid) {
            self.touched[i] = self.touched[tl - 1];
            self.touched_len -= 1;
        }
        match self.position(solid) {
            Some(i) => self.set_entering(i, entering),
            None => self.push(solid, rank, entering),
        }
    }
}

/// The first true hit of a query and the solid surfaces coincident with it.
#[derive(Debug, Clone, Copy)]
pub struct TrueHit {
    /// The nearest hit on a solid ranked at or above P0, or on a non-solid.
    pub hit: Hit,
    /// Solid surfaces at the same point (within the crossing window), crossed with it.
    pub coincident: Coincident,
}

/// Apply recorded false hits with `t < t_hit` to `list`. Events are grouped per
/// solid in t order; within one window a solid's enter and leave cancel (a
/// tangent touch or a silhouette-edge double report), duplicates of one
/// direction count once. Returns the number of distinct false crossings.
#[inline]
pub fn apply_rejected(list: &mut InteriorList, rejected: &mut [Rejected], t_hit: f32, win: f32) -> u32 {
    if rejected.is_empty() {
        return 0; // most queries: no false hit
    }
    apply_records(list, rejected, t_hit, win)
}

#[inline(never)]
fn apply_records(list: &mut InteriorList, rejected: &mut [Rejected], t_hit: f32, win: f32) -> u32 {
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
            (true, false) => list.insert(r.solid, r.rank),
            (false, true) => list.remove(r.solid),
            _ => {}
        }
        crossings += 1;
        i = j;
    }
    crossings
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coincident_crossings_cancel_touch_and_settle_and_a_true_hit_stays_small() {
        let mut c = Coincident::NONE;
        c.push(3, 7, true);
        c.push(5, 9, false);
        c.push(3, 7, true); // a duplicate of one direction counts once
        assert_eq!(c.iter().collect::<Vec<_>>(), [(3, 7, true), (5, 9, false)]);
        // Both directions of solid 3 cancel (a touch); the last crossing
        // moves into its place with its own direction.
        c.push(3, 7, false);
        assert_eq!(c.iter().collect::<Vec<_>>(), [(5, 9, false)]);
        c.push(3, 7, true); // touched: ignored
        assert_eq!((c.len(), c.entering_of(3)), (1, None));
        // Point-in-solid undoes the touch and decides the direction.
        c.settle(3, 7, true);
        c.settle(5, 9, true);
        assert_eq!(c.iter().collect::<Vec<_>>(), [(5, 9, true), (3, 7, true)]);
        assert_eq!(
            (c.entering_of(5), c.entering_of(3), c.entering_of(4)),
            (Some(true), Some(true), None)
        );
        // Inline copies, not memcpy calls (see `Coincident`).
        assert!(
            std::mem::size_of::<TrueHit>() <= 128,
            "{}",
            std::mem::size_of::<TrueHit>()
        );
    }

    #[test]
    fn skip_ranges_name_non_solids_and_solids_no_accepted_solid_can_meet() {
        let scene = crate::dielectric::water_in_glass(
            r#"[[objects]]
name = "far"
shape = { type = "sphere", center = [5.0, 0.0, 0.0], radius = 1.0 }
material = { type = "dielectric", ior = 1.5, priority = 3 }
[[objects]]
name = "core"
shape = { type = "sphere", center = [5.0, 0.0, 0.0], radius = 0.5 }
material = { type = "dielectric", ior = 1.2, priority = 4 }
[[objects]]
name = "ground"
shape = { type = "rect", center = [0.0, -3.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [4.0, 4.0] }
material = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }
"#,
        );
        let t = skip_ranges(&scene);
        assert_eq!(t.len(), scene.geoms.len());
        let of = |name: &str| {
            let g = scene.geoms.iter().position(|g| g.name == name).unwrap();
            (g, scene.solid_by_geom[g].map(|s| scene.solids[s as usize].rank))
        };
        let (water, glass, far, ground) = (of("water"), of("glass"), of("far"), of("ground"));
        let (rw, rg, rf) = (water.1.unwrap(), glass.1.unwrap(), far.1.unwrap());
        let (core, rc) = (of("core").0, of("core").1.unwrap());
        let skips = |g: usize, key: u32| t[g].0 <= key && key <= t[g].1;
        // The water can be false (inside the glass) and meets the glass: always seen.
        assert!((0..=rf + 1).all(|k| !skips(water.0, k)));
        // The glass is never false; its hits can coincide with an accepted
        // water hit only for rays whose top is the water.
        assert!(skips(glass.0, rg) && !skips(glass.0, rw) && !skips(glass.0, rf));
        // Solids whose surfaces meet no other (two concentric spheres, their
        // bounds nested): skipped whenever the filter would accept them.
        assert!((0..=rf).all(|k| skips(far.0, k)) && !skips(far.0, rf + 1));
        assert!((0..=rc).all(|k| skips(core, k)) && !skips(core, rc + 1));
        // A non-solid: always.
        assert!(ground.1.is_none() && skips(ground.0, 0) && skips(ground.0, u32::MAX));
        // One table per scene.
        assert!(std::ptr::eq(t, skip_ranges(&scene)));
    }

    #[test]
    fn duplicate_and_tangent_reports_collapse() {
        let mut l = InteriorList::new();
        let r = |solid, t: f32, entering| Rejected {
            solid,
            rank: solid,
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
