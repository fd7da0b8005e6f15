//! Agreement with Mitsuba 3 itself: f·|cos θi| (what Mitsuba's `eval`
//! returns) and pdf at fixed pairs of directions, as printed by Mitsuba
//! 3.9.1 (`scalar_rgb`, PyPI), with `si.wi` = our `wo`:
//!
//! ```python
//! b = mi.load_dict({'type': 'roughdielectric', 'distribution': 'ggx', 'alpha': 0.3,
//!                   'int_ior': 1.5, 'ext_ior': 1.0})
//! si = mi.SurfaceInteraction3f(); si.wi = wo
//! b.eval(mi.BSDFContext(), si, wi), b.pdf(mi.BSDFContext(), si, wi)
//! ```
//!
//! (and likewise `roughconductor` with `material`, `plastic` and
//! `roughplastic` with `diffuse_reflectance` = (0.8, 0.4, 0.1) and Mitsuba's
//! default indices). Directions are (θ, φ) in degrees, [`dir`].
//!
//! Tolerances: GGX and the smooth models agree to f32 rounding (2e-4
//! relative). Beckmann differs by Mitsuba's rational fit of G1 (< 0.35% per
//! G1 factor, so < 0.7% for f); the rough plastic's diffuse part by the
//! quadrature of its tables (GGX visible normals are mapped from the unit
//! square differently here, so the rule sees another integrand).
use super::*;
use crate::bsdf::{
    Conductor, MicrofacetDistribution, MicrofacetKind, Plastic, PlasticParams, RoughConductor,
    RoughDielectric, RoughPlastic,
};

