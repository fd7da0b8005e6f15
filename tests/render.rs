//! The renderer end to end: furnace tests, an analytic direct-lighting case,
//! thread-count independence, reference-scene means, and bad input.
mod common;

use glam::Vec3A as V3;
use snell::render::{render, RenderOptions, RenderSettings, Rendered};
use snell::scene::{load_scene, load_scene_str, BuildOptions};
use std::path::Path;

fn render_str(text: &str, threads: usize) -> Rendered {
    let s = load_scene_str("test.toml", text, Path::new("scenes"), &BuildOptions::default())
        .expect("scene loads");
    render(
        &s,
        &RenderSettings::from_scene(&s),
        &RenderOptions {
            threads: Some(threads),
            want_aovs: false,
            ..Default::default()
        },
    )
    .expect("render")
}

/// The shipped scene `scenes/NAME.toml`.
fn shipped_scene(name: &str) -> snell::RenderScene {
    load_scene(
        Path::new(&format!("scenes/{name}.toml")),
        &BuildOptions::default(),
    )
    .unwrap()
}

/// Image mean and Monte Carlo standard error of one channel.
fn mean_se(r: &Rendered, ch: usize) -> (f64, f64) {
    r.mean_and_se(ch)
}

const FURNACE: &str = r#"
ambient_ior = 1.0
[camera]
position = [0.0, 0.0, 4.0]
target = [0.0, 0.0, 0.0]
fov = 30.0
[film]
width = 48
height = 48
spp = SPP
[integrator]
max_depth = 256
rr_depth = 5
[environment]
type = "constant"
radiance = [0.5, 0.5, 0.5]
[[objects]]
shape = { type = "sphere", center = [0.0, 0.0, 0.0], radius = 1.0 }
material = MATERIAL
"#;

#[test]
fn furnace_diffuse_sphere_of_albedo_one_returns_the_environment() {
    let text = FURNACE.replace("SPP", "4").replace(
        "MATERIAL",
        r#"{ type = "diffuse", reflectance = [1.0, 1.0, 1.0] }"#,
    );
    let r = render_str(&text, 2);
    // A convex albedo-1 sphere: every path escapes after one bounce carrying
    // weight exactly 1, so every pixel is 0.5 up to f32 rounding.
    for p in &r.pixels {
        assert!((p.x - 0.5).abs() < 1e-5 && (p.z - 0.5).abs() < 1e-5, "{p}");
    }
}

#[test]
fn furnace_glass_sphere_returns_the_environment() {
    for mat in [
        r#"{ type = "dielectric", ior = 1.5 }"#,
        r#"{ type = "dielectric", int_ior = 1.5, ext_ior = 1.0 }"#,
    ] {
        let text = FURNACE.replace("SPP", "64").replace("MATERIAL", mat);
        let r = render_str(&text, 2);
        let (m, se) = mean_se(&r, 1);
        // Unbiased: the image mean is 0.5 within 5 standard errors (se from
        // the pixel spread; paths are independent across pixels).
        assert!((m - 0.5).abs() < 5.0 * se + 1e-4, "{mat}: mean {m} ± {se}");
        assert_eq!(r.stats.counters.nan, 0);
    }
    // Power: a glass that loses 5% of the light per unit length (a wrong
    // "lossless" glass) must fail the same threshold.
    let lossy =
        r#"{ type = "dielectric", ior = 1.5, absorption = { color = [0.95, 0.95, 0.95], distance = 1.0 } }"#;
    let r = render_str(&FURNACE.replace("SPP", "64").replace("MATERIAL", lossy), 2);
    let (m, se) = mean_se(&r, 1);
    assert!(
        (m - 0.5).abs() >= 5.0 * se + 1e-4,
        "no power: a lossy glass passes as lossless ({m} ± {se})"
    );
}

#[test]
fn diffuse_plane_under_directional_light_matches_analytic_radiance() {
    let text = r#"
ambient_ior = 1.0
[camera]
position = [0.0, 3.0, 3.0]
target = [0.0, 0.0, 0.0]
fov = 20.0
[film]
width = 16
height = 16
spp = 2
[integrator]
max_depth = 2
[[lights]]
type = "directional"
direction = [0.6, -0.8, 0.0]
irradiance = [2.0, 1.0, 0.5]
[[objects]]
shape = { type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [20.0, 20.0] }
material = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }
"#;
    let r = render_str(text, 1);
    // L = ρ/π · E · cosθ with cosθ = 0.8.
    let want = V3::new(2.0, 1.0, 0.5) * (0.5 / std::f32::consts::PI * 0.8);
    for p in &r.pixels {
        assert!(
            (*p - want).abs().max_element() < 1e-5 * want.max_element(),
            "{p} vs {want}"
        );
    }
}

