//! Emitting objects as lights: next-event estimation with MIS against BSDF
//! sampling alone (which finds emitters only by hitting them, and so needs
//! no density of the light), with known-wrong densities for the tests'
//! power; and emitting objects against the `rect` and `sphere` lights of the
//! same size and radiance. Images are compared by 16×16 block means against
//! the seed-to-seed noise of the two renders (`sun_tests::ratio`: about 1
//! when both are unbiased).
use super::sun_tests::{blocks, ratio, rms};
use crate::integrator::LightSampling;
use crate::render::{render, RenderOptions, RenderSettings, Rendered};
use crate::scene::emitter::EmitterSampling;
use crate::scene::{load_scene_str, BuildOptions, Light, RenderScene};
use std::path::Path;

/// A floor and a back wall, both diffuse; `EMITTERS` is replaced by the
/// lights under test. Three segments: MIS works at the second bounce too.
const ROOM: &str = r#"
ambient_ior = 1.0
[camera]
position = [0.0, 2.2, 3.2]
target = [0.0, 0.4, 0.0]
fov = 50.0
[film]
width = 128
height = 128
spp = 32
[integrator]
max_depth = 3
[[objects]]
name = "floor"
shape = { type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [6.0, 6.0] }
material = { type = "diffuse", reflectance = [0.6, 0.6, 0.6] }
[[objects]]
name = "wall"
shape = { type = "rect", center = [0.0, 1.5, -1.5], normal = [0.0, 0.0, 1.0], u_axis = [1.0, 0.0, 0.0], size = [6.0, 3.0] }
material = { type = "diffuse", reflectance = [0.5, 0.4, 0.3] }
EMITTERS
"#;

/// A black quad (a `rect` shape: two triangles) facing down onto the floor.
const QUAD: &str = r#"
[[objects]]
name = "lamp"
shape = { type = "rect", center = [0.0, 1.2, 0.0], normal = [0.0, -1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [0.8, 0.8] }
material = { type = "black" }
emission = { radiance = [6.0, 5.0, 4.0] }
"#;

/// The `rect` light of the same size, place and radiance as [`QUAD`].
const RECT_LIGHT: &str = r#"
[[lights]]
type = "rect"
center = [0.0, 1.2, 0.0]
normal = [0.0, -1.0, 0.0]
u_axis = [1.0, 0.0, 0.0]
size = [0.8, 0.8]
radiance = [6.0, 5.0, 4.0]
"#;

/// A unit quad scaled non-uniformly (1.2 × 0.4: world area 0.48) and
/// tilted 30° about x, emitting a checker from both sides: its front
/// lights the floor before it and the camera, its back the floor behind it
/// and the wall.
const SCALED_QUAD: &str = r#"
[[objects]]
name = "lamp"
shape = { type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0], u_axis = [1.0, 0.0, 0.0], size = [1.0, 1.0] }
material = { type = "black" }
emission = { radiance = { type = "checker", axes = ["x", "y"], size = 0.2, color0 = [8.0, 8.0, 8.0], color1 = [1.0, 2.0, 4.0] }, two_sided = true }
transform = [{ scale = [1.2, 0.4, 1.0] }, { rotate = { axis = [1.0, 0.0, 0.0], degrees = -30.0 } }, { translate = [0.2, 0.9, 0.0] }]
"#;

/// Analytic emitters sampled by area: a capped cylinder (wall and caps)
/// lying on the floor, and a tilted disk that also reflects.
const ANALYTIC: &str = r#"
[[objects]]
name = "tube_lamp"
shape = { type = "cylinder", p0 = [-0.8, 0.3, 0.4], p1 = [-0.8, 0.3, -0.6], radius = 0.15, caps = true }
material = { type = "black" }
emission = { radiance = [4.0, 3.0, 2.0] }
[[objects]]
name = "disk_lamp"
shape = { type = "disk", center = [0.7, 1.0, 0.0], normal = [-0.3, -1.0, 0.2], radius = 0.35 }
material = { type = "diffuse", reflectance = [0.3, 0.3, 0.3] }
emission = { radiance = [3.0, 4.0, 6.0] }
"#;

/// An emitting analytic sphere.
const SPHERE: &str = r#"
[[objects]]
name = "ball"
shape = { type = "sphere", center = [0.0, 0.9, 0.0], radius = 0.25 }
material = { type = "black" }
emission = { radiance = [8.0, 7.0, 6.0] }
"#;

