//! The neighbourhood of a true hit: other solids' surfaces so close to it
//! that no query crosses them (issue 12 §3; the diagnosis is in
//! `docs/nested-wrong-rays.md`).
//!
//! A ray that meets its true hit at p does not go on from p: its child starts
//! at q, a spawn offset (2·10⁻⁶ here) off the surface. A surface of another
//! solid within that offset of p is crossed by nobody: the query that found
//! the hit stopped there (Embree clips the ray at an accepted hit, so a
//! candidate 10⁻⁷ beyond it is never offered to the filter, and the re-cast
//! and the plain query return the first true hit), and the child starts past
//! it. The list was then wrong by that one solid: 29 rays in 10M on the mesh
//! scenes. Two steps close it, both gated by an exact distance test so that a
//! hit with no other surface near pays one bounds test per solid:
//!
//! 1. [`look_ahead`], inside `trace`, before the boundary event: each solid
//!    whose surface passes within four crossing windows of p gets its
//!    membership just past the hit from point-in-solid, as a coincident
//!    crossing when it differs from the list. The event's indices are then
//!    right too (a glass exit with the water's surface 6·10⁻⁸ beyond it goes
//!    glass → water, not glass → air, which at 45° is a total internal
//!    reflection instead of a refraction).
//! 2. [`settle_child`], where the child ray is spawned: those solids'
//!    membership at the child's origin q, by point-in-solid at q (a
//!    reflection's q lies on the side the query already crossed; a
//!    refraction's q may lie past a surface between p and q).
//!
//! A hit near a mesh edge also settles the hit's own solid for the child, at
//! a probe a little along the child ray rather than at q itself: at a convex
//! edge q may lie outside the solid the ray just entered (a ray clipping the
//! glass's rim), and q itself lies on the adjacent face's plane to within
//! rounding, where point-in-solid is a coin toss.
//!
//! The paper's toggle strategy is left as the paper has it.
use super::filter::{
    near_edge, surface_may_come_within_box, surfaces_may_come_within, Coincident, NearSolids, TrueHit,
};
use super::InteriorList;
use crate::counters::Counters;
use crate::ray::{crossing_window, Hit, Ray};
use crate::scene::model::Neighbours;
use crate::scene::{RenderScene, Shape};
use glam::DVec3;

/// The point at distance `t` along `ray`, in f64.
#[inline]
fn at(ray: &Ray, t: f32) -> DVec3 {
    ray.org.as_dvec3() + ray.dir.as_dvec3() * t as f64
}

/// Four crossing windows at `t` along `ray`, as a distance: every surface
/// a child's spawn offset can step over (the window is twice the offset) and
/// every surface the filter would call coincident.
#[inline]
fn neighbourhood(ray: &Ray, t: f32) -> f64 {
    4.0 * crossing_window(ray.org, ray.dir, t) as f64 * ray.dir.length() as f64
}

/// Per geometry, the solids (other than its own) whose surfaces may come
/// within a thousandth of the scene's size of its surface (bounds, and exact
/// tests for spheres: `filter::surfaces_may_come_within`); computed on first
/// use.
fn neighbours(scene: &RenderScene) -> &Neighbours {
    scene.neighbours.get_or_init(|| {
        let scale = scene
            .solids
            .iter()
            .map(|s| s.aabb.0.abs().max(s.aabb.1.abs()).max_element())
            .fold(0.0, f64::max);
        let tol = 1e-3 * (1.0 + scale);
        let n = scene.solids.len() as u32;
        let of = scene
            .geoms
            .iter()
            .enumerate()
            .map(|(g, rec)| match scene.solid_by_geom[g] {
                Some(a) => (0..n)
                    .filter(|&b| b != a && surfaces_may_come_within(scene, a, b, tol))
                    .collect(),
                None => {
                    let bx = match &rec.shape {
                        Shape::Mesh(m) => m.aabb(),
                        Shape::Analytic(a) => a.aabb(),
                    };
                    (0..n)
                        .filter(|&b| surface_may_come_within_box(scene, b, bx, tol))
                        .collect()
                }
            })
            .collect::<Vec<Vec<u32>>>();
        let near_prims: Vec<Option<Vec<bool>>> = scene
            .geoms
            .iter()
            .zip(&of)
            .map(|(rec, nbs)| match &rec.shape {
                Shape::Mesh(m) if !nbs.is_empty() => {
                    let mut budget = PIECE_TESTS;
                    Some(
                        m.indices
                            .iter()
                            .map(|t| {
                                let v = t.map(|i| {
                                    let p = m.positions[i as usize];
                                    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
                                });
                                nbs.iter()
                                    .any(|&s| piece_may_be_near(scene, s, v, tol, 0, &mut budget))
                            })
                            .collect(),
                    )
                }
                _ => None,
            })
            .collect();
        Neighbours { tol, of, near_prims }
    })
}

