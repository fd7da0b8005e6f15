//! Metals: the rough conductor's sampling (χ²), energy (white furnace with
//! Mitsuba's ideal mirror `none`, whose Fresnel term is 1), reciprocity, and
//! the smooth conductor's delta lobe.
use super::*;
use crate::bsdf::{fresnel, metals, Conductor, MicrofacetDistribution, MicrofacetKind, RoughConductor};

fn rough(kind: MicrofacetKind, alpha: f32, metal: &str) -> RoughConductor {
    let d = MicrofacetDistribution::isotropic(kind, alpha).unwrap();
    RoughConductor::from_metal(d, metal, Vec3::ONE).unwrap()
}

fn configs() -> Vec<(MicrofacetKind, f32)> {
    let mut v = Vec::new();
    for kind in [MicrofacetKind::Ggx, MicrofacetKind::Beckmann] {
        for alpha in [0.1, 0.5] {
            v.push((kind, alpha));
        }
    }
    v
}

fn wos() -> [Vec3; 2] {
    [dir(30.0, 40.0), dir(75.0, 190.0)]
}

fn sample_full(b: &RoughConductor, wo: Vec3) -> impl FnMut(&mut Rng) -> Option<BsdfSample> + '_ {
    move |rng| b.sample(wo, u2(rng))
}

#[test]
fn rough_conductor_sampling_matches_its_pdf_chi2() {
    for (kind, alpha) in configs() {
        let b = rough(kind, alpha, "Au");
        for (i, wo) in wos().into_iter().enumerate() {
            let label = format!("{kind:?} α = {alpha}, wo = {wo}");
            let h = histogram(40, 80, 200_000, 200 + i as u64, |rng| {
                b.sample(wo, u2(rng)).map(|s| (s.wi, s.is_delta))
            });
            let c = chi2(&h, |wi| f64::from(b.pdf(wo, wi)));
            assert!(c.passes(), "{label}: {c:?}");
            let f = h.fraction();
            let sd = (f * (1.0 - f) / h.draws as f64).sqrt();
            assert!(
                c.pdf_mass <= 1.0 + 1e-4 && (c.pdf_mass - f).abs() < 4.0 * sd + 1e-4,
                "{label}: {c:?} {f}"
            );
            // Independently: uniform directions.
            let mass = estimate(400_000, 3, |rng| {
                DVec3::splat(f64::from(b.pdf(wo, sphere(rng))) * 4.0 * PI)
            });
            assert!(
                (mass.mean.x - f).abs() < 4.0 * (mass.stderr.x + sd),
                "{label}: {mass:?} vs {f}"
            );
            let s = consistency(
                20_000,
                9,
                sample_full(&b, wo),
                |wi| b.f(wo, wi),
                |wi| b.pdf(wo, wi),
            );
            assert!(
                s.pdf_error < 1e-3 && s.weight_error < 1e-3,
                "{label}: {}, {}",
                s.pdf_error,
                s.weight_error
            );
        }
    }
}

#[test]
fn rough_conductor_white_furnace() {
    let n = 100_000;
    for (kind, alpha) in configs() {
        let mut mirror = Vec::new();
        for metal in ["none", "Au", "Al"] {
            let b = rough(kind, alpha, metal);
            for (i, wo) in wos().into_iter().enumerate() {
                let label = format!("{kind:?} α = {alpha}, {metal}, wo = {wo}");
                let sampled = furnace_sampled(n, 20 + i as u64, sample_full(&b, wo));
                let uniform = furnace_uniform(3 * n, 30 + i as u64, |wi| b.f(wo, wi));
                assert!(
                    agree(&sampled, &uniform, 4.0, 1e-3),
                    "{label}: {sampled:?} vs {uniform:?}"
                );
                assert!(sampled.mean.max_element() <= 1.0 + 1e-3, "{label}: {sampled:?}");
                // The same samples as the ideal mirror's, each weighted by F ≤ 1.
                if metal == "none" {
                    mirror.push(sampled.mean);
                } else {
                    assert!(
                        sampled.mean.cmple(mirror[i]).all(),
                        "{label}: {sampled:?} vs {:?}",
                        mirror[i]
                    );
                    assert!(
                        sampled.mean.min_element() < 0.99 * mirror[i].x,
                        "{label}: absorbs"
                    );
                }
            }
        }
    }
    // Nearly smooth, lossless: everything is reflected.
    for kind in [MicrofacetKind::Ggx, MicrofacetKind::Beckmann] {
        let b = rough(kind, 0.01, "none");
        for wo in [dir(30.0, 0.0), dir(60.0, 100.0)] {
            let e = furnace_sampled(100_000, 5, sample_full(&b, wo));
            assert!(
                (e.mean - DVec3::ONE).abs().max_element() < 1e-3,
                "{kind:?}, wo = {wo}: {e:?}"
            );
        }
    }
}