#[test]
fn same_image_with_one_or_two_threads_bit_for_bit() {
    let text = std::fs::read_to_string("scenes/glass_of_water.toml").unwrap();
    let text = text
        .replace("width = 640", "width = 40")
        .replace("height = 480", "height = 30")
        .replace("spp = 64", "spp = 3");
    let a = render_str(&text, 1);
    let b = render_str(&text, 2);
    assert!(a
        .pixels
        .iter()
        .zip(&b.pixels)
        .all(|(x, y)| x.to_array().map(f32::to_bits) == y.to_array().map(f32::to_bits)));
    assert!(a.pixels.iter().any(|p| p.max_element() > 0.0));
}

/// Image means of the reference scenes at 80×60 against stored high-spp means
/// (tests/data/reference_means.json; how they were made is recorded there).
#[test]
fn reference_scenes_have_no_nan_and_match_stored_means() {
    let stored: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string("tests/data/reference_means.json").unwrap()).unwrap();
    let render_80x60 = |s: snell::scene::RenderScene| {
        let set = RenderSettings::from_scene(&s)
            .with_resolution(80, 60)
            .unwrap()
            .with_spp(16)
            .with_seed(12345);
        let opts = RenderOptions {
            threads: Some(2),
            want_aovs: false,
            ..Default::default()
        };
        render(&s, &set, &opts).unwrap()
    };
    for name in ["three_spheres", "glass_of_water", "cylinder_refraction"] {
        let path = format!("scenes/{name}.toml");
        // Channel ch of `r` against the stored mean: (|difference|, tolerance).
        let off_by = |r: &Rendered, ch: usize| {
            let (m, se) = mean_se(r, ch);
            let want = stored[name]["mean"][ch].as_f64().unwrap();
            let want_se = stored[name]["se"][ch].as_f64().unwrap();
            (
                (m - want).abs(),
                5.0 * (se * se + want_se * want_se).sqrt() + 1e-4,
                m,
                want,
            )
        };
        let r = render_80x60(load_scene(Path::new(&path), &BuildOptions::default()).unwrap());
        assert_eq!(r.stats.counters.nan, 0, "{name}: NaN/Inf samples");
        assert!(r.pixels.iter().all(|p| p.is_finite()));
        for ch in 0..3 {
            let (diff, tol, m, want) = off_by(&r, ch);
            assert!(
                diff < tol,
                "{name} channel {ch}: {m} vs stored {want} (tol {tol})"
            );
        }
        // Power: the same scene with a light 5% too dim must fail the same
        // tolerance in some channel (three_spheres and glass_of_water have a
        // rect key light; cylinder_refraction an emissive backdrop).
        let text = std::fs::read_to_string(&path).unwrap();
        let dim = text
            .replace("radiance = [6.0, 6.0, 6.0]", "radiance = [5.7, 5.7, 5.7]")
            .replace(
                "color0 = [1.0, 1.0, 1.0], color1 = [0.1, 0.2, 0.6]",
                "color0 = [0.95, 0.95, 0.95], color1 = [0.095, 0.19, 0.57]",
            );
        assert_ne!(dim, text, "{name}: no light to dim");
        let rw = render_80x60(
            snell::scene::load_scene_str(&path, &dim, Path::new("scenes"), &BuildOptions::default()).unwrap(),
        );
        let caught = (0..3).any(|ch| {
            let (diff, tol, _, _) = off_by(&rw, ch);
            diff >= tol
        });
        assert!(caught, "{name}: no power: a 5% dimmer light passes");
    }
}

const BASE: &str = r#"
[camera]
position = [0.0, 1.0, 5.0]
target = [0.0, 0.5, 0.0]
fov = 40.0
[film]
width = 8
height = 8
spp = 1
[[lights]]
type = "point"
position = [0.0, 4.0, 0.0]
intensity = [10.0, 10.0, 10.0]
[[objects]]
name = "ball"
shape = { type = "sphere", center = [0.0, 0.5, 0.0], radius = 0.5 }
material = { type = "dielectric", ior = 1.5, priority = 1 }
"#;

