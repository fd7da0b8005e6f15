//! Nested dielectrics end to end: the filter against the paper's re-cast, the
//! nested glass of water against the interface-mesh one, unions of equal-ior
//! solids, rays through vertices and edges, grazing rays, coincident faces and
//! cameras inside media.
use glam::{DVec3, Vec3A as V3};
use snell::audit::audit_ray;
use snell::counters::Counters;
use snell::dielectric::NestedStrategy;
use snell::integrator::{refraction_path, Tracer};
use snell::render::{render, RenderOptions, RenderSettings, Rendered};
use snell::scene::{load_scene, load_scene_str, BuildOptions, RenderScene};
use std::path::Path;

/// A scene and the settings a test renders it with.
type Case = (RenderScene, RenderSettings);

fn settings(s: &RenderScene, nested: NestedStrategy, w: u32, h: u32, spp: u32, seed: u64) -> RenderSettings {
    RenderSettings::from_scene(s)
        .with_resolution(w, h)
        .unwrap()
        .with_spp(spp)
        .with_seed(seed)
        .with_strategy(nested)
}

fn load(path: &str, nested: NestedStrategy, w: u32, h: u32, spp: u32, seed: u64) -> Case {
    let s = load_scene(Path::new(path), &BuildOptions::default()).unwrap();
    let set = settings(&s, nested, w, h, spp, seed);
    (s, set)
}

fn go((s, set): &Case) -> Rendered {
    render(
        s,
        set,
        &RenderOptions {
            threads: Some(2),
            want_aovs: false,
            ..Default::default()
        },
    )
    .unwrap()
}

const NESTED_SCENES: [&str; 5] = [
    "scenes/nested_spheres_a.toml",
    "scenes/nested_spheres_b.toml",
    "scenes/glass_of_water_nested.toml",
    "scenes/glass_ice_bubbles.toml",
    "scenes/deep_nesting.toml",
];

/// Share of pixels equal to 1e-4 (relative) between two images.
fn equal_share(a: &Rendered, b: &Rendered) -> f64 {
    let equal = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(x, y)| {
            (**x - **y).abs().max_element() <= 1e-4 * x.max_element().max(y.max_element()).max(1e-6)
        })
        .count();
    equal as f64 / a.pixels.len() as f64
}

#[test]
fn filter_and_recast_agree_pixel_for_pixel() {
    // Power: the paper's Fig. 1 in the other priority order (a wrong order
    // for scene a) must fail the 99% criterion that filter vs recast passes.
    let a = go(&load(NESTED_SCENES[0], NestedStrategy::Filter, 48, 36, 2, 7));
    let wrong = go(&load(NESTED_SCENES[1], NestedStrategy::Recast, 48, 36, 2, 7));
    let share = equal_share(&a, &wrong);
    assert!(
        share < 0.99,
        "no power: the wrong priority order matches {:.2}% of pixels",
        share * 100.0
    );
    for path in NESTED_SCENES {
        let a = go(&load(path, NestedStrategy::Filter, 48, 36, 2, 7));
        let b = go(&load(path, NestedStrategy::Recast, 48, 36, 2, 7));
        let share = equal_share(&a, &b);
        assert!(
            share >= 0.99,
            "{path}: only {:.2}% of pixels equal",
            share * 100.0
        );
        for ch in 0..3 {
            let (ma, sa) = a.mean_and_se(ch);
            let (mb, sb) = b.mean_and_se(ch);
            assert!(
                (ma - mb).abs() <= 5.0 * (sa * sa + sb * sb).sqrt() + 1e-6,
                "{path} ch {ch}: {ma} vs {mb}"
            );
        }
        assert!(
            a.stats.counters.false_hits > 0,
            "{path}: the scene must exercise false hits"
        );
        assert_eq!(a.stats.counters.nan, 0);
    }
}

/// Block means (k×k) of channel `ch`.
fn blocks(r: &Rendered, k: u32, ch: usize) -> Vec<f64> {
    let (bw, bh) = (r.width / k, r.height / k);
    let mut out = vec![0.0; (bw * bh) as usize];
    for by in 0..bh {
        for bx in 0..bw {
            let mut s = 0.0;
            for y in by * k..(by + 1) * k {
                for x in bx * k..(bx + 1) * k {
                    s += r.pixels[(y * r.width + x) as usize][ch] as f64;
                }
            }
            out[(by * bw + bx) as usize] = s / (k * k) as f64;
        }
    }
    out
}