#[test]
fn omitting_shadowing_masking_fails_the_furnace() {
    // A test-local copy of f with G = 1 (D F / (4 cos θo cos θi)): at grazing
    // wo on a rough mirror it returns more light than arrives (by ≈ 1 + Λ(wo)).
    let wo = dir(80.0, 0.0);
    for kind in [MicrofacetKind::Ggx, MicrofacetKind::Beckmann] {
        let b = rough(kind, 0.5, "none");
        let d = *b.distribution();
        let right = furnace_uniform(800_000, 8, |wi| b.f(wo, wi));
        let no_g = furnace_uniform(800_000, 8, |wi| {
            let g = (wo + wi).try_normalize().map_or(0.0, |m| d.g(wo, wi, m));
            if g > 0.0 {
                b.f(wo, wi) / g
            } else {
                Vec3::ZERO
            }
        });
        let bound = |e: &Estimate| e.mean.x <= 1.0 + 4.0 * e.stderr.x + 1e-3;
        assert!(bound(&right), "{kind:?}: {right:?}");
        assert!(!bound(&no_g) && no_g.mean.x > 1.2, "{kind:?}: {no_g:?}");
    }
}

#[test]
fn rough_conductor_is_reciprocal_and_one_sided() {
    let mut rng = Rng::new(3);
    for (kind, alpha) in configs() {
        let b = rough(kind, alpha, "Cu");
        let mut nonzero = 0;
        for _ in 0..20_000 {
            let (wo, wi) = (sphere(&mut rng), sphere(&mut rng));
            let (x, y) = (b.f(wo, wi), b.f(wi, wo));
            assert!((x - y).abs().max_element() <= 1e-4 * x.max_element().max(y.max_element()) + 1e-7);
            if wo.z <= 0.0 || wi.z <= 0.0 {
                assert_eq!(x, Vec3::ZERO);
                assert_eq!(b.pdf(wo, wi), 0.0);
            } else {
                nonzero += usize::from(x.x > 0.0);
            }
        }
        // Beckmann at α = 0.1 underflows beyond ~45° facets: still many pairs.
        assert!(nonzero > 1000, "{nonzero}");
        assert!(b.sample(-Vec3::Z, Vec2::splat(0.3)).is_none());
    }
}

#[test]
fn smooth_conductor_reflects_the_fresnel_term() {
    let none = Conductor::from_metal("none", Vec3::ONE).unwrap();
    let au = Conductor::from_metal("Au", Vec3::new(1.0, 0.5, 0.25)).unwrap();
    let gold = metals::find("Au").unwrap();
    for wo in [Vec3::Z, dir(40.0, 10.0), dir(85.0, 200.0)] {
        let s = none.sample(wo).unwrap();
        assert!(s.is_delta && !s.is_transmission && s.pdf == 1.0);
        assert!((s.wi - Vec3::new(-wo.x, -wo.y, wo.z)).length() < 1e-7);
        assert!((s.weight - Vec3::ONE).abs().max_element() < 1e-6);
        let a = au.sample(wo).unwrap();
        let want = fresnel::conductor(wo.z, gold.eta, gold.k) * Vec3::new(1.0, 0.5, 0.25);
        assert!((a.weight - want).abs().max_element() < 1e-6);
        assert_eq!(au.f(wo, a.wi), Vec3::ZERO);
        assert_eq!(au.pdf(wo, a.wi), 0.0);
    }
    assert!(none.sample(-Vec3::Z).is_none());
}

#[test]
fn conductors_reject_bad_parameters() {
    let e = Conductor::try_new(Vec3::new(0.2, -1.0, 0.3), Vec3::ONE, Vec3::ONE).unwrap_err();
    assert!(e.to_string().starts_with("eta.g = -1"), "{e}");
    let e = Conductor::try_new(Vec3::ONE, Vec3::new(0.0, 0.0, f32::INFINITY), Vec3::ONE).unwrap_err();
    assert!(e.to_string().starts_with("k.b = inf"), "{e}");
    let e = Conductor::from_metal("Fe", Vec3::ONE).unwrap_err();
    assert!(
        e.to_string().contains("unknown metal \"Fe\"") && e.to_string().contains("Au"),
        "{e}"
    );
    let d = MicrofacetDistribution::isotropic(MicrofacetKind::Ggx, 0.2).unwrap();
    let e = RoughConductor::from_metal(d, "Au", Vec3::new(1.0, f32::NAN, 1.0)).unwrap_err();
    assert!(e.to_string().starts_with("specular_reflectance.g = NaN"), "{e}");
}
