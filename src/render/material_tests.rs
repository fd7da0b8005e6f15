//! The microfacet materials in the path tracer: next-event estimation with
//! MIS against BSDF sampling alone (which needs no density of the light),
//! per material class, with known-wrong variants ([`BsdfVariant`]) for the
//! tests' power; and a white furnace of a rough glass sphere. Images are
//! compared by 16×16 block means against the seed-to-seed noise
//! (`sun_tests::ratio`: about 1 when both are unbiased).
use super::light_tests::{mean_and_error, pair, render_at, run, LIMIT};
use super::sun_tests::{ratio, rms};
use crate::integrator::LightSampling;
use crate::scene::model::BsdfVariant;
use crate::scene::{load_scene_str, BuildOptions, RenderScene};
use std::path::Path;

/// A floor, a back wall and a rect light above; `OBJECTS` is replaced by
/// the surfaces under test. Three segments: MIS at the second bounce too.
const ROOM: &str = r#"
ambient_ior = 1.0
[camera]
position = [0.0, 1.4, 3.0]
target = [0.0, 0.5, 0.0]
fov = 40.0
[film]
width = 128
height = 128
spp = 32
[integrator]
max_depth = 3
[[lights]]
type = "rect"
center = [0.0, 2.0, 0.6]
normal = [0.0, -1.0, 0.0]
u_axis = [1.0, 0.0, 0.0]
size = [LIGHT_SIZE, LIGHT_SIZE]
radiance = [6.0, 5.0, 4.0]
[[objects]]
name = "floor"
shape = { type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [6.0, 6.0] }
material = { type = "diffuse", reflectance = [0.6, 0.6, 0.6] }
[[objects]]
name = "wall"
shape = { type = "rect", center = [0.0, 1.5, -1.5], normal = [0.0, 0.0, 1.0], u_axis = [1.0, 0.0, 0.0], size = [6.0, 3.0] }
material = { type = "diffuse", reflectance = [0.5, 0.4, 0.3] }
OBJECTS
"#;

/// Rough gold and a rough conductor given by its complex index, tilted
/// to mirror the light towards the camera.
const METALS: &str = r#"
[[objects]]
name = "gold"
shape = { type = "sphere", center = [-0.45, 0.4, 0.0], radius = 0.4 }
material = { type = "rough_conductor", material = "Au", alpha = 0.2 }
[[objects]]
name = "plate"
shape = { type = "rect", center = [0.5, 0.5, 0.0], normal = [0.0, 0.5, 1.0], u_axis = [1.0, 0.0, 0.0], size = [0.7, 0.7] }
material = { type = "rough_conductor", eta = [0.2, 0.9, 1.1], k = [3.9, 2.4, 2.2], alpha = 0.3, distribution = "beckmann", two_sided = true }
"#;

/// A smooth and a rough plastic: the delta coating beside the diffuse lobe.
const PLASTICS: &str = r#"
[[objects]]
name = "smooth"
shape = { type = "sphere", center = [-0.45, 0.4, 0.0], radius = 0.4 }
material = { type = "plastic", diffuse_reflectance = [0.2, 0.4, 0.8] }
[[objects]]
name = "rough"
shape = { type = "sphere", center = [0.5, 0.4, 0.0], radius = 0.4 }
material = { type = "rough_plastic", diffuse_reflectance = [0.8, 0.3, 0.2], alpha = 0.25, nonlinear = true }
"#;

/// A frosted pane (a rough interface, glass behind its front) between the
/// camera and a second light facing it: the light reaches the camera by
/// transmission, the floor and wall by reflection; and a nested rough solid.
const FROSTED: &str = r#"
[[lights]]
type = "rect"
center = [0.4, 0.9, -1.2]
normal = [0.0, 0.0, 1.0]
u_axis = [1.0, 0.0, 0.0]
size = [0.6, 0.6]
radiance = [4.0, 4.0, 6.0]
[[objects]]
name = "pane"
shape = { type = "rect", center = [0.4, 0.9, -0.6], normal = [0.0, 0.0, 1.0], u_axis = [1.0, 0.0, 0.0], size = [1.2, 1.2] }
material = { type = "rough_dielectric", int_ior = 1.5, ext_ior = 1.0, alpha = 0.3 }
[[objects]]
name = "ball"
shape = { type = "sphere", center = [-0.5, 0.4, 0.3], radius = 0.4 }
material = { type = "rough_dielectric", ior = 1.5, alpha = 0.2, distribution = "beckmann" }
"#;

/// The room with `objects` under a light of side `light_size`.
fn room(objects: &str, light_size: f64) -> RenderScene {
    let text = ROOM
        .replace("OBJECTS", objects)
        .replace("LIGHT_SIZE", &format!("{light_size:?}"));
    load_scene_str("materials.toml", &text, Path::new("."), &BuildOptions::default()).expect("scene loads")
}

