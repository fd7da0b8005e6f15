//! `snell grin-fan`: the fan's paths against the closed-form path of a
//! linear field (the straight fan of the same scene fails the same check),
//! its profile showing objects beside its plane, its errors, and the SVG.
use snell::grin_fan::{fan_svg, trace_fan, Fan, FanOptions};
use snell::media::grin_trace::{trace, Query, Stop};
use snell::media::{IndexField, Method};
use snell::scene::{load_scene_str, BuildOptions, RenderScene};
use std::path::Path;

/// Eye 1.5 m above a floor, looking along +x; a wall at 120 m; a box
/// beside the fan's plane (z = 3) at 60 m. `medium` is a TOML table or "".
fn scene(medium: &str) -> RenderScene {
    let text = format!(
        r#"
ambient_ior = 1.0003
[camera]
position = [0.0, 1.5, 0.0]
target = [100.0, 1.5, 0.0]
fov = 4.0
[film]
width = 96
height = 32
spp = 1
[environment]
type = "constant"
radiance = [1.0, 1.0, 1.0]
{medium}
[[objects]]
name = "floor"
shape = {{ type = "rect", center = [100.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [400.0, 400.0] }}
material = {{ type = "diffuse", reflectance = [0.5, 0.5, 0.5] }}
[[objects]]
name = "wall"
shape = {{ type = "rect", center = [120.0, 2.0, 0.0], normal = [-1.0, 0.0, 0.0], u_axis = [0.0, 0.0, 1.0], size = [100.0, 8.0] }}
material = {{ type = "diffuse", reflectance = [0.5, 0.5, 0.5] }}
[[objects]]
name = "crate & co"
shape = {{ type = "box", center = [60.0, 0.5, 3.0], size = [2.0, 1.0, 2.0] }}
material = {{ type = "diffuse", reflectance = [0.5, 0.5, 0.5] }}
"#
    );
    load_scene_str("fan.toml", &text, Path::new("."), &BuildOptions::default()).unwrap()
}

/// n = 1.0003 + 2e-4·h: rays curve upward by about half a metre over 100 m.
const LINEAR: &str = r#"
[medium]
field = { kind = "linear", n0 = 1.0003, m = 0.0002 }
bounds = { min = [-1.0, -1.0, -50.0], max = [200.0, 20.0, 50.0] }
method = "rk45"
tolerance = 0.001
"#;

fn linear_field() -> IndexField {
    IndexField::Linear {
        n0: 1.0003,
        m: 0.0002,
        up: glam::DVec3::Y,
        base: 0.0,
    }
}

/// The closed-form height at distance x of the ray leaving the eye at
/// `elevation_deg` (grin-trace's `exact` method, stopping at the plane x).
fn exact_height(elevation_deg: f64, x: f64) -> f64 {
    let e = elevation_deg.to_radians();
    let q = Query {
        id: String::new(),
        field: linear_field(),
        start: glam::DVec3::new(0.0, 1.5, 0.0),
        direction: glam::DVec3::new(e.cos(), e.sin(), 0.0),
        stop: Stop { x: Some(x), s: None },
        method: Method::Exact,
        tolerance: None,
        step: None,
        steps: None,
        max_length: None,
    };
    trace(&q).unwrap().end.unwrap().y
}

/// The largest height error of the fan's path points (and hits) against
/// the closed form, over points farther than a metre from the eye.
fn worst_path_error(fan: &Fan) -> f64 {
    let mut worst = 0.0f64;
    for r in &fan.rays {
        let pts = r.points.iter().chain(r.hit.as_ref().map(|h| &h.at));
        for p in pts.filter(|p| p[0] > 1.0 && p[0] < 150.0) {
            worst = worst.max((p[1] - exact_height(r.elevation_deg, p[0])).abs());
        }
    }
    worst
}

const TOLERANCE_M: f64 = 1e-3;

#[test]
fn fan_paths_follow_the_closed_form_and_a_straight_fan_does_not() {
    let opts = FanOptions {
        rays: 9,
        elevations: Some((-1.2, 0.8)),
        tolerance: Some(1e-5),
        ..FanOptions::default()
    };
    let curved = trace_fan(&scene(LINEAR), &opts).unwrap();
    assert_eq!(curved.rays.len(), 9);
    assert!(curved.rays.iter().all(|r| r.failure.is_none()));
    let err = worst_path_error(&curved);
    assert!(err < TOLERANCE_M, "fan vs closed form: {err:.3e} m");
    // Every ray lands (floor or wall), and floor hits lie on the floor.
    for r in &curved.rays {
        let h = r
            .hit
            .as_ref()
            .unwrap_or_else(|| panic!("ray at {}° met nothing", r.elevation_deg));
        if h.object == "floor" {
            assert!(h.at[1].abs() < 1e-4, "{h:?}");
        }
    }
    // The same fan with the field ignored: the check has the power to fail.
    let straight = trace_fan(&scene(""), &opts).unwrap();
    assert!(straight.tolerance.is_none());
    let wrong = worst_path_error(&straight);
    eprintln!("worst height error: fan {err:.3e} m, straight fan {wrong:.3e} m");
    assert!(
        wrong > 50.0 * TOLERANCE_M,
        "straight fan vs closed form only {wrong:.3e} m"
    );
}

#[test]
fn profile_shows_objects_beside_the_fan_plane() {
    let fan = trace_fan(&scene(LINEAR), &FanOptions::default()).unwrap();
    let k = fan
        .objects
        .iter()
        .position(|o| o == "crate & co")
        .expect("the crate is in the profile");
    let on_crate: Vec<_> = fan.profile.iter().filter(|c| c.object == Some(k)).collect();
    assert!(!on_crate.is_empty());
    for c in on_crate {
        assert!((59.0..=61.0).contains(&c.distance), "{c:?}");
        assert!((c.height.unwrap() - 1.0).abs() < 1e-3, "{c:?}");
    }
    // Beyond the wall (120 m) the camera sees nothing of the floor's far end
    // through the wall, but the profile still finds the floor there.
    assert!(fan.distance_range[1] > 120.0);
    let svg = fan_svg(&fan, "fan <test>.toml");
    assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
    assert_eq!(svg.matches("<polyline").count(), fan.rays.len());
    assert!(svg.contains("crate &amp; co") && !svg.contains("crate & co"));
    assert!(svg.contains("fan &lt;test&gt;.toml"));
}

#[test]
fn bad_options_name_the_flag() {
    let s = scene(LINEAR);
    let cases = [
        (
            FanOptions {
                rays: 1,
                ..FanOptions::default()
            },
            "--rays",
        ),
        (
            FanOptions {
                elevations: Some((1.0, -1.0)),
                ..FanOptions::default()
            },
            "--from/--to",
        ),
        (
            FanOptions {
                elevations: Some((-95.0, 1.0)),
                ..FanOptions::default()
            },
            "--from/--to",
        ),
        (
            FanOptions {
                tolerance: Some(0.0),
                ..FanOptions::default()
            },
            "--tolerance",
        ),
        (
            FanOptions {
                max_distance: Some(f64::NAN),
                ..FanOptions::default()
            },
            "--max-distance",
        ),
    ];
    for (opts, flag) in cases {
        let e = trace_fan(&s, &opts).unwrap_err().to_string();
        assert!(e.contains(flag), "{flag}: {e}");
    }
}
