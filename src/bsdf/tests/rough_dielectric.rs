//! Rough glass (η = 1.5 inside, 1 outside), GGX and Beckmann at α = 0.1
//! and 0.5, with `wo` on both sides of the boundary.
//!
//! The conserved quantity. Let ηo, ηi be the indices on wo's and wi's
//! sides. In importance mode f_imp has no (ηo/ηi)² factor and is the
//! adjoint of the radiance BSDF: f_imp(wo, wi) = f_rad(wi, wo). Power is
//! conserved for light arriving from a direction and leaving in all the
//! others, i.e. ∫ f_rad(wo, wi) |cos θo| dωo ≤ 1 for every wi (the
//! integral is over the *outgoing* radiance direction), which is the same
//! as ∫ f_imp(wo, wi) |cos θi| dωi = R(wo) + T(wo) ≤ 1: the fractions of
//! power reflected and transmitted. What a radiance path tracer's weights
//! average to, ∫ f_rad(wo, wi) |cos θi| dωi = R + (ηo/ηi)² T, is *not*
//! bounded by 1 (light focused into glass grows in radiance). With no
//! roughness R + T = 1 and R = F(cos θo).
//!
//! Reciprocity: f_imp(wo, wi) / ηi² is symmetric, hence
//! f_rad(wo, wi) / ηo² = f_rad(wi, wo) / ηi² (Veach 1997, §6.2), and
//! f(wo, wi) = f(wi, wo) for reflection.
use super::*;
use crate::bsdf::{fresnel, MicrofacetDistribution, MicrofacetKind, RoughDielectric, TransportMode};

const N_COS: usize = 40;
const N_PHI: usize = 80;
const N: usize = 200_000;

fn glass(kind: MicrofacetKind, alpha: f32) -> RoughDielectric {
    RoughDielectric::try_new(MicrofacetDistribution::isotropic(kind, alpha).unwrap(), 1.0, 1.5).unwrap()
}

/// `wo` outside at 30° and 70°, inside at 30° from the normal (below the
/// critical angle, 41.8°) and at 60° (beyond it).
fn wos() -> [Vec3; 4] {
    [
        dir(30.0, 10.0),
        dir(70.0, 200.0),
        dir(150.0, 45.0),
        dir(120.0, 300.0),
    ]
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

fn sample_dir(b: &RoughDielectric, wo: Vec3) -> impl FnMut(&mut Rng) -> Option<(Vec3, bool)> + '_ {
    move |rng| {
        let ul = rng.uniform();
        b.sample(wo, ul, u2(rng)).map(|s| (s.wi, s.is_delta))
    }
}

fn sample_full(b: &RoughDielectric, wo: Vec3) -> impl FnMut(&mut Rng) -> Option<BsdfSample> + '_ {
    move |rng| {
        let ul = rng.uniform();
        b.sample(wo, ul, u2(rng))
    }
}

/// The index of wi's side over wo's for a transmission.
fn eta_rel(b: &RoughDielectric, wo: Vec3) -> f32 {
    if wo.z > 0.0 {
        b.eta()
    } else {
        1.0 / b.eta()
    }
}