/// (model, wo (θ, φ), wi (θ, φ), Mitsuba's eval (RGB), Mitsuba's pdf).
type Row = (&'static str, [i16; 2], [i16; 2], [f32; 3], f32);

const MITSUBA: &[Row] = &[
    (
        "roughdielectric ggx 0.3",
        [35, 20],
        [50, 210],
        [0.032383982, 0.032383982, 0.032383982],
        0.03338774,
    ),
    (
        "roughdielectric ggx 0.3",
        [35, 20],
        [160, 190],
        [4.0544777, 4.0544777, 4.0544777],
        9.149684,
    ),
    (
        "roughdielectric ggx 0.3",
        [150, 20],
        [130, 200],
        [0.14160411, 0.14160411, 0.14160411],
        0.14599317,
    ),
    (
        "roughdielectric ggx 0.3",
        [150, 20],
        [20, 190],
        [0.5007859, 0.5007859, 0.5007859],
        0.22323297,
    ),
    (
        "roughdielectric ggx 0.3",
        [70, 0],
        [120, 170],
        [0.48332837, 0.48332837, 0.48332837],
        1.1565131,
    ),
    (
        "roughdielectric beckmann 0.3",
        [35, 20],
        [50, 210],
        [0.041364808, 0.041364808, 0.041364808],
        0.041364808,
    ),
    (
        "roughdielectric beckmann 0.3",
        [35, 20],
        [160, 190],
        [5.405347, 5.405347, 5.405347],
        12.162028,
    ),
    (
        "roughdielectric beckmann 0.3",
        [150, 20],
        [130, 200],
        [0.18847923, 0.18847923, 0.18847923],
        0.1884792,
    ),
    (
        "roughdielectric beckmann 0.3",
        [150, 20],
        [20, 190],
        [3.9874056e-05, 3.9874056e-05, 3.9874056e-05],
        1.7721804e-05,
    ),
    (
        "roughdielectric beckmann 0.3",
        [70, 0],
        [120, 170],
        [0.0013004342, 0.0013004342, 0.0013004342],
        0.0029259769,
    ),
    (
        "roughconductor ggx Au 0.2",
        [35, 20],
        [50, 210],
        [0.954437, 0.79172844, 0.32924083],
        1.0022786,
    ),
    (
        "roughconductor ggx Au 0.2",
        [70, 0],
        [30, 160],
        [0.2568415, 0.21325313, 0.09102172],
        0.26712963,
    ),
    (
        "roughconductor ggx Au 0.2",
        [10, 45],
        [15, 200],
        [1.6167517, 1.3413341, 0.54217845],
        1.6736913,
    ),
    (
        "roughconductor beckmann Cu 0.4",
        [35, 20],
        [50, 210],
        [0.52181184, 0.34003443, 0.28191546],
        0.5489681,
    ),
    (
        "roughconductor beckmann Cu 0.4",
        [70, 0],
        [30, 160],
        [0.62644094, 0.40915135, 0.3412601],
        0.6599228,
    ),
    (
        "roughconductor beckmann Cu 0.4",
        [10, 45],
        [15, 200],
        [0.47244114, 0.30757082, 0.2533735],
        0.49625853,
    ),
    (
        "plastic nonlinear=False",
        [35, 20],
        [50, 210],
        [0.16293485, 0.08146743, 0.020366857],
        0.18593965,
    ),
    (
        "plastic nonlinear=False",
        [70, 0],
        [30, 160],
        [0.19356082, 0.09678041, 0.024195103],
        0.18758245,
    ),
    (
        "plastic nonlinear=False",
        [10, 45],
        [15, 200],
        [0.25013554, 0.12506777, 0.031266943],
        0.28133526,
    ),
    (
        "plastic nonlinear=True",
        [35, 20],
        [50, 210],
        [0.12646537, 0.043679316, 0.008864062],
        0.18593965,
    ),
    (
        "plastic nonlinear=True",
        [70, 0],
        [30, 160],
        [0.15023637, 0.05188948, 0.010530191],
        0.18758245,
    ),
    (
        "plastic nonlinear=True",
        [10, 45],
        [15, 200],
        [0.19414805, 0.06705594, 0.013607996],
        0.28133526,
    ),
    (
        "roughplastic ggx 0.2 nonlinear=False",
        [35, 20],
        [50, 210],
        [0.17113364, 0.10835439, 0.061269958],
        0.29002926,
    ),
    (
        "roughplastic ggx 0.2 nonlinear=False",
        [70, 0],
        [30, 160],
        [0.16808046, 0.091318004, 0.03374615],
        0.27309072,
    ),
    (
        "roughplastic ggx 0.2 nonlinear=False",
        [10, 45],
        [15, 200],
        [0.26037085, 0.16255406, 0.089191444],
        0.43233174,
    ),
    (
        "roughplastic beckmann 0.3 nonlinear=True",
        [35, 20],
        [50, 210],
        [0.15343283, 0.0817768, 0.04881334],
        0.27024078,
    ),
    (
        "roughplastic beckmann 0.3 nonlinear=True",
        [70, 0],
        [30, 160],
        [0.16752437, 0.079725236, 0.039335568],
        0.34852177,
    ),
    (
        "roughplastic beckmann 0.3 nonlinear=True",
        [10, 45],
        [15, 200],
        [0.20950042, 0.09817865, 0.046968017],
        0.35531023,
    ),
];

/// Our BSDF for a row's model name: (f, pdf) as functions of (wo, wi), and the tolerance.
#[allow(clippy::type_complexity)]
fn model(name: &str) -> (Box<dyn Fn(Vec3, Vec3) -> (Vec3, f32)>, f32) {
    use MicrofacetKind::{Beckmann, Ggx};
    let kind = |s: &str| if s.contains("beckmann") { Beckmann } else { Ggx };
    let tol = |s: &str| if s.contains("beckmann") { 7e-3 } else { 2e-4 };
    let colour = PlasticParams {
        diffuse_reflectance: Vec3::new(0.8, 0.4, 0.1),
        nonlinear: name.ends_with("nonlinear=True"),
        ..Default::default()
    };
    let words: Vec<&str> = name.split(' ').collect();
    match words[0] {
        "roughdielectric" => {
            let d = MicrofacetDistribution::isotropic(kind(name), words[2].parse().unwrap()).unwrap();
            let b = RoughDielectric::try_new(d, 1.0, 1.5).unwrap();
            (Box::new(move |wo, wi| (b.f(wo, wi), b.pdf(wo, wi))), tol(name))
        }
        "roughconductor" => {
            let d = MicrofacetDistribution::isotropic(kind(name), words[3].parse().unwrap()).unwrap();
            let b = RoughConductor::from_metal(d, words[2], Vec3::ONE).unwrap();
            (Box::new(move |wo, wi| (b.f(wo, wi), b.pdf(wo, wi))), tol(name))
        }
        "plastic" => {
            let b = Plastic::try_new(&colour).unwrap();
            (Box::new(move |wo, wi| (b.f(wo, wi), b.pdf(wo, wi))), 2e-4)
        }
        "roughplastic" => {
            let d = MicrofacetDistribution::isotropic(kind(name), words[2].parse().unwrap()).unwrap();
            let b = RoughPlastic::try_new(&colour, d).unwrap();
            (
                Box::new(move |wo, wi| (b.f(wo, wi), b.pdf(wo, wi))),
                tol(name).max(2e-3),
            )
        }
        other => panic!("no model {other}"),
    }
}

#[test]
fn eval_and_pdf_agree_with_mitsuba_3() {
    let mut models: Vec<(&str, _)> = Vec::new();
    for &(name, wo, wi, eval, pdf) in MITSUBA {
        if !models.iter().any(|m| m.0 == name) {
            models.push((name, model(name)));
        }
        let (b, tol) = &models.iter().find(|m| m.0 == name).unwrap().1;
        let tol = *tol;
        let (wo, wi) = (
            dir(f32::from(wo[0]), f32::from(wo[1])),
            dir(f32::from(wi[0]), f32::from(wi[1])),
        );
        let (f, p) = b(wo, wi);
        let ours = f * wi.z.abs();
        let want = Vec3::from_array(eval);
        let rel = ((ours - want).abs() / want.max(Vec3::splat(1e-30))).max_element();
        assert!(
            rel < tol,
            "{name}, wo = {wo}, wi = {wi}: f cos = {ours}, Mitsuba {want} ({rel:e})"
        );
        let rel = (p - pdf).abs() / pdf;
        assert!(
            rel < tol,
            "{name}, wo = {wo}, wi = {wi}: pdf = {p}, Mitsuba {pdf} ({rel:e})"
        );
    }
}

#[test]
fn delta_lobes_agree_with_mitsuba_3() {
    // `conductor` with material Au: the sample weight at θo = 0°, 45°, 80°.
    let au = Conductor::from_metal("Au", Vec3::ONE).unwrap();
    for (theta, want) in [
        (0.0, [0.9666793, 0.80200994, 0.32412148]),
        (45.0, [0.9652941, 0.80090666, 0.33594158]),
        (80.0, [0.9632077, 0.87555945, 0.5917323]),
    ] {
        let w = au.sample(dir(theta, 0.0)).unwrap().weight;
        assert!(
            (w - Vec3::from_array(want)).abs().max_element() < 2e-6,
            "θ = {theta}: {w} vs {want:?}"
        );
    }
    // `plastic` (diffuse (0.8, 0.4, 0.1), default indices): the delta lobe's
    // probability and weight at θo = 30°, 75°.
    let p = Plastic::try_new(&PlasticParams {
        diffuse_reflectance: Vec3::new(0.8, 0.4, 0.1),
        ..Default::default()
    })
    .unwrap();
    for (theta, pdf, weight) in [(30.0, 0.08807965, 0.45609808), (75.0, 0.43619207, 0.5756101)] {
        let s = p.sample(dir(theta, 0.0), 0.0, Vec2::splat(0.5)).unwrap();
        assert!(s.is_delta);
        assert!(
            (s.pdf - pdf).abs() < 2e-6 && (s.weight.x - weight).abs() < 2e-6,
            "θ = {theta}: {s:?}"
        );
    }
}

#[test]
fn rough_plastic_albedo_agrees_with_mitsuba_3() {
    // Mitsuba 3.9.1's mean sample weight over 300 000 calls of `sample`
    // (random numbers from Python's `random`), white base (ρ = 1),
    // int_ior = 1.5, ext_ior = 1, wo at (θ, 20°): (mean, standard error).
    // The coating's tables are part of what this compares.
    use MicrofacetKind::{Beckmann, Ggx};
    let white = PlasticParams {
        int_ior: 1.5,
        ext_ior: 1.0,
        diffuse_reflectance: Vec3::ONE,
        ..Default::default()
    };
    for (i, (kind, alpha, theta, mean, stderr)) in [
        (Ggx, 0.1, 75.0, 0.89447, 0.00026),
        (Ggx, 0.4, 30.0, 0.60251, 0.00013),
        (Beckmann, 0.1, 30.0, 0.9676, 0.00017),
        (Beckmann, 0.4, 75.0, 0.78715, 0.00022),
    ]
    .into_iter()
    .enumerate()
    {
        let b =
            RoughPlastic::try_new(&white, MicrofacetDistribution::isotropic(kind, alpha).unwrap()).unwrap();
        let wo = dir(theta, 20.0);
        let e = furnace_sampled(200_000, 500 + i as u64, |rng| {
            b.sample(wo, rng.uniform(), u2(rng))
        });
        let sd = (e.stderr.x * e.stderr.x + stderr * stderr).sqrt();
        assert!(
            (e.mean.x - mean).abs() < 4.0 * sd + 1e-3,
            "{kind:?} α = {alpha}, θo = {theta}: {e:?} vs Mitsuba {mean} ± {stderr}"
        );
    }
}
