//! The analytic set's kernels against Embree's callbacks and the scalar
//! code, at every vector level, on scenes the builder makes: here, above
//! both the shapes and the builder.
use super::shapes::{Analytic, AnalyticSet, Quadric, SetScratch, SurfaceLanes, ERROR_SAFETY};
use crate::embree::{Packet8, Ray, RayPacket};
use crate::scene::{load_scene_str, BuildOptions, RenderScene, Shape, SurfacePoint};
use glam::DVec3;
use glam::Vec3A as V3;

use crate::vector_levels as levels;

fn scene(objects: &str, analytic_set: bool) -> RenderScene {
    let text = format!(
        r#"
[camera]
position = [0.0, 1.0, 6.0]
target = [0.0, 0.5, 0.0]
fov = 40.0
[film]
width = 8
height = 8
spp = 1
[[objects]]
name = "ground"
shape = {{ type = "rect", center = [0.0, -1.2, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [8.0, 8.0] }}
material = {{ type = "diffuse", reflectance = [0.5, 0.5, 0.5] }}
{objects}"#
    );
    let opts = BuildOptions {
        analytic_set,
        ..BuildOptions::default()
    };
    load_scene_str("set_test.toml", &text, std::path::Path::new("."), &opts).unwrap()
}

const SETS: [&str; 2] = [
    r#"
[[objects]]
name = "ball"
shape = { type = "sphere", center = [0.3, 0.6, -0.2], radius = 0.6 }
material = { type = "dielectric", int_ior = 1.5, ext_ior = 1.0 }
[[objects]]
name = "pipe"
shape = { type = "cylinder", p0 = [0.0, -1.0, 0.0], p1 = [0.0, 1.0, 0.0], radius = 1.0, normal = "in" }
material = { type = "dielectric", int_ior = 1.5, ext_ior = 1.0 }
[[objects]]
name = "tilted"
shape = { type = "cylinder", p0 = [0.1, -1.0, 0.2], p1 = [0.5, 1.0, 0.4], radius = 0.7, caps = true }
material = { type = "dielectric", int_ior = 1.5, ext_ior = 1.0 }
[[objects]]
name = "disk"
shape = { type = "disk", center = [0.0, 1.2, 0.0], normal = [0.0, 1.0, 0.0], radius = 0.5 }
material = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }
[[objects]]
name = "card"
shape = { type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0], u_axis = [1.0, 0.0, 0.0], size = [1.2, 0.8] }
transform = [{ matrix = [[1.0, 0.4, 0.0, -0.6], [0.0, 1.0, 0.3, 0.2], [0.2, 0.0, 1.0, 0.8], [0.0, 0.0, 0.0, 1.0]] }]
material = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }
"#,
    r#"
[[objects]]
name = "tube"
shape = { type = "tube", p0 = [0.0, -1.0, 0.0], p1 = [0.0, 1.0, 0.0], outer_radius = 1.0, inner_radius = 0.8 }
material = { type = "dielectric", int_ior = 1.5, ext_ior = 1.0 }
[[objects]]
name = "ball"
shape = { type = "sphere", center = [0.0, 0.2, 0.0], radius = 0.5 }
material = { type = "dielectric", int_ior = 1.3, ext_ior = 1.0 }
[[objects]]
name = "can"
shape = { type = "cylinder", p0 = [1.5, -1.0, 0.0], p1 = [1.5, 1.0, 0.0], radius = 0.4, caps = true }
material = { type = "dielectric", int_ior = 1.5, ext_ior = 1.0 }
"#,
];

/// `SETS[0]` with every primitive in a vector form: its tilted capped
/// cylinder upright.
fn vector_forms() -> String {
    let tilted = "p1 = [0.5, 1.0, 0.4]";
    assert!(SETS[0].contains(tilted));
    SETS[0].replace(tilted, "p1 = [0.1, 1.0, 0.2]")
}

