//! Renders under a sky with a sun: next-event estimation of the disk against
//! the exact irradiance and against BSDF sampling alone (here, above the
//! scene layer, because they render).
use crate::render::{render, RenderOptions, RenderSettings, Rendered};
use crate::scene::sun::{SunSampling, SUN_DIAMETER_DEG};
use crate::scene::{load_scene_str, BuildOptions, Environment, RenderScene};
use glam::DVec3;
use std::f64::consts::PI;
use std::path::Path;

/// A ground plane, a diffuse ball on it casting a shadow, under a sky.
const SCENE: &str = r#"
ambient_ior = 1.0
[camera]
position = [0.0, 4.0, 3.0]
target = [0.3, 0.0, 0.0]
fov = 50.0
[film]
width = WIDTH
height = HEIGHT
spp = SPP
[integrator]
max_depth = DEPTH
[environment]
type = "sky"
sun_direction = [0.6, 0.7, 0.3]
sun_diameter = DIAMETER
sun_irradiance = [3.0, 2.7, 2.4]
zenith = [0.1, 0.15, 0.3]
horizon = [0.3, 0.3, 0.3]
ground = [0.05, 0.05, 0.05]
[[objects]]
shape = { type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [40.0, 40.0] }
material = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }
[[objects]]
shape = { type = "sphere", center = [0.0, 0.6, 0.0], radius = 0.6 }
material = { type = "diffuse", reflectance = [0.7, 0.6, 0.5] }
"#;

fn scene(w: u32, h: u32, spp: u32, depth: u32, diameter: f64) -> RenderScene {
    let text = SCENE
        .replace("WIDTH", &w.to_string())
        .replace("HEIGHT", &h.to_string())
        .replace("SPP", &spp.to_string())
        .replace("DEPTH", &depth.to_string())
        .replace("DIAMETER", &diameter.to_string());
    load_scene_str("sun.toml", &text, Path::new("."), &BuildOptions::default()).expect("scene loads")
}

fn set_sampling(s: &mut RenderScene, sampling: SunSampling) {
    match &mut s.environment {
        Environment::Sky(sky) => sky.sun.sampling = sampling,
        _ => unreachable!("a sky scene"),
    }
}

fn go(s: &RenderScene, seed: u64) -> Rendered {
    let opts = RenderOptions {
        threads: Some(2),
        want_aovs: false,
        ..Default::default()
    };
    render(s, &RenderSettings::from_scene(s).with_seed(seed), &opts).expect("render")
}

#[test]
fn a_plane_under_the_real_sun_is_lit_as_the_formula_says() {
    // Nothing but the plane in view, no sky, direct light only: with NEE the
    // real sun's disk (14 700 /sr) is sampled; the exact irradiance is
    // E cos θ_s (1 + cos α)/2, cos θ_s = 0.7 / |(0.6, 0.7, 0.3)|.
    let text = SCENE
        .replace("WIDTH", "16")
        .replace("HEIGHT", "16")
        .replace("SPP", "4")
        .replace("DEPTH", "2")
        .replace("DIAMETER", "0.53")
        .replace("target = [0.3, 0.0, 0.0]", "target = [-3.0, 0.0, -3.0]")
        .replace("fov = 50.0", "fov = 10.0")
        .replace("zenith = [0.1, 0.15, 0.3]", "")
        .replace("horizon = [0.3, 0.3, 0.3]", "");
    let s = load_scene_str("sun.toml", &text, Path::new("."), &BuildOptions::default()).unwrap();
    let r = go(&s, 1);
    let cos_s = 0.7 / (0.36f64 + 0.49 + 0.09).sqrt();
    let a = 0.5 * SUN_DIAMETER_DEG.to_radians();
    let want = DVec3::new(3.0, 2.7, 2.4) * (0.5 / PI * cos_s * 0.5 * (1.0 + a.cos()));
    // cos θ varies by ~α tan θ_s = 4·10⁻³ across the disk: pixels of 4
    // samples spread ~10⁻³, the image mean of 1024 ~10⁻⁴.
    let mut mean = DVec3::ZERO;
    for p in &r.pixels {
        let rel = ((p.as_dvec3() - want) / want).abs().max_element();
        assert!(rel < 1e-2, "{p} vs {want}");
        mean += p.as_dvec3() / r.pixels.len() as f64;
    }
    let rel = ((mean - want) / want).abs().max_element();
    assert!(rel < 5e-4, "mean {mean} vs {want}: {rel}");
    // Power: BSDF sampling alone almost never finds the disk at 4 spp.
    let mut s = s;
    set_sampling(&mut s, SunSampling::BsdfOnly);
    let r = go(&s, 1);
    let mean = r.pixels.iter().map(|p| p.x as f64).sum::<f64>() / r.pixels.len() as f64;
    assert!(
        (mean - want.x).abs() > 0.5 * want.x,
        "BSDF alone, 4 spp: {mean} vs {}",
        want.x
    );
}

