//! The orthographic camera against geometry: a checker plane facing it
//! covers exactly the pixels its size predicts, at any distance, by the path
//! tracer's packets, through a medium and by Whitted; an emitting sphere's
//! silhouette has the same area at two distances. Each check is also run on
//! the perspective camera that sees the same view at the nearer distance,
//! which fails it: what the test shows is the projection, not a lucky scene.
//! Bad `[camera]` tables are refused at their key.
use snell::render::{render, RenderOptions, RenderSettings, Rendered};
use snell::scene::{load_scene_str, BuildOptions, RenderScene};
use std::path::Path;

/// Film 80 × 60 over a 4 × 3 m view: 20 pixels a metre.
const PX_PER_M: f64 = 20.0;
const ORTHO: &str = "type = \"orthographic\"\nsize = [4.0, 3.0]";

/// A 2 × 2 m checker of 0.25 m squares at z = 0 facing +z, emitting 1 and
/// 0.1, on a black material: what a pixel sees is the square's radiance
/// alone. Its squares fall on whole pixels (5 a side), so every pixel is
/// exactly one radiance, whatever the jitter.
const CHECKER: &str = r#"
[[objects]]
name = "checker"
shape = { type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0], u_axis = [1.0, 0.0, 0.0], size = [2.0, 2.0] }
material = { type = "black" }
emission = { radiance = { type = "checker", axes = ["x", "y"], size = 0.25, color0 = [1.0, 1.0, 1.0], color1 = [0.1, 0.1, 0.1] } }
"#;

fn scene(camera: &str, z: f64, rest: &str) -> snell::Result<RenderScene> {
    let text = format!(
        "[camera]\nposition = [0.0, 0.0, {z}]\ntarget = [0.0, 0.0, 0.0]\n{camera}\n[film]\nwidth = 80\nheight = 60\nspp = 4\n{rest}"
    );
    load_scene_str("ortho.toml", &text, Path::new("scenes"), &BuildOptions::default())
}

fn shoot(s: &RenderScene, spp: u32) -> Rendered {
    let set = RenderSettings::from_scene(s).with_spp(spp).with_seed(5);
    let opts = RenderOptions {
        threads: Some(2),
        want_aovs: false,
        ..Default::default()
    };
    render(s, &set, &opts).unwrap()
}

/// Pixels (of 4800) whose red differs by more than 1e-4 from the checker
/// the orthographic view predicts: centre (x, y) in metres, the square's
/// radiance by the parity of its cell (either colour first: the prediction
/// takes the better of the two), black off the checker.
fn off_checker(r: &Rendered) -> usize {
    let predict = |first: f32| {
        let mut bad = 0;
        for py in 0..r.height {
            for px in 0..r.width {
                let x = (px as f64 + 0.5) / PX_PER_M - 2.0;
                let y = 1.5 - (py as f64 + 0.5) / PX_PER_M;
                let want = if x.abs() < 1.0 && y.abs() < 1.0 {
                    let parity = ((x / 0.25).floor() + (y / 0.25).floor()).rem_euclid(2.0) == 0.0;
                    if parity {
                        first
                    } else {
                        1.1 - first
                    }
                } else {
                    0.0
                };
                bad += ((r.pixels[(py * r.width + px) as usize].x - want).abs() > 1e-4) as usize;
            }
        }
        bad
    };
    predict(1.0).min(predict(0.1))
}

/// The perspective camera that sees the 4 × 3 m view at distance `d`.
fn perspective_at(d: f64) -> String {
    format!("fov = {}", 2.0 * (1.5f64 / d).atan().to_degrees())
}