#[test]
fn bad_scene_files_give_located_errors() {
    // (what to replace, replacement, expected key path, expected words in the message)
    let cases: &[(&str, &str, &str, &str)] = &[
        ("fov = 40.0", "fov = 40.0\nfocal = 3", "camera.focal", "unknown field"),
        ("fov = 40.0", "fov = 0.0", "camera.fov", "(0, 180)"),
        ("fov = 40.0", "fov = \"wide\"", "camera.fov", "invalid type"),
        ("radius = 0.5", "radius = -0.5", "objects[0].shape.radius", "> 0"),
        ("radius = 0.5", "radius = nan", "objects[0].shape.radius", "> 0"),
        ("radius = 0.5", "radius = 0.5, colour = 1", "objects[0].shape", "colour"),
        ("type = \"sphere\"", "type = \"blob\"", "objects[0].shape", "blob"),
        ("ior = 1.5", "ior = 0.0", "objects[0].material.ior", "> 0"),
        ("ior = 1.5, priority = 1", "int_ior = 1.5", "objects[0].material", "ext_ior"),
        ("ior = 1.5, priority = 1", "int_ior = 1.5, ext_ior = 1.0, priority = 2", "objects[0].material.priority", "priority"),
        ("width = 8", "width = 1000000000", "film.width", "GB"),
        ("spp = 1", "spp = 1000000000000", "film.spp", "samples per pixel"),
        ("spp = 1", "spp = 0", "film.spp", "samples per pixel"),
        ("spp = 1", "spp = 1\nfilter = \"gauss\"", "film.filter", "box"),
        ("position = [0.0, 1.0, 5.0]", "position = [0.0, 1.0]", "camera.position", "3"),
        ("position = [0.0, 1.0, 5.0]", "position = [0.0, 0.5, 0.0]", "camera", "target"),
        ("intensity = [10.0, 10.0, 10.0]", "intensity = [10.0, -1.0, 10.0]", "lights[0].intensity", ">= 0"),
        ("type = \"point\"", "type = \"laser\"", "lights[0]", "laser"),
        (
            "shape = { type = \"sphere\", center = [0.0, 0.5, 0.0], radius = 0.5 }",
            "shape = { type = \"mesh\", file = \"no_such_mesh.obj\" }",
            "objects[0].shape.file",
            "no_such_mesh.obj",
        ),
        (
            "shape = { type = \"sphere\", center = [0.0, 0.5, 0.0], radius = 0.5 }",
            "shape = { type = \"rect\", center = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [1.0, 1.0] }",
            "objects[0].shape",
            "closed",
        ),
        (
            "shape = { type = \"sphere\", center = [0.0, 0.5, 0.0], radius = 0.5 }",
            "shape = { type = \"rect\", center = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [0.0, 1.0, 0.0], size = [1.0, 1.0] }",
            "objects[0].shape.u_axis",
            "perpendicular",
        ),
        (
            "shape = { type = \"sphere\", center = [0.0, 0.5, 0.0], radius = 0.5 }",
            "shape = { type = \"heightfield\", size = [1.0, 1.0], levels = 27, height = 1.0, roughness = 0.5 }",
            "objects[0].shape.levels",
            "triangles",
        ),
        (
            "shape = { type = \"sphere\", center = [0.0, 0.5, 0.0], radius = 0.5 }",
            "shape = { type = \"lathe\", profile = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]] }",
            "objects[0].shape",
            "closed",
        ),
        ("[[objects]]\nname = \"ball\"", "[[objects]]\nname = \"ball\"\ntransform = [{ scale = [1.0, 2.0, 1.0] }]", "objects[0].transform", "uniform"),
        ("[[objects]]\nname = \"ball\"", "[[objects]]\nname = \"ball\"\ntransform = [{ translate = [1.0, 2.0, 1.0], scale = 2.0 }]", "objects[0].transform[0]", "exactly one"),
        ("[camera]", "ambient_ior = -1.0\n[camera]", "ambient_ior", "> 0"),
        // Fuzzer finding: a light at 1e300 made an invalid (non-finite) shadow ray,
        // and Debian's Embree aborts on those. Rejected at load now.
        ("position = [0.0, 4.0, 0.0]", "position = [0.0, 1e300, 0.0]", "lights[0].position", "1e15"),
        ("[film]", "[integrator]\ntype = \"bdpt\"\n[film]", "integrator.type", "path"),
        ("[film]", "[camera2]\n[film]", "camera2", "unknown field"),
        (
            "[film]",
            "[environment]\ntype = \"sky\"\nsun_direction = [0.0, 1.0, 0.0]\nsun_irradiance = [1.0, 1.0, 1.0]\nsun_size = 1.0\n[film]",
            "environment",
            "sun_size",
        ),
        (
            "[film]",
            "[environment]\ntype = \"sky\"\nsun_direction = [0.0, 1.0, 0.0]\nsun_irradiance = [1.0, 1.0, 1.0]\nsun_diameter = 0.0\n[film]",
            "environment.sun_diameter",
            "(0, 90]",
        ),
        (
            "[film]",
            "[environment]\ntype = \"sky\"\nsun_direction = [0.0, 0.0, 0.0]\nsun_irradiance = [1.0, 1.0, 1.0]\n[film]",
            "environment.sun_direction",
            "non-zero",
        ),
        (
            "[film]",
            "[environment]\ntype = \"map\"\nfile = \"glass_of_water_backdrop.png\"\nto_world = [{ scale = [1.0, 2.0, 1.0] }]\n[film]",
            "environment.to_world",
            "expected a rotation",
        ),
        (
            "[film]",
            "[environment]\ntype = \"map\"\nfile = \"glass_of_water_backdrop.png\"\nto_world = [{ matrix = [[-1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]] }]\n[film]",
            "environment.to_world",
            "mirrors",
        ),
        (
            "[film]",
            "[environment]\ntype = \"map\"\nfile = \"glass_of_water_backdrop.png\"\nto_world = [{ rotate = { axis = [0.0, 1.0, 0.0], degrees = 30.0 } }, { translate = [0.0, 1.0, 0.0] }]\n[film]",
            "environment.to_world",
            "translation",
        ),
        (
            "[film]",
            "[environment]\ntype = \"map\"\nfile = \"glass_of_water_backdrop.png\"\nrows = \"middle\"\n[film]",
            "environment.rows",
            "poles",
        ),
    ];
    assert!(cases.len() >= 20);
    for (from, to, key, words) in cases {
        assert!(BASE.contains(from), "case setup: {from}");
        let text = BASE.replacen(from, to, 1);
        let err = match load_scene_str("bad.toml", &text, Path::new("scenes"), &BuildOptions::default()) {
            Ok(_) => panic!("accepted bad input: {to}"),
            Err(e) => e,
        };
        let msg = err.to_string();
        match &err {
            snell::Error::Input {
                file, key: k, line, ..
            } => {
                assert_eq!(file, "bad.toml");
                assert!(k.starts_with(key), "key path for {to}: {msg}");
                assert!(*line >= 1);
            }
            other => panic!("not an input error for {to}: {other}"),
        }
        assert!(msg.contains(words), "message for {to} lacks \"{words}\": {msg}");
    }
}

