//! Numerical robustness: far from the origin, very thin slabs, grazing
//! incidence, and total internal reflection that must terminate.
use glam::{DVec3, Vec3A as V3};
use snell::counters::Counters;
use snell::integrator::{refraction_path, Tracer};
use snell::render::{render, RenderOptions, RenderSettings, Rendered};
use snell::scene::{load_scene_str, BuildOptions, RenderScene};
use std::path::Path;

fn scene(text: &str) -> RenderScene {
    load_scene_str("n.toml", text, Path::new("."), &BuildOptions::default()).unwrap()
}

fn go(s: &RenderScene) -> Rendered {
    render(
        s,
        &RenderSettings::from_scene(s),
        &RenderOptions {
            threads: Some(2),
            want_aovs: false,
            ..Default::default()
        },
    )
    .unwrap()
}

fn glass_scene(ox: f64, oz: f64) -> String {
    format!(
        r#"
ambient_ior = 1.0
[camera]
position = [{cx}, 1.5, {cz}]
target = [{ox}, 0.4, {oz}]
fov = 35.0
[film]
width = 48
height = 36
spp = 32
seed = 5
[environment]
type = "constant"
radiance = [0.4, 0.4, 0.4]
[[lights]]
type = "rect"
center = [{lx}, 4.0, {oz}]
normal = [0.0, -1.0, 0.0]
u_axis = [1.0, 0.0, 0.0]
size = [2.0, 2.0]
radiance = [5.0, 5.0, 5.0]
[[objects]]
shape = {{ type = "rect", center = [{ox}, 0.0, {oz}], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [20.0, 20.0] }}
material = {{ type = "diffuse", reflectance = {{ type = "checker", axes = ["x", "z"], size = 0.5, color0 = [0.8, 0.8, 0.8], color1 = [0.1, 0.1, 0.1] }} }}
[[objects]]
shape = {{ type = "sphere", center = [{ox}, 0.5, {oz}], radius = 0.5 }}
material = {{ type = "dielectric", ior = 1.5 }}
[[objects]]
shape = {{ type = "box", center = [{bx}, 0.3, {oz}], size = [0.6, 0.6, 0.6] }}
material = {{ type = "dielectric", ior = 1.33, priority = 1 }}
"#,
        cx = ox + 0.3,
        cz = oz + 4.0,
        lx = ox + 1.0,
        bx = ox + 0.9,
    )
}

#[test]
fn hits_ten_thousand_units_from_the_origin_render_like_at_the_origin() {
    let near = go(&scene(&glass_scene(0.0, 0.0)));
    let far = go(&scene(&glass_scene(10_000.0, -10_000.0)));
    assert_eq!(far.stats.counters.nan, 0);
    for ch in 0..3 {
        let (a, sa) = near.mean_and_se(ch);
        let (b, sb) = far.mean_and_se(ch);
        // f32 at 1e4 m has 1 mm ulps: the images agree within noise plus 1%.
        assert!(
            (a - b).abs() < 5.0 * (sa * sa + sb * sb).sqrt() + 0.01 * a,
            "channel {ch}: {a} vs {b}"
        );
    }
}

#[test]
fn a_glass_slab_a_tenth_of_a_millimetre_thick_shifts_rays_by_the_analytic_amount() {
    let s = scene(
        r#"
ambient_ior = 1.0
[camera]
position = [0.0, 1.0, 3.0]
target = [0.0, 0.0, 0.0]
fov = 30.0
[[objects]]
shape = { type = "box", center = [0.0, 0.0, 0.0], size = [2.0, 1e-4, 2.0] }
material = { type = "dielectric", ior = 1.5 }
"#,
    );
    for deg in [0.0f64, 20.0, 45.0, 70.0] {
        let th = deg.to_radians();
        let d = DVec3::new(th.sin(), -th.cos(), 0.0);
        let o = DVec3::new(-0.5 * th.tan(), 0.5, 0.1);
        let mut c = Counters::default();
        let to_f = |v: DVec3| v.as_vec3a();
        let p = refraction_path(Tracer::new(&s), to_f(o), to_f(d), &[], 8, &mut c).unwrap();
        assert_eq!(p.events.len(), 2, "{deg}°: {:?}", p.events);
        assert!(p.final_list.is_empty() && p.escaped);
        let exit = &p.events[1];
        let exit_dir = exit.next_dir;
        assert!((exit_dir - to_f(d)).length() < 1e-5, "{deg}°: direction restored");
        // Entry at y = +5e-5, exit at y = −5e-5, displaced by W·tanφ inside.
        let phi = (th.sin() / 1.5).asin();
        let entry_x = o.x + (o.y - 5e-5) * th.tan();
        let want_x = entry_x + 1e-4 * phi.tan();
        assert!(
            (exit.point.x as f64 - want_x).abs() < 2e-6,
            "{deg}°: exit x {} vs {want_x}",
            exit.point.x
        );
        assert!((exit.point.y as f64 + 5e-5).abs() < 1e-6);
    }
}

#[test]
fn grazing_incidence_stays_finite_and_leaves_the_list_empty() {
    let s = scene(
        r#"
ambient_ior = 1.0
[camera]
position = [0.0, 0.0, 3.0]
target = [0.0, 0.0, 0.0]
fov = 30.0
[[objects]]
shape = { type = "sphere", center = [0.0, 0.0, 0.0], radius = 1.0 }
material = { type = "dielectric", ior = 1.5, priority = 1 }
[[objects]]
shape = { type = "box", center = [0.0, 0.0, 0.0], size = [1.2, 1.2, 1.2] }
material = { type = "dielectric", ior = 1.2 }
"#,
    );
    let mut c = Counters::default();
    for k in 1..=7 {
        for sign in [-1.0f32, 1.0] {
            let b = 1.0 - 10f32.powi(-k) * sign;
            let p = refraction_path(Tracer::new(&s), V3::new(-3.0, b, 0.0), V3::X, &[], 64, &mut c).unwrap();
            for e in &p.events {
                assert!(e.point.is_finite() && e.next_dir.is_finite() && e.n1.is_finite());
            }
            if p.escaped {
                assert!(p.final_list.is_empty(), "b = {b}: {:?}", p.final_list);
            }
        }
    }
}

#[test]
fn total_internal_reflection_inside_a_closed_solid_terminates() {
    // Camera inside a glass cube: many paths are trapped by TIR.
    let s = scene(
        r#"
ambient_ior = 1.0
[camera]
position = [0.1, 0.05, 0.2]
target = [0.4, 0.3, -1.0]
fov = 60.0
[film]
width = 12
height = 9
spp = 8
[integrator]
max_depth = 1024
rr_depth = 1000
[environment]
type = "constant"
radiance = [1.0, 1.0, 1.0]
[[objects]]
shape = { type = "box", center = [0.0, 0.0, 0.0], size = [2.0, 2.0, 2.0] }
material = { type = "dielectric", ior = 1.5 }
"#,
    );
    assert_eq!(s.camera_interior.len(), 1, "the camera is found inside the cube");
    let r = go(&s);
    assert_eq!(r.stats.counters.nan, 0);
    assert!(r.stats.counters.tir > 0, "the scene must exercise TIR");
    assert!(
        r.stats.counters.segments <= 12 * 9 * 8 * 1024,
        "depth bounds every path"
    );
    assert!(r.pixels.iter().all(|p| p.is_finite()));
}
