//! The neighbourhood of a true hit: other solids' surfaces so close to it
//! that no query crosses them (docs/design.md, "The crossing window").
//!
//! A ray that meets its true hit at p does not go on from p: its child starts
//! at q, a spawn offset (2·10⁻⁶ here) off the surface. A surface of another
//! solid within that offset of p is crossed by nobody: the query that found
//! the hit stopped there (Embree clips the ray at an accepted hit, so a
//! candidate 10⁻⁷ beyond it is never offered to the filter, and the re-cast
//! and the plain query return the first true hit), and the child starts past
//! it, and the list would be wrong by that one solid. Two steps close it, both gated by an exact distance test so that a
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
    analytic, near_edge, surface_may_come_within_box, surfaces_may_come_within, Coincident, NearSolids,
    TrueHit,
};
use super::InteriorList;
use crate::counters::Counters;
use crate::ray::{crossing_window, Hit, Ray};
use crate::scene::model::{Box32, Neighbours, Zone};
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
            .map(|(g, rec)| {
                let own = scene.solid_by_geom[g];
                let bx = match &rec.shape {
                    Shape::Mesh(m) => m.aabb(),
                    Shape::Analytic(a) => a.aabb(),
                };
                (0..n)
                    .filter(|&b| match own {
                        Some(a) => b != a && surfaces_may_come_within(scene, a, b, tol),
                        None => surface_may_come_within_box(scene, b, bx, tol),
                    })
                    .filter_map(|b| zone(scene, g as u32, bx, b, tol))
                    .collect()
            })
            .collect::<Vec<Vec<Zone>>>();
        let near_prims: Vec<Option<Vec<Box32>>> = scene
            .geoms
            .iter()
            .zip(&of)
            .map(|(rec, zones)| match &rec.shape {
                Shape::Mesh(m) if !zones.is_empty() => {
                    let mut budget = PIECE_TESTS;
                    Some(
                        m.indices
                            .iter()
                            .map(|t| {
                                let v = t.map(|i| {
                                    let p = m.positions[i as usize];
                                    DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
                                });
                                let mut near = (DVec3::INFINITY, DVec3::NEG_INFINITY);
                                for z in zones {
                                    near_pieces(scene, z.solid, v, tol, 0, &mut budget, &mut near);
                                }
                                if near.0.cmple(near.1).all() {
                                    // Padded as a zone is (see `zone`).
                                    Box32::padded(near.0, near.1, tol)
                                } else {
                                    Box32::EMPTY
                                }
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

/// The [`Zone`] of solid `s` on the surface of geometry `geom` with bounds
/// `bx`: the points of that surface within `tol` of the solid's surface lie
/// in both bounds (dilated by `tol`) and in what each shape's own tests keep
/// of them (for a sphere, its ball widened by `tol`; on a sphere near a
/// second sphere, the band of the first around the circle where they meet).
/// `None` when that box is empty.
fn zone(scene: &RenderScene, geom: u32, bx: (DVec3, DVec3), s: u32, tol: f64) -> Option<Zone> {
    let solid = &scene.solids[s as usize];
    let mut b = (
        (bx.0 - tol).max(solid.aabb.0 - tol),
        (bx.1 + tol).min(solid.aabb.1 + tol),
    );
    let other = analytic(scene, solid.geom);
    let own = analytic(scene, geom);
    for a in [other, own].into_iter().flatten() {
        b = a.clip_to_near_surface(tol, b)?;
    }
    if let (Some(g), Some(o)) = (own, other) {
        b = g.clip_to_band(o, tol, b)?;
    }
    if !b.0.cmple(b.1).all() {
        return None;
    }
    // Padded by `tol` again: a hit point computed in f32 lies within it of
    // the true point wherever the table applies (see `for_each_near`).
    Some(Zone {
        solid: s,
        bx: Box32::padded(b.0, b.1, tol),
    })
}

/// Distance tests one mesh's triangles may spend in [`near_pieces`]
/// (a few milliseconds); past them each piece left counts as near whole.
const PIECE_TESTS: u32 = 2_000_000;

/// The parts of the triangle `v` that the surface of solid `s` may come
/// within `tol` of, added to the box `acc`. Its distance test at the
/// centroid, widened by the farthest vertex, rules a piece out; where it
/// cannot, the halves (split at the longest edge) are tested, down to pieces
/// no wider than `tol` or 16 levels (whose bounds are then added), while
/// `budget` lasts (past it, each piece left is added whole). A lathe's wall
/// triangle is a sliver as tall as the glass (bisection halves its length
/// every other level): only a band of it, where the water's cap meets it,
/// is near the water's surface, and hits elsewhere on it skip the
/// look-ahead (a flag per triangle kept 12k look-aheads per pass of
/// glass_ice_bubbles, every one of which found nothing).
fn near_pieces(
    scene: &RenderScene,
    s: u32,
    v: [DVec3; 3],
    tol: f64,
    depth: u32,
    budget: &mut u32,
    acc: &mut (DVec3, DVec3),
) {
    let add = |acc: &mut (DVec3, DVec3)| {
        acc.0 = acc.0.min(v[0].min(v[1]).min(v[2]));
        acc.1 = acc.1.max(v[0].max(v[1]).max(v[2]));
    };
    if *budget == 0 {
        add(acc);
        return;
    }
    *budget -= 1;
    let c = (v[0] + v[1] + v[2]) / 3.0;
    let rho = v.iter().map(|p| (*p - c).length()).fold(0.0, f64::max);
    if !scene.surface_may_be_near(s, c, rho + tol) {
        return;
    }
    if depth >= 16 || rho <= tol {
        add(acc);
        return;
    }
    let e = [0, 1, 2].map(|k| (v[(k + 1) % 3] - v[k]).length_squared());
    let k = (0..3).max_by(|&a, &b| e[a].total_cmp(&e[b])).unwrap_or(0);
    let (a, b, o) = (v[k], v[(k + 1) % 3], v[(k + 2) % 3]);
    let m = (a + b) / 2.0;
    near_pieces(scene, s, [a, m, o], tol, depth + 1, budget, acc);
    near_pieces(scene, s, [m, b, o], tol, depth + 1, budget, acc);
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
        let q = [p.x as f32, p.y as f32, p.z as f32];
        for z in &nb.of[geom as usize] {
            if z.holds(q) && scene.surface_may_be_near(z.solid, p, tol) && !f(z.solid) {
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
/// hit `h` of `ray`? `false` (most hits, at the cost of a table lookup and
/// a few box tests) when its geometry has no neighbours, or its triangle has
/// none near, or the hit lies in none of their zones, and the neighbourhood
/// is within the table's tolerance.
#[inline(always)]
fn may_have_neighbours(scene: &RenderScene, h: &Hit, ray: &Ray) -> bool {
    let nb = neighbours(scene);
    let g = h.geom_id as usize;
    let zones = &nb.of[g];
    let table = !zones.is_empty() && {
        let p = (ray.org + ray.dir * h.t).to_array();
        nb.near_prims[g]
            .as_ref()
            .is_none_or(|near| near.get(h.prim_id as usize).is_none_or(|b| b.holds(p)))
            && zones.iter().any(|z| z.holds(p))
    };
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
/// a true hit whose neighbourhood `look_ahead` kept in `coincident`: each
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on the unit sphere (Fibonacci spiral).
    fn sphere_points(n: usize) -> impl Iterator<Item = DVec3> {
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        (0..n).map(move |i| {
            let y = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
            let r = (1.0 - y * y).sqrt();
            let phi = golden * i as f64;
            DVec3::new(r * phi.cos(), y, r * phi.sin())
        })
    }

    /// A lathe glass whose inner wall the water's top cap crosses (as in
    /// glass_ice_bubbles): each wall triangle's near box holds every point
    /// of it within the table's tolerance of the water's surface (distance
    /// to the capped cylinder computed here, independently), and only a
    /// band of it: a flag per triangle (its whole surface) holds ~100x more
    /// (1.34 M sampled points against 13.6 k; asked: 20x).
    #[test]
    fn triangle_boxes_hold_every_near_point_and_only_a_band() {
        let scene = crate::dielectric::test_scene(
            r#"
[camera]
position = [0.0, 1.0, 5.0]
target = [0.0, 1.0, 0.0]
fov = 40.0
[[objects]]
name = "glass"
shape = { type = "lathe", segments = 32, profile = [[0.0, 0.0], [1.0, 0.0], [1.0, 2.5], [0.9, 2.5], [0.9, 0.1], [0.0, 0.1]] }
material = { type = "dielectric", ior = 1.5, priority = 2 }
[[objects]]
name = "water"
shape = { type = "cylinder", p0 = [0.0, 0.05, 0.0], p1 = [0.0, 1.8, 0.0], radius = 0.95, caps = true }
material = { type = "dielectric", ior = 1.33, priority = 1 }
"#,
        );
        let nb = neighbours(&scene);
        let g = scene.geoms.iter().position(|g| g.name == "glass").unwrap();
        let Shape::Mesh(m) = &scene.geoms[g].shape else {
            panic!("the lathe is a mesh")
        };
        let boxes = nb.near_prims[g].as_ref().expect("the glass has a neighbour");
        // Distance from `p` to the surface of the capped cylinder.
        let dist = |p: DVec3| {
            let r = (p.x * p.x + p.z * p.z).sqrt();
            let (dr, dy) = (r - 0.95, (0.05 - p.y).max(p.y - 1.8));
            if dr <= 0.0 && dy <= 0.0 {
                (-dr).min(-dy)
            } else {
                (dr.max(0.0).powi(2) + dy.max(0.0).powi(2)).sqrt()
            }
        };
        let (mut near, mut held, mut flagged) = (0, 0, 0);
        let mut rng = crate::sampling::Rng::new(3);
        let k = 40;
        for (t, tri) in m.indices.iter().enumerate() {
            let [a, b, c] = tri.map(|i| DVec3::from_array(m.positions[i as usize].map(f64::from)));
            let bx = boxes[t];
            let whole = bx != Box32::EMPTY;
            // A grid over the triangle, and where it spans the cap's height
            // (y = 1.8) random points too: the band within the tolerance is
            // a few thousandths tall, finer than the grid.
            let grid =
                (0..=k).flat_map(|i| (0..=(k - i)).map(move |j| (i as f64 / k as f64, j as f64 / k as f64)));
            let spans = a.y.min(b.y).min(c.y) < 1.81 && a.y.max(b.y).max(c.y) > 1.79;
            let random: Vec<(f64, f64)> = (0..if spans { 20_000 } else { 0 })
                .map(|_| {
                    let (u, v) = (rng.uniform_f64(), rng.uniform_f64());
                    if u + v > 1.0 {
                        (1.0 - u, 1.0 - v)
                    } else {
                        (u, v)
                    }
                })
                .collect();
            for (u, v) in grid.chain(random) {
                let p = a + (b - a) * u + (c - a) * v;
                let q = [p.x as f32, p.y as f32, p.z as f32];
                let inside = bx.holds(q);
                held += inside as u32;
                flagged += whole as u32;
                if dist(p) <= nb.tol {
                    near += 1;
                    assert!(inside, "{p} (triangle {t}) is {} from the water", dist(p));
                }
            }
        }
        assert!(near > 100, "{near} points near the water's surface");
        assert!(
            held * 20 < flagged,
            "{held} points in the boxes, {flagged} on flagged triangles"
        );
    }

    #[test]
    fn zones_hold_every_point_near_the_other_surface_and_few_others() {
        let ground = r#"[[objects]]
name = "ground"
shape = { type = "rect", center = [0.0, -1.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [6.0, 6.0] }
material = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }
"#;
        let scene = crate::dielectric::two_spheres(([1.5, 0.2, 0.0], 0.8), ground);
        let nb = neighbours(&scene);
        let geom = |name: &str| scene.geoms.iter().position(|g| g.name == name).unwrap();
        let (ga, gg) = (geom("a"), geom("ground"));
        let (cb, rb) = (DVec3::new(1.5, 0.2, 0.0), 0.8);
        let zone_b = nb.of[ga]
            .iter()
            .find(|z| z.solid == 1)
            .expect("b is a's neighbour");
        let q = |p: DVec3| [p.x as f32, p.y as f32, p.z as f32];
        let (mut near, mut held, mut held_by_bounds) = (0, 0, 0);
        let b_box = scene.solids[1].aabb;
        for x in sphere_points(200_000) {
            let in_zone = zone_b.holds(q(x));
            held += in_zone as u32;
            held_by_bounds += ((x - nb.tol).cmple(b_box.1).all() && (x + nb.tol).cmpge(b_box.0).all()) as u32;
            if ((x - cb).length() - rb).abs() <= nb.tol {
                near += 1;
                assert!(in_zone, "{x} is within {} of b's surface", nb.tol);
            }
        }
        assert!(near > 0);
        // The box of the band around the circle where they meet (with the cap
        // beyond it): 4.5% of a's surface, against 14.5% in b's bounds (the
        // test before zones), which fails this bound.
        assert!(
            held * 3 < held_by_bounds,
            "{held} held, {held_by_bounds} by b's bounds"
        );
        // The ground touches a at (0, -1, 0): its zone is a small box there.
        let ground_a = nb.of[gg]
            .iter()
            .find(|z| z.solid == 0)
            .expect("a is the ground's neighbour");
        assert!(ground_a.holds(q(DVec3::new(0.0, -1.0, 0.0))));
        assert!(!ground_a.holds(q(DVec3::new(0.3, -1.0, 0.0))));
        // b (bottom at y = -0.6) is 0.4 above the ground: no neighbour.
        assert!(nb.of[gg].iter().all(|z| z.solid != 1));
    }
}