#[test]
fn empty_scene_and_inside_out_mesh_are_errors_and_flip_is_offered() {
    let text = "[camera]\nposition = [0.0, 0.0, 1.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 40.0\n";
    let e = load_scene_str("e.toml", text, Path::new("."), &BuildOptions::default())
        .err()
        .unwrap();
    assert!(e.to_string().contains("empty"), "{e}");

    let dir = std::env::temp_dir().join(format!("snell-inside-out-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A tetrahedron wound inward.
    std::fs::write(
        dir.join("tet.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n",
    )
    .unwrap();
    let scene = |flip: bool| {
        format!(
            "{text}[[objects]]\nname = \"tet\"\nflip_inside_out = {flip}\nshape = {{ type = \"mesh\", file = \"tet.obj\" }}\nmaterial = {{ type = \"dielectric\", ior = 1.5 }}\n"
        )
    };
    // This tetrahedron's windings are inconsistent: it is not a valid solid at all.
    let e = load_scene_str("t.toml", &scene(false), &dir, &BuildOptions::default())
        .err()
        .unwrap();
    assert!(e.to_string().contains("not a closed solid"), "{e}");
    // Consistently inward.
    std::fs::write(
        dir.join("tet.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 4 2\nf 1 3 4\nf 2 4 3\n",
    )
    .unwrap();
    let e = load_scene_str("t.toml", &scene(false), &dir, &BuildOptions::default())
        .err()
        .unwrap();
    assert!(e.to_string().contains("inside out"), "{e}");
    let s = load_scene_str("t.toml", &scene(true), &dir, &BuildOptions::default()).unwrap();
    assert_eq!(s.warnings.len(), 1);
    let _ = std::fs::remove_dir_all(&dir);
}

/// Regression: with a point light declared before a rect light, a
/// duplicate object name was reported at `objects[1].name` (the line of "b"),
/// because the index subtracted every light while only rect and sphere lights
/// are pending objects. The error must name the duplicate's own key and line.
#[test]
fn duplicate_object_name_is_located_at_the_duplicate() {
    let text = r#"[camera]
position = [0.0, 1.0, 5.0]
target = [0.0, 0.0, 0.0]
fov = 40.0
[film]
width = 8
height = 8
spp = 1
[[lights]]
type = "point"
position = [0.0, 4.0, 0.0]
intensity = [10.0, 10.0, 10.0]
[[lights]]
type = "rect"
center = [0.0, 4.0, 0.0]
normal = [0.0, -1.0, 0.0]
u_axis = [1.0, 0.0, 0.0]
size = [1.0, 1.0]
radiance = [1.0, 1.0, 1.0]
[[objects]]
name = "a"
shape = { type = "sphere", center = [0.0, 0.5, 0.0], radius = 0.5 }
material = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }
[[objects]]
name = "b"
shape = { type = "sphere", center = [2.0, 0.5, 0.0], radius = 0.5 }
material = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }
[[objects]]
name = "a"
shape = { type = "sphere", center = [-2.0, 0.5, 0.0], radius = 0.5 }
material = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }
"#;
    let Err(err) = load_scene_str("dup.toml", text, Path::new("scenes"), &BuildOptions::default()) else {
        panic!("a duplicate name was accepted")
    };
    let want_line = text.lines().position(|l| l == "name = \"a\"").unwrap();
    let want_line = want_line
        + 1
        + text
            .lines()
            .skip(want_line + 1)
            .position(|l| l == "name = \"a\"")
            .unwrap()
        + 1;
    match &err {
        snell::Error::Input { key, line, .. } => {
            assert_eq!(key, "objects[2].name", "{err}");
            assert_eq!(*line, want_line, "{err}");
        }
        other => panic!("not an input error: {other}"),
    }
    // A duplicate of a light's name is located at the object that repeats it.
    let text2 = text.replace(
        "radiance = [1.0, 1.0, 1.0]",
        "radiance = [1.0, 1.0, 1.0]\nname = \"b\"",
    );
    let Err(err) = load_scene_str("dup.toml", &text2, Path::new("scenes"), &BuildOptions::default()) else {
        panic!("a duplicate of a light's name was accepted")
    };
    assert!(
        matches!(&err, snell::Error::Input { key, .. } if key == "objects[1].name"),
        "{err}"
    );
}

/// The path tracer's packets of 16 and 8 lanes (the wavefront, what renders use without
/// a gradient-index medium) give every path the radiance and counters of the
/// scalar path (`radiance`) with the same random numbers, bit for bit (also
/// where the packets' analytic shapes are intersected by snell's own vector
/// code and the scalar path's by Embree's callbacks), on the
/// three reference scenes (every segment a packet query) and on two nested
/// scenes with both strategies (packets outside every solid, `trace` inside);
/// the comparison has power: the same lanes with each path's sample index
/// shifted by one give different radiance. (Scalar shading, as the single
/// rays': vector shading is compared in `the_wavefront_traces_the_same_paths_as_single_rays`.)
#[test]
fn packet_lanes_trace_the_same_paths_as_single_rays() {
    use snell::counters::Counters;
    use snell::dielectric::{InteriorList, NestedStrategy};
    use snell::embree::{Packet16, Packet8};
    use snell::integrator::{radiance, Scheduler, Tracer};
    use snell::render::RenderSettings;
    use snell::sampling::Rng;
    let cases = [
        ("three_spheres", NestedStrategy::Filter),
        ("glass_of_water", NestedStrategy::Filter),
        ("cylinder_refraction", NestedStrategy::Filter),
        ("glass_of_water_nested", NestedStrategy::Filter),
        ("glass_of_water_nested", NestedStrategy::Recast),
        ("deep_nesting", NestedStrategy::Filter),
    ];
    for (name, strategy) in cases {
        let scene = shipped_scene(name);
        let tr = Tracer::new(&scene).with_strategy(strategy);
        assert!(
            matches!(Scheduler::of(tr, Default::default()), Scheduler::Wavefront(_)),
            "{name}: no medium, the wavefront applies"
        );
        // The scenes of few analytic shapes intersect them outside Embree
        // (`shapes::AnalyticSet`) in packets; `radiance` through Embree.
        if matches!(name, "three_spheres" | "cylinder_refraction") {
            assert!(scene.analytic_set.is_some(), "{name}: an analytic set");
            // Their rects too: no mesh is left for Embree.
            assert!(
                scene
                    .geoms
                    .iter()
                    .all(|g| matches!(g.shape, snell::scene::Shape::Analytic(_))),
                "{name}: every shape analytic, rects included"
            );
        }
        let settings = RenderSettings::from_scene(&scene)
            .with_resolution(64, 48)
            .unwrap();
        let cam = settings.camera(&scene);
        let list = InteriorList::from_solids(&scene.solids, &scene.camera_interior);
        let (mut lit, mut shifted_differs) = (0, 0);
        for pixel in (0..64 * 48).step_by(37) {
            let (x, y) = ((pixel % 64) as f32, (pixel / 64) as f32);
            let rngs_at = |first: u64| -> [Rng; 16] {
                std::array::from_fn(|i| Rng::for_sample(3, pixel, first + i as u64))
            };
            let mut rngs = rngs_at(0);
            let cams: Vec<_> = rngs
                .iter_mut()
                .map(|r| cam.ray(x + r.uniform(), y + r.uniform(), (r.uniform(), r.uniform())))
                .collect();
            let mut scalar_rngs = rngs.clone();
            // The renderer's width (16) on all of them, and 8 on the first half.
            let rngs8 = rngs.clone();
            let mut sts8 = [Counters::default(); 8];
            let lanes8 = common::wavefront_paths::<8, Packet8>(
                tr,
                &cams[..8],
                &list,
                &rngs8,
                &mut sts8,
                &mut Default::default(),
            );
            let mut sts = [Counters::default(); 16];
            let lanes = common::wavefront_paths::<16, Packet16>(
                tr,
                &cams,
                &list,
                &rngs,
                &mut sts,
                &mut Default::default(),
            );
            assert_eq!(lanes8[..], lanes[..8], "{name}: 8 and 16 lanes");
            assert_eq!(sts8[..], sts[..8], "{name}: 8 and 16 lanes, counters");
            for i in 0..16 {
                let mut st = Counters::default();
                let (o, d) = cams[i];
                let l = radiance(tr, o, d, list.clone(), &mut scalar_rngs[i], &mut st).unwrap();
                let what = format!("{name} {strategy:?} pixel {pixel} lane {i}");
                assert_eq!(
                    l.to_array().map(f32::to_bits),
                    lanes[i].to_array().map(f32::to_bits),
                    "{what}"
                );
                // A packet hit that only touches a mesh solid is re-traced: one
                // more query than the scalar path, nothing else differs.
                assert!(sts[i].queries >= st.queries, "{what}: queries");
                assert_eq!(
                    Counters {
                        queries: st.queries,
                        ..sts[i]
                    },
                    st,
                    "{what}: counters"
                );
                lit += (l.max_element() > 0.0) as u32;
            }
            // Power: other random numbers give other paths.
            let other = rngs_at(1);
            let mut sts2 = [Counters::default(); 16];
            let shifted = common::wavefront_paths::<16, Packet16>(
                tr,
                &cams,
                &list,
                &other,
                &mut sts2,
                &mut Default::default(),
            );
            shifted_differs += (shifted != lanes) as u32;
        }
        assert!(lit > 100, "{name}: {lit} lit paths, too few to compare");
        assert!(
            shifted_differs > 40,
            "{name}: shifted random numbers changed only {shifted_differs} groups"
        );
    }
}

/// The wavefront (`trace_paths`, what renders use without a gradient-index
/// medium): hundreds of paths from many pixels, compacted into full packets
/// at every step, each give the radiance and counters of the scalar path
/// (`radiance`) with the same random numbers, bit for bit, at 16 and 8
/// lanes, with both nested strategies. Power: the same paths with each
/// one's random numbers shifted by one sample give different radiance, and
/// the packets the wavefront sent are full where fixed groups of a pixel's
/// samples were not.
#[test]
fn the_wavefront_traces_the_same_paths_as_single_rays() {
    use snell::counters::Counters;
    use snell::dielectric::{InteriorList, NestedStrategy};
    use snell::embree::{Packet16, Packet8};
    use snell::integrator::{
        radiance, trace_paths, PathStart, Scheduler, Shading, Tracer, Wavefront, WavefrontMode,
    };
    use snell::sampling::Rng;
    let cases = [
        ("three_spheres", NestedStrategy::Filter),
        ("glass_of_water", NestedStrategy::Filter),
        ("glass_of_water_nested", NestedStrategy::Recast),
        ("deep_nesting", NestedStrategy::Filter),
    ];
    for (name, strategy) in cases {
        let scene = shipped_scene(name);
        let tr = Tracer::new(&scene).with_strategy(strategy);
        let settings = RenderSettings::from_scene(&scene)
            .with_resolution(64, 48)
            .unwrap();
        let cam = settings.camera(&scene);
        let list = InteriorList::from_solids(&scene.solids, &scene.camera_interior);
        // Seven samples of each of 60 pixels: groups that do not fill a packet.
        let starts = |shift: u64| -> Vec<(usize, (V3, V3), Rng)> {
            (0..60u64)
                .flat_map(|p| (0..7u64).map(move |s| (p * 51 % 3072, s)))
                .enumerate()
                .map(|(i, (pixel, s))| {
                    let mut r = Rng::for_sample(11, pixel, s + shift);
                    let (x, y) = ((pixel % 64) as f32, (pixel / 64) as f32);
                    let ray = cam.ray(x + r.uniform(), y + r.uniform(), (r.uniform(), r.uniform()));
                    (i, ray, r)
                })
                .collect()
        };
        let stream_with = |shift: u64, wide: bool, vector: bool| {
            let all = starts(shift);
            let starts: Vec<PathStart> = all
                .iter()
                .map(|(_, ray, rng)| PathStart {
                    ray: *ray,
                    rng: rng.clone(),
                })
                .collect();
            let mut out = vec![(V3::splat(f32::NAN), Counters::default()); all.len()];
            let mut total = Counters::default();
            // `done` names a path by its place in `starts`.
            let done = |i: u32, l: V3, st: &Counters| out[i as usize] = (l, *st);
            // The renderer's vector mode, or the reference.
            let mode = match Scheduler::of(tr, Shading::Vector) {
                Scheduler::Wavefront(m) if vector => m,
                _ => WavefrontMode::SCALAR,
            };
            if wide {
                let mut packets = Wavefront::<Packet16>::default();
                trace_paths::<16, _>(tr, mode, &list, &starts, done, true, &mut total, &mut packets).unwrap();
                total += packets.take_occupancy();
            } else {
                let mut packets = Wavefront::<Packet8>::default();
                trace_paths::<8, _>(tr, mode, &list, &starts, done, true, &mut total, &mut packets).unwrap();
                total += packets.take_occupancy();
            }
            (out, total)
        };
        let stream = |shift: u64, wide: bool| stream_with(shift, wide, false);
        let (wide, total) = stream(0, true);
        let (narrow, _) = stream(0, false);
        let mut lit = 0;
        for (i, _, rng) in starts(0) {
            let (o, d) = starts(0)[i].1;
            let mut st = Counters::default();
            let l = radiance(tr, o, d, list.clone(), &mut rng.clone(), &mut st).unwrap();
            for (got, what) in [(&wide[i], "16 lanes"), (&narrow[i], "8 lanes")] {
                let what = format!("{name} {strategy:?} path {i}, {what}");
                assert_eq!(
                    l.to_array().map(f32::to_bits),
                    got.0.to_array().map(f32::to_bits),
                    "{what}"
                );
                // A packet hit that only touches a mesh solid is re-traced.
                assert_eq!(
                    Counters {
                        queries: st.queries,
                        ..got.1
                    },
                    st,
                    "{what}: counters"
                );
            }
            lit += (l.max_element() > 0.0) as u32;
        }
        assert!(lit > 60, "{name}: {lit} lit paths, too few to compare");
        // Vector shading (f32) gives the same paths up to rounding, but for
        // the few that pick another lobe at a Fresnel or critical-angle tie.
        for sixteen in [true, false] {
            let (vector, _) = stream_with(0, sixteen, true);
            let scalar = if sixteen { &wide } else { &narrow };
            let off = vector
                .iter()
                .zip(scalar)
                .filter(|(v, s)| {
                    ((v.0 - s.0).abs() - (v.0.abs() + s.0.abs()) * 1e-4 - V3::splat(1e-6)).max_element() > 0.0
                })
                .count();
            assert!(
                off * 100 <= vector.len(),
                "{name}: vector shading, {off} of {} paths differ",
                vector.len()
            );
        }
        let (shifted, _) = stream(1, true);
        let differs = shifted.iter().zip(&wide).filter(|(a, b)| a.0 != b.0).count();
        assert!(
            differs > 60,
            "{name}: shifted random numbers changed only {differs} paths"
        );
        // Fuller packets than the same paths in fixed groups of a pixel's 7
        // (at most 7/16 full; with nested solids, lanes inside a solid go
        // one by one and count in neither).
        let mut grouped = Counters::default();
        let mut packets = Wavefront::<Packet16>::default();
        for group in starts(0).chunks(7) {
            let cams: Vec<_> = group.iter().map(|g| g.1).collect();
            let rngs: Vec<_> = group.iter().map(|g| g.2.clone()).collect();
            common::wavefront_paths::<16, _>(
                tr,
                &cams,
                &list,
                &rngs,
                &mut [Counters::default()],
                &mut packets,
            );
        }
        grouped += packets.take_occupancy();
        let share = |c: &Counters| c.packet_lanes as f64 / c.packet_slots as f64;
        assert_eq!(
            total.packet_lanes, grouped.packet_lanes,
            "{name}: the same queries"
        );
        assert!(
            share(&total) > 1.5 * share(&grouped),
            "{name}: lane share {:.2} streamed, {:.2} in groups",
            share(&total),
            share(&grouped)
        );
    }
}

/// The packet counters say how full the path tracer's packets went out:
/// without solids every segment is a lane of a packet (so the lanes equal
/// the segments, and a miscount would show), with nested solids some go
/// one by one instead, and a gradient-index scene sends no packet at all.
/// Eight-wide packets: the slots are a multiple of eight, at least the lanes.
#[test]
fn packet_counters_count_the_lanes_sent() {
    let counters = |name: &str| {
        let s = load_scene(
            Path::new(&format!("scenes/{name}.toml")),
            &BuildOptions::default(),
        )
        .unwrap();
        let set = RenderSettings::from_scene(&s)
            .with_resolution(32, 24)
            .unwrap()
            .with_spp(4);
        let opts = RenderOptions {
            threads: Some(2),
            want_aovs: false,
            ..Default::default()
        };
        render(&s, &set, &opts).unwrap().stats.counters
    };
    for name in [
        "three_spheres",
        "glass_of_water",
        "glass_of_water_nested",
        "mirage_road",
    ] {
        let c = counters(name);
        assert!(
            c.packet_slots % 8 == 0 && c.shadow_packet_slots % 8 == 0,
            "{name}: {c:?}"
        );
        assert!(c.packet_lanes <= c.packet_slots && c.shadow_packet_lanes <= c.shadow_packet_slots);
        assert!(c.shadow_packet_lanes <= c.shadow_rays, "{name}: {c:?}");
        // Every path ends once, for one reason (a failed curved ray is
        // counted as such).
        let ends = c.ended_escaped + c.ended_max_depth + c.ended_roulette + c.ended_absorbed;
        assert_eq!(ends + c.grin_failures, c.samples, "{name}: {c:?}");
        assert!(c.ended_escaped > 0, "{name}: {c:?}");
        match name {
            "three_spheres" | "glass_of_water" => {
                assert_eq!(c.packet_lanes, c.segments, "{name}: every segment in a packet");
                assert!(c.shadow_packet_lanes > 0, "{name}: shadow rays in packets");
                // Without a medium a shadow ray needs a light sample.
                assert!(c.shadow_rays <= c.nee_draws, "{name}: {c:?}");
            }
            "glass_of_water_nested" => {
                // Rays inside overlapping solids go in packets too, masked
                // (the set reads the masks): here every segment; a
                // segment the check refuses is traced again alone.
                assert!(
                    c.packet_lanes > 0 && c.packet_lanes <= c.segments,
                    "{name}: {c:?}"
                );
                assert!(c.queries >= c.segments, "{name}: {c:?}");
            }
            _ => assert_eq!(
                c.packet_slots + c.shadow_packet_slots,
                0,
                "{name}: a medium, no packets"
            ),
        }
    }
}

/// `[environment] type = "map"`: without `to_world` and `rows` the lookup
/// is the one snell has always made (bit for bit); `to_world` turns the
/// map (direction R·e reads what e read before; known wrong: Rᵀ·e);
/// `rows = "poles"` puts row j at polar angle j/(H − 1) · 180°.
#[test]
fn map_environment_turns_by_to_world_and_places_rows() {
    use snell::scene::texture::{load_image, Rows};
    let dir = std::env::temp_dir().join(format!("snell-render-envmap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let (w, h) = (12u32, 6u32);
    // Columns differ within a row, rows by whole units.
    let px: Vec<V3> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            V3::new(y + 1.0 + 0.01 * x, y + 1.0, y + 1.0 + 0.02 * (x * 7.0 % 5.0))
        })
        .collect();
    let file = dir.join("sky.exr");
    std::fs::write(&file, snell::image_io::encode_exr(w, h, &px, &[], &[]).unwrap()).unwrap();
    let scene = |extra: &str| {
        let text = format!(
            "[camera]\nposition = [0.0, 0.0, 5.0]\ntarget = [0.0, 0.0, 0.0]\nfov = 40.0\n\
             [environment]\ntype = \"map\"\nfile = \"sky.exr\"\nscale = 2.0\n{extra}\n\
             [[objects]]\nshape = {{ type = \"sphere\", center = [0.0, 0.0, 0.0], radius = 0.5 }}\n\
             material = {{ type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }}\n"
        );
        load_scene_str("m.toml", &text, &dir, &BuildOptions::default()).unwrap()
    };
    let image = load_image(&file).unwrap();
    let golden = std::f32::consts::PI * (3.0 - 5f32.sqrt());
    let dirs: Vec<V3> = (0..300)
        .map(|i| {
            let y = 1.0 - (i as f32 + 0.5) / 150.0;
            let r = (1.0 - y * y).sqrt();
            let phi = golden * i as f32;
            V3::new(r * phi.cos(), y, r * phi.sin())
        })
        .collect();
    let plain = scene("");
    for d in &dirs {
        let u = 0.5 + d.x.atan2(-d.z) / std::f32::consts::TAU;
        let v = d.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
        let old = image.lookup(u, v) * 2.0;
        let got = plain.environment.eval(*d);
        assert_eq!(
            got.to_array().map(f32::to_bits),
            old.to_array().map(f32::to_bits),
            "{d}"
        );
        assert_eq!(image.lookup_rows(u, v, Rows::Centres), image.lookup(u, v));
    }
    let axis = glam::Vec3::new(1.0, 1.0, 0.0).normalize();
    let r = glam::Mat3A::from_axis_angle(axis, 50f32.to_radians());
    let turned = scene("to_world = [{ rotate = { axis = [1.0, 1.0, 0.0], degrees = 50.0 } }]");
    let worst = |f: &dyn Fn(V3) -> V3| {
        dirs.iter()
            .map(|e| {
                (turned.environment.eval(f(*e)) - plain.environment.eval(*e))
                    .abs()
                    .max_element()
            })
            .fold(0.0f32, f32::max)
    };
    let good = worst(&|e| r * e);
    let wrong = worst(&|e| r.transpose() * e);
    assert!(good < 1e-3, "{good}");
    assert!(wrong > 0.5, "no power: {wrong}");
    // Rows on the poles: at polar angle j/(H − 1) · 180° a direction reads
    // row j (every value of row j is within 0.1 of j + 1); at pixel centres
    // (the default) it reads between rows.
    let poles = scene("rows = \"poles\"");
    for j in 1..h - 1 {
        let theta = std::f32::consts::PI * j as f32 / (h - 1) as f32;
        let d = V3::new(theta.sin() * 0.6, theta.cos(), theta.sin() * -0.8);
        let want = 2.0 * (j as f32 + 1.0);
        let at_poles = poles.environment.eval(d).y;
        let at_centres = plain.environment.eval(d).y;
        assert!((at_poles - want).abs() < 1e-3, "row {j}: {at_poles} vs {want}");
        assert!((at_centres - want).abs() > 0.1, "row {j}: {at_centres}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}
