//! Emitting objects as lights: next-event estimation with MIS against BSDF
//! sampling alone (which finds emitters only by hitting them, and so needs
//! no density of the light), with known-wrong densities for the tests'
//! power; and emitting objects against the `rect` and `sphere` lights of the
//! same size and radiance. Images are compared by 16×16 block means against
//! the seed-to-seed noise of the two renders (`sun_tests::ratio`: about 1
//! when both are unbiased). Environment maps as lights: irradiance by
//! NEE+MIS against BSDF sampling alone, and the variance it saves.
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
pub(super) const SCALED_QUAD: &str = r#"
[[objects]]
name = "lamp"
shape = { type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0], u_axis = [1.0, 0.0, 0.0], size = [1.0, 1.0] }
material = { type = "black" }
emission = { radiance = { type = "checker", axes = ["x", "y"], size = 0.2, color0 = [8.0, 8.0, 8.0], color1 = [1.0, 2.0, 4.0] }, two_sided = true }
transform = [{ scale = [1.2, 0.4, 1.0] }, { rotate = { axis = [1.0, 0.0, 0.0], degrees = -30.0 } }, { translate = [0.2, 0.9, 0.0] }]
"#;

/// Analytic emitters sampled by area: a capped cylinder (wall and caps)
/// lying on the floor, and a tilted disk that also reflects.
pub(super) const ANALYTIC: &str = r#"
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

pub(super) fn room(emitters: &str) -> RenderScene {
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

/// A 64×32 lat-long EXR, dim blue-grey with a bright patch of texels
/// `cols` × `rows` of radiance `bright`, written to a folder of its own;
/// the folder.
fn env_map_dir(
    tag: &str,
    cols: std::ops::Range<u32>,
    rows: std::ops::Range<u32>,
    bright: glam::Vec3A,
) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("snell-env-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    let (w, h) = (64u32, 32u32);
    let px: Vec<glam::Vec3A> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            if cols.contains(&x) && rows.contains(&y) {
                bright
            } else {
                glam::Vec3A::new(0.2, 0.25, 0.3) * (1.0 + 0.5 * (x as f32 * 0.3).sin())
            }
        })
        .collect();
    let exr = crate::image_io::encode_exr(w, h, &px, &[], &[]).expect("encode");
    std::fs::write(dir.join("spot.exr"), exr).expect("write map");
    dir
}

/// `text` loaded from `dir` (where its map is).
fn load_in(dir: &Path, text: &str) -> RenderScene {
    load_scene_str("env.toml", text, dir, &BuildOptions::default()).expect("scene loads")
}

/// The environment map's sampler of `s`: `None` turns its next-event
/// estimation off (BSDF sampling alone finds the map, as before it was sampled).
fn map_sampler(s: &mut RenderScene) -> &mut Option<std::sync::Arc<crate::scene::envmap::EnvSampler>> {
    match &mut s.environment {
        crate::scene::Environment::Map { sampler, .. } => sampler,
        _ => unreachable!("a map scene"),
    }
}