/// NEE+MIS against BSDF sampling alone on `objects`, and each of `wrong`
/// against the same threshold; NEE must also lower the noise (else MIS
/// would be BSDF sampling alone and pass trivially).
fn mis_matches_bsdf_alone(name: &str, objects: &str, light_size: f64, wrong: &[BsdfVariant]) {
    let t = std::time::Instant::now();
    let mut s = room(objects, light_size);
    let bsdf = run(&s, LightSampling::Bsdf);
    let mis = run(&s, LightSampling::Mis);
    let b = pair(&bsdf);
    let r_mis = ratio(pair(&mis), b);
    let (n_mis, n_bsdf) = (rms(&mis[0], &mis[1]), rms(b[0], b[1]));
    let mut line = format!("{name}: block-mean RMS / noise RMS: mis {r_mis:.3}");
    let mut failed_wrong = Vec::new();
    for &v in wrong {
        s.bsdf_variant = v;
        let r = ratio(pair(&run(&s, LightSampling::Mis)), b);
        line += &format!(", {v:?} {r:.3}");
        if r <= LIMIT {
            failed_wrong.push((v, r));
        }
    }
    eprintln!(
        "{line}; seed-to-seed RMS mis {n_mis:.4}, bsdf {n_bsdf:.4}; {:.1} s",
        t.elapsed().as_secs_f64()
    );
    assert!(r_mis <= LIMIT, "{name}: NEE+MIS vs BSDF alone: {r_mis}");
    assert!(failed_wrong.is_empty(), "{name}: no power: {failed_wrong:?} pass");
    assert!(
        n_mis < 0.8 * n_bsdf,
        "{name}: NEE carries nothing: {n_mis} vs {n_bsdf}"
    );
}

#[test]
fn rough_metals_by_nee_and_mis_match_bsdf_sampling_alone_and_a_wrong_density_does_not() {
    mis_matches_bsdf_alone("metals", METALS, 1.0, &[BsdfVariant::WrongMisPdf]);
}

#[test]
fn plastics_by_nee_and_mis_match_bsdf_sampling_alone_and_a_wrong_density_does_not() {
    // A large light: its density is comparable to the diffuse lobe's, where
    // a wrong density in the MIS weights shows.
    mis_matches_bsdf_alone("plastics", PLASTICS, 3.0, &[BsdfVariant::WrongMisPdf]);
}

#[test]
fn frosted_glass_by_nee_and_mis_matches_bsdf_sampling_alone_and_wrong_variants_do_not() {
    mis_matches_bsdf_alone(
        "frosted",
        FROSTED,
        1.0,
        &[BsdfVariant::WrongMisPdf, BsdfVariant::WrongDoubleScale],
    );
}

/// A rough glass sphere (a nested solid, index 1.5) filling the view under
/// a uniform sky of radiance 1, nothing else: every path ends in the sky,
/// so a lossless surface shows 1 everywhere.
const FURNACE: &str = r#"
ambient_ior = 1.0
[camera]
position = [0.0, 0.0, 3.0]
target = [0.0, 0.0, 0.0]
fov = 12.0
[film]
width = 64
height = 64
spp = 32
[integrator]
max_depth = 100
rr_depth = 100
[environment]
type = "constant"
radiance = [1.0, 1.0, 1.0]
[[objects]]
name = "ball"
shape = { type = "sphere", center = [0.0, 0.0, 0.0], radius = 1.0 }
material = { type = "rough_dielectric", ior = 1.5, alpha = ALPHA }
"#;

#[test]
fn a_rough_glass_sphere_in_a_white_furnace_stays_white_and_a_wrong_jacobian_does_not() {
    // Single-scattering microfacet models lose the light that would scatter
    // between facets (measured: 0.01 % at α = 0.01, 1.6 % at α = 0.1, 14 %
    // at α = 0.3, where light trapped inside meets the surface many times):
    // so ≈ 1 near smooth, never above 1, and the loss growing with α.
    // The sky is no NEE light: the path tracer samples the BSDF alone here.
    let furnace = |alpha: &str, v: BsdfVariant| {
        let text = FURNACE.replace("ALPHA", alpha);
        let mut s =
            load_scene_str("furnace.toml", &text, Path::new("."), &BuildOptions::default()).expect("loads");
        s.bsdf_variant = v;
        mean_and_error(&render_at(&s, 1, LightSampling::Mis))
    };
    let (near_smooth, e0) = furnace("0.01", BsdfVariant::Right);
    let (rough, e1) = furnace("0.1", BsdfVariant::Right);
    let (wrong, e2) = furnace("0.01", BsdfVariant::WrongJacobian);
    eprintln!(
        "furnace means: α 0.01 {near_smooth:.5} ± {e0:.5}, α 0.1 {rough:.5} ± {e1:.5}, \
         α 0.01 with the reflection's Jacobian {wrong:.3} ± {e2:.3}"
    );
    let white = |mean: f64, err: f64| (mean - 1.0).abs() <= 1e-3 + 4.0 * err;
    assert!(
        white(near_smooth, e0),
        "α 0.01 loses or gains: {near_smooth} ± {e0}"
    );
    assert!(
        rough <= 1.0 + 4.0 * e1 && rough >= 0.97 && rough < near_smooth,
        "α 0.1: {rough} ± {e1}"
    );
    assert!(
        !white(wrong, e2),
        "no power: the wrong Jacobian is white ({wrong})"
    );
}