fn rms_diff(a: &[f64], b: &[f64]) -> f64 {
    (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
}

/// docs/design.md "Comparing images honestly": block means, judged against the
/// difference between two renders of the reference with different seeds.
/// The criterion: 640×480×64, 16×16 block means, ≤ 1.3× the
/// seed-to-seed RMSE. The same test shows its power: the flat-shaded lathe
/// (facet streaks, a shifted checker in the water) must fail that threshold.
#[test]
fn nested_glass_of_water_matches_interface_meshes() {
    let (w, h, spp, k) = (640, 480, 64, 16);
    let threshold = 1.3;
    let reference = go(&load(
        "scenes/glass_of_water.toml",
        NestedStrategy::Filter,
        w,
        h,
        spp,
        1,
    ));
    let reference2 = go(&load(
        "scenes/glass_of_water.toml",
        NestedStrategy::Filter,
        w,
        h,
        spp,
        2,
    ));
    let nested = go(&load(
        "scenes/glass_of_water_nested.toml",
        NestedStrategy::Filter,
        w,
        h,
        spp,
        3,
    ));
    let text = std::fs::read_to_string("scenes/glass_of_water_nested.toml").unwrap();
    let flat_text = text.replace("type = \"lathe\",", "type = \"lathe\", smooth = false,");
    assert_ne!(text, flat_text, "the scene must have a lathe to flatten");
    let flat_scene = load_scene_str(
        "flat.toml",
        &flat_text,
        Path::new("scenes"),
        &BuildOptions::default(),
    )
    .unwrap();
    let flat_settings = settings(&flat_scene, NestedStrategy::Filter, w, h, spp, 3);
    let flat = go(&(flat_scene, flat_settings));
    let score = |img: &Rendered| -> f64 {
        // Over the three channels together: block RMS against the reference
        // divided by the reference's own seed-to-seed block RMS.
        let (mut num, mut den) = (0.0, 0.0);
        for ch in 0..3 {
            let (r1, r2, n) = (
                blocks(&reference, k, ch),
                blocks(&reference2, k, ch),
                blocks(img, k, ch),
            );
            num += rms_diff(&n, &r1).powi(2);
            den += rms_diff(&r1, &r2).powi(2);
        }
        (num / den).sqrt()
    };
    let (good, bad) = (score(&nested), score(&flat));
    eprintln!("block RMS vs reference / seed-to-seed: smooth lathe {good:.2}, flat lathe {bad:.2}");
    assert!(
        good <= threshold,
        "nested differs from interface meshes (score {good:.2} > {threshold})"
    );
    assert!(
        bad > threshold,
        "no power: the flat-shaded glass also passes (score {bad:.2} <= {threshold})"
    );
    for ch in 0..3 {
        let (mn, sn) = nested.mean_and_se(ch);
        let (mr, sr) = reference.mean_and_se(ch);
        assert!(
            (mn - mr).abs() < 5.0 * (sn * sn + sr * sr).sqrt(),
            "channel {ch} mean {mn} vs {mr}"
        );
    }
}

const HEADER: &str = "ambient_ior = 1.0\n[camera]\nposition = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 40.0\n[film]\nwidth = 8\nheight = 8\nspp = 1\n";

fn solid(name: &str, shape: &str, ior: f64, priority: i64) -> String {
    format!("[[objects]]\nname = \"{name}\"\nshape = {shape}\nmaterial = {{ type = \"dielectric\", ior = {ior}, priority = {priority} }}\n")
}

fn scene_of(objects: &str) -> RenderScene {
    load_scene_str(
        "t.toml",
        &format!("{HEADER}{objects}"),
        Path::new("."),
        &BuildOptions::default(),
    )
    .unwrap()
}

/// Exact union of two spheres: refraction in at the first, out at the union's exit.
fn union_exit(c: [DVec3; 2], r: f64, o: DVec3, d: DVec3, n: f64) -> (DVec3, DVec3) {
    let hits = |o: DVec3, d: DVec3, c: DVec3| {
        let oc = o - c;
        let b = oc.dot(d);
        let disc = b * b - (oc.length_squared() - r * r);
        (disc >= 0.0).then(|| (-b - disc.sqrt(), -b + disc.sqrt()))
    };
    let (ia, ta) = [0, 1]
        .iter()
        .filter_map(|&i| hits(o, d, c[i]).map(|h| (i, h.0)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap();
    let p = o + d * ta;
    let nrm = (p - c[ia]).normalize();
    let d1 = snell::optics::refract(d, nrm, 1.0, n).unwrap().normalize();
    // Inside the union: leave at the largest exit among the spheres the chord passes through.
    let (ib, tb) = [0, 1]
        .iter()
        .filter_map(|&i| hits(p, d1, c[i]).map(|h| (i, h.1)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .unwrap();
    let q = p + d1 * tb;
    let d2 = snell::optics::refract(d1, (q - c[ib]).normalize(), n, 1.0).unwrap();
    (q, d2.normalize())
}

#[test]
fn overlapping_equal_ior_spheres_refract_like_their_union() {
    let objs = solid(
        "a",
        "{ type = \"sphere\", center = [-0.3, 0.0, 0.0], radius = 0.5 }",
        1.5,
        1,
    ) + &solid(
        "b",
        "{ type = \"sphere\", center = [0.3, 0.0, 0.0], radius = 0.5 }",
        1.5,
        2,
    );
    for strategy in [NestedStrategy::Filter, NestedStrategy::Recast] {
        let s = scene_of(&objs);
        let mut checked = 0;
        for k in 0..15 {
            let y = -0.35 + 0.05 * k as f64;
            let o = DVec3::new(-3.0, y, 0.07);
            let d = DVec3::X;
            let mut c = Counters::default();
            let p = refraction_path(
                Tracer::new(&s).with_strategy(strategy),
                o.as_vec3a(),
                V3::X,
                &[],
                16,
                &mut c,
            )
            .unwrap();
            let bends: Vec<_> = p.events.iter().filter(|e| e.n1 != e.n2).collect();
            if p.events.iter().any(|e| e.tir) {
                continue;
            }
            assert_eq!(
                bends.len(),
                2,
                "{strategy:?} y={y}: two interfaces, not four: {:?}",
                p.events
            );
            assert!(p.final_list.is_empty());
            let (q, d2) = union_exit(
                [DVec3::new(-0.3, 0.0, 0.0), DVec3::new(0.3, 0.0, 0.0)],
                0.5,
                o,
                d,
                1.5,
            );
            let last = bends[1];
            assert!(
                (last.point.as_dvec3() - q).length() < 1e-4,
                "exit point {:?} vs {q}",
                last.point
            );
            let _ = d2;
            checked += 1;
        }
        assert!(checked >= 10);
    }
}

/// Overlapping closed meshes and analytic solids, all with the index of air so
/// rays run straight, and rays aimed exactly at mesh vertices and edge midpoints.
fn vertex_edge_scene() -> RenderScene {
    let objs = solid("box_a", "{ type = \"box\", center = [0.0, 0.0, 0.0], size = [1.0, 1.0, 1.0] }", 1.0, 1)
        + &solid("box_b", "{ type = \"box\", center = [0.53, 0.43, 0.11], size = [1.0, 0.9, 1.1] }", 1.0, 2)
        + &solid("box_c", "{ type = \"box\", center = [1.07, 0.52, -0.13], size = [1.2, 1.3, 0.8] }", 1.0, 0)
        + &solid(
            "cup",
            "{ type = \"lathe\", segments = 12, profile = [[0.0, -0.8], [0.6, -0.8], [0.6, 0.4], [0.5, 0.4], [0.5, -0.6], [0.0, -0.6]] }\ntransform = [{ rotate = { axis = [0.3, 1.0, 0.2], degrees = 7.0 } }, { translate = [0.013, -0.021, 0.017] }]",
            1.0,
            3,
        )
        + &solid("ball", "{ type = \"sphere\", center = [-0.4, 0.3, 0.2], radius = 0.45 }", 1.0, 1);
    scene_of(&objs)
}

fn vertex_edge_targets(s: &RenderScene) -> Vec<V3> {
    let mut targets = Vec::new();
    for g in &s.geoms {
        if let snell::scene::Shape::Mesh(m) = &g.shape {
            for t in &m.indices {
                let p = t.map(|i| V3::from(m.positions[i as usize]));
                targets.extend_from_slice(&p);
                targets.push((p[0] + p[1]) * 0.5);
                targets.push((p[1] + p[2]) * 0.5);
                targets.push((p[2] + p[0]) * 0.5);
            }
        }
    }
    targets
}

fn audit_all(strategy: NestedStrategy) -> (u32, u32, u32, usize) {
    let s = vertex_edge_scene();
    let eyes = [
        V3::new(3.1, 2.3, 4.7),
        V3::new(-4.2, 1.1, 3.3),
        V3::new(0.31, -5.0, 0.23),
        V3::new(0.013, 0.021, 6.0),
    ];
    let (mut seg, mut mis, mut nonempty, mut rays) = (0, 0, 0, 0);
    let mut c = Counters::default();
    for t in vertex_edge_targets(&s) {
        for e in eyes {
            let a = audit_ray(
                Tracer::new(&s).with_strategy(strategy),
                e,
                (t - e).normalize(),
                &mut c,
            )
            .unwrap();
            if (a.left_nonempty || a.mismatches > 0) && std::env::var("SNELL_DEBUG").is_ok() {
                let p = refraction_path(
                    Tracer::new(&s).with_strategy(strategy),
                    e,
                    (t - e).normalize(),
                    &s.solids_containing(e.as_dvec3()),
                    64,
                    &mut c,
                )
                .unwrap();
                eprintln!("{strategy:?} eye {e} target {t}: {a:?}\n{p:?}");
            }
            seg += a.segments;
            mis += a.mismatches;
            nonempty += a.left_nonempty as u32;
            rays += 1;
        }
    }
    (seg, mis, nonempty, rays)
}

#[test]
fn rays_through_vertices_and_edges_never_gain_or_lose_entries() {
    let (seg, mis, nonempty, rays) = audit_all(NestedStrategy::Filter);
    eprintln!("Filter: {rays} rays, {seg} segments, {mis} mismatches, {nonempty} left non-empty");
    assert!(seg > 1000);
    assert_eq!(
        nonempty, 0,
        "filter: interior list not empty after leaving everything"
    );
    assert_eq!(mis, 0, "filter: interior list disagrees with point-in-solid");
    // The paper's re-cast sees only the nearest hit, so a surface of another
    // solid at the same point as a hit (here: a vertex or edge of one solid on
    // a face of another) is skipped with it. Rare, but not zero on exact rays.
    let (seg, mis, nonempty, rays) = audit_all(NestedStrategy::Recast);
    eprintln!("Recast: {rays} rays, {seg} segments, {mis} mismatches, {nonempty} left non-empty");
    assert!(
        mis + nonempty <= rays as u32 / 100,
        "recast is wrong on more than 1% of exact rays"
    );
    // The paper's toggle, for comparison (not asserted to be wrong; reported).
    let (seg, mis, nonempty, rays) = audit_all(NestedStrategy::Toggle);
    eprintln!("Toggle: {rays} rays, {seg} segments, {mis} mismatches, {nonempty} left non-empty");
}

#[test]
fn grazing_rays_and_coincident_faces_keep_lists_consistent() {
    // Two boxes sharing the face x = 0.5 exactly, and a sphere grazed at its silhouette.
    let objs = solid(
        "glass",
        "{ type = \"box\", center = [0.0, 0.0, 0.0], size = [1.0, 1.0, 1.0] }",
        1.0,
        2,
    ) + &solid(
        "water",
        "{ type = \"box\", center = [1.0, 0.0, 0.0], size = [1.0, 1.0, 1.0] }",
        1.0,
        1,
    ) + &solid(
        "ball",
        "{ type = \"sphere\", center = [0.0, 2.0, 0.0], radius = 0.5 }",
        1.0,
        3,
    ) + &solid(
        "shell",
        "{ type = \"sphere\", center = [0.0, 2.0, 0.0], radius = 0.7 }",
        1.0,
        0,
    );
    for strategy in [NestedStrategy::Filter, NestedStrategy::Recast] {
        let s = scene_of(&objs);
        let mut c = Counters::default();
        let (mut coincident_bad, mut grazing_bad) = (0, 0);
        // Through the coincident face, many heights.
        for k in 0..200 {
            let y = -0.45 + 0.9 * k as f32 / 199.0;
            let a = audit_ray(
                Tracer::new(&s).with_strategy(strategy),
                V3::new(-3.0, y, 0.123),
                V3::X,
                &mut c,
            )
            .unwrap();
            coincident_bad += (a.mismatches > 0 || a.left_nonempty) as u32;
            let a = audit_ray(
                Tracer::new(&s).with_strategy(strategy),
                V3::new(3.0, y, -0.2),
                -V3::X,
                &mut c,
            )
            .unwrap();
            coincident_bad += (a.mismatches > 0 || a.left_nonempty) as u32;
        }
        // Grazing the sphere's silhouette from outside, inside and exactly.
        for k in 0..200 {
            let off = 0.5 + (k as f32 - 100.0) * 1e-7;
            let a = audit_ray(
                Tracer::new(&s).with_strategy(strategy),
                V3::new(-3.0, 2.0 + off, 0.0),
                V3::X,
                &mut c,
            )
            .unwrap();
            grazing_bad += (a.mismatches > 0 || a.left_nonempty) as u32;
        }
        eprintln!("{strategy:?}: coincident faces: {coincident_bad}/400 rays wrong; grazing: {grazing_bad}/200 rays wrong");
        assert_eq!(grazing_bad, 0, "{strategy:?}: silhouette-grazing rays");
        if strategy == NestedStrategy::Filter {
            // The filter sees every surface at the hit point; the paper's
            // re-cast sees one of two coincident faces and skips the other.
            assert_eq!(coincident_bad, 0, "filter: coincident faces");
        }
    }
}

#[test]
fn camera_inside_water_and_inside_ice_is_found_automatically() {
    let base = std::fs::read_to_string("scenes/glass_ice_bubbles.toml").unwrap();
    let cam = |pos: &str, inside: Option<&str>| {
        let mut t = base
            .replace("position = [0.0, 3.0, 6.5]", &format!("position = {pos}"))
            .replace("width = 640", "width = 24")
            .replace("height = 480", "height = 18")
            .replace("spp = 64", "spp = 2");
        if let Some(i) = inside {
            t = t.replace("fov = 32.0", &format!("fov = 32.0\ninside = {i}"));
        }
        let s = load_scene_str(
            "scenes/glass_ice_bubbles.toml",
            &t,
            Path::new("scenes"),
            &BuildOptions::default(),
        )
        .unwrap();
        let names: Vec<String> = s
            .camera_interior
            .iter()
            .map(|&i| s.solids[i as usize].name.clone())
            .collect();
        (s, names)
    };
    // In the water, away from ice and bubbles.
    let (auto, names) = cam("[0.55, 0.9, -0.3]", None);
    assert_eq!(names, vec!["water".to_string()]);
    let (explicit, _) = cam("[0.55, 0.9, -0.3]", Some("[\"water\"]"));
    let (outside, none) = cam("[0.55, 0.9, -0.3]", Some("[]"));
    assert!(none.is_empty());
    let case = |s: RenderScene| {
        let set = RenderSettings::from_scene(&s);
        (s, set)
    };
    let (a, b, c) = (go(&case(auto)), go(&case(explicit)), go(&case(outside)));
    assert_eq!(
        a.pixels, b.pixels,
        "automatic and explicit interior lists give the same image"
    );
    assert_ne!(a.pixels, c.pixels, "the interior list at the camera matters");
    // In an ice cube (its centre is below the water line): inside ice and water.
    let (_, mut names) = cam("[-0.25, 1.75, 0.1]", None);
    names.sort();
    assert_eq!(names, vec!["ice_a".to_string(), "water".to_string()]);
}

/// The wrong rays of `snell audit nested` at 10M rays (seed 1) that the
/// same-line continuation, the re-cast from just past a false hit, the
/// point-in-solid test after (not before) a near-edge hit and the leaked-entry
/// test of a ray's first hit fixed: (scene, eye,
/// direction), as the audit printed them. Each must now keep its interior
/// list right on every segment and leave the scene with an empty list, with
/// both strategies.
const FIXED_AUDIT_RAYS: [(&str, [f32; 3], [f32; 3]); 12] = [
    // The paper's Fig. 1 spheres: rays through the circle where two spheres
    // meet. Type 2: the next sphere's entry a hair past the exit (never shown
    // to the filter, stepped over by the spawn).
    (
        "scenes/nested_spheres_a.toml",
        [-5.2695994, 0.42831358, 0.13586542],
        [0.9912739, 0.070101984, -0.1116331],
    ),
    (
        "scenes/nested_spheres_a.toml",
        [4.9949594, 2.2372847, 0.43161866],
        [-0.9426052, -0.28893533, -0.16736746],
    ),
    // Type 1: a grazing exit spawned sideways out of a sphere whose entry
    // was recorded (left the list non-empty).
    (
        "scenes/nested_spheres_a.toml",
        [-1.9450641, 0.012660265, -4.8670697],
        [0.4197671, 0.18319376, 0.888952],
    ),
    (
        "scenes/nested_spheres_a.toml",
        [-2.0430703, 1.2435844, -4.819572],
        [0.4362442, -0.04474696, 0.898715],
    ),
    // The re-cast's tangent ray: the middle sphere's exit within the crossing
    // window of the right sphere's false exit, stepped over by the re-cast.
    (
        "scenes/nested_spheres_a.toml",
        [-1.1880548, 0.16964287, 5.12054],
        [0.28992975, 0.15974504, -0.94362193],
    ),
    (
        "scenes/nested_spheres_b.toml",
        [2.5292873, 0.33920786, -4.620747],
        [-0.40637496, 0.13217877, 0.90409523],
    ),
    // The nested glass of water: total internal reflection at the glass's
    // outer base edge and at the rim's inner edge; the reflected ray's exit
    // 5e-5 away was judged a touch by a point-in-solid test behind its start.
    (
        "scenes/glass_of_water_nested.toml",
        [-3.9830706, 4.6448355, -2.4412918],
        [0.5055467, -0.7129679, 0.4859004],
    ),
    (
        "scenes/glass_of_water_nested.toml",
        [3.9957917, 0.5422303, 4.108817],
        [-0.72816193, 0.36097983, -0.5826438],
    ),
    (
        "scenes/glass_of_water_nested.toml",
        [5.284079, 3.454292, 0.75450003],
        [-0.81933326, -0.51033425, -0.2612508],
    ),
    // Rays from above through a vertex of the glass rim's inner edge: Embree
    // reports no triangle at all (a vertex leak), and the water's top, inside
    // the glass wall, was taken as the first true hit.
    (
        "scenes/glass_of_water_nested.toml",
        [0.69297755, 6.8771353, -1.0976338],
        [0.044584084, -0.9745151, 0.21984671],
    ),
    (
        "scenes/glass_of_water_nested.toml",
        [-0.5138044, 6.8540316, -1.2963412],
        [-0.03998575, -0.99068505, 0.13017018],
    ),
    (
        "scenes/glass_ice_bubbles.toml",
        [3.4339752, 5.7480564, -1.1510727],
        [-0.577557, -0.724546, 0.37611282],
    ),
];

/// Audit each ray `(label, scene path, eye, direction)` with the filter and
/// the re-cast (each scene loaded once): `(label, strategy, audit, counters)`.
fn audit_rays<'a>(
    rays: impl IntoIterator<Item = (&'a str, &'a str, [f32; 3], [f32; 3])>,
) -> Vec<(&'a str, NestedStrategy, snell::audit::RayAudit, Counters)> {
    let mut scenes: Vec<(&str, RenderScene)> = Vec::new();
    let mut out = Vec::new();
    for (label, path, eye, dir) in rays {
        if !scenes.iter().any(|(p, _)| *p == path) {
            scenes.push((
                path,
                load_scene(Path::new(path), &BuildOptions::default()).unwrap(),
            ));
        }
        let s = &scenes.iter().find(|(p, _)| *p == path).unwrap().1;
        for strategy in [NestedStrategy::Filter, NestedStrategy::Recast] {
            let mut c = Counters::default();
            let a = audit_ray(
                Tracer::new(s).with_strategy(strategy),
                V3::from(eye),
                V3::from(dir),
                &mut c,
            )
            .unwrap();
            out.push((label, strategy, a, c));
        }
    }
    out
}

#[test]
fn the_audits_wrong_rays_keep_their_lists() {
    let labels: Vec<String> = FIXED_AUDIT_RAYS
        .iter()
        .map(|(path, eye, dir)| format!("{path} eye {eye:?} dir {dir:?}"))
        .collect();
    let rays = FIXED_AUDIT_RAYS
        .iter()
        .zip(&labels)
        .map(|(&(path, eye, dir), l)| (l.as_str(), path, eye, dir));
    let wrong: Vec<String> = audit_rays(rays)
        .into_iter()
        .filter(|(_, _, a, _)| a.mismatches > 0 || a.left_nonempty)
        .map(|(l, strategy, a, _)| format!("{l} {strategy:?}: {a:?}"))
        .collect();
    assert!(
        wrong.is_empty(),
        "{} wrong rays:\n{}",
        wrong.len(),
        wrong.join("\n")
    );
}

/// Rays R1–R10, S1–S7 and W1, found wrong by 10M-ray audits of a tracer
/// that did not settle the neighbourhood of a true hit (docs/design.md, "The
/// crossing window"), each with another solid's surface (or, W1, its own rim)
/// within the spawn offset of a hit.
const SPAWN_OFFSET_RAYS: [(&str, &str, [f32; 3], [f32; 3]); 18] = {
    const GIB: &str = "scenes/glass_ice_bubbles.toml";
    const GWN: &str = "scenes/glass_of_water_nested.toml";
    [
        (
            "R1",
            GIB,
            [4.587685, 4.278874, -1.7688236],
            [-0.832372, -0.44134185, 0.3352224],
        ),
        (
            "R2",
            GIB,
            [-5.6272097, 2.1425853, -0.9420563],
            [0.98464274, -0.051934037, 0.16667832],
        ),
        (
            "R3",
            GIB,
            [2.178983, 0.18904519, 5.2417626],
            [-0.2942578, 0.28127977, -0.91339695],
        ),
        (
            "R4",
            GIB,
            [-0.28779808, 7.017721, 0.015330509],
            [0.07740572, -0.995661, 0.051646177],
        ),
        (
            "R5",
            GIB,
            [1.5567709, 6.8072867, -0.2066366],
            [-0.36326313, -0.9305085, 0.04683815],
        ),
        (
            "R6",
            GIB,
            [-5.1746097, 3.335758, 1.4908705],
            [0.92211527, -0.279353, -0.26770392],
        ),
        (
            "R7",
            GIB,
            [5.672933, 2.221803, -0.47233167],
            [-0.9961943, -0.06582646, 0.057128802],
        ),
        (
            "R8",
            GIB,
            [2.4699175, 5.037301, 3.5924258],
            [-0.51328164, -0.5666336, -0.6445683],
        ),
        (
            "R9",
            GIB,
            [0.38613105, 5.734791, 3.6176262],
            [-0.017286962, -0.72232246, -0.6913403],
        ),
        (
            "R10",
            GWN,
            [-3.7638438, 5.08054, 2.123702],
            [0.58308303, -0.68061817, -0.44359115],
        ),
        (
            "S1",
            GIB,
            [-0.19937626, 6.9640813, 0.8119056],
            [0.07135295, -0.98522806, -0.15567389],
        ),
        (
            "S2",
            GIB,
            [-2.872872, 6.227626, 0.56525445],
            [0.50041366, -0.8594054, -0.10492181],
        ),
        (
            "S3",
            GIB,
            [3.119867, 3.5717137, 4.269162],
            [-0.5521671, -0.39914495, -0.73197997],
        ),
        (
            "S4",
            GIB,
            [4.536217, 0.99056506, 3.5644207],
            [-0.7967853, 0.1353771, -0.58890253],
        ),
        (
            "S5",
            GIB,
            [5.579873, 1.5060928, -1.4659805],
            [-0.96891963, 0.06635148, 0.23831105],
        ),
        (
            "S6",
            GIB,
            [-3.7583892, 4.1264167, 3.3091395],
            [0.65344626, -0.4254719, -0.6260844],
        ),
        (
            "S7",
            GIB,
            [5.738144, 0.6255308, -0.18277995],
            [-0.9814286, 0.18463014, 0.052053444],
        ),
        (
            "W1",
            GWN,
            [-4.363732, 2.3809896, 3.6094837],
            [0.64576006, 0.02130922, -0.76324296],
        ),
    ]
};

#[test]
fn surfaces_within_the_spawn_offset_of_a_hit_are_settled() {
    let mut wrong = Vec::new();
    let mut unsettled = Vec::new();
    for (name, strategy, a, c) in audit_rays(SPAWN_OFFSET_RAYS) {
        if a.mismatches > 0 || a.left_nonempty {
            wrong.push(format!("{name} {strategy:?}: {a:?}"));
        }
        // The test's power: each ray meets a surface that the lists and
        // queries alone got wrong, so the re-cast (plain queries) needs the
        // step on every ray. The filter leaves the water (an analytic
        // cylinder ranked below the glass) out of its queries by ray mask
        // and gives the list its membership by point-in-solid just past each
        // hit, which settles it without the look-ahead.
        if c.settled == 0 && strategy == NestedStrategy::Recast {
            unsettled.push(format!("{name} {strategy:?}"));
        }
    }
    assert!(
        wrong.is_empty(),
        "{} wrong rays:\n{}",
        wrong.len(),
        wrong.join("\n")
    );
    assert!(
        unsettled.is_empty(),
        "rays that needed no settling: {unsettled:?}"
    );
}

#[test]
fn a_glass_exit_onto_the_waters_surface_refracts_into_the_water() {
    // R10: it leaves the glass through the inner wall exactly where the
    // water's top cap meets it (the cap 6e-8 beyond the exit on the ray). The
    // event goes glass -> water (1.5 -> 1.33), not glass -> air.
    let s = load_scene(
        Path::new("scenes/glass_of_water_nested.toml"),
        &BuildOptions::default(),
    )
    .unwrap();
    let (_, _, eye, dir) = SPAWN_OFFSET_RAYS[9];
    let start = s.solids_containing(V3::from(eye).as_dvec3());
    for strategy in [NestedStrategy::Filter, NestedStrategy::Recast] {
        let mut c = Counters::default();
        let path = refraction_path(
            Tracer::new(&s).with_strategy(strategy),
            V3::from(eye),
            V3::from(dir).normalize(),
            &start,
            16,
            &mut c,
        )
        .unwrap();
        let e = &path.events[1];
        assert!(
            (e.point.y - 1.8).abs() < 1e-4,
            "{strategy:?}: the second event is at the cap: {e:?}"
        );
        assert_eq!((e.n1, e.n2), (1.5, 1.33), "{strategy:?}: {e:?}");
        assert!(!e.tir);
    }
}

/// The frosted glass of water: rough glass (a microfacet surface on a
/// nested solid) holding water by priorities. Rendered, no ray falls back
/// and no sample is lost; audited, no interior list is wrong.
#[test]
fn frosted_glass_of_water_renders_without_fallbacks_and_audits_clean() {
    let case = load(
        "scenes/frosted_glass_of_water.toml",
        NestedStrategy::Filter,
        96,
        72,
        4,
        1,
    );
    let r = go(&case);
    let c = &r.stats.counters;
    assert_eq!((c.fallbacks, c.nan), (0, 0), "{c:?}");
    assert!(c.false_hits > 0, "the water's false hits are skipped: {c:?}");
    let tr = Tracer::new(&case.0);
    let report = snell::audit::audit_scene(tr, 20_000, 1).unwrap();
    assert_eq!(report.wrong_rays, 0, "{report}");
    assert!(report.segments > 20_000, "{report}");
}
