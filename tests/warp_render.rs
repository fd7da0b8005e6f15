//! The warp renderer end to end: the warp image against the exact trace of
//! the same scene, with stated tolerances; the paper's approximation is
//! measurably worse; `snell render` traces the same [warp] scene; bad input.
use snell::scene::shapes::Analytic;
use snell::scene::{load_scene, load_scene_str, BuildOptions, Shape};
use snell::warp::WarpMethod;
use snell::warp_render::{run, WarpRunOptions};
use std::path::Path;
use std::process::Command;

fn compare(scene: &str, w: u32, h: u32, method: WarpMethod) -> snell::warp_render::Comparison {
    let mut s = load_scene(Path::new(scene), &BuildOptions::default()).unwrap();
    s.set_resolution(w, h).unwrap();
    let rep = run(
        &s,
        &WarpRunOptions {
            compare: true,
            method: Some(method),
            ..Default::default()
        },
    )
    .unwrap();
    let (_, cmp, _) = rep.exact.unwrap();
    eprintln!("{scene} {method:?}: {cmp:?}");
    cmp
}

/// Tolerances: mean position error ≤ 0.25 pixel footprints, 95th percentile
/// ≤ 0.5; pixels showing a different object (the seams where a ray changes
/// family, the tube's silhouette) ≤ 2 % of the image; RMSE ≤ 0.1.
#[test]
fn warp_matches_the_exact_trace() {
    for scene in ["scenes/warp_cylinder.toml", "scenes/warp_plate.toml"] {
        let c = compare(scene, 160, 120, WarpMethod::Exact);
        assert!(c.matched as f64 > 0.5 * c.pixels as f64, "{scene}: {c:?}");
        assert!(c.px_mean <= 0.25 && c.px_p95 <= 0.5, "{scene}: {c:?}");
        assert!((c.mismatched as f64) <= 0.02 * c.pixels as f64, "{scene}: {c:?}");
        assert!(c.rmse <= 0.1, "{scene}: {c:?}");
    }
}

#[test]
fn paper_method_is_measurably_worse_on_the_tube() {
    let exact = compare("scenes/warp_cylinder.toml", 96, 72, WarpMethod::Exact);
    let paper = compare("scenes/warp_cylinder.toml", 96, 72, WarpMethod::Paper);
    assert!(
        paper.px_mean > 10.0 * exact.px_mean.max(1e-3),
        "paper {paper:?} exact {exact:?}"
    );
}

/// A `[warp]` scene keeps its rects as meshes even in a build for the
/// analytic set, since the warp renderer moves mesh vertices; the shipped
/// ones prepare.
#[test]
fn warp_scenes_keep_rects_as_meshes_and_prepare() {
    let set = BuildOptions::default();
    for path in ["scenes/warp_plate.toml", "scenes/warp_cylinder.toml"] {
        let s = load_scene(Path::new(path), &set).unwrap();
        let rects = s
            .geoms
            .iter()
            .filter(|g| matches!(g.shape, Shape::Analytic(Analytic::Rect(_))))
            .count();
        assert_eq!(rects, 0, "{path}");
        let spec = s.warp.clone().unwrap();
        snell::warp_render::prepare(&s, &spec, 1e9).unwrap();
    }
}

