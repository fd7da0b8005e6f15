//! The lanes against the scalar `Micro` of a `Plastic` or a GGX
//! `RoughPlastic`, lane by lane at every vector level, and known-wrong
//! variants failing the same thresholds.
use super::super::lane_check::{
    at_every_level, eval_dirs, load, load3, load_mask, micro_numbers, parity, random_hit, LaneCase,
    LaneModel, LaneVectors, Run, Scalar,
};
use super::*;
use crate::bsdf::{MicrofacetDistribution, MicrofacetKind, Plastic, PlasticParams};
use crate::integrator::scatter::{Micro, MicroModel};
use crate::sampling::Rng;
use glam::{Vec3, Vec3A as V3};
use std::sync::Arc;

/// One hit and what is asked of it.
struct Case {
    d: V3,
    /// The shading normal oriented to the incident side.
    n: V3,
    side: V3,
    material: Material,
    /// The seed of the generator `Micro::sample` draws its three numbers from.
    seed: u64,
    /// Where to evaluate: the scalar's sampled direction (a random one
    /// where it gave none) and a random direction.
    at: [V3; 2],
}

fn micro(c: &Case) -> Micro<'_> {
    let model = match &c.material {
        Material::Plastic { bsdf, .. } => MicroModel::Plastic(*bsdf),
        Material::RoughPlastic { bsdf, .. } => MicroModel::RoughPlastic(bsdf),
        _ => unreachable!("plastics only"),
    };
    Micro::new(model, c.n, c.d, c.side, None)
}

/// Rough coatings, shared by the rough cases through `with_base` (a
/// coating's tables take 0.06 s to build): GGX roughnesses from nearly
/// smooth to very rough, coating indices above and below the outside's.
fn coatings() -> Vec<RoughPlastic> {
    [(0.05, 1.49), (0.2, 1.49), (0.5, 1.3), (0.8, 1.8), (0.3, 0.75)]
        .into_iter()
        .map(|(alpha, int_ior)| {
            let d = MicrofacetDistribution::isotropic(MicrofacetKind::Ggx, alpha).unwrap();
            let params = PlasticParams {
                int_ior,
                ext_ior: 1.0,
                ..PlasticParams::default()
            };
            RoughPlastic::try_new(&params, d).unwrap()
        })
        .collect()
}

/// `count` random hits as `Bsdf::at` orients them (a one-sided plastic's
/// back is never asked): half smooth plastics with a coating index in
/// [1.05, 2.5] (in [0.6, 0.95] at one in eight: the coating reflects
/// totally past its critical angle), half rough ones over the shared
/// coatings; random base albedos, the reflectance factor random or 1,
/// linear or not.
fn cases(count: usize, seed: u64) -> Vec<Case> {
    let coats = coatings();
    let mut rng = Rng::new(seed);
    let mut out = Vec::with_capacity(count);
    while out.len() < count {
        let Some((d, n, side)) = random_hit(&mut rng) else {
            continue;
        };
        let k = out.len();
        let mut u3 = || Vec3::new(rng.uniform(), rng.uniform(), rng.uniform());
        let diffuse = u3();
        let specular = if k % 4 == 0 { Vec3::ONE } else { u3() };
        let nonlinear = k % 3 == 0;
        let material = if k % 2 == 0 {
            let int_ior = if k % 16 == 0 {
                0.6 + 0.35 * rng.uniform()
            } else {
                1.05 + 1.45 * rng.uniform()
            };
            let params = PlasticParams {
                int_ior,
                ext_ior: 1.0,
                diffuse_reflectance: diffuse,
                specular_reflectance: specular,
                nonlinear,
            };
            Material::Plastic {
                bsdf: Plastic::try_new(&params).unwrap(),
                two_sided: true,
            }
        } else {
            let coat = &coats[k / 2 % coats.len()];
            Material::RoughPlastic {
                bsdf: Arc::new(coat.with_base(diffuse, specular, nonlinear).unwrap()),
                two_sided: true,
            }
        };
        let seed = 0x91a5_0000 + k as u64;
        let mut c = Case {
            d,
            n,
            side,
            material,
            seed,
            at: [V3::ZERO; 2],
        };
        let at = eval_dirs(&mut rng, &micro(&c), seed);
        c.at = at;
        out.push(c);
    }
    out
}

