//! Finding the first true hit along a ray: [`trace`] with every strategy, the
//! re-cast baseline, and the point-in-solid verification near mesh edges.
use super::filter::{
    apply_rejected, near_edge, Coincident, FalseHitFilter, Rejected, TrueHit, NEAR_CAPACITY, RECORDS,
};
use super::settle::{has_neighbours, look_ahead};
use super::{InteriorList, NestedStrategy};
use crate::counters::Counters;
use crate::ray::{crossing_window, front_facing, just_past, Hit, Ray};
use crate::scene::RenderScene;

#[inline]
fn window(r: &Ray, t: f32) -> f32 {
    crossing_window(r.org, r.dir, t)
}

/// Is the point just past the crossing of `solid` at distance `t` along
/// `ray` inside the solid? A point-in-solid test, used only near mesh edges
/// and vertices, where the triangle Embree reports (and its normal) need not
/// be the one the ray crosses.
///
/// Only the side *after* the hit is tested: the side before is what the
/// interior list holds. (A test before the hit looked at a point behind the
/// ray's start when the hit was nearer than the test distance: a ray
/// reflected at the rim's inner edge of the glass saw its own exit through
/// the inner wall, 5e-5 away, as a touch, and crossed the cavity as glass.)
fn inside_after(scene: &RenderScene, solid: u32, ray: &Ray, t: f32) -> bool {
    let d = ray.dir.as_dvec3().normalize();
    let o = ray.org.as_dvec3();
    let len = (ray.dir.length() as f64) * t as f64;
    let p = o + d * len;
    let delta = 2e-5 * (1.0 + p.abs().max_element());
    scene.solid_contains(solid, p + d * delta)
}

/// Give near-edge events their verified meaning: the ray is inside the solid
/// after the event iff the point just past it is. A touch (inside as before)
/// becomes an insert or remove that changes nothing; two reports of one
/// crossing (a shared edge) agree.
#[inline]
fn verify_rejected(scene: &RenderScene, ray: &Ray, rejected: &mut [Rejected]) -> usize {
    // Most queries record nothing.
    if !rejected.is_empty() {
        verify_near_edge(scene, ray, rejected);
    }
    rejected.len()
}

#[inline(never)]
fn verify_near_edge(scene: &RenderScene, ray: &Ray, rejected: &mut [Rejected]) {
    for r in rejected.iter_mut() {
        if r.near_edge && (r.solid as usize) < scene.solids.len() {
            r.entering = inside_after(scene, r.solid, ray, r.t);
        }
    }
}

/// A true hit near a mesh edge that does not change whether the ray is in
/// its solid (as `list` says before the hit) is no crossing.
#[inline]
fn is_touch(scene: &RenderScene, ray: &Ray, h: &Hit, list: &InteriorList) -> bool {
    !scene.mesh_solids.is_empty() && near_edge(h.u, h.v) && mesh_touch(scene, ray, h, list)
}

#[inline(never)]
fn mesh_touch(scene: &RenderScene, ray: &Ray, h: &Hit, list: &InteriorList) -> bool {
    match scene.solid_by_geom[h.geom_id as usize] {
        Some(s)
            if matches!(
                scene.geoms[h.geom_id as usize].shape,
                crate::scene::Shape::Mesh(_)
            ) =>
        {
            inside_after(scene, s, ray, h.t) == list.contains(s)
        }
        _ => false,
    }
}

/// The mesh solid a ray outside every solid was already in when it hit `h`:
/// Embree leaked that solid's entry. Robust mode closes edge leaks, not
/// vertex ones, and a ray aimed through a mesh vertex (the glass's rim, seen
/// from above) can cross no triangle at all, so there is no hit to verify;
/// the next hit then lies inside the solid. Tested here, by point-in-solid
/// just before the hit, for the first hit on a solid of a ray whose list is
/// empty: the only place such a ray meets a vertex exactly (every later
/// segment starts at a refraction). Analytic solids do not leak.
#[inline]
fn leaked_entry(scene: &RenderScene, r: &Ray, h: &Hit) -> Option<(u32, u32)> {
    let hit_solid = scene.solid_by_geom[h.geom_id as usize]?;
    // Only a mesh solid other than the hit's own can have leaked.
    if scene.mesh_solids.iter().all(|&(i, _)| i == hit_solid) {
        return None;
    }
    leaked_mesh_entry(scene, r, h, hit_solid)
}

