//! Spot lights and emitting objects end to end: the spot's irradiance on a
//! plane against the closed form (and a wrong falloff against it), bad
//! spot and emission input, and the packet path tracing the new lights'
//! paths as single rays do. (Next-event estimation of emitters against BSDF
//! sampling alone, with known-wrong densities: `src/render/light_tests.rs`.)
mod common;

use glam::{DVec3, Vec3A as V3};
use snell::counters::Counters;
use snell::dielectric::InteriorList;
use snell::integrator::{radiance, Tracer};
use snell::sampling::Rng;
use snell::scene::{load_scene_str, BuildOptions, RenderScene};
use std::path::Path;

/// A white floor (albedo 0.8) lit by one spot, direct light only.
const SPOT: &str = r#"
ambient_ior = 1.0
[camera]
position = [0.0, 3.0, 3.0]
target = [0.0, 0.0, 0.0]
fov = 40.0
[film]
width = 8
height = 8
spp = 1
[integrator]
type = "INTEGRATOR"
max_depth = 2
[[lights]]
name = "spot"
type = "spot"
position = [0.3, 2.0, -0.2]
direction = [0.2, -1.0, 0.1]
intensity = [10.0, 8.0, 6.0]
cutoff_angle = 30.0
beam_width = 20.0
[[objects]]
shape = { type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [40.0, 40.0] }
material = { type = "diffuse", reflectance = [0.8, 0.8, 0.8] }
"#;

fn load(name: &str, text: &str) -> snell::Result<RenderScene> {
    load_scene_str(name, text, Path::new("."), &BuildOptions::default())
}

/// Mitsuba 3's falloff: 1 in the beam, linear in the angle to 0 at the cutoff.
fn mitsuba(theta_deg: f64) -> f64 {
    ((30.0 - theta_deg) / (30.0 - 20.0)).clamp(0.0, 1.0)
}

/// A wrong falloff: linear in cos θ between the two angles.
fn linear_in_cos(theta_deg: f64) -> f64 {
    let c = |d: f64| d.to_radians().cos();
    ((c(theta_deg) - c(30.0)) / (c(20.0) - c(30.0))).clamp(0.0, 1.0)
}

/// A wrong falloff: pbrt's smoothstep in cos θ.
fn smoothstep_in_cos(theta_deg: f64) -> f64 {
    let t = linear_in_cos(theta_deg);
    t * t * (3.0 - 2.0 * t)
}

#[test]
fn a_spot_lights_a_plane_as_intensity_times_falloff_times_cos_over_r2() {
    let pos = DVec3::new(0.3, 2.0, -0.2);
    let axis = DVec3::new(0.2, -1.0, 0.1).normalize();
    let (t, _) = axis.any_orthonormal_pair();
    let intensity = DVec3::new(10.0, 8.0, 6.0);
    // Inside the beam, in the falloff band, and outside the cutoff; on two
    // sides of the axis.
    let angles: [f64; 9] = [0.0, 10.0, 19.5, 21.0, 25.0, 28.0, 29.7, 30.5, 40.0];
    for integrator in ["path", "whitted"] {
        let s = load("spot.toml", &SPOT.replace("INTEGRATOR", integrator)).unwrap();
        let tr = Tracer::new(&s);
        let list = InteriorList::from_solids(&s.solids, &s.camera_interior);
        let (mut band, mut lit, mut dark) = (0, 0, 0);
        for (k, &deg) in angles.iter().enumerate() {
            let side = if k % 2 == 0 { 1.0 } else { -1.0 };
            let th = deg.to_radians();
            let d = axis * th.cos() + t * (side * th.sin());
            // Where that direction from the light meets the floor (y = 0).
            let q = pos + d * (-pos.y / d.y);
            let r2 = (pos - q).length_squared();
            let cos_s = pos.y / r2.sqrt();
            let e = intensity * (mitsuba(deg) * cos_s / r2);
            let want = e * (0.8 / std::f64::consts::PI);
            // Seen straight from above the point.
            let eye = q + DVec3::new(0.05, 1.0, 0.1);
            let dir = (q - eye).normalize();
            let mut rng = Rng::new(k as u64);
            let mut st = Counters::default();
            let got = radiance(
                tr,
                eye.as_vec3a(),
                dir.as_vec3a(),
                list.clone(),
                &mut rng,
                &mut st,
            )
            .unwrap()
            .as_dvec3();
            let tol = 1e-4 * intensity.x * (0.8 / std::f64::consts::PI) * cos_s / r2;
            let err = (got - want).abs().max_element();
            eprintln!("{integrator} θ = {deg:5.1}°: {got:.6} vs {want:.6}");
            assert!(
                err <= tol,
                "{integrator} θ = {deg}°: {got} vs {want} (tolerance {tol:e})"
            );
            if deg >= 30.0 {
                assert_eq!(got, DVec3::ZERO, "{integrator}: outside the cutoff, {got}");
                dark += 1;
            } else {
                lit += 1;
            }
            // Power: in the band, both wrong falloffs miss by far more than
            // the tolerance.
            if deg > 20.0 && deg < 30.0 {
                band += 1;
                for (name, f) in [
                    ("linear in cos", linear_in_cos as fn(f64) -> f64),
                    ("smoothstep", smoothstep_in_cos),
                ] {
                    let wrong = intensity * (f(deg) * cos_s / r2) * (0.8 / std::f64::consts::PI);
                    let miss = (got - wrong).abs().max_element();
                    assert!(miss > 20.0 * tol, "no power at {deg}°: {name} {wrong} vs {got}");
                }
            }
        }
        assert!(band >= 4 && lit >= 5 && dark >= 2);
    }
}