/// The image's mean (over pixels and channels) and its standard error from
/// the per-pixel spread.
pub(super) fn mean_and_error(r: &Rendered) -> (f64, f64) {
    let v: Vec<f64> = r
        .pixels
        .iter()
        .map(|p| ((p.x + p.y + p.z) / 3.0) as f64)
        .collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

#[test]
fn irradiance_under_a_map_by_nee_and_mis_matches_bsdf_sampling_alone_and_a_pdf_without_sin_does_not() {
    // A white plane under the map, direct light only (two segments), every
    // pixel an estimate of the same irradiance; the map turned so that its
    // spot is not where it would be unturned.
    // A 2×2 spot around polar angle 31° (sin θ ≈ 0.5: a density without
    // its 1/sin θ is off by 2 there).
    let dir = env_map_dir("irradiance", 20..22, 5..7, glam::Vec3A::new(900.0, 800.0, 600.0));
    let text = r#"
[camera]
position = [0.0, 2.0, 1.0]
target = [0.0, 0.0, 0.0]
fov = 30.0
[film]
width = 64
height = 64
spp = 16
[integrator]
max_depth = 2
[environment]
type = "map"
file = "spot.exr"
rows = "ROWS"
to_world = [{ rotate = { axis = [0.3, 1.0, 0.2], degrees = 40.0 } }]
[[objects]]
shape = { type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [200.0, 200.0] }
material = { type = "diffuse", reflectance = [1.0, 1.0, 1.0] }
"#;
    for rows in ["centres", "poles"] {
        let mut s = load_in(&dir, &text.replace("ROWS", rows));
        assert_eq!(s.nee_count(), 1, "the map is next-event estimation's one choice");
        let bsdf = mean_and_error(&render_at(&s, 1, LightSampling::Bsdf));
        let mis = mean_and_error(&render_at(&s, 2, LightSampling::Mis));
        let sampler = map_sampler(&mut s).as_mut().expect("sampled");
        std::sync::Arc::get_mut(sampler).expect("one owner").sampling =
            crate::scene::envmap::EnvSampling::WrongNoSinJacobian;
        let wrong = mean_and_error(&render_at(&s, 2, LightSampling::Mis));
        let z = |a: (f64, f64), b: (f64, f64)| (a.0 - b.0).abs() / (a.1 * a.1 + b.1 * b.1).sqrt();
        let (z_mis, z_wrong) = (z(mis, bsdf), z(wrong, bsdf));
        eprintln!(
            "{rows}: bsdf {:.4} ± {:.4}, nee+mis {:.4} ± {:.4} (z {z_mis:.2}), \
             without 1/sin θ {:.4} ± {:.4} (z {z_wrong:.1})",
            bsdf.0, bsdf.1, mis.0, mis.1, wrong.0, wrong.1
        );
        // Four standard errors of the difference: a false alarm 1 in 16 000.
        assert!(z_mis < 4.0, "{rows}: NEE+MIS vs BSDF alone: z = {z_mis}");
        assert!(
            z_wrong > 4.0,
            "{rows}: no power: the pdf without 1/sin θ passes (z = {z_wrong})"
        );
        // NEE must carry the spot (else MIS would be BSDF sampling alone).
        assert!(
            mis.1 < 0.5 * bsdf.1,
            "{rows}: NEE does not carry the map: {mis:?} vs {bsdf:?}"
        );
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// The median over pixels of the per-pixel variance across `seeds` renders.
fn median_pixel_variance(s: &RenderScene, seeds: std::ops::Range<u64>) -> f64 {
    let renders: Vec<Rendered> = seeds.map(|k| render_at(s, k, LightSampling::Mis)).collect();
    let k = renders.len() as f64;
    let mut var: Vec<f64> = (0..renders[0].pixels.len())
        .map(|i| {
            let v: Vec<f64> = renders
                .iter()
                .map(|r| {
                    let p = r.pixels[i];
                    ((p.x + p.y + p.z) / 3.0) as f64
                })
                .collect();
            let m = v.iter().sum::<f64>() / k;
            v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (k - 1.0)
        })
        .collect();
    var.sort_by(f64::total_cmp);
    var[var.len() / 2]
}

#[test]
fn sampling_the_map_at_least_halves_the_pixel_variance_of_a_diffuse_scene() {
    // A diffuse ball on a plane under the map, every pixel on a surface.
    // The patch (10×6 texels, ~0.3 sr) is one BSDF sampling finds often
    // enough (~5 % of bounces) that a pixel's variance over 8 seeds is
    // measured, not hidden in rare fireflies, as it is for a tiny spot.
    let dir = env_map_dir("variance", 16..26, 3..9, glam::Vec3A::new(40.0, 36.0, 30.0));
    let text = r#"
[camera]
position = [0.0, 3.0, 3.0]
target = [0.0, 0.3, 0.0]
fov = 45.0
[film]
width = 48
height = 48
spp = 16
[integrator]
max_depth = 4
[environment]
type = "map"
file = "spot.exr"
[[objects]]
shape = { type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [200.0, 200.0] }
material = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }
[[objects]]
shape = { type = "sphere", center = [0.0, 0.6, 0.0], radius = 0.6 }
material = { type = "diffuse", reflectance = [0.7, 0.6, 0.5] }
"#;
    let mut s = load_in(&dir, text);
    let sampled = median_pixel_variance(&s, 1..9);
    *map_sampler(&mut s) = None;
    let bsdf_only = median_pixel_variance(&s, 1..9);
    eprintln!(
        "median per-pixel variance over 8 seeds, 16 spp: map sampled {sampled:.4e}, BSDF sampling alone \
         {bsdf_only:.4e} (÷{:.1})",
        bsdf_only / sampled
    );
    assert!(bsdf_only >= 2.0 * sampled, "{sampled} vs {bsdf_only}");
    let _ = std::fs::remove_dir_all(&dir);
}