#[test]
fn full_trace_of_a_warp_scene_renders() {
    for scene in ["scenes/warp_cylinder.toml", "scenes/warp_plate.toml"] {
        let s = load_scene(Path::new(scene), &BuildOptions::default()).unwrap();
        assert!(s.warp.is_some());
        let set = snell::render::RenderSettings::from_scene(&s)
            .with_resolution(32, 24)
            .unwrap()
            .with_spp(2);
        let r = snell::render::render(
            &s,
            &set,
            &snell::render::RenderOptions {
                threads: Some(1),
                want_aovs: false,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(r.stats.counters.nan, 0);
        assert!(
            r.pixels.iter().any(|p| p.max_element() > 0.05),
            "{scene}: black image"
        );
    }
}

#[test]
fn bad_warp_input_is_a_located_error() {
    let base = std::fs::read_to_string("scenes/warp_cylinder.toml").unwrap();
    let cases = [
        (
            base.replace("subdivide = 4.0", "subdivide = 4.0\ncolour = 1"),
            "colour",
        ),
        (
            base.replace("inner_radius = 0.8", "inner_radius = 1.2"),
            "warp.glass",
        ),
        (
            base.replace("subdivide = 4.0", "subdivide = 0.0"),
            "warp.subdivide",
        ),
        (
            base.replace("ambient_ior = 1.0", "ambient_ior = 1.33"),
            "ambient_ior",
        ),
        (base.replace("\"hollow_cylinder\"", "\"sphere\""), "warp"),
    ];
    for (text, key) in cases {
        let e = load_scene_str("w.toml", &text, Path::new("scenes"), &BuildOptions::default())
            .err()
            .unwrap_or_else(|| panic!("accepted: {key}"))
            .to_string();
        assert!(e.contains("w.toml:") && e.contains(key), "{key}: {e}");
    }
    // A scene without [warp], and analytic shapes, are refused by warp-render.
    let s = load_scene(Path::new("scenes/three_spheres.toml"), &BuildOptions::default()).unwrap();
    let e = run(&s, &WarpRunOptions::default()).err().unwrap().to_string();
    assert!(e.contains("[warp]"), "{e}");
    let text = base.replace(
        "[[objects]]",
        "[[objects]]\nname = \"ball\"\nshape = { type = \"sphere\", center = [0.0, 0.0, -2.0], radius = 0.3 }\nmaterial = { type = \"diffuse\", reflectance = [0.5, 0.5, 0.5] }\n\n[[objects]]",
    );
    let s = load_scene_str("w.toml", &text, Path::new("scenes"), &BuildOptions::default()).unwrap();
    let e = run(&s, &WarpRunOptions::default()).err().unwrap().to_string();
    assert!(e.contains("ball") && e.contains("mesh"), "{e}");
}

#[test]
fn cli_writes_image_heatmap_and_stats() {
    let d = std::env::temp_dir().join(format!("snell-warp-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_snell"))
        .args([
            "warp-render",
            "scenes/warp_plate.toml",
            "--width",
            "64",
            "--height",
            "48",
            "-o",
        ])
        .arg(d.join("w.png"))
        .arg("--compare")
        .arg(d.join("heat.png"))
        .arg("--stats-json")
        .arg(d.join("s.json"))
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(d.join("w.png").exists() && d.join("heat.png").exists());
    let st: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("s.json")).unwrap()).unwrap();
    assert!(
        st["comparison"]["rmse"].as_f64().is_some() && st["provenance"]["commit"].is_string(),
        "{st}"
    );
    let bad = Command::new(env!("CARGO_BIN_EXE_snell"))
        .args(["warp-render", "scenes/warp_plate.toml", "--method", "magic", "-o"])
        .arg(d.join("x.png"))
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--method"));
    assert!(!d.join("x.png").exists());
    let _ = std::fs::remove_dir_all(&d);
}

/// Fresnel weights: both renderers weight by the transmittance of the
/// pixel's exact path, so they still agree, and the plate's pixels seen
/// through the glass darken by the two-interface transmittance (about
/// (1 − 0.04)² = 0.92 near normal incidence, less at grazing).
#[test]
fn fresnel_weights_darken_the_view_through_the_glass() {
    let mut s = load_scene(Path::new("scenes/warp_plate.toml"), &BuildOptions::default()).unwrap();
    s.set_resolution(64, 48).unwrap();
    let plain = run(&s, &WarpRunOptions::default()).unwrap();
    let weighted = run(
        &s,
        &WarpRunOptions {
            fresnel: Some(true),
            compare: true,
            ..Default::default()
        },
    )
    .unwrap();
    let (_, cmp, _) = weighted.exact.as_ref().unwrap();
    assert!(cmp.rmse < 1e-3, "{cmp:?}");
    let mut ratios = Vec::new();
    for (a, b) in plain.frame.pixels.iter().zip(&weighted.frame.pixels) {
        if a.max_element() > 0.05 {
            ratios.push(b.element_sum() / a.element_sum());
        }
    }
    let lo = ratios.iter().cloned().fold(f32::INFINITY, f32::min);
    let hi = ratios.iter().cloned().fold(0.0f32, f32::max);
    assert!(lo > 0.5 && hi <= 1.0 + 1e-6, "{lo} {hi}");
    assert!(ratios.iter().any(|r| (r - 0.92).abs() < 0.02), "{lo} {hi}");
}