#[inline(never)]
fn leaked_mesh_entry(scene: &RenderScene, r: &Ray, h: &Hit, hit_solid: u32) -> Option<(u32, u32)> {
    let d = r.dir.as_dvec3();
    let dl = d.length();
    let p = r.org.as_dvec3() + d * h.t as f64;
    // A point on the segment the ray travelled, just before the hit.
    let back = (2e-5 * (1.0 + p.abs().max_element())).min(0.5 * (h.t - r.tnear) as f64 * dl);
    let q = p - d * (back / dl);
    scene
        .mesh_solids
        .iter()
        .find(|&&(i, (lo, hi))| {
            i != hit_solid && q.cmpge(lo).all() && q.cmple(hi).all() && scene.solid_contains(i, q)
        })
        .map(|&(i, _)| (i, scene.solids[i as usize].rank))
}

/// After a leaked entry of `leaked` (solid, rank) found at the hit `h`: the
/// list holds the solid. Is the hit still true? If not (its solid ranks
/// below the leaked one), its crossing is applied as the false hit it is.
fn repair_leak(scene: &RenderScene, r: &Ray, h: &Hit, leaked: (u32, u32), list: &mut InteriorList) -> bool {
    list.insert(leaked.0, leaked.1);
    let rank = scene.rank_by_geom[h.geom_id as usize];
    if rank > leaked.1 {
        return true;
    }
    if let Some(w) = scene.solid_by_geom[h.geom_id as usize] {
        let entering = if near_edge(h.u, h.v)
            && matches!(
                scene.geoms[h.geom_id as usize].shape,
                crate::scene::Shape::Mesh(_)
            ) {
            inside_after(scene, w, r, h.t)
        } else {
            front_facing(h.ng, r.dir)
        };
        if entering {
            list.insert(w, rank);
        } else {
            list.remove(w);
        }
    }
    false
}

/// Offset for re-casting past a false hit (recast strategies).
#[inline]
fn recast_tnear(r: &Ray, t: f32) -> f32 {
    t + window(r, t)
}