/// A two-sided emitting sphere around the room (a dome), and the quad.
const DOME: &str = r#"
[[objects]]
name = "dome"
shape = { type = "sphere", center = [0.0, 0.0, 0.0], radius = 8.0 }
material = { type = "black" }
emission = { radiance = [0.3, 0.4, 0.5], two_sided = true }
[[objects]]
name = "lamp"
shape = { type = "rect", center = [0.0, 1.2, 0.0], normal = [0.0, -1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [0.8, 0.8] }
material = { type = "black" }
emission = { radiance = [6.0, 5.0, 4.0] }
"#;

/// The `sphere` light of the same size, place and radiance as [`SPHERE`].
const SPHERE_LIGHT: &str = r#"
[[lights]]
type = "sphere"
center = [0.0, 0.9, 0.0]
radius = 0.25
radiance = [8.0, 7.0, 6.0]
"#;

fn room(emitters: &str) -> RenderScene {
    let text = ROOM.replace("EMITTERS", emitters);
    load_scene_str("lights.toml", &text, Path::new("."), &BuildOptions::default()).expect("scene loads")
}

/// Every emitting object's densities.
fn set_sampling(s: &mut RenderScene, sampling: EmitterSampling) {
    for l in &mut s.lights {
        if let Light::Emitter(e) = l {
            e.sampling = sampling;
        }
    }
}

/// The render of `s` at `seed` (two threads, no AOVs).
pub(super) fn render_at(s: &RenderScene, seed: u64, light_sampling: LightSampling) -> Rendered {
    let opts = RenderOptions {
        threads: Some(2),
        want_aovs: false,
        ..Default::default()
    };
    let set = RenderSettings::from_scene(s)
        .with_seed(seed)
        .with_light_sampling(light_sampling);
    render(s, &set, &opts).expect("render")
}

/// Block means of the renders of `s` at seeds 1 and 2.
pub(super) fn run(s: &RenderScene, light_sampling: LightSampling) -> [Vec<f64>; 2] {
    [1, 2].map(|seed| blocks(&render_at(s, seed, light_sampling)))
}

pub(super) fn pair(x: &[Vec<f64>; 2]) -> [&[f64]; 2] {
    [&x[0], &x[1]]
}

/// The threshold of `sun_tests`: a ratio of RMS over 64 blocks has a
/// spread of ~9 % when both images are unbiased, so 1.3 is over 3 spreads.
pub(super) const LIMIT: f64 = 1.3;

#[test]
fn an_emitting_quad_by_nee_and_mis_matches_bsdf_sampling_alone_and_wrong_densities_do_not() {
    let t = std::time::Instant::now();
    let mut s = room(QUAD);
    assert_eq!(s.lights.len(), 1, "the emitting quad is a light");
    let bsdf = run(&s, LightSampling::Bsdf);
    let mis = run(&s, LightSampling::Mis);
    set_sampling(&mut s, EmitterSampling::WrongAreaPdf);
    let area_pdf = run(&s, LightSampling::Mis);
    set_sampling(&mut s, EmitterSampling::WrongUnweightedHit);
    let unweighted = run(&s, LightSampling::Mis);
    let b = pair(&bsdf);
    let (r_mis, r_area, r_hit) = (
        ratio(pair(&mis), b),
        ratio(pair(&area_pdf), b),
        ratio(pair(&unweighted), b),
    );
    let (n_mis, n_bsdf) = (rms(&mis[0], &mis[1]), rms(b[0], b[1]));
    eprintln!(
        "quad: block-mean RMS / noise RMS: mis {r_mis:.3}, area pdf without d²/cos {r_area:.3}, \
         unweighted hits {r_hit:.3}; seed-to-seed RMS mis {n_mis:.4}, bsdf {n_bsdf:.4}; {:.1} s",
        t.elapsed().as_secs_f64()
    );
    assert!(r_mis <= LIMIT, "NEE+MIS vs BSDF alone: {r_mis}");
    assert!(
        r_area > LIMIT,
        "no power: the area pdf without d²/cos passes ({r_area})"
    );
    assert!(r_hit > LIMIT, "no power: double counting passes ({r_hit})");
    // Next-event estimation must carry the light (else MIS would be BSDF
    // sampling alone, and pass trivially).
    assert!(
        n_mis < 0.5 * n_bsdf,
        "NEE does not carry the quad: {n_mis} vs {n_bsdf}"
    );
}

#[test]
fn a_scaled_two_sided_textured_quad_by_nee_and_mis_matches_bsdf_sampling_alone() {
    let t = std::time::Instant::now();
    let mut s = room(SCALED_QUAD);
    let bsdf = run(&s, LightSampling::Bsdf);
    let mis = run(&s, LightSampling::Mis);
    // Power: the same wrong area density (here also wrong by the scale's
    // change of area, were it taken from the unit quad).
    set_sampling(&mut s, EmitterSampling::WrongAreaPdf);
    let area_pdf = run(&s, LightSampling::Mis);
    let b = pair(&bsdf);
    let (r_mis, r_area) = (ratio(pair(&mis), b), ratio(pair(&area_pdf), b));
    let (n_mis, n_bsdf) = (rms(&mis[0], &mis[1]), rms(b[0], b[1]));
    eprintln!(
        "scaled two-sided quad: block-mean RMS / noise RMS: mis {r_mis:.3}, area pdf {r_area:.3}; \
         seed-to-seed RMS mis {n_mis:.4}, bsdf {n_bsdf:.4}; {:.1} s",
        t.elapsed().as_secs_f64()
    );
    assert!(r_mis <= LIMIT, "NEE+MIS vs BSDF alone: {r_mis}");
    assert!(r_area > LIMIT, "no power: {r_area}");
    // Less of a gain than for the plain quad: the camera sees the checker
    // itself, whose edges are as noisy either way.
    assert!(
        n_mis < 0.75 * n_bsdf,
        "NEE does not carry the quad: {n_mis} vs {n_bsdf}"
    );
}

#[test]
fn analytic_emitters_by_area_match_bsdf_sampling_alone() {
    let t = std::time::Instant::now();
    let s = room(ANALYTIC);
    assert_eq!(s.lights.len(), 2);
    let bsdf = run(&s, LightSampling::Bsdf);
    let mis = run(&s, LightSampling::Mis);
    let b = pair(&bsdf);
    let r = ratio(pair(&mis), b);
    let (n_mis, n_bsdf) = (rms(&mis[0], &mis[1]), rms(b[0], b[1]));
    eprintln!(
        "cylinder and disk: block-mean RMS / noise RMS: mis {r:.3}; seed-to-seed RMS mis {n_mis:.4}, \
         bsdf {n_bsdf:.4}; {:.1} s",
        t.elapsed().as_secs_f64()
    );
    assert!(r <= LIMIT, "NEE+MIS vs BSDF alone: {r}");
    // (The camera sees the emitters, and the disk reflects: less of a gain.)
    assert!(
        n_mis < 0.75 * n_bsdf,
        "NEE does not carry the emitters: {n_mis} vs {n_bsdf}"
    );
}

#[test]
fn a_two_sided_dome_around_the_scene_by_area_from_inside_matches_bsdf_sampling_alone() {
    let mut s = room(DOME);
    assert_eq!(s.lights.len(), 2);
    let bsdf = run(&s, LightSampling::Bsdf);
    let mis = run(&s, LightSampling::Mis);
    set_sampling(&mut s, EmitterSampling::WrongAreaPdf);
    let area_pdf = run(&s, LightSampling::Mis);
    let b = pair(&bsdf);
    let (r, r_area) = (ratio(pair(&mis), b), ratio(pair(&area_pdf), b));
    eprintln!("dome and quad: block-mean RMS / noise RMS: mis {r:.3}, area pdf {r_area:.3}");
    assert!(r <= LIMIT, "NEE+MIS vs BSDF alone: {r}");
    assert!(r_area > LIMIT, "no power: {r_area}");
}

#[test]
fn emitting_objects_match_the_rect_and_sphere_lights_of_the_same_size_and_radiance() {
    let t = std::time::Instant::now();
    for (name, object, light) in [("quad", QUAD, RECT_LIGHT), ("sphere", SPHERE, SPHERE_LIGHT)] {
        let obj = run(&room(object), LightSampling::Mis);
        let lit = run(&room(light), LightSampling::Mis);
        // (The sphere's images are the same bit for bit: its sampling is
        // the light's, and it draws the same numbers.)
        let r = ratio(pair(&obj), pair(&lit));
        let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
        eprintln!(
            "{name}: object vs light: block-mean RMS / noise RMS {r:.3}; image means {:.4} vs {:.4}",
            mean(&obj[0]),
            mean(&lit[0])
        );
        assert!(
            r <= LIMIT,
            "{name}: the emitting object differs from the light: {r}"
        );
        // Power: the light 5 % brighter must fail.
        let brighter = light
            .replace("[6.0, 5.0, 4.0]", "[6.3, 5.25, 4.2]")
            .replace("[8.0, 7.0, 6.0]", "[8.4, 7.35, 6.3]");
        let hot = run(&room(&brighter), LightSampling::Mis);
        let r_hot = ratio(pair(&obj), pair(&hot));
        eprintln!("{name}: against the light at 1.05× radiance: {r_hot:.3}");
        assert!(r_hot > LIMIT, "{name}: no power ({r_hot})");
    }
    eprintln!("{:.1} s", t.elapsed().as_secs_f64());
}

#[test]
fn whitted_takes_one_sample_of_each_emitting_object_as_of_each_light() {
    // A diffuse room lit by the quad alone: Whitted (emission and one
    // sample of each light at a diffuse hit) and the path tracer at two
    // segments (emission and direct light) estimate the same image.
    let two = ROOM.replace("max_depth = 3", "max_depth = 2");
    let load = |text: &str| {
        load_scene_str(
            "lights.toml",
            &text.replace("EMITTERS", QUAD),
            Path::new("."),
            &BuildOptions::default(),
        )
        .expect("scene loads")
    };
    let path = load(&two);
    let whitted = load(&two.replace("[integrator]\n", "[integrator]\ntype = \"whitted\"\n"));
    let p = run(&path, LightSampling::Mis);
    let w = run(&whitted, LightSampling::Mis);
    // Power: Whitted without the emitter's samples sees the quad alone.
    let dark = run(&whitted, LightSampling::Bsdf);
    let (r, r_dark) = (ratio(pair(&w), pair(&p)), ratio(pair(&dark), pair(&p)));
    eprintln!("whitted vs path (direct light): {r:.3}; whitted without light samples: {r_dark:.3}");
    assert!(r <= LIMIT, "Whitted vs the path tracer: {r}");
    assert!(r_dark > LIMIT, "no power: {r_dark}");
}