/// Distance tests one mesh's triangles may spend in [`piece_may_be_near`]
/// (a few milliseconds); past them every triangle counts as near.
const PIECE_TESTS: u32 = 2_000_000;

/// May the surface of solid `s` come within `tol` of the triangle `v`? Its
/// distance test at the centroid, widened by the farthest vertex; where
/// that cannot rule the triangle out, its halves (split at the longest
/// edge) are tested, down to pieces no wider than `tol` or 16 levels (then
/// `true`), while `budget` lasts. A lathe's wall triangle is a sliver as
/// tall as the glass (bisection halves its length every other level): most
/// of it is far from the water's surface that meets one end.
fn piece_may_be_near(
    scene: &RenderScene,
    s: u32,
    v: [DVec3; 3],
    tol: f64,
    depth: u32,
    budget: &mut u32,
) -> bool {
    let c = (v[0] + v[1] + v[2]) / 3.0;
    let rho = v.iter().map(|p| (*p - c).length()).fold(0.0, f64::max);
    if *budget == 0 {
        return true;
    }
    *budget -= 1;
    if !scene.surface_may_be_near(s, c, rho + tol) {
        return false;
    }
    if depth >= 16 || rho <= tol {
        return true;
    }
    let e = [0, 1, 2].map(|k| (v[(k + 1) % 3] - v[k]).length_squared());
    let k = (0..3).max_by(|&a, &b| e[a].total_cmp(&e[b])).unwrap_or(0);
    let (a, b, o) = (v[k], v[(k + 1) % 3], v[(k + 2) % 3]);
    let m = (a + b) / 2.0;
    piece_may_be_near(scene, s, [a, m, o], tol, depth + 1, budget)
        || piece_may_be_near(scene, s, [m, b, o], tol, depth + 1, budget)
}

/// Calls `f(solid)` for every solid other than `own` (the solid of the hit
/// geometry `geom`, if any) whose surface may pass within `tol` of `p`, a
/// point on `geom`'s surface (its bounds, dilated, hold `p` and its distance
/// test says so); stops at the first `false`. Only `geom`'s neighbours can
/// qualify (concentric shells have none), unless `tol` is beyond the
/// neighbour table's.
#[inline]
fn for_each_near(
    scene: &RenderScene,
    geom: u32,
    own: Option<u32>,
    p: DVec3,
    tol: f64,
    mut f: impl FnMut(u32) -> bool,
) {
    let nb = neighbours(scene);
    // Twice: `p` is on the surface only to rounding.
    if 2.0 * tol <= nb.tol {
        let (lo, hi) = (p - tol, p + tol);
        for &i in &nb.of[geom as usize] {
            let b = scene.solids[i as usize].aabb;
            if hi.cmpge(b.0).all() && lo.cmple(b.1).all() && scene.surface_may_be_near(i, p, tol) && !f(i) {
                return;
            }
        }
        return;
    }
    scene.solid_boxes.meeting(p, tol, |i| {
        Some(i) == own || !scene.surface_may_be_near(i, p, tol) || f(i)
    });
}

/// May any solid's surface pass within the look-ahead's neighbourhood of a
/// hit `h` of `ray`? `false` (most hits, at the cost of a table lookup) when
/// its geometry has no neighbours, or its triangle has none near, and the
/// neighbourhood is within the table's tolerance.
#[inline]
fn may_have_neighbours(scene: &RenderScene, h: &Hit, ray: &Ray) -> bool {
    let nb = neighbours(scene);
    let g = h.geom_id as usize;
    let table = !nb.of[g].is_empty()
        && nb.near_prims[g]
            .as_ref()
            .is_none_or(|near| near.get(h.prim_id as usize).copied().unwrap_or(true));
    table || 2.0 * neighbourhood(ray, h.t) > nb.tol
}

/// Is `h` on a mesh solid, near one of the triangle's edges? Its own solid
/// is then settled for the child (the module's doc).
#[inline]
fn own_mesh_edge(scene: &RenderScene, h: &Hit) -> Option<u32> {
    if scene.mesh_solids.is_empty() || !near_edge(h.u, h.v) {
        return None;
    }
    let s = scene.solid_by_geom[h.geom_id as usize]?;
    matches!(scene.geoms[h.geom_id as usize].shape, Shape::Mesh(_)).then_some(s)
}