/// Packets of rays aimed near the shapes (grazing ones included), with
/// any interval.
fn packets(seed: u64, count: usize) -> Vec<[Ray; 8]> {
    let mut rng = crate::sampling::Rng::new(seed);
    let mut u = move || rng.uniform();
    (0..count)
        .map(|_| {
            std::array::from_fn(|_| {
                let org = V3::new(u(), u(), u()) * 6.0 - V3::splat(3.0);
                let aim = V3::new(u(), u(), u()) * 2.4 - V3::splat(1.2);
                let mut dir = aim - org;
                if u() < 0.2 {
                    dir = dir.cross(V3::new(0.3, 1.0, -0.2));
                }
                let mut r = Ray::new(org, dir);
                r.tnear = if u() < 0.5 { 0.0 } else { u() };
                r.tfar = if u() < 0.5 {
                    f32::INFINITY
                } else {
                    r.tnear + 4.0 * u()
                };
                r
            })
        })
        .collect()
}

/// Bit patterns of a hit, for exact comparison.
fn bits(p: &Packet8, i: usize) -> Option<(u32, u32, u32, [u32; 3], u32, u32)> {
    p.hit(i).map(|h| {
        (
            h.geom_id,
            h.prim_id,
            h.t.to_bits(),
            h.ng.to_array().map(f32::to_bits),
            h.u.to_bits(),
            h.v.to_bits(),
        )
    })
}

/// Lanes of `rays` where `set` (with the meshes from Embree) answers
/// otherwise than Embree with its callbacks in the whole scene, nearest
/// hits and occlusion.
fn disagreements(set: &AnalyticSet, with: &RenderScene, rays: &[[Ray; 8]]) -> usize {
    let mut bad = 0;
    for batch in rays {
        let (mut a, mut b) = (Packet8::new(), Packet8::new());
        for (i, r) in batch.iter().enumerate() {
            a.set_ray(i, r);
            b.set_ray(i, r);
        }
        a.intersect_meshes(&with.embree, false);
        set.intersect(&mut a, &mut SetScratch::default());
        b.intersect(&with.embree, false);
        bad += (0..8).filter(|&i| bits(&a, i) != bits(&b, i)).count();
        for (i, r) in batch.iter().enumerate() {
            a.set_ray(i, r);
            b.set_ray(i, r);
        }
        a.occlude_meshes(&with.embree, false);
        set.occlude(&mut a, &mut SetScratch::default());
        b.occlude(&with.embree, false);
        bad += (0..8).filter(|&i| a.occluded(i) != b.occluded(i)).count();
    }
    bad
}