#[test]
fn spot_targets_and_overrides_work_and_bad_spots_are_located_errors() {
    // `target` instead of `direction`: the same light.
    let by_target = SPOT
        .replace("INTEGRATOR", "path")
        .replace("direction = [0.2, -1.0, 0.1]", "target = [0.5, 1.0, -0.1]");
    let a = load("t.toml", &by_target).unwrap();
    let b = load("d.toml", &SPOT.replace("INTEGRATOR", "path")).unwrap();
    let (sa, sb) = match (&a.lights[0], &b.lights[0]) {
        (snell::scene::Light::Spot(x), snell::scene::Light::Spot(y)) => (*x, *y),
        _ => panic!("spot lights"),
    };
    assert!((sa.axis - sb.axis).length() < 1e-6, "{} vs {}", sa.axis, sb.axis);
    // `--set lights.spot.…` reaches the spot's keys and is checked as well.
    let src = || snell::scene::source::Source::new("d.toml", SPOT.replace("INTEGRATOR", "path"));
    let over = snell::overrides::apply(src(), &["lights.spot.cutoff_angle=45".into()]).unwrap();
    assert!(over.text.contains("cutoff_angle = 45"), "{}", over.text);
    snell::scene::load_scene_source(&over, Path::new("."), &BuildOptions::default()).unwrap();
    let bad = snell::overrides::apply(src(), &["lights.spot.cutoff_angle=95".into()]).unwrap();
    let e = snell::scene::load_scene_source(&bad, Path::new("."), &BuildOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("--set 'lights.spot.cutoff_angle=95'") && e.contains("(0, 90]"),
        "{e}"
    );

    // (replacement of the spot's lines, key path, words in the message)
    let base = SPOT.replace("INTEGRATOR", "path");
    let cases: &[(&str, &str, &str, &str)] = &[
        ("cutoff_angle = 30.0", "cutoff_angle = 0.0", "lights[0].cutoff_angle", "(0, 90]"),
        ("cutoff_angle = 30.0", "cutoff_angle = 90.5", "lights[0].cutoff_angle", "(0, 90]"),
        ("cutoff_angle = 30.0", "cutoff_angle = nan", "lights[0].cutoff_angle", "(0, 90]"),
        ("beam_width = 20.0", "beam_width = 31.0", "lights[0].beam_width", "must not exceed cutoff_angle"),
        ("beam_width = 20.0", "beam_width = -1.0", "lights[0].beam_width", ">= 0"),
        ("beam_width = 20.0", "beam_width = 20.0\nbeam_angle = 3.0", "lights[0]", "beam_angle"),
        ("direction = [0.2, -1.0, 0.1]", "direction = [0.0, 0.0, 0.0]", "lights[0].direction", "non-zero"),
        ("direction = [0.2, -1.0, 0.1]", "", "lights[0]", "`direction` or `target`"),
        (
            "direction = [0.2, -1.0, 0.1]",
            "direction = [0.2, -1.0, 0.1]\ntarget = [0.0, 0.0, 0.0]",
            "lights[0].target",
            "not both",
        ),
        ("direction = [0.2, -1.0, 0.1]", "target = [0.3, 2.0, -0.2]", "lights[0].target", "differ"),
        ("intensity = [10.0, 8.0, 6.0]", "intensity = [10.0, -8.0, 6.0]", "lights[0].intensity", ">= 0"),
        (
            "material = { type = \"diffuse\", reflectance = [0.8, 0.8, 0.8] }",
            "material = { type = \"diffuse\", reflectance = [0.8, 0.8, 0.8] }\nemission = { radiance = [1.0, 1.0, 1.0], two_side = true }",
            "objects[0].emission",
            "two_side",
        ),
        (
            "material = { type = \"diffuse\", reflectance = [0.8, 0.8, 0.8] }",
            "material = { type = \"diffuse\", reflectance = [0.8, 0.8, 0.8] }\nemission = { radiance = [1.0, 1.0, 1.0], two_sided = 1 }",
            "objects[0].emission.two_sided",
            "bool",
        ),
    ];
    for (from, to, key, words) in cases {
        assert!(base.contains(from), "case setup: {from}");
        let text = base.replacen(from, to, 1);
        let err = match load("bad_spot.toml", &text) {
            Ok(_) => panic!("accepted bad input: {to}"),
            Err(e) => e,
        };
        let msg = err.to_string();
        match &err {
            snell::Error::Input {
                file, key: k, line, ..
            } => {
                assert_eq!(file, "bad_spot.toml", "{msg}");
                assert!(k.starts_with(key), "key path for {to:?}: {msg}");
                assert!(*line > 1, "{msg}");
            }
            other => panic!("not an input error for {to:?}: {other}"),
        }
        assert!(msg.contains("bad_spot.toml"), "{msg}");
        assert!(msg.contains(words), "message for {to:?} lacks \"{words}\": {msg}");
    }
}