fn chi2_suite(kind: MicrofacetKind) {
    for (k, alpha) in configs().into_iter().filter(|c| c.0 == kind) {
        let b = glass(k, alpha);
        for (i, wo) in wos().into_iter().enumerate() {
            let label = format!("{k:?} α = {alpha}, wo = {wo}");
            let h = histogram(N_COS, N_PHI, N, 100 + i as u64, sample_dir(&b, wo));
            let c = chi2(&h, |wi| f64::from(b.pdf(wo, wi)));
            assert!(c.passes(), "{label}: {c:?} (level {})", significance());
            // ∫ pdf over the sphere = the fraction of draws that return a
            // direction (binomial error, 4 sd, plus the quadrature's 1e-4).
            let f = h.fraction();
            let sd = (f * (1.0 - f) / N as f64).sqrt();
            assert!(c.pdf_mass <= 1.0 + 1e-4, "{label}: ∫ pdf = {}", c.pdf_mass);
            assert!(
                (c.pdf_mass - f).abs() < 4.0 * sd + 1e-4,
                "{label}: ∫ pdf = {}, fraction {f}",
                c.pdf_mass
            );
            let s = consistency(
                20_000,
                7 + i as u64,
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
fn rough_dielectric_ggx_sampling_matches_its_pdf_chi2() {
    chi2_suite(MicrofacetKind::Ggx);
}

#[test]
fn rough_dielectric_beckmann_sampling_matches_its_pdf_chi2() {
    chi2_suite(MicrofacetKind::Beckmann);
}

#[test]
fn rough_dielectric_pdf_integrates_to_the_sampled_fraction_uniform_mc() {
    // The same check as in the χ² suite by an independent estimator: uniform
    // directions, 4 standard errors.
    for (kind, alpha) in configs() {
        let b = glass(kind, alpha);
        for wo in wos() {
            let mass = estimate(400_000, 3, |rng| {
                DVec3::splat(f64::from(b.pdf(wo, sphere(rng))) * 4.0 * PI)
            });
            let frac = estimate(100_000, 4, |rng| {
                let ul = rng.uniform();
                DVec3::splat(if b.sample(wo, ul, u2(rng)).is_some() {
                    1.0
                } else {
                    0.0
                })
            });
            assert!(
                agree(&mass, &frac, 4.0, 0.0),
                "{kind:?} α = {alpha}, wo = {wo}: {mass:?} vs {frac:?}"
            );
            assert!(mass.mean.x <= 1.0 + 4.0 * mass.stderr.x);
        }
    }
}

/// A test-local copy of the transmission Jacobian dω_m/dω_i, right or
/// wrong, and the density `b.pdf` would have with it.
#[derive(Clone, Copy, Debug)]
enum Jacobian {
    /// ηi² |wi·m| / (ηo wo·m + ηi wi·m)² (divided through by ηo²).
    Walter,
    /// The reflection Jacobian 1 / (4 |wi·m|) used for transmission.
    Reflection,
    /// Walter's with the ηi² factor dropped.
    NoEta2,
}

fn pdf_with(b: &RoughDielectric, wo: Vec3, wi: Vec3, jacobian: Jacobian) -> f64 {
    let p = f64::from(b.pdf(wo, wi));
    if p == 0.0 || wo.z * wi.z >= 0.0 {
        return p;
    }
    let eta = f64::from(eta_rel(b, wo));
    let (wo, wi) = (wo.as_dvec3(), wi.as_dvec3());
    let m = (wo + wi * eta).normalize();
    let m = if m.z < 0.0 { -m } else { m };
    let (om, im) = (wo.dot(m), wi.dot(m));
    let denom = (om + eta * im).powi(2);
    let walter = eta * eta * im.abs() / denom;
    let j = match jacobian {
        Jacobian::Walter => walter,
        Jacobian::Reflection => 1.0 / (4.0 * im.abs()),
        Jacobian::NoEta2 => im.abs() / denom,
    };
    p * j / walter
}

#[test]
fn a_wrong_transmission_jacobian_fails_the_chi2_test() {
    for (kind, alpha, wo) in [
        (MicrofacetKind::Ggx, 0.5, dir(30.0, 10.0)),
        (MicrofacetKind::Beckmann, 0.1, dir(150.0, 45.0)),
    ] {
        let b = glass(kind, alpha);
        let h = histogram(N_COS, N_PHI, N, 55, sample_dir(&b, wo));
        let right = chi2(&h, |wi| pdf_with(&b, wo, wi, Jacobian::Walter));
        assert!(right.passes(), "{kind:?} α = {alpha}: {right:?}");
        for wrong in [Jacobian::Reflection, Jacobian::NoEta2] {
            let c = chi2(&h, |wi| pdf_with(&b, wo, wi, wrong));
            assert!(!c.passes(), "{kind:?} α = {alpha}, {wrong:?} passes: {c:?}");
            assert!(
                c.statistic > 2.0 * c.dof as f64,
                "{kind:?} α = {alpha}, {wrong:?}: {c:?}"
            );
            assert!(c.p_value < 1e-12, "{kind:?} α = {alpha}, {wrong:?}: {c:?}");
        }
    }
}

#[test]
fn rough_dielectric_white_furnace() {
    let n = 100_000;
    for (kind, alpha) in configs() {
        let rad = glass(kind, alpha);
        let imp = rad.with_mode(TransportMode::Importance);
        for (i, wo) in wos().into_iter().enumerate() {
            let label = format!("{kind:?} α = {alpha}, wo = {wo}");
            let seed = 10 + i as u64;
            // Importance mode: R + T ≤ 1, through sampling and by uniform directions.
            let sampled = furnace_sampled(n, seed, sample_full(&imp, wo));
            let uniform = furnace_uniform(3 * n, seed + 1, |wi| imp.f(wo, wi));
            assert!(sampled.mean.x <= 1.0 + 1e-3, "{label}: R + T = {:?}", sampled);
            assert!(
                uniform.mean.x <= 1.0 + 4.0 * uniform.stderr.x + 1e-3,
                "{label}: {uniform:?}"
            );
            assert!(
                agree(&sampled, &uniform, 4.0, 1e-3),
                "{label}: {sampled:?} vs {uniform:?}"
            );
            // The rough surface loses energy to masking only: at α = 0.1, a little.
            if alpha == 0.1 && wo.z.abs() < 0.9 {
                assert!(sampled.mean.x > 0.9, "{label}: {sampled:?}");
            }
            // Radiance mode, for light arriving along wi: ∫ f_rad(w, wi) |cos θ(w)| dω ≤ 1
            // over the outgoing w; with wi = wo it is the importance albedo at wo.
            let wi = wo;
            let per_wi = estimate(3 * n, seed + 2, |rng| {
                let w = sphere(rng);
                DVec3::splat(f64::from(rad.f(w, wi).x * w.z.abs()) * 4.0 * PI)
            });
            assert!(
                per_wi.mean.x <= 1.0 + 4.0 * per_wi.stderr.x + 1e-3,
                "{label}: {per_wi:?}"
            );
            assert!(
                agree(&per_wi, &uniform, 4.0, 1e-3),
                "{label}: adjoint {per_wi:?} vs {uniform:?}"
            );
            // Radiance-mode weights average R + (ηo/ηi)² T, which exceeds 1
            // into glass: exactly the importance weights rescaled.
            let k = eta_rel(&rad, wo).powi(-2);
            let rescaled = estimate(n, seed, |rng| {
                let ul = rng.uniform();
                let u = u2(rng);
                match (rad.sample(wo, ul, u), imp.sample(wo, ul, u)) {
                    (Some(r), Some(s)) => {
                        let want = if s.is_transmission { s.weight * k } else { s.weight };
                        assert!((r.weight - want).abs().max_element() <= 1e-6 * want.max_element());
                        r.weight.as_dvec3()
                    }
                    (None, None) => DVec3::ZERO,
                    _ => panic!("{label}: the modes sample differently"),
                }
            });
            let rad_uniform = furnace_uniform(3 * n, seed + 3, |wi| rad.f(wo, wi));
            assert!(
                agree(&rescaled, &rad_uniform, 4.0, 1e-3),
                "{label}: {rescaled:?} vs {rad_uniform:?}"
            );
            // A camera outside sees the glass's inner radiance divided by
            // η²; one inside (below the critical angle) sees the outside's
            // multiplied by η².
            if wo.z > 0.0 {
                assert!(rescaled.mean.x < 1.0, "{label}: {rescaled:?}");
            }
            if alpha == 0.1 && i == 2 {
                assert!(rescaled.mean.x > 1.3, "{label}: {rescaled:?}");
            }
        }
    }
}

#[test]
fn nearly_smooth_glass_conserves_energy_and_reflects_fresnel() {
    // α = 0.01: R + T = 1 to within the masking's ~1e-4, R = F(cos θo).
    let n = 200_000;
    for kind in [MicrofacetKind::Ggx, MicrofacetKind::Beckmann] {
        let b = glass(kind, 0.01).with_mode(TransportMode::Importance);
        for (i, wo) in [
            dir(30.0, 0.0),
            dir(60.0, 90.0),
            dir(150.0, 180.0),
            dir(120.0, 270.0),
        ]
        .into_iter()
        .enumerate()
        {
            let label = format!("{kind:?}, wo = {wo}");
            let mut reflected = 0usize;
            let total = estimate(n, 40 + i as u64, |rng| {
                let ul = rng.uniform();
                match b.sample(wo, ul, u2(rng)) {
                    Some(s) => {
                        reflected += usize::from(!s.is_transmission);
                        s.weight.as_dvec3()
                    }
                    None => DVec3::ZERO,
                }
            });
            assert!((total.mean.x - 1.0).abs() < 1e-3, "{label}: R + T = {:?}", total);
            let r = reflected as f64 / n as f64;
            let fresnel = f64::from(fresnel::dielectric(wo.z, b.eta()).r);
            let sd = (fresnel * (1.0 - fresnel) / n as f64).sqrt();
            assert!(
                (r - fresnel).abs() < 5.0 * sd + 2e-3,
                "{label}: R = {r}, F = {fresnel}"
            );
        }
    }
}

#[test]
fn rough_dielectric_reciprocity() {
    let mut rng = Rng::new(77);
    for (kind, alpha) in configs() {
        let rad = glass(kind, alpha);
        let imp = rad.with_mode(TransportMode::Importance);
        let mut checked = [0usize; 2];
        for _ in 0..20_000 {
            let (wo, wi) = (sphere(&mut rng), sphere(&mut rng));
            let a = f64::from(rad.f(wo, wi).x);
            let b = f64::from(rad.f(wi, wo).x);
            let tol = 1e-5 * a.max(b) + 1e-9;
            if wo.z * wi.z > 0.0 {
                assert!(
                    (a - b).abs() <= tol,
                    "{kind:?} α = {alpha}: reflection {a} vs {b}"
                );
                checked[0] += usize::from(a > 0.0);
            } else {
                // f_rad(wo, wi) / ηo² = f_rad(wi, wo) / ηi².
                let (eta_o, eta_i) = if wo.z > 0.0 { (1.0, 1.5) } else { (1.5, 1.0) };
                let (x, y) = (a / (eta_o * eta_o), b / (eta_i * eta_i));
                // To f32 rounding: the facet and F are computed in f64, so
                // F at wo·m and at wi·m agree even at the critical angle.
                let tol = 1e-5 * x.max(y) + 1e-9;
                assert!(
                    (x - y).abs() <= tol,
                    "{kind:?} α = {alpha}: transmission {a} vs {b}"
                );
                // The importance BSDF is the radiance one's adjoint.
                let adj = f64::from(imp.f(wo, wi).x);
                assert!(
                    (adj - b).abs() <= 1e-5 * adj.max(b) + 1e-9,
                    "{kind:?} α = {alpha}: adjoint {adj} vs {b}"
                );
                checked[1] += usize::from(a > 0.0);
            }
        }
        // Both relations were exercised on nonzero values (Beckmann at
        // α = 0.1 is 0 in f32 beyond ~45° facets, which leaves hundreds).
        assert!(checked.iter().all(|&c| c > 300), "{checked:?}");
    }
}

#[test]
fn rough_dielectric_rejects_bad_indices() {
    let d = MicrofacetDistribution::isotropic(MicrofacetKind::Ggx, 0.2).unwrap();
    let e = RoughDielectric::try_new(d, 1.0, 1.0).unwrap_err();
    assert!(e.to_string().starts_with("int_ior = 1"), "{e}");
    let e = RoughDielectric::try_new(d, 0.0, 1.5).unwrap_err();
    assert!(e.to_string().starts_with("ext_ior = 0"), "{e}");
    let e = RoughDielectric::try_new(d, 1.0, f32::NAN).unwrap_err();
    assert!(e.to_string().starts_with("int_ior = NaN"), "{e}");
    // Grazing and degenerate inputs give zeros, not NaN.
    let b = RoughDielectric::try_new(d, 1.0, 1.5).unwrap();
    assert_eq!(b.f(Vec3::X, Vec3::Z), Vec3::ZERO);
    assert_eq!(b.pdf(Vec3::Z, Vec3::X), 0.0);
    assert!(b.sample(Vec3::X, 0.5, Vec2::splat(0.5)).is_none());
}