/// The set answers packet queries as Embree's user-geometry callbacks
/// do, bit for bit (hit distance, normal, ids; occlusion), at every
/// vector level the CPU has: spheres, walls about y and other axes,
/// caps, disks, tubes and rects (the ground and a sheared card, when
/// they fit in the set: the first scene; the second keeps its ground a
/// mesh), rays grazing them, any interval. A sphere larger by a
/// relative 1e-7 is caught, and so are rects with their edges swapped.
#[test]
fn set_answers_as_embree_at_every_level() {
    let rays = packets(3, 4000);
    for (n, objects) in SETS.iter().enumerate() {
        let with = scene(objects, true);
        let without = scene(objects, false);
        assert!(with.embree.has_meshes_only() && !without.embree.has_meshes_only());
        let set = with.analytic_set.clone().expect("a set of few shapes");
        assert!(without.analytic_set.is_none());
        let rects = |s: &RenderScene| {
            s.geoms
                .iter()
                .filter(|g| matches!(g.shape, Shape::Analytic(Analytic::Rect(_))))
                .count()
        };
        assert_eq!(rects(&with), [2, 0][n], "set {n}: analytic rects");
        assert_eq!(rects(&without), 0, "set {n}: no set, no analytic rects");
        let hits: usize = rays
            .iter()
            .map(|batch| {
                let mut p = Packet8::new();
                for (i, r) in batch.iter().enumerate() {
                    p.set_ray(i, r);
                }
                p.intersect(&without.embree, false);
                (0..8)
                    .filter(|&i| p.hit(i).is_some_and(|h| h.geom_id > 0))
                    .count()
            })
            .sum();
        assert!(
            hits > 8000,
            "set {n}: {hits} analytic hits: the rays should meet the shapes"
        );
        for arch in levels() {
            let set = set.clone().with_arch(arch);
            assert_eq!(disagreements(&set, &with, &rays), 0, "set {n}, {arch:?}");
        }
        // Power: every sphere a relative 1e-7 larger; every rect with its
        // edges swapped (facing the other way).
        let grown = |grow: &dyn Fn(&Analytic) -> Option<Analytic>| {
            AnalyticSet::try_new(
                with.geoms
                    .iter()
                    .enumerate()
                    .filter_map(|(g, rec)| match &rec.shape {
                        Shape::Analytic(a) => Some((g as u32, grow(a).unwrap_or(*a))),
                        Shape::Mesh(_) => None,
                    }),
            )
            .unwrap()
        };
        let spheres = grown(&|a| match a {
            Analytic::Sphere(s) => Some(Analytic::Sphere(crate::scene::shapes::Sphere {
                radius: s.radius * (1.0 + 1e-7),
                ..*s
            })),
            _ => None,
        });
        let bad = disagreements(&spheres, &with, &rays);
        assert!(bad > 0, "set {n}: a grown sphere went unnoticed");
        if rects(&with) > 0 {
            let swapped = grown(&|a| match a {
                Analytic::Rect(r) => {
                    let flip = r.normal.dot(r.edge_u.cross(r.edge_v)) < 0.0;
                    crate::scene::shapes::Rect::new(r.corner, r.edge_v, r.edge_u, flip).map(Analytic::Rect)
                }
                _ => None,
            });
            let bad = disagreements(&swapped, &with, &rays);
            assert!(bad > 0, "set {n}: rects with swapped edges went unnoticed");
        }
    }
}

/// Rays whose interval starts or ends exactly at the f32 distance of a
/// crossing (Embree's hit in the whole scene): where the rounding of a
/// root to f32 decides whether it is kept, the kernel is unsure and the
/// lane is answered in scalar code, as Embree answers it at every
/// level. Trusting the kernel's answer for those lanes instead is
/// caught.
#[test]
fn lanes_at_a_crossing_are_replayed() {
    let with = scene(SETS[0], true);
    let without = scene(SETS[0], false);
    let mut rays = packets(5, 2000);
    for batch in rays.iter_mut() {
        let mut p = Packet8::new();
        for (i, r) in batch.iter().enumerate() {
            p.set_ray(i, r);
        }
        p.intersect(&without.embree, false);
        for (i, r) in batch.iter_mut().enumerate() {
            if let Some(h) = p.hit(i) {
                if i % 2 == 0 {
                    r.tfar = h.t;
                } else {
                    r.tnear = h.t;
                }
            }
        }
    }
    let set = with.analytic_set.clone().expect("a set of few shapes");
    for arch in levels() {
        let set = set.clone().with_arch(arch);
        assert_eq!(disagreements(&set, &with, &rays), 0, "{arch:?}");
    }
    let trusting = AnalyticSet {
        trust_kernel: true,
        ..set
    };
    let bad = disagreements(&trusting, &with, &rays);
    assert!(
        bad > 500,
        "trusting the kernel at the interval's ends: {bad} disagreements"
    );
}

/// What [`f32_against_embree`] found.
#[derive(Debug, Default)]
struct F32Check {
    /// Lanes (nearest-hit and occlusion queries) answered otherwise
    /// than by Embree: another primitive, a hit for a miss, or the
    /// other occlusion.
    wrong: usize,
    /// The largest |t − Embree's t| / max(1, |t|) of the same hits.
    t_err: f64,
    /// The largest distance of a hit point `o + t·d` (f64) from its
    /// f64 shape: the f32 queries' and Embree's.
    point_err: (f64, f64),
    /// The nearest-hit lanes that hit a primitive of the set.
    hits: usize,
    /// The share of the lanes (both queries) answered again in f64.
    replayed: f64,
}