/// Plastics through the lanes under a variant.
struct Plastics(Variant);

impl LaneModel for Plastics {
    type Case = Case;

    #[inline(always)]
    fn vectors<S: pulp::Simd>(&self, simd: S, c: &[Case]) -> LaneVectors<S> {
        let params: Vec<PlasticLaneParams<'_>> = c
            .iter()
            .map(|x| PlasticLaneParams::of(&x.material).expect("a plastic the lanes model"))
            .collect();
        let ld = |f: fn(&PlasticLaneParams<'_>) -> f32| load(simd, params.iter().map(f));
        let ld3 = |f: fn(&PlasticLaneParams<'_>) -> Vec3| load3(simd, params.iter().map(|x| V3::from(f(x))));
        let at = |f: fn(&Case) -> V3| load3(simd, c.iter().map(f));
        let coats: Vec<Option<&RoughPlastic>> = params.iter().map(|x| x.rough.map(|r| &**r)).collect();
        let lanes = PlasticLanes::new(
            simd,
            at(|x| x.d),
            at(|x| x.n),
            at(|x| x.side),
            ld(|x| x.terms.eta),
            ld3(|x| x.terms.base),
            ld3(|x| x.terms.specular),
            ld(|x| x.terms.specular_sampling_weight),
            ld(|x| x.alpha),
            load_mask(simd, params.iter().map(|x| x.rough.is_none())),
            &coats,
            self.0,
        );
        let [u_lobe, u1, u2] = micro_numbers(simd, c.iter().map(|x| x.seed));
        let s = lanes.sample(simd, u_lobe, u1, u2);
        let eval = [0, 1].map(|j| lanes.eval(simd, load3(simd, c.iter().map(|x| x.at[j]))));
        LaneVectors::reflection(s, eval)
    }
}

impl LaneCase for Case {
    fn scalar(&self) -> Scalar {
        Scalar::of(&micro(self), self.seed, self.at)
    }
}

#[test]
fn plastic_lanes_agree_with_the_scalar_model_and_wrong_ones_do_not() {
    // PLASTIC_CASES=131072 for a longer run.
    let count = std::env::var("PLASTIC_CASES").map_or(8192, |v| v.parse().unwrap());
    let cases = cases(count, 29);
    let n = cases.len();
    at_every_level(
        Variant::Right,
        &[Variant::HalfFresnel, Variant::NoEta2],
        |arch, v| {
            let lanes = arch.dispatch(Run(&cases, Plastics(v)));
            // (The lobe flag: a delta reflection.)
            (parity(&cases, &lanes, |x| x.is_delta), ())
        },
        // Samples (the smooth coating's delta reflections among them) and
        // evaluations.
        |got, ()| got.covers(n / 2, n / 50, n / 2),
    );
}

#[test]
fn params_take_smooth_and_ggx_plastics_and_leave_beckmann() {
    let smooth = Material::Plastic {
        bsdf: Plastic::try_new(&PlasticParams::default()).unwrap(),
        two_sided: true,
    };
    let p = PlasticLaneParams::of(&smooth).unwrap();
    assert!(p.rough.is_none() && p.two_sided);
    assert_eq!(p.terms.eta, 1.49 / 1.000277);
    let rough = |kind| {
        let d = MicrofacetDistribution::isotropic(kind, 0.3).unwrap();
        Material::RoughPlastic {
            bsdf: Arc::new(RoughPlastic::try_new(&PlasticParams::default(), d).unwrap()),
            two_sided: false,
        }
    };
    let ggx = rough(MicrofacetKind::Ggx);
    let p = PlasticLaneParams::of(&ggx).unwrap();
    assert!(p.rough.is_some() && !p.two_sided && p.alpha == 0.3);
    assert!(PlasticLaneParams::of(&rough(MicrofacetKind::Beckmann)).is_none());
    assert!(PlasticLaneParams::of(&Material::Black).is_none());
}
