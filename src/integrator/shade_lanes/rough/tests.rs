//! The lanes against the scalar `Micro` of a `RoughDielectric`, lane by
//! lane at every vector level, and a known-wrong variant failing the same
//! thresholds.
use super::super::lane_check::{
    at_every_level, eval_dirs, load, load3, micro_numbers, random_hit, Lane, LaneModel, LaneVectors, Parity,
    Run, Scalar,
};
use super::*;
use crate::bsdf::{MicrofacetDistribution, MicrofacetKind, RoughDielectric};
use crate::integrator::scatter::{Micro, MicroModel};
use crate::sampling::Rng;
use glam::Vec3A as V3;

/// One hit and what is asked of it.
struct Case {
    d: V3,
    /// The shading normal oriented to the incident side.
    n: V3,
    side: V3,
    n1: f32,
    n2: f32,
    alpha_u: f32,
    alpha_v: f32,
    /// The seed of the generator `Micro::sample` draws its three numbers from.
    seed: u64,
    /// Where to evaluate: the scalar's sampled direction (a random one
    /// where it gave none) and a random direction.
    at: [V3; 2],
}

fn micro(c: &Case) -> Micro<'static> {
    let dist = MicrofacetDistribution::try_new(MicrofacetKind::Ggx, c.alpha_u, c.alpha_v).unwrap();
    let model = RoughDielectric::try_new(dist, c.n1, c.n2).unwrap();
    Micro::new(MicroModel::RoughDielectric(model), c.n, c.d, c.side, None)
}

/// `count` random hits as `Bsdf::at` orients them: half with the shading
/// normal tilted off the geometric one (so that it sometimes leans past
/// the incident ray), indices in [1, 2.5] on either side (n1 > n2: total
/// internal reflection at some facets) differing by more than 2 %,
/// roughnesses in [0.05, 0.8], half of them anisotropic.
fn cases(count: usize, seed: u64) -> Vec<Case> {
    let mut rng = Rng::new(seed);
    let mut out = Vec::with_capacity(count);
    while out.len() < count {
        let Some((d, n, side)) = random_hit(&mut rng) else {
            continue;
        };
        let (n1, n2) = (1.0 + 1.5 * rng.uniform(), 1.0 + 1.5 * rng.uniform());
        if (n1 / n2 - 1.0).abs() < 0.02 {
            continue;
        }
        let alpha_u = 0.05 + 0.75 * rng.uniform();
        let alpha_v = if rng.uniform() < 0.5 {
            alpha_u
        } else {
            0.05 + 0.75 * rng.uniform()
        };
        let seed = 0x5eed_0000 + out.len() as u64;
        let mut c = Case {
            d,
            n,
            side,
            n1,
            n2,
            alpha_u,
            alpha_v,
            seed,
            at: [V3::ZERO; 2],
        };
        let at = eval_dirs(&mut rng, &micro(&c), seed);
        c.at = at;
        out.push(c);
    }
    out
}

/// Rough glass through the lanes under a variant.
struct Glass(Variant);

impl LaneModel for Glass {
    type Case = Case;

    #[inline(always)]
    fn vectors<S: pulp::Simd>(&self, simd: S, c: &[Case]) -> LaneVectors<S> {
        let variant = self.0;
        let ld = |f: fn(&Case) -> f32| load(simd, c.iter().map(f));
        let ld3 = |f: fn(&Case) -> V3| load3(simd, c.iter().map(f));
        let lanes = RoughLanes::new(
            simd,
            ld3(|x| x.d),
            ld3(|x| x.n),
            ld3(|x| x.side),
            ld(|x| x.n1),
            ld(|x| x.n2),
            ld(|x| x.alpha_u),
            ld(|x| x.alpha_v),
        );
        let [u_lobe, u1, u2] = micro_numbers(simd, c.iter().map(|x| x.seed));
        let s = if variant == Variant::Right {
            lanes.sample(simd, u_lobe, u1, u2)
        } else {
            lanes.sample_variant(simd, u_lobe, u1, u2, variant)
        };
        // Rough glass is grey: its values in every channel.
        let grey = |x: S::f32s| [x, x, x];
        let eval = [0, 1].map(|j| {
            let at = load3(simd, c.iter().map(|x| x.at[j]));
            let (f, p) = if variant == Variant::Right {
                lanes.eval(simd, at)
            } else {
                lanes.eval_variant(simd, at, variant)
            };
            (grey(f), p)
        });
        LaneVectors {
            wi: s.wi,
            weight: grey(s.weight),
            pdf: s.pdf,
            flag: s.transmission,
            valid: s.valid,
            eval,
        }
    }
}

/// The lanes against the scalar model, case by case (the lobe flag: a
/// transmission), and how many of the compared samples are reflections
/// off a facet past the critical angle (coverage).
fn parity(cases: &[Case], lanes: &[Lane]) -> (Parity, usize) {
    let mut p = Parity::default();
    let mut tir = 0;
    for (c, l) in cases.iter().zip(lanes) {
        let m = micro(c);
        let scalar = Scalar::of(&m, c.seed, c.at);
        let Some(s) = p.add(&scalar, |x| x.is_transmission, l) else {
            continue;
        };
        let wo = m.wo;
        let wi = m.frame.to_local(glam::Vec3::from(s.wi));
        let h = (wo + wi).normalize();
        let (eta_o, eta_b) = if wo.z > 0.0 { (c.n1, c.n2) } else { (c.n2, c.n1) };
        let sin2 = (eta_o / eta_b).powi(2) * (1.0 - wo.dot(h).powi(2));
        tir += usize::from(!s.is_transmission && sin2 > 1.0);
    }
    (p, tir)
}

#[test]
fn rough_glass_lanes_agree_with_the_scalar_model_and_wrong_ones_do_not() {
    // ROUGH_CASES=131072 for a longer run.
    let count = std::env::var("ROUGH_CASES").map_or(8192, |v| v.parse().unwrap());
    let cases = cases(count, 17);
    let n = cases.len();
    at_every_level(
        Variant::Right,
        &[Variant::HalfFresnel, Variant::NoEta2],
        |arch, v| parity(&cases, &arch.dispatch(Run(&cases, Glass(v)))),
        // Samples (transmissions among them), evaluations, and reflections
        // past the critical angle.
        |got, &tir| got.covers(n * 3 / 4, n / 4, n * 3 / 4) && tir > n / 100,
    );
}

#[test]
fn beckmann_stays_scalar() {
    let ggx = MicrofacetDistribution::try_new(MicrofacetKind::Ggx, 0.1, 0.3).unwrap();
    let beckmann = MicrofacetDistribution::isotropic(MicrofacetKind::Beckmann, 0.1).unwrap();
    assert!(supports(&ggx) && !supports(&beckmann));
}