/// Distance of `p` from the surface of quadric `q`.
fn surface_distance(q: &Quadric, p: DVec3) -> f64 {
    match *q {
        Quadric::Sphere { center, radius } => ((p - center).length() - radius).abs(),
        Quadric::WallY { base, radius, .. } => {
            let v = p - base;
            (DVec3::new(v.x, 0.0, v.z).length() - radius).abs()
        }
        Quadric::Rect { corner, normal, .. } => (p - corner).dot(normal).abs(),
        Quadric::Disk { center, normal, .. } => (p - center).dot(normal).abs(),
    }
}

/// `rays` in packets of `N`, nearest hits and occlusion: the set's f32
/// queries (`SetScratch::f32`, or with `trust` every lane taken from the
/// kernel) against Embree's callbacks in the whole scene.
fn f32_against_embree<const N: usize, P: RayPacket<N>>(
    set: &AnalyticSet,
    with: &RenderScene,
    rays: &[Ray],
    new: impl Fn() -> P,
) -> F32Check {
    let mut c = F32Check::default();
    let scratch = &mut SetScratch::<N>::f32();
    for batch in rays.chunks(N) {
        let (mut a, mut b) = (new(), new());
        for (i, r) in batch.iter().enumerate() {
            a.set_ray(i, r);
            b.set_ray(i, r);
        }
        a.intersect_meshes(&with.embree, false);
        set.intersect(&mut a, scratch);
        b.intersect(&with.embree, false);
        for (i, r) in batch.iter().enumerate() {
            let (ha, hb) = (a.hit(i), b.hit(i));
            let (Some(ha), Some(hb)) = (ha, hb) else {
                c.wrong += usize::from(ha.is_some() != hb.is_some());
                continue;
            };
            if (ha.geom_id, ha.prim_id) != (hb.geom_id, hb.prim_id) {
                c.wrong += 1;
                continue;
            }
            let (ta, tb) = (ha.t as f64, hb.t as f64);
            c.t_err = c.t_err.max((ta - tb).abs() / tb.abs().max(1.0));
            let prim = set
                .prims
                .iter()
                .find(|p| p.geom == ha.geom_id && p.prim == ha.prim_id);
            if let Some(q) = prim.and_then(|p| p.quadric) {
                c.hits += 1;
                let at = |t: f64| r.org.as_dvec3() + r.dir.as_dvec3() * t;
                c.point_err.0 = c.point_err.0.max(surface_distance(&q, at(ta)));
                c.point_err.1 = c.point_err.1.max(surface_distance(&q, at(tb)));
            }
        }
        for (i, r) in batch.iter().enumerate() {
            a.set_ray(i, r);
            b.set_ray(i, r);
        }
        a.occlude_meshes(&with.embree, false);
        set.occlude(&mut a, scratch);
        b.occlude(&with.embree, false);
        c.wrong += (0..batch.len())
            .filter(|&i| a.occluded(i) != b.occluded(i))
            .count();
    }
    c.replayed = scratch.replayed as f64 / scratch.answered.max(1) as f64;
    c
}