/// Would [`look_ahead`] find anything at the hit `h` of `ray`? (A plain
/// query's hit, taken from a packet, stands only when it would not.)
pub(crate) fn has_neighbours(scene: &RenderScene, ray: &Ray, h: &Hit) -> bool {
    if own_mesh_edge(scene, h).is_some() {
        return true;
    }
    if !may_have_neighbours(scene, h, ray) {
        return false;
    }
    let own = scene.solid_by_geom[h.geom_id as usize];
    let mut any = false;
    for_each_near(
        scene,
        h.geom_id,
        own,
        at(ray, h.t),
        neighbourhood(ray, h.t),
        |_| {
            any = true;
            false
        },
    );
    any
}

/// Step 1 (the module's doc): at the true hit `th` of `ray`, for a ray
/// inside `list` (before the boundary event), every other solid whose
/// surface passes near the hit gets its membership just past the hit (one
/// crossing window on, along `ray`) from point-in-solid; where that differs
/// from what the list and the coincident crossings say, the crossing is
/// made coincident with the hit. The solids are kept for [`settle_child`].
#[inline]
pub(crate) fn look_ahead(
    scene: &RenderScene,
    ray: &Ray,
    th: &mut TrueHit,
    list: &InteriorList,
    c: &mut Counters,
) {
    let h = &th.hit;
    let own_edge = own_mesh_edge(scene, h);
    // Most hits: no solid's surface can be near (a ground, a backdrop, a
    // solid with no neighbours), and nothing is touched.
    if own_edge.is_none() && !may_have_neighbours(scene, h, ray) {
        return;
    }
    look_ahead_near(scene, ray, th, own_edge, list, c);
}

#[inline(never)]
fn look_ahead_near(
    scene: &RenderScene,
    ray: &Ray,
    th: &mut TrueHit,
    own_edge: Option<u32>,
    list: &InteriorList,
    c: &mut Counters,
) {
    let h = th.hit;
    let own = scene.solid_by_geom[h.geom_id as usize];
    let p = at(ray, h.t);
    let mut near = NearSolids::NONE;
    near.own_edge = own_edge;
    let coincident = &mut th.coincident;
    for_each_near(scene, h.geom_id, own, p, neighbourhood(ray, h.t), |s| {
        near.push(s);
        // Computed here: most hits have no neighbour near.
        let past = at(ray, h.t + crossing_window(ray.org, ray.dir, h.t));
        let inside = scene.solid_contains(s, past);
        let claimed = coincident.entering_of(s).unwrap_or_else(|| list.contains(s));
        if inside != claimed {
            coincident.settle(s, scene.solids[s as usize].rank, inside);
            c.settled += 1;
        }
        true
    });
    if !near.is_empty() {
        coincident.near = near;
    }
}

/// Step 2 (the module's doc): the list `list` of the ray `child` spawned at
/// a true hit whose neighbourhood [`look_ahead`] kept in `coincident`: each
/// solid kept gets its membership at the child's origin from point-in-solid.
/// Nothing to do for most hits, and nothing for a child that continues its
/// parent's line (`tnear > 0`): its query starts at the hit and crosses every
/// surface past it itself.
#[inline]
pub fn settle_child(
    scene: &RenderScene,
    coincident: &Coincident,
    child: &Ray,
    list: &mut InteriorList,
    c: &mut Counters,
) {
    if coincident.near.is_empty() || child.tnear > 0.0 {
        return;
    }
    settle(scene, &coincident.near, child, list, c);
}

#[inline(never)]
fn settle(scene: &RenderScene, near: &NearSolids, child: &Ray, list: &mut InteriorList, c: &mut Counters) {
    let q = child.org.as_dvec3();
    let mut set = |s: u32, inside: bool| {
        if inside != list.contains(s) {
            c.settled += 1;
            if inside {
                list.insert(s, scene.solids[s as usize].rank);
            } else {
                list.remove(s);
            }
        }
    };
    for &s in near.ids() {
        set(s, scene.solid_contains(s, q));
    }
    if let Some(s) = near.own_edge {
        let d = child.dir.as_dvec3().normalize();
        let probe = q + d * (2e-5 * (1.0 + q.abs().max_element()));
        set(s, scene.solid_contains(s, probe));
    }
}