/// Per 16×16 block, the mean of the channels' sum.
pub(super) fn blocks(r: &Rendered) -> Vec<f64> {
    let (w, h) = (r.width as usize, r.height as usize);
    let mut out = Vec::new();
    for by in 0..h / 16 {
        for bx in 0..w / 16 {
            let mut s = 0.0;
            for y in by * 16..by * 16 + 16 {
                for x in bx * 16..bx * 16 + 16 {
                    let p = r.pixels[y * w + x];
                    s += (p.x + p.y + p.z) as f64;
                }
            }
            out.push(s / 256.0);
        }
    }
    out
}

pub(super) fn rms(a: &[f64], b: &[f64]) -> f64 {
    (a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
}

/// The RMS of the difference of the two methods' block means (each the
/// mean of two seeds), over the noise RMS that difference would have from
/// noise alone: seed-to-seed RMS² per method estimates twice its variance,
/// so (RMS²(a₁−a₂) + RMS²(b₁−b₂))/4 is the variance of the difference of
/// the two-seed means. About 1 when both are unbiased.
pub(super) fn ratio(a: [&[f64]; 2], b: [&[f64]; 2]) -> f64 {
    let mean = |x: [&[f64]; 2]| {
        x[0].iter()
            .zip(x[1])
            .map(|(p, q)| 0.5 * (p + q))
            .collect::<Vec<_>>()
    };
    let noise = ((rms(a[0], a[1]).powi(2) + rms(b[0], b[1]).powi(2)) / 4.0).sqrt();
    rms(&mean(a), &mean(b)) / noise
}

#[test]
fn sun_nee_with_mis_matches_bsdf_sampling_alone_and_wrong_variants_do_not() {
    // A 16° sun: BSDF sampling alone finds it often enough to converge at
    // 64 spp; three segments, so MIS also works at the second bounce.
    let mut s = scene(128, 128, 64, 3, 16.0);
    let seeds = [1, 2];
    let run = |s: &RenderScene| seeds.map(|k| blocks(&go(s, k)));
    set_sampling(&mut s, SunSampling::BsdfOnly);
    let bsdf = run(&s);
    let b = [&bsdf[0][..], &bsdf[1][..]];
    let mut results = Vec::new();
    for (name, sampling) in [
        ("mis", SunSampling::Mis),
        ("wide pdf", SunSampling::WrongWidePdf),
        ("unweighted escape", SunSampling::WrongUnweightedEscape),
    ] {
        set_sampling(&mut s, sampling);
        let x = run(&s);
        results.push((name, ratio([&x[0], &x[1]], b)));
    }
    eprintln!("block-mean RMS / noise RMS: {results:?}");
    assert!(results[0].1 <= 1.3, "NEE+MIS vs BSDF alone: {results:?}");
    for (name, r) in &results[1..] {
        assert!(*r > 1.3, "no power: {name} passes ({results:?})");
    }
}

/// A box on a diffuse ground in a strong inferior mirage (hot ground: n
/// rises from 1.0 on the ground to 1.05 at 3 m, so a ray climbing from the
/// ground bends upward), under an 8° sun 25° high. From the ground the
/// disk's light arrives 7° lower than the sun stands (cos θ₀ =
/// n_t cos θ_e / n₀ = 1.05 cos 25°): more than the disk's 4° radius.
const MIRAGE: &str = r#"
ambient_ior = 1.05
[camera]
position = [0.0, 3.5, 2.5]
target = [0.0, 0.3, -1.0]
fov = 40.0
[film]
width = 128
height = 128
spp = SPP
[integrator]
max_depth = 3
[environment]
type = "sky"
sun_direction = [-0.6, 0.43, -0.7]
sun_diameter = 8.0
sun_irradiance = [3.0, 2.7, 2.4]
zenith = [0.05, 0.07, 0.12]
horizon = [0.1, 0.1, 0.1]
ground = [0.02, 0.02, 0.02]
[medium]
field = { kind = "hot_ground", n_inf = 1.05, dn = 0.05, h0 = 0.5 }
bounds = { min = [-20.0, -1.0, -20.0], max = [20.0, 3.0, 20.0] }
[[objects]]
shape = { type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [40.0, 40.0] }
material = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }
[[objects]]
shape = { type = "box", center = [0.0, 0.5, -1.0], size = [1.0, 1.0, 1.0] }
material = { type = "diffuse", reflectance = [0.7, 0.6, 0.5] }
"#;