#[test]
fn a_checker_plane_covers_exactly_the_predicted_pixels_at_any_distance() {
    let medium = "[medium]\nfield = { kind = \"constant\", n = 1.000293 }\nbounds = { min = [-3.0, -3.0, 1.0], max = [3.0, 3.0, 4.0] }\n";
    let whitted = "[integrator]\ntype = \"whitted\"\n";
    let mut figures = Vec::new();
    for z in [5.0, 50.0] {
        for (how, rest) in [("path", ""), ("medium", medium), ("whitted", whitted)] {
            let s = scene(ORTHO, z, &format!("{CHECKER}{rest}")).unwrap();
            let bad = off_checker(&shoot(&s, 4));
            figures.push(format!("ortho z={z} {how}: {bad}"));
            assert_eq!(
                bad, 0,
                "orthographic at z = {z} ({how}): {bad} pixels off the checker"
            );
        }
    }
    // Power: the perspective camera matching the view at z = 5 passes there
    // (a plane across the view is a linear map for both) and fails at z = 50,
    // where the checker is a tenth the size.
    let near = off_checker(&shoot(&scene(&perspective_at(5.0), 5.0, CHECKER).unwrap(), 4));
    let far = off_checker(&shoot(&scene(&perspective_at(5.0), 50.0, CHECKER).unwrap(), 4));
    eprintln!(
        "{}; perspective z=5: {near}, z=50: {far} pixels off",
        figures.join(", ")
    );
    assert!(
        near <= 40,
        "the perspective reference at z = 5: {near} pixels off"
    );
    assert!(
        far > 1000,
        "no power: the perspective camera at z = 50 is only {far} pixels off"
    );
}

/// The emitting sphere's silhouette in square metres: the image's summed
/// radiance over the pixels a square metre covers.
fn silhouette_area(r: &Rendered) -> f64 {
    r.pixels.iter().map(|p| p.x as f64).sum::<f64>() / (PX_PER_M * PX_PER_M)
}

#[test]
fn a_spheres_silhouette_has_the_same_size_at_two_distances() {
    let sphere = r#"
[[objects]]
name = "ball"
shape = { type = "sphere", center = [0.0, 0.0, 0.0], radius = 0.5 }
material = { type = "black" }
emission = { radiance = [1.0, 1.0, 1.0] }
"#;
    let want = std::f64::consts::PI * 0.25;
    let area = |camera: &str, z: f64| silhouette_area(&shoot(&scene(camera, z, sphere).unwrap(), 256));
    let (a3, a12) = (area(ORTHO, 3.0), area(ORTHO, 12.0));
    let (p3, p12) = (area(&perspective_at(3.0), 3.0), area(&perspective_at(3.0), 12.0));
    eprintln!(
        "silhouette m² (πr² = {want:.4}): ortho z=3 {a3:.4}, z=12 {a12:.4}; perspective z=3 {p3:.4}, z=12 {p12:.4}"
    );
    // At 256 samples a pixel the ~70 edge pixels leave the area within
    // about 0.05 % (at 64 it was 0.36 % over by chance).
    for a in [a3, a12] {
        assert!(
            (a / want - 1.0).abs() < 0.002,
            "orthographic silhouette {a} vs πr² {want}"
        );
    }
    assert!(
        (a3 / a12 - 1.0).abs() < 0.002,
        "orthographic silhouettes differ: {a3} vs {a12}"
    );
    // Power: the perspective silhouette is the tangent cone's, πr² / (1 −
    // (r/d)²) on the plane through the centre (2.9 % over πr² at d = 3),
    // and shrinks with the square of the distance.
    let cone = want / (1.0 - (0.5f64 / 3.0).powi(2));
    assert!(
        (p3 / cone - 1.0).abs() < 0.002,
        "the perspective reference: {p3} vs {cone}"
    );
    assert!((p3 / want - 1.0).abs() > 0.02, "no power at z = 3: {p3}");
    assert!(p3 / p12 > 10.0, "no power: perspective {p3} vs {p12}");
}

/// Renders at another film size keep the view's height and its pixels'
/// shape, as a perspective camera keeps its vertical field: at 160 × 60 the
/// view is 8 × 3 m, so the checker is still 40 pixels high and 40 wide.
#[test]
fn another_film_size_keeps_the_views_height() {
    let s = scene(ORTHO, 5.0, CHECKER).unwrap();
    let set = RenderSettings::from_scene(&s)
        .with_resolution(160, 60)
        .unwrap()
        .with_spp(2);
    let r = render(
        &s,
        &set,
        &RenderOptions {
            threads: Some(2),
            ..Default::default()
        },
    )
    .unwrap();
    let lit: Vec<(u32, u32)> = (0..r.height)
        .flat_map(|y| (0..r.width).map(move |x| (x, y)))
        .filter(|&(x, y)| r.pixels[(y * r.width + x) as usize].x > 0.05)
        .collect();
    let xs = (
        lit.iter().map(|p| p.0).min().unwrap(),
        lit.iter().map(|p| p.0).max().unwrap(),
    );
    let ys = (
        lit.iter().map(|p| p.1).min().unwrap(),
        lit.iter().map(|p| p.1).max().unwrap(),
    );
    assert_eq!((xs, ys, lit.len()), ((60, 99), (10, 49), 1600));
}