/// Emitting objects of every kind, a rect light and a spot, on a floor.
const LAMPS: &str = r#"
ambient_ior = 1.0
[camera]
position = [0.0, 2.2, 3.2]
target = [0.0, 0.4, 0.0]
fov = 50.0
[film]
width = 32
height = 24
spp = 1
[integrator]
max_depth = 4
[[lights]]
type = "spot"
position = [-1.0, 2.0, 1.0]
target = [0.0, 0.0, 0.0]
intensity = [5.0, 5.0, 5.0]
cutoff_angle = 35.0
[[lights]]
type = "rect"
center = [1.0, 1.5, -0.5]
normal = [0.0, -1.0, 0.0]
u_axis = [1.0, 0.0, 0.0]
size = [0.5, 0.5]
radiance = [3.0, 3.0, 3.0]
[[objects]]
shape = { type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [6.0, 6.0] }
material = { type = "diffuse", reflectance = [0.6, 0.6, 0.6] }
[[objects]]
shape = { type = "rect", center = [0.0, 1.2, 0.0], normal = [0.0, -1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [0.8, 0.8] }
material = { type = "black" }
emission = { radiance = [6.0, 5.0, 4.0], two_sided = true }
transform = [{ scale = [1.5, 1.0, 0.5] }]
[[objects]]
shape = { type = "sphere", center = [-0.8, 0.4, 0.0], radius = 0.3 }
material = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }
emission = { radiance = [2.0, 1.0, 0.5] }
[[objects]]
shape = { type = "cylinder", p0 = [0.8, 0.0, 0.5], p1 = [0.8, 0.6, 0.5], radius = 0.2, caps = true }
material = { type = "diffuse", reflectance = [0.4, 0.5, 0.6] }
emission = { radiance = [1.0, 2.0, 1.0] }
[[objects]]
shape = { type = "box", center = [0.0, 0.25, 0.8], size = [0.5, 0.5, 0.5] }
material = { type = "mirror" }
"#;

/// The path tracer's packets (eight paths side by side) give every path the
/// radiance of the same path traced alone, bit for bit, with emitting
/// objects and a spot among the lights: in the reference mode (scalar
/// shading, the analytic shapes' queries in f64), which is what this
/// compares.
#[test]
fn packet_lanes_trace_the_new_lights_as_single_rays_do() {
    use snell::embree::Packet8;
    use snell::integrator::Scheduler;
    let s = load("lamps.toml", LAMPS).unwrap();
    assert_eq!(s.lights.len(), 5, "spot, rect and three emitting objects");
    let tr = Tracer::new(&s);
    assert!(matches!(
        Scheduler::of(tr, Default::default()),
        Scheduler::Wavefront(_)
    ));
    let list = InteriorList::from_solids(&s.solids, &s.camera_interior);
    let (mut lit, mut differs) = (0, 0);
    for pixel in 0..32 * 24u64 {
        let (x, y) = ((pixel % 32) as f32, (pixel / 32) as f32);
        let rngs_at =
            |first: u64| -> [Rng; 8] { std::array::from_fn(|i| Rng::for_sample(5, pixel, first + i as u64)) };
        let mut rngs = rngs_at(0);
        let cams: Vec<(V3, V3)> = rngs
            .iter_mut()
            .map(|r| s.camera.ray(x + r.uniform(), y + r.uniform(), (0.5, 0.5)))
            .collect();
        let mut scalar = rngs.clone();
        let mut sts = [Counters::default(); 8];
        let lanes =
            common::wavefront_paths::<8, Packet8>(tr, &cams, &list, &rngs, &mut sts, &mut Default::default());
        for i in 0..8 {
            let mut st = Counters::default();
            let l = radiance(tr, cams[i].0, cams[i].1, list.clone(), &mut scalar[i], &mut st).unwrap();
            assert_eq!(
                l.to_array().map(f32::to_bits),
                lanes[i].to_array().map(f32::to_bits),
                "pixel {pixel} lane {i}"
            );
            lit += (l.max_element() > 0.0) as u32;
        }
        let other = rngs_at(8);
        let mut sts2 = [Counters::default(); 8];
        let shifted = common::wavefront_paths::<8, Packet8>(
            tr,
            &cams,
            &list,
            &other,
            &mut sts2,
            &mut Default::default(),
        );
        differs += (shifted != lanes) as u32;
    }
    assert!(lit > 2000, "{lit} lit paths");
    assert!(differs > 500, "other numbers, other paths: {differs}");
}