/// Find the first true hit along `ray` for a ray inside `list`, updating the
/// list with every false crossing before it. `None` when nothing true is hit
/// (the list then reflects all false crossings to infinity).
///
/// # Errors
/// A filter that panicked or an Embree error during the query; a ray that
/// crosses more than 100 000 false surfaces (degenerate geometry).
///
/// # Examples
///
/// A ray inside water (priority 1) and the glass that overlaps it
/// (priority 2): the water's face at x = 0.5 lies inside the glass and is
/// false, so the first true hit is the glass's face at x = 0.8, and the list
/// has left the water on the way.
///
/// ```
/// use glam::Vec3A;
/// use snell::counters::Counters;
/// use snell::dielectric::{trace, InteriorList, NestedStrategy};
/// use snell::ray::Ray;
/// use snell::scene::{load_scene_str, BuildOptions};
///
/// let text = r#"
/// [camera]
/// position = [0.0, 0.0, 5.0]
/// target = [0.0, 0.0, 0.0]
/// fov = 40.0
/// [[objects]]
/// name = "water"
/// shape = { type = "box", center = [0.0, 0.0, 0.0], size = [1.0, 1.0, 1.0] }
/// material = { type = "dielectric", ior = 1.33, priority = 1 }
/// [[objects]]
/// name = "glass"
/// shape = { type = "box", center = [0.3, 0.0, 0.0], size = [1.0, 2.0, 2.0] }
/// material = { type = "dielectric", ior = 1.5, priority = 2 }
/// "#;
/// let scene = load_scene_str("t.toml", text, std::path::Path::new("."), &BuildOptions::default())?;
/// let (water, glass) = (0, 1); // solid indices follow declaration order
/// for strategy in [NestedStrategy::Filter, NestedStrategy::Recast] {
///     let mut list = InteriorList::from_solids(&scene.solids, &[water, glass]);
///     let mut counters = Counters::default();
///     let ray = Ray::new(Vec3A::new(0.0, 0.1, 0.3), Vec3A::X);
///     let hit = trace(&scene, strategy, &ray, &mut list, &mut counters)?.expect("the glass is ahead");
///     assert!((hit.hit.t - 0.8).abs() < 1e-5, "the glass's far face");
///     assert_eq!(list.sorted(), vec![glass]);
///     assert_eq!(counters.false_hits, 1);
/// }
/// # Ok::<(), snell::Error>(())
/// ```
#[inline]
pub fn trace(
    scene: &RenderScene,
    strategy: NestedStrategy,
    ray: &Ray,
    list: &mut InteriorList,
    c: &mut Counters,
) -> crate::error::Result<Option<TrueHit>> {
    traced(scene, strategy, ray, list, c, None)
}

/// Time spent applying false hits to interior lists (the point-in-solid
/// verification of near-edge records, `apply_rejected` and the masked
/// solids' settling after each filtered query), for the benchmark's share
/// of "list updates". Each timed application adds the cost of one pair of
/// clock reads to the caller's time and to `seconds`; subtract it (see
/// `bench::clock_pair_s`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ListUpdateTimer {
    /// Seconds spent in the timed applications.
    pub seconds: f64,
    /// Number of timed applications.
    pub count: u64,
}

impl ListUpdateTimer {
    /// Add the time since `t0` as one application.
    #[inline]
    fn add_since(&mut self, t0: std::time::Instant) {
        self.seconds += t0.elapsed().as_secs_f64();
        self.count += 1;
    }
}

/// [`trace`], with the filter strategy's list updates timed into `timer`.
///
/// # Errors
/// As [`trace`].
pub fn trace_timing_list_updates(
    scene: &RenderScene,
    strategy: NestedStrategy,
    ray: &Ray,
    list: &mut InteriorList,
    c: &mut Counters,
    timer: &mut ListUpdateTimer,
) -> crate::error::Result<Option<TrueHit>> {
    traced(scene, strategy, ray, list, c, Some(timer))
}

/// [`trace`], timing the list updates into `timer` if there is one.
fn traced(
    scene: &RenderScene,
    strategy: NestedStrategy,
    ray: &Ray,
    list: &mut InteriorList,
    c: &mut Counters,
    timer: Option<&mut ListUpdateTimer>,
) -> crate::error::Result<Option<TrueHit>> {
    c.queries += 1;
    let plain = |h: Option<Hit>| {
        h.map(|hit| TrueHit {
            hit,
            coincident: Coincident::NONE,
        })
    };
    // Model only what the scene needs: without overlapping solids no hit can
    // be false and no two solid surfaces coincide.
    if !scene.has_overlap || strategy == NestedStrategy::Off {
        return Ok(plain(scene.embree.intersect(ray)));
    }
    let mut th = match strategy {
        NestedStrategy::Filter if list.is_empty() => {
            // Outside every solid nothing is false: a plain query, as cheap as
            // the re-cast baseline's. (Entering two solids through coincident
            // faces at once from outside is therefore resolved when the ray
            // leaves them, not on entry; inside a solid the filter sees them.)
            let mut r = *ray;
            loop {
                match scene.embree.intersect(&r) {
                    Some(h) if is_touch(scene, &r, &h, list) => {
                        r.tnear = recast_tnear(&r, h.t);
                        c.queries += 1;
                    }
                    Some(h) => {
                        let Some(leaked) = leaked_entry(scene, &r, &h) else {
                            break plain(Some(h));
                        };
                        if repair_leak(scene, &r, &h, leaked, list) {
                            break plain(Some(h));
                        }
                        // A false hit: trace on from it with the list the ray had.
                        c.false_hits += 1;
                        r.tnear = just_past(h.t);
                        return traced(scene, strategy, &r, list, c, timer);
                    }
                    None => return Ok(None),
                }
            }
        }
        NestedStrategy::Filter => filtered(scene, ray, list, c, timer)?,
        NestedStrategy::Recast => plain(recast(scene, ray, list, c, false)?),
        // The paper's method as the paper has it.
        NestedStrategy::Toggle => return Ok(plain(recast(scene, ray, list, c, true)?)),
        NestedStrategy::Off => unreachable!("handled above"),
    };
    if let Some(th) = &mut th {
        // Every query of this ray shared its origin and direction: the hit's
        // t is on `ray`.
        look_ahead(scene, ray, th, list, c);
    }
    Ok(th)
}