/// Rays for the f32 queries: the random ones of [`packets`] and rays
/// spawned off the surfaces those hit (offset as the integrator offsets
/// them, to either side, in random directions); and apart, rays whose
/// interval starts or ends exactly at a crossing.
fn f32_rays(without: &RenderScene) -> (Vec<Ray>, Vec<Ray>) {
    let random: Vec<Ray> = packets(11, 1500).into_iter().flatten().collect();
    let mut rng = crate::sampling::Rng::new(12);
    let (mut spawned, mut at_ends) = (Vec::new(), Vec::new());
    for batch in random.chunks(8) {
        let mut p = Packet8::new();
        for (i, r) in batch.iter().enumerate() {
            p.set_ray(i, r);
        }
        p.intersect(&without.embree, false);
        for (i, r) in batch.iter().enumerate() {
            let Some(h) = p.hit(i) else { continue };
            let point = r.org + r.dir * h.t;
            let n = h.ng.normalize();
            for _ in 0..2 {
                let side = if rng.uniform() < 0.5 { n } else { -n };
                let mut d = V3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0 - V3::ONE;
                if d.dot(side) < 0.0 {
                    d -= 2.0 * d.dot(side) * side;
                }
                let mut s = Ray::new(crate::ray::offset_origin(point, side), d);
                if rng.uniform() < 0.3 {
                    s.tfar = 4.0 * rng.uniform();
                }
                spawned.push(s);
            }
            let mut e = *r;
            if i % 2 == 0 {
                e.tfar = h.t;
            } else {
                e.tnear = h.t;
            }
            at_ends.push(e);
        }
    }
    assert!(spawned.len() > 10_000 && at_ends.len() > 5_000);
    ([random, spawned].concat(), at_ends)
}

/// The f32 queries answer as Embree's callbacks on every lane, at every
/// vector level and in packets of 8 and 16: the same primitive hit (or
/// none) and the same occlusion, on random rays, rays grazing the
/// shapes, rays spawned off the surfaces and rays whose interval ends at
/// a crossing (where the kernel is unsure and the lane is answered in
/// f64). Their hit points lie within 10⁻⁵ of the f64 shapes (Embree's
/// within the f32 rounding of t), and t within a relative 10⁻³ of
/// Embree's (larger only at grazing incidence, where a tiny move of the
/// point is a long one along the ray; the other root of the same
/// primitive is much farther). Trusting the kernel on the lanes it is
/// unsure of is caught on the same rays. Away from the intervals' ends,
/// with every primitive in a vector form, fewer than 0.2 % of the lanes
/// are replayed in f64, where bounds a hundred times looser replay more.
#[test]
fn f32_queries_agree_with_embree() {
    let with = scene(SETS[0], true);
    let without = scene(SETS[0], false);
    let set = with.analytic_set.clone().expect("a set of few shapes");
    let (free, at_ends) = f32_rays(&without);
    let rays = [free.as_slice(), at_ends.as_slice()].concat();
    for arch in levels() {
        let set = set.clone().with_arch(arch);
        for (width, c) in [
            (8, f32_against_embree::<8, _>(&set, &with, &rays, Packet8::new)),
            (
                16,
                f32_against_embree::<16, _>(&set, &with, &rays, crate::embree::Packet16::new),
            ),
        ] {
            eprintln!("{arch:?}, packets of {width}: {c:?}");
            assert!(c.hits > 20_000, "{arch:?} {width}: {} hits", c.hits);
            assert_eq!(c.wrong, 0, "{arch:?} {width}: {c:?}");
            assert!(c.t_err <= 1e-3, "{arch:?} {width}: {c:?}");
            assert!(c.point_err.0 <= 1e-5, "{arch:?} {width}: {c:?}");
        }
    }
    let trusting = AnalyticSet {
        trust_kernel: true,
        ..set.clone()
    };
    let c = f32_against_embree::<16, _>(&trusting, &with, &rays, crate::embree::Packet16::new);
    eprintln!("trusting every lane: {c:?}");
    assert!(c.wrong > 500, "trusting the f32 kernel went unnoticed: {c:?}");
    // Away from the intervals' ends, on primitives that all have a
    // vector form (no tilted wall, whose lanes are always replayed), the
    // kernel is sure of nearly every lane (renders replay a few in a
    // million); bounds a hundred times looser, still right, replay many.
    let with = scene(&vector_forms(), true);
    let set = with.analytic_set.clone().expect("a set of few shapes");
    let (free, _) = f32_rays(&scene(&vector_forms(), false));
    let free_share = |set: &AnalyticSet| {
        let c = f32_against_embree::<16, _>(set, &with, &free, crate::embree::Packet16::new);
        assert_eq!(c.wrong, 0);
        c.replayed
    };
    let (tight, loose) = (
        free_share(&set),
        free_share(&AnalyticSet {
            safety: 100.0 * ERROR_SAFETY,
            ..set.clone()
        }),
    );
    eprintln!("replayed lanes: {tight:.2e}, with bounds 100x looser {loose:.2e}");
    assert!(tight < 2e-3, "replayed {tight}");
    assert!(loose >= 2e-3, "looser bounds replayed only {loose}");
}