#[test]
fn bad_orthographic_cameras_are_refused_at_their_key() {
    let sphere = "[[objects]]\nname = \"ball\"\nshape = { type = \"sphere\", center = [0.0, 0.0, 0.0], radius = 0.5 }\nmaterial = { type = \"dielectric\", ior = 1.5, priority = 1 }\n";
    let cases: &[(&str, &str, &str, &str)] = &[
        ("type = \"orthographic\"", "", "camera.size", "needs size"),
        (ORTHO, "fov = 30.0", "camera.fov", "no field of view"),
        ("type = \"orthographic\"\nsize = [0.0, 3.0]", "", "camera.size", "width"),
        ("type = \"orthographic\"\nsize = [4.0, inf]", "", "camera.size", "height"),
        ("type = \"orthographic\"\nsize = [4.0]", "", "camera.size", "length"),
        (ORTHO, "aperture_radius = 0.1", "camera.aperture_radius", "no lens"),
        (ORTHO, "focus_distance = 2.0", "camera.focus_distance", "no lens"),
        (ORTHO, "zoom = 2.0", "camera.zoom", "unknown field"),
        ("type = \"fisheye\"\nfov = 30.0", "", "camera.type", "perspective or orthographic"),
        ("fov = 30.0\nsize = [4.0, 3.0]", "", "camera.size", "perspective"),
        ("type = \"perspective\"", "", "camera.fov", "needs fov"),
        // The view rectangle through the glass ball: some rays would start
        // inside it with the list of a camera outside.
        ("type = \"orthographic\"\nsize = [4.0, 3.0]", "", "camera.size", "crosses the surface of solid \"ball\""),
        (
            ORTHO,
            "[medium]\nfield = { kind = \"constant\", n = 1.000293 }\nbounds = { min = [-3.0, -3.0, 1.0], max = [3.0, 3.0, 4.0] }\npixel_tolerance = 0.1",
            "medium.pixel_tolerance",
            "orthographic",
        ),
    ];
    for (i, &(camera, extra, key, words)) in cases.iter().enumerate() {
        // Case 11 puts the camera's rectangle through the ball (z = 0);
        // the others look at it from z = 5.
        let z = if i == 11 { 0.2 } else { 5.0 };
        let (cam_extra, rest) = if extra.starts_with('[') {
            ("", extra)
        } else {
            (extra, "")
        };
        let err = match scene(&format!("{camera}\n{cam_extra}"), z, &format!("{sphere}{rest}")) {
            Ok(_) => panic!("accepted: {camera} {extra}"),
            Err(e) => e,
        };
        let msg = err.to_string();
        match &err {
            snell::Error::Input { key: k, .. } => {
                assert!(k.starts_with(key), "key for {camera} {extra}: {msg}")
            }
            other => panic!("not an input error for {camera} {extra}: {other}"),
        }
        assert!(
            msg.contains(words),
            "message for {camera} {extra} lacks \"{words}\": {msg}"
        );
    }
    // The same rectangle from outside the ball loads (the check's power).
    assert!(scene(ORTHO, 5.0, sphere).is_ok());
}

/// Tools that need one eye refuse an orthographic camera with a reason.
#[test]
fn grin_fan_refuses_an_orthographic_camera() {
    let s = scene(
        ORTHO,
        5.0,
        &format!("{CHECKER}[medium]\nfield = {{ kind = \"linear\", n0 = 1.0003, m = 0.0002 }}\nbounds = {{ min = [-3.0, -3.0, 1.0], max = [3.0, 3.0, 4.0] }}\n"),
    )
    .unwrap();
    let e = snell::grin_fan::trace_fan(&s, &Default::default())
        .unwrap_err()
        .to_string();
    assert!(e.contains("orthographic"), "{e}");
}