#[test]
fn sun_nee_through_a_mirage_matches_bsdf_sampling_alone_and_a_straight_launch_does_not() {
    let text = MIRAGE.replace("SPP", "64");
    let mut s = load_scene_str("mirage_sun.toml", &text, Path::new("."), &BuildOptions::default()).unwrap();
    let seeds = [1, 2];
    let t = std::time::Instant::now();
    // BSDF sampling finds the 8° disk (through the launch's 1.5× wider cone,
    // at a cosine ≈ 0.3) in ~0.2 % of samples: 4× the samples halve its noise.
    let run = |s: &RenderScene, spp: u32| {
        seeds.map(|k| {
            let opts = RenderOptions {
                threads: Some(2),
                want_aovs: false,
                ..Default::default()
            };
            let set = RenderSettings::from_scene(s).with_seed(k).with_spp(spp);
            blocks(&render(s, &set, &opts).expect("render"))
        })
    };
    set_sampling(&mut s, SunSampling::BsdfOnly);
    let bsdf = run(&s, 256);
    let b = [&bsdf[0][..], &bsdf[1][..]];
    set_sampling(&mut s, SunSampling::Mis);
    let mis = run(&s, 64);
    set_sampling(&mut s, SunSampling::WrongStraightLaunch);
    let straight = run(&s, 64);
    let r_mis = ratio([&mis[0], &mis[1]], b);
    let r_straight = ratio([&straight[0], &straight[1]], b);
    // Seed-to-seed RMS: next-event estimation through the medium must
    // actually carry the sun (with none, Mis would be BsdfOnly's estimator).
    let (n_mis, n_bsdf) = (rms(&mis[0], &mis[1]), rms(b[0], b[1]));
    let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
    eprintln!(
        "image means: bsdf {:.4}, mis {:.4}, straight {:.4}",
        mean(b[0]),
        mean(&mis[0]),
        mean(&straight[0])
    );
    eprintln!(
        "block-mean RMS / noise RMS: mis {r_mis:.3}, straight launch {r_straight:.3}; \
         seed-to-seed RMS mis (64 spp) {n_mis:.4}, bsdf (256 spp) {n_bsdf:.4}; {:.1} s",
        t.elapsed().as_secs_f64()
    );
    assert!(r_mis <= 1.3, "NEE+MIS through the medium vs BSDF alone: {r_mis}");
    assert!(
        r_straight > 1.3,
        "no power: the straight launch passes ({r_straight})"
    );
    assert!(
        n_mis < 0.1 * n_bsdf,
        "NEE does not carry the sun: {n_mis} vs {n_bsdf}"
    );
}