/// The frame pipeline (copies kept across frames, refit when the triangle
/// sets are unchanged, packets of eight) shows what the one-shot renderer
/// shows, and the packet exact trace what the single-ray one shows, on both
/// scenes, for a first frame, a refitted repeat and a moved camera.
#[test]
fn pipeline_and_packets_match_the_single_ray_renderers() {
    use snell::warp_render::pipeline::Pipeline;
    use snell::warp_render::{
        build_originals, prepare, render_exact, render_exact_packets, render_warped, warp_scene, Frame,
    };
    let same = |a: &Frame, b: &Frame| -> (usize, f64) {
        let mut differ = 0;
        let mut worst: f64 = 0.0;
        for (x, y) in a.shown.iter().zip(&b.shown) {
            match (x, y) {
                (Some(p), Some(q)) if p.object == q.object => worst = worst.max((p.point - q.point).length()),
                (None, None) => {}
                _ => differ += 1,
            }
        }
        (differ, worst)
    };
    for scene in ["scenes/warp_cylinder.toml", "scenes/warp_plate.toml"] {
        let mut s = load_scene(Path::new(scene), &BuildOptions::default()).unwrap();
        s.set_resolution(160, 120).unwrap();
        let spec = s.warp.clone().unwrap();
        let prep = prepare(&s, &spec, spec.subdivide).unwrap();
        let mut pipe = Pipeline::new(&s, &spec, &prep, true).unwrap();
        let orig = build_originals(&s, &prep).unwrap();
        let pos = s.camera.position;
        let mut fb = pipe.render(&s, &spec, &prep);
        for (step, dx) in [(0, 0.0f32), (1, 0.0), (2, 0.05)] {
            if dx != 0.0 {
                let cam = snell::camera::Camera::try_new(
                    pos + glam::Vec3A::new(dx, 0.02, 0.0),
                    glam::Vec3A::new(0.0, 0.0, 0.0),
                    glam::Vec3A::Y,
                    40.0,
                    160,
                    120,
                    0.0,
                    1.0,
                )
                .unwrap();
                s.camera = cam;
            }
            let fw = pipe.warp(&s).unwrap();
            if step == 1 {
                assert!(fw.refits >= 1 && fw.rebuilds == 0, "{scene}: {fw:?}");
            }
            if step == 2 && scene.ends_with("plate.toml") {
                // The plate's triangle sets do not depend on the eye (a
                // vertex is direct or warped by its side of the near face),
                // so a moved camera refits too: the bench's plate frame
                // counts the refit.
                assert!(fw.refits >= 1 && fw.rebuilds == 0, "{scene} moved: {fw:?}");
            }
            let a = pipe.render(&s, &spec, &prep);
            // Rendering into the previous step's frame buffer (another
            // camera, stale pixels) gives the same frame: every pixel is
            // rewritten.
            pipe.render_into(&s, &spec, &prep, &mut fb);
            assert!(
                fb.pixels == a.pixels && fb.shown == a.shown,
                "{scene} step {step}: render_into differs"
            );
            let warped = warp_scene(&s, &spec, &prep).unwrap();
            assert_eq!(fw.dropped_triangles, warped.dropped_triangles, "{scene}");
            let b = render_warped(&s, &spec, &prep, &warped);
            let (differ, worst) = same(&a, &b);
            assert!(
                differ <= 10 && worst < 1e-4,
                "{scene} step {step}: warp {differ} pixels, {worst}"
            );
            let ea = render_exact_packets(&s, &spec, &prep, &orig);
            let eb = render_exact(&s, &spec, &prep, &orig);
            let (differ, worst) = same(&ea, &eb);
            assert!(
                differ <= 10 && worst < 1e-4,
                "{scene} step {step}: exact {differ} pixels, {worst}"
            );
        }
    }
}