/// The surface points of a packet's hits on the set's spheres, walls
/// about y and rects are `RenderScene::surface_point`'s bit for bit (point,
/// normals, texture coordinates) at every vector level; hits on other
/// primitives are left to it. Taking the hit point unprojected instead is
/// caught by the same comparison.
#[test]
fn surface_points_are_the_scenes() {
    let with = scene(SETS[0], true);
    let set = with.analytic_set.clone().expect("a set of few shapes");
    let rays = packets(9, 3000);
    let bits = |sp: &SurfacePoint| {
        (
            sp.p.to_array().map(f32::to_bits),
            sp.ng.to_array().map(f32::to_bits),
            sp.ns.to_array().map(f32::to_bits),
            sp.uv.map(f32::to_bits),
        )
    };
    for arch in levels() {
        let set = set.clone().with_arch(arch);
        let (mut solved, mut bad, mut unprojected) = (0, 0, 0);
        for batch in &rays {
            let mut p = Packet8::new();
            for (i, r) in batch.iter().enumerate() {
                p.set_ray(i, r);
            }
            p.intersect_meshes(&with.embree, false);
            set.intersect(&mut p, &mut SetScratch::default());
            let mut s = SurfaceLanes::<8>::default();
            set.surface_points(&p, &mut s);
            for (i, r) in batch.iter().enumerate() {
                let Some(h) = p.hit(i) else {
                    assert_eq!(s.done[i], 0.0, "{arch:?}: a lane without a hit");
                    continue;
                };
                let quadric = set
                    .prims
                    .iter()
                    .any(|q| q.geom == h.geom_id && q.prim == h.prim_id && q.quadric.is_some());
                assert_eq!(s.done[i] != 0.0, quadric, "{arch:?}: lane {i}, hit {h:?}");
                if !quadric {
                    continue;
                }
                solved += 1;
                let pd = DVec3::new(s.pd[0][i], s.pd[1][i], s.pd[2][i]);
                let point = V3::new(s.p[0][i], s.p[1][i], s.p[2][i]);
                let ng = V3::new(s.ng[0][i], s.ng[1][i], s.ng[2][i]);
                let got = with
                    .analytic_surface_point(&h, pd, point, ng)
                    .expect("an analytic hit");
                let want = with.surface_point(r, &h);
                bad += (bits(&got) != bits(&want)) as usize;
                // The wrong variant: the hit point as found, not projected.
                let raw = (r.org + r.dir * h.t).as_dvec3();
                let wrong = with.analytic_surface_point(&h, raw, raw.as_vec3a(), ng).unwrap();
                unprojected += (bits(&wrong) != bits(&want)) as usize;
            }
        }
        assert!(solved > 5000, "{arch:?}: {solved} lanes solved");
        assert_eq!(bad, 0, "{arch:?}: {bad} of {solved} differ");
        assert!(
            unprojected > solved / 10,
            "{arch:?}: unprojected points: {unprojected} of {solved} differ"
        );
    }
}

/// Too many primitives, or none: no set.
#[test]
fn a_set_holds_one_to_eight_primitives() {
    let ball = Analytic::Sphere(crate::scene::shapes::Sphere {
        center: DVec3::ZERO,
        radius: 1.0,
    });
    assert!(AnalyticSet::try_new([]).is_none());
    assert_eq!(
        AnalyticSet::try_new((0..8).map(|g| (g, ball))).map(|s| s.len()),
        Some(8)
    );
    assert!(AnalyticSet::try_new((0..9).map(|g| (g, ball))).is_none());
}