/// [`trace`] with the false-hit filter, for a ray inside `list` (not empty);
/// the list updates timed into `timer` if there is one.
fn filtered(
    scene: &RenderScene,
    ray: &Ray,
    list: &mut InteriorList,
    c: &mut Counters,
    mut timer: Option<&mut ListUpdateTimer>,
) -> crate::error::Result<Option<TrueHit>> {
    let plain = |h: Option<Hit>| {
        h.map(|hit| TrueHit {
            hit,
            coincident: Coincident::NONE,
        })
    };
    let p0 = list.top_rank().unwrap_or(0);
    let (mask, below) = ray_mask(scene, p0);
    if p0 <= scene.lowest_unmasked_rank {
        if let Some(th) = masked_plain(scene, ray, list, c, mask, below, timer.as_deref_mut()) {
            return Ok(th);
        }
    }
    // Hits the filter need not see (non-solids; solids that cannot be false
    // for this P0 nor coincide with another accepted solid).
    let skip = super::filter::skip_ranges(scene);
    RECORDS.with_borrow_mut(|rec| {
        let mut filter;
        let mut r = *ray;
        let hit = loop {
            filter = FalseHitFilter::new(scene, p0, &r, &mut *rec);
            let skip = crate::embree::SkipRanges {
                ranges: skip,
                key: p0,
            };
            let hit = scene
                .embree
                .intersect_filtered_masked(&r, &mut filter, skip, mask)?;
            c.filter_calls += filter.calls as u64;
            if filter.overflow {
                break None;
            }
            match hit {
                Some(h) if is_touch(scene, &r, &h, list) => {
                    // Touching a mesh solid at an edge or vertex: not a crossing.
                    // Apply the false hits before it and continue past it.
                    let n = verify_rejected(scene, &r, &mut filter.rec.rejected[..filter.len]);
                    let win = window(&r, h.t);
                    let limit = h.t + win;
                    c.false_hits += apply_rejected(list, &mut filter.rec.rejected[..n], limit, win) as u64;
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
                    c.false_hits += settle_masked(scene, &scene.masked_solids[..below], &r, Some(h.t), list);
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
        let clock = timer.is_some().then(std::time::Instant::now);
        let n = verify_rejected(scene, &r, &mut filter.rec.rejected[..filter.len]);
        // False crossings up to and including those coincident with the true hit.
        // The filter's coefficients: the same window without a square root.
        let win = filter.window(if t_hit.is_finite() { t_hit } else { 0.0 });
        let limit = t_hit + win;
        c.false_hits += apply_rejected(list, &mut filter.rec.rejected[..n], limit, win) as u64;
        c.false_hits += settle_masked(scene, &scene.masked_solids[..below], &r, hit.map(|h| h.t), list);
        if let (Some(t0), Some(timer)) = (clock, timer) {
            timer.add_since(t0);
        }
        c.max_list_depth = c.max_list_depth.max(list.len() as u64);
        if list.spilled() {
            c.list_spills += 1;
        }
        Ok(hit.map(|hit| {
            let mut coincident = Coincident::NONE;
            let own = scene.solid_by_geom[hit.geom_id as usize];
            for r in &filter.rec.near[..filter.near_len] {
                if Some(r.solid) != own && (r.t - hit.t).abs() <= win {
                    coincident.push(r.solid, r.rank, r.entering);
                }
            }
            TrueHit { hit, coincident }
        }))
    })
}

/// [`filtered`] for a ray that can see no solid ranked below its P0 once
/// the ray mask `mask` leaves out the `below` first of
/// `scene.masked_solids` (every solid below P0 is one of them): no hit can
/// be false, so one plain query with the mask finds the true hit, and the
/// masked solids are settled as `filtered` settles them. `None` when the
/// hit is a touch of a mesh solid at an edge or vertex (the plain query
/// counted as one more query): the filter decides there, as it records the
/// surfaces the touch point lies on. Other solids' surfaces coincident with
/// the hit, which the filter records, are found by `settle::look_ahead`.
/// The settling is timed into `timer` if there is one.
#[inline]
fn masked_plain(
    scene: &RenderScene,
    ray: &Ray,
    list: &mut InteriorList,
    c: &mut Counters,
    mask: u32,
    below: usize,
    timer: Option<&mut ListUpdateTimer>,
) -> Option<Option<TrueHit>> {
    let hit = scene.embree.intersect_masked(ray, mask);
    if let Some(h) = &hit {
        if is_touch(scene, ray, h, list) {
            c.queries += 1;
            return None;
        }
    }
    if below > 0 {
        let clock = timer.is_some().then(std::time::Instant::now);
        c.false_hits += settle_masked(scene, &scene.masked_solids[..below], ray, hit.map(|h| h.t), list);
        if let (Some(t0), Some(timer)) = (clock, timer) {
            timer.add_since(t0);
        }
    }
    c.max_list_depth = c.max_list_depth.max(list.len() as u64);
    if list.spilled() {
        c.list_spills += 1;
    }
    Some(hit.map(|hit| TrueHit {
        hit,
        coincident: Coincident::NONE,
    }))
}

/// The ray mask of a filtered query by a ray whose list's top rank is `p0`,
/// and how many of `scene.masked_solids` (sorted by rank) it leaves out:
/// those ranked below `p0`. Their hits would all be false (rank < P0), so
/// the query need not see them at all ([`settle_masked`] gives the list
/// their membership instead). Every other geometry has mask bit 31.
#[inline]
fn ray_mask(scene: &RenderScene, p0: u32) -> (u32, usize) {
    let below = scene
        .masked_solids
        .partition_point(|&s| scene.solids[s as usize].rank < p0);
    if below == 0 {
        return (u32::MAX, 0);
    }
    // Bit r for every rank r >= p0 (a masked solid's bit is its rank < 31).
    (1 << 31 | u32::MAX.checked_shl(p0).unwrap_or(0), below)
}

/// A filtered query that left the analytic solids `masked` (all ranked
/// below its P0) out by its ray mask crossed none of their surfaces as far
/// as the list knows: give the list their membership just past `t` on `ray`
/// (one crossing window on, where the filter would have applied their
/// crossings up to) by point-in-solid; past a miss (`None`) the ray is
/// outside every bounded solid. Returns the number of memberships changed
/// (counted as false hits: one per solid whose side changed, not per
/// crossing).
///
/// Departure from the paper: Schmidt & Budge find the false hits one by
/// one; a solid that cannot be the answer and has an exact point-in-solid
/// test need not be intersected at all: where the ray ends up decides.
#[inline]
fn settle_masked(
    scene: &RenderScene,
    masked: &[u32],
    ray: &Ray,
    t: Option<f32>,
    list: &mut InteriorList,
) -> u64 {
    if masked.is_empty() {
        return 0;
    }
    let q = t.map(|t| {
        let t = t + window(ray, t);
        ray.org.as_dvec3() + ray.dir.as_dvec3() * t as f64
    });
    let mut changed = 0;
    // The list's members as bits, read once: a lookup per masked solid
    // would cost masked × listed comparisons on deep nests.
    let held = list.member_bits();
    for &s in masked {
        let solid = &scene.solids[s as usize];
        let inside = q.is_some_and(|q| {
            q.cmpge(solid.aabb.0).all() && q.cmple(solid.aabb.1).all() && scene.solid_contains(s, q)
        });
        let listed = match held {
            Some(bits) => s < 128 && bits >> s & 1 != 0,
            None => list.contains(s),
        };
        if inside != listed {
            changed += 1;
            if inside {
                list.insert(s, solid.rank);
            } else {
                list.remove(s);
            }
        }
    }
    changed
}

/// How a ray inside a list may be answered by a packet's plain query
/// ([`packet_query`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PacketQuery {
    /// The hit must be checked: [`plain_hit_is_true`] outside every solid,
    /// [`masked_hit_is_true`] inside one.
    pub check: bool,
    /// The query's ray mask (`u32::MAX`: every geometry).
    pub mask: u32,
    /// How many of the scene's masked solids (sorted by rank) the mask
    /// leaves out: their membership is settled after the hit.
    pub below: usize,
}

/// [`plain_query_suffices`], and for a ray inside overlapping solids that
/// the filter strategy would answer by one masked query (every solid below
/// its P0 is an analytic solid the mask leaves out: `masked_plain`), that
/// query: a packet lane can make it, checked by [`masked_hit_is_true`] and
/// settled by [`settle_masked_after`]. The re-cast and toggle baselines keep
/// their own single-ray queries.
#[inline]
pub fn packet_query(
    scene: &RenderScene,
    strategy: NestedStrategy,
    list: &InteriorList,
) -> Option<PacketQuery> {
    if let Some(check) = plain_query_suffices(scene, strategy, list) {
        return Some(PacketQuery {
            check,
            mask: u32::MAX,
            below: 0,
        });
    }
    let p0 = list.top_rank().unwrap_or(0);
    if strategy != NestedStrategy::Filter || p0 > scene.lowest_unmasked_rank {
        return None;
    }
    let (mask, below) = ray_mask(scene, p0);
    // (The analytic set reads the ray masks as Embree does: `AnalyticSet::hide_ranks`.)
    Some(PacketQuery {
        check: true,
        mask,
        below,
    })
}

/// Does the hit `hit` of a masked packet query (`q` from [`packet_query`])
/// of `ray`, inside the non-empty `list`, stand for [`trace`]'s? Not when it
/// is a solid ranked below the list's P0 (which neither Embree nor the
/// analytic set gives a masked lane), a touch at a mesh edge (the filter
/// decides there), or
/// another solid's surface passes near it (`trace` looks ahead there).
#[inline]
pub fn masked_hit_is_true(scene: &RenderScene, ray: &Ray, hit: Option<&Hit>, list: &InteriorList) -> bool {
    hit.is_none_or(|h| {
        let p0 = list.top_rank().unwrap_or(0);
        scene.rank_by_geom[h.geom_id as usize] >= p0
            && !is_touch(scene, ray, h, list)
            && !has_neighbours(scene, ray, h)
    })
}

/// After a masked packet query's true hit (or miss, `t` = `None`) that
/// [`masked_hit_is_true`] accepted: the memberships of the `q.below`
/// masked solids, as [`trace`] settles them; counted in `c` as `trace`
/// counts them.
#[inline]
pub fn settle_masked_after(
    scene: &RenderScene,
    q: PacketQuery,
    ray: &Ray,
    t: Option<f32>,
    list: &mut InteriorList,
    c: &mut Counters,
) {
    c.false_hits += settle_masked(scene, &scene.masked_solids[..q.below], ray, t, list);
    c.max_list_depth = c.max_list_depth.max(list.len() as u64);
    if list.spilled() {
        c.list_spills += 1;
    }
}

/// Can one plain query of a ray inside `list` stand in for [`trace`]?
/// `Some(check)` when it can: without overlapping solids (or with nesting
/// off) its hit is the true hit; outside every solid (`list` empty) too,
/// unless [`plain_hit_is_true`] says otherwise (`check`). `None`: only
/// `trace` will do.
pub fn plain_query_suffices(
    scene: &RenderScene,
    strategy: NestedStrategy,
    list: &InteriorList,
) -> Option<bool> {
    if !scene.has_overlap || strategy == NestedStrategy::Off {
        Some(false)
    } else if list.is_empty() {
        Some(true)
    } else {
        None
    }
}

/// Is the answer `hit` of a plain query of `ray`, by a ray outside every
/// solid (`list` empty), the hit [`trace`] returns with `strategy`? Not when
/// it only touches a mesh solid at an edge or vertex, nor (except for the
/// toggle, which does not test them) when the point just before it lies in a
/// mesh solid whose entry Embree leaked (`trace` continues past those) or
/// another solid's surface passes near it (`trace` looks ahead there:
/// `settle::look_ahead`).
pub fn plain_hit_is_true(
    scene: &RenderScene,
    strategy: NestedStrategy,
    ray: &Ray,
    hit: Option<&Hit>,
    list: &InteriorList,
) -> bool {
    hit.is_none_or(|h| {
        !is_touch(scene, ray, h, list)
            && (strategy == NestedStrategy::Toggle
                || (leaked_entry(scene, ray, h).is_none() && !has_neighbours(scene, ray, h)))
    })
}

fn recast(
    scene: &RenderScene,
    ray: &Ray,
    list: &mut InteriorList,
    c: &mut Counters,
    toggle: bool,
) -> crate::error::Result<Option<Hit>> {
    let mut r = *ray;
    // Bound the loop: a ray cannot cross more surfaces than this without a bug.
    for _ in 0..100_000 {
        let Some(h) = scene.embree.intersect(&r) else {
            return Ok(None);
        };
        if is_touch(scene, &r, &h, list) {
            r.tnear = recast_tnear(&r, h.t);
            c.queries += 1;
            continue;
        }
        if list.is_empty() {
            match leaked_entry(scene, &r, &h).filter(|_| !toggle) {
                None => return Ok(Some(h)),
                Some(leaked) => {
                    if repair_leak(scene, &r, &h, leaked, list) {
                        return Ok(Some(h));
                    }
                    c.false_hits += 1;
                    r.tnear = just_past(h.t);
                    c.queries += 1;
                    continue;
                }
            }
        }
        let rank = scene.rank_by_geom[h.geom_id as usize];
        let p0 = list.top_rank();
        let is_false = p0.is_some_and(|p| rank < p);
        if !is_false {
            return Ok(Some(h));
        }
        c.false_hits += 1;
        let s = scene.solid_by_geom[h.geom_id as usize].expect("ranked geometry is a solid");
        let entering = if near_edge(h.u, h.v) && !toggle {
            inside_after(scene, s, &r, h.t)
        } else {
            front_facing(h.ng, r.dir)
        };
        if toggle {
            list.toggle(s, rank);
        } else if entering {
            list.insert(s, rank);
        } else {
            list.remove(s);
        }
        c.max_list_depth = c.max_list_depth.max(list.len() as u64);
        if list.spilled() {
            c.list_spills += 1;
        }
        // Re-cast from just past the false hit, not past its crossing window:
        // a surface within the window (the true hit's solid leaving where
        // a lower solid's surface meets it) would be stepped over. A second
        // report of the same crossing (a shared mesh edge) repeats the same
        // insert or remove; the toggle would undo its first, so it keeps the window.
        r.tnear = if toggle {
            recast_tnear(&r, h.t)
        } else {
            just_past(h.t)
        };
        c.queries += 1;
    }
    Err(crate::error::Error::Invalid(
        "a ray crossed more than 100000 false surfaces; the scene geometry is degenerate".into(),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    #[test]
    fn list_updates_are_timed_once_per_filtered_query_and_change_nothing() {
        let scene = crate::dielectric::water_in_glass("");
        let ray = Ray::new(Vec3A::new(0.0, 0.1, 0.3), Vec3A::X);
        let mut timer = ListUpdateTimer::default();
        let (mut timed, mut plain) = (Counters::default(), Counters::default());
        for _ in 0..3 {
            let mut list = InteriorList::from_solids(&scene.solids, &[0, 1]);
            let a = trace_timing_list_updates(
                &scene,
                NestedStrategy::Filter,
                &ray,
                &mut list,
                &mut timed,
                &mut timer,
            )
            .unwrap();
            let mut plain_list = InteriorList::from_solids(&scene.solids, &[0, 1]);
            let b = trace(&scene, NestedStrategy::Filter, &ray, &mut plain_list, &mut plain).unwrap();
            assert_eq!(a.map(|t| t.hit.t), b.map(|t| t.hit.t));
            assert_eq!(list.sorted(), plain_list.sorted());
        }
        assert_eq!(timer.count, 3, "one timed application per filtered query");
        assert!(timer.seconds > 0.0);
        assert_eq!(timed.false_hits, 3);
        assert_eq!(timed.false_hits, plain.false_hits);
    }

    #[test]
    fn inside_the_lowest_solid_a_plain_query_answers_and_the_look_ahead_finds_a_surface_at_the_hit() {
        // Sphere a (the lowest rank) overlaps sphere b; they meet on the
        // circle x = 0.75, radius sqrt(0.4375).
        let scene = crate::dielectric::two_spheres(([1.5, 0.0, 0.0], 1.0), "");
        let org = Vec3A::new(-0.5, 0.0, 0.0);
        let mut c = Counters::default();
        // Away from b: one plain query, no filter call.
        let mut list = InteriorList::from_solids(&scene.solids, &[0]);
        let h = trace(
            &scene,
            NestedStrategy::Filter,
            &Ray::new(org, -Vec3A::X),
            &mut list,
            &mut c,
        )
        .unwrap()
        .unwrap();
        assert!((h.hit.t - 0.5).abs() < 1e-5);
        assert_eq!((c.queries, c.filter_calls), (1, 0));
        // Through the circle where a's exit is b's entry: still one plain
        // query (nothing ranks below a), and the look-ahead gives the hit
        // the other sphere's crossing.
        let on_circle = Vec3A::new(0.75, 0.4375f32.sqrt(), 0.0);
        let mut list = InteriorList::from_solids(&scene.solids, &[0]);
        let h = trace(
            &scene,
            NestedStrategy::Filter,
            &Ray::new(org, on_circle - org),
            &mut list,
            &mut c,
        )
        .unwrap()
        .unwrap();
        assert!((h.hit.t - 1.0).abs() < 1e-5);
        assert_eq!((c.queries, c.filter_calls), (2, 0));
        // The hit is on one sphere; the other's crossing comes with it: a's
        // exit (rank 0) or b's entry (rank 1).
        let hit_solid = scene.solid_by_geom[h.hit.geom_id as usize];
        let other = if hit_solid == Some(0) {
            (1, 1, true)
        } else {
            (0, 0, false)
        };
        assert_eq!(
            h.coincident.iter().collect::<Vec<_>>(),
            [other],
            "{:?}",
            h.coincident
        );
        assert_eq!(c.settled, 1, "found by the look-ahead");
    }
}
