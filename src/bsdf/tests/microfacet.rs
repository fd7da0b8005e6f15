//! The distributions themselves: normalization of D and of the visible
//! normals (which ties Λ to D), and χ² tests of visible-normal sampling.
use super::*;
use crate::bsdf::{MicrofacetDistribution, MicrofacetKind};

fn dists() -> Vec<MicrofacetDistribution> {
    use MicrofacetKind::{Beckmann, Ggx};
    vec![
        MicrofacetDistribution::isotropic(Ggx, 0.1).unwrap(),
        MicrofacetDistribution::isotropic(Ggx, 0.5).unwrap(),
        MicrofacetDistribution::try_new(Ggx, 0.1, 0.4).unwrap(),
        MicrofacetDistribution::isotropic(Beckmann, 0.1).unwrap(),
        MicrofacetDistribution::isotropic(Beckmann, 0.5).unwrap(),
        MicrofacetDistribution::try_new(Beckmann, 0.4, 0.1).unwrap(),
    ]
}

fn wis() -> [Vec3; 3] {
    [Vec3::Z, dir(45.0, 30.0), dir(80.0, 250.0)]
}

/// ∫ g over the sphere, by the χ² suite's adaptive cell quadrature.
fn integral(g: impl Fn(Vec3) -> f64) -> f64 {
    cell_masses(40, 80, g).iter().sum()
}

#[test]
fn d_and_the_visible_normals_are_normalized() {
    for d in dists() {
        // ∫ D(m) cos θm dm = 1: the projected facet area is the macrosurface's.
        let proj = integral(|m| f64::from(d.d(m) * m.z));
        assert!((proj - 1.0).abs() < 1e-4, "{d:?}: ∫ D cos = {proj}");
        // ∫ G1(wi, m) max(0, wi·m) D(m) dm = cos θi (the projected visible
        // area): holds only with the Λ that belongs to D.
        for wi in wis().into_iter().chain([-dir(60.0, 0.0)]) {
            let vis = integral(|m| f64::from(d.pdf(wi, m)));
            assert!((vis - 1.0).abs() < 1e-4, "{d:?}, wi = {wi}: ∫ pdf = {vis}");
        }
    }
}

#[test]
fn lambda_and_g1_follow_smith() {
    let mut rng = Rng::new(5);
    for d in dists() {
        for _ in 0..1000 {
            let w = sphere(&mut rng);
            let m = d.sample_visible(w, u2(&mut rng));
            assert!(m.z >= 0.0 && (m.length() - 1.0).abs() < 1e-5, "{m}");
            assert_eq!(d.lambda(w), d.lambda(-w));
            let g1 = d.g1(w, m);
            if w.dot(m) * w.z > 0.0 {
                assert!((g1 - 1.0 / (1.0 + d.lambda(w))).abs() < 1e-6);
            } else {
                assert_eq!(g1, 0.0);
            }
            assert!((d.g(w, -w, m) - d.g1(w, m) * d.g1(-w, m)).abs() < 1e-7);
        }
        assert_eq!(d.lambda(Vec3::Z), 0.0);
        assert_eq!(d.g1(Vec3::Z, Vec3::Z), 1.0);
        assert_eq!(d.g1(Vec3::X, Vec3::Z), 0.0);
    }
}

#[test]
fn visible_normal_sampling_matches_its_pdf_chi2() {
    for (k, d) in dists().into_iter().enumerate() {
        for (i, wi) in wis().into_iter().enumerate() {
            let h = histogram(40, 80, 200_000, (10 * k + i) as u64, |rng| {
                Some((d.sample_visible(wi, u2(rng)), false))
            });
            let c = chi2(&h, |m| f64::from(d.pdf(wi, m)));
            assert!(c.passes(), "{d:?}, wi = {wi}: {c:?}");
        }
    }
}

#[test]
fn a_wrong_normal_density_fails_the_chi2_test() {
    // Visible normals against the density of all normals, D(m) cos θm, and
    // Beckmann samples against GGX's visible pdf: both rejected.
    let wi = dir(60.0, 0.0);
    for alpha in [0.1, 0.5] {
        let ggx = MicrofacetDistribution::isotropic(MicrofacetKind::Ggx, alpha).unwrap();
        let beckmann = MicrofacetDistribution::isotropic(MicrofacetKind::Beckmann, alpha).unwrap();
        let h = histogram(40, 80, 200_000, 9, |rng| {
            Some((ggx.sample_visible(wi, u2(rng)), false))
        });
        assert!(chi2(&h, |m| f64::from(ggx.pdf(wi, m))).passes());
        let not_visible = chi2(&h, |m| f64::from(ggx.d(m) * m.z));
        assert!(!not_visible.passes(), "α = {alpha}: {not_visible:?}");
        let h = histogram(40, 80, 200_000, 9, |rng| {
            Some((beckmann.sample_visible(wi, u2(rng)), false))
        });
        assert!(chi2(&h, |m| f64::from(beckmann.pdf(wi, m))).passes());
        let other = chi2(&h, |m| f64::from(ggx.pdf(wi, m)));
        assert!(!other.passes(), "α = {alpha}: {other:?}");
    }
}
