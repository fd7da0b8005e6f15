//! The lanes against the scalar `Micro` of a `Conductor` or a GGX
//! `RoughConductor`, lane by lane at every vector level, and known-wrong
//! variants failing the same thresholds.
use super::super::lane_check::{
    at_every_level, eval_dirs, load, load3, load_mask, micro_numbers, parity, random_hit, LaneCase,
    LaneModel, LaneVectors, Run, Scalar,
};
use super::*;
use crate::bsdf::{metals::METALS, MicrofacetDistribution, MicrofacetKind};
use crate::integrator::scatter::{Micro, MicroModel};
use crate::sampling::Rng;
use crate::vector_levels as levels;
use glam::{Vec3, Vec3A as V3};

/// One hit and what is asked of it.
struct Case {
    d: V3,
    /// The shading normal oriented to the incident side.
    n: V3,
    side: V3,
    eta: V3,
    k: V3,
    spec: V3,
    alpha_u: f32,
    alpha_v: f32,
    smooth: bool,
    /// The seed of the generator `Micro::sample` draws its three numbers from.
    seed: u64,
    /// Where to evaluate: the scalar's sampled direction (a random one
    /// where it gave none) and a random direction.
    at: [V3; 2],
}

fn micro(c: &Case) -> Micro<'static> {
    let (eta, k, spec) = (Vec3::from(c.eta), Vec3::from(c.k), Vec3::from(c.spec));
    let model = if c.smooth {
        MicroModel::Conductor(Conductor::try_new(eta, k, spec).unwrap())
    } else {
        let dist = MicrofacetDistribution::try_new(MicrofacetKind::Ggx, c.alpha_u, c.alpha_v).unwrap();
        MicroModel::RoughConductor(RoughConductor::try_new(dist, eta, k, spec).unwrap())
    };
    Micro::new(model, c.n, c.d, c.side, None)
}

/// `count` random hits as `Bsdf::at` orients them (a one-sided metal's
/// back is never asked, so every hit is a front or a two-sided back): half
/// with the shading normal tilted off the geometric one (so that it
/// sometimes leans past the incident ray); half of the metals from the
/// named table with a random reflectance factor (or 1), half with random
/// η in [0.05, 3] and κ in [0, 8] (κ = 0 at one in eight: a dielectric);
/// a quarter smooth, the others with roughnesses in [0.05, 0.8], half of
/// them anisotropic.
fn cases(count: usize, seed: u64) -> Vec<Case> {
    let mut rng = Rng::new(seed);
    let mut out = Vec::with_capacity(count);
    while out.len() < count {
        let Some((d, n, side)) = random_hit(&mut rng) else {
            continue;
        };
        let mut u3 = || V3::new(rng.uniform(), rng.uniform(), rng.uniform());
        let (eta, k, spec) = if out.len() % 2 == 0 {
            let m = &METALS[out.len() / 2 % METALS.len()];
            let spec = if out.len() % 4 == 0 { V3::ONE } else { u3() };
            (V3::from(m.eta), V3::from(m.k), spec)
        } else {
            let eta = V3::splat(0.05) + 2.95 * u3();
            let k = if out.len() % 8 == 1 { V3::ZERO } else { 8.0 * u3() };
            (eta, k, u3())
        };
        let smooth = rng.uniform() < 0.25;
        let alpha_u = 0.05 + 0.75 * rng.uniform();
        let alpha_v = if rng.uniform() < 0.5 {
            alpha_u
        } else {
            0.05 + 0.75 * rng.uniform()
        };
        let seed = 0xc0_0000 + out.len() as u64;
        let mut c = Case {
            d,
            n,
            side,
            eta,
            k,
            spec,
            alpha_u,
            alpha_v,
            smooth,
            seed,
            at: [V3::ZERO; 2],
        };
        let at = eval_dirs(&mut rng, &micro(&c), seed);
        c.at = at;
        out.push(c);
    }
    out
}

/// Metals through the lanes under a variant.
struct Metals(Variant);

impl LaneModel for Metals {
    type Case = Case;

    #[inline(always)]
    fn vectors<S: pulp::Simd>(&self, simd: S, c: &[Case]) -> LaneVectors<S> {
        let variant = self.0;
        let ld = |f: fn(&Case) -> f32| load(simd, c.iter().map(f));
        let ld3 = |f: fn(&Case) -> V3| load3(simd, c.iter().map(f));
        let lanes = ConductorLanes::new(
            simd,
            ld3(|x| x.d),
            ld3(|x| x.n),
            ld3(|x| x.side),
            ld3(|x| x.eta),
            ld3(|x| x.k),
            ld3(|x| x.spec),
            // A smooth lane's roughness is not used: 1, as `ConductorParams`.
            ld(|x| if x.smooth { 1.0 } else { x.alpha_u }),
            ld(|x| if x.smooth { 1.0 } else { x.alpha_v }),
            load_mask(simd, c.iter().map(|x| x.smooth)),
        );
        // `Micro::sample`'s order: the lobe's number (unused), then the facet's two.
        let [_, u1, u2] = micro_numbers(simd, c.iter().map(|x| x.seed));
        let s = if variant == Variant::Right {
            lanes.sample(simd, u1, u2)
        } else {
            lanes.sample_variant(simd, u1, u2, variant)
        };
        let eval = [0, 1].map(|j| {
            let at = load3(simd, c.iter().map(|x| x.at[j]));
            if variant == Variant::Right {
                lanes.eval(simd, at)
            } else {
                lanes.eval_variant(simd, at, variant)
            }
        });
        LaneVectors::reflection(s, eval)
    }
}

impl LaneCase for Case {
    fn scalar(&self) -> Scalar {
        Scalar::of(&micro(self), self.seed, self.at)
    }
}

#[test]
fn metal_lanes_agree_with_the_scalar_model_and_wrong_ones_do_not() {
    // CONDUCTOR_CASES=131072 for a longer run.
    let count = std::env::var("CONDUCTOR_CASES").map_or(8192, |v| v.parse().unwrap());
    let cases = cases(count, 23);
    let n = cases.len();
    at_every_level(
        Variant::Right,
        &[Variant::NoAbsorption, Variant::OneG1],
        |arch, v| {
            let lanes = arch.dispatch(Run(&cases, Metals(v)));
            // (The lobe flag: a delta reflection.)
            (parity(&cases, &lanes, |x| x.is_delta), ())
        },
        // Samples (smooth ones among them) and evaluations.
        |got, ()| got.covers(n / 2, n / 8, n / 2),
    );
}

/// The lanes' Fresnel term against `fresnel::conductor_channel` (f64) over
/// the named metals, random indices and the whole range of angles,
/// grazing and normal incidence included: within 1e-4 relative (absolute
/// below a reflectance of 1e-3). The worst is a κ = 0, η < 1 index near
/// its critical angle, where R has a square-root slope in cos θ and the
/// f32 sin²θ's rounding shows; the named metals are far from that.
#[test]
fn f32_fresnel_is_within_1e_4_of_the_f64_closed_form() {
    struct Check(Vec<(f32, f32, f32)>);
    impl pulp::WithSimd for Check {
        type Output = (f64, (f32, f32, f32));
        #[inline(always)]
        fn with_simd<S: pulp::Simd>(self, simd: S) -> (f64, (f32, f32, f32)) {
            let mut worst = (0.0f64, (0.0, 0.0, 0.0));
            for c in self.0.chunks(S::F32_LANES) {
                let ld = |j: usize| {
                    let v: Vec<f32> = c.iter().map(|x| [x.0, x.1, x.2][j]).collect();
                    simd.partial_load_f32s(&v)
                };
                let r = fresnel_channel(simd, ld(0), ld(1), ld(2));
                let mut out = vec![0.0f32; c.len()];
                simd.partial_store_f32s(&mut out, r);
                for (x, r) in c.iter().zip(out) {
                    let exact = crate::bsdf::fresnel::conductor_channel(x.0 as f64, x.1 as f64, x.2 as f64);
                    let e = (r as f64 - exact).abs() / exact.max(1e-3);
                    if e > worst.0 {
                        worst = (e, *x);
                    }
                }
            }
            worst
        }
    }
    let mut rng = Rng::new(5);
    let mut v = Vec::new();
    let cosines = |rng: &mut Rng| [0.0, 1e-6, 0.5 * rng.uniform(), rng.uniform(), 1.0];
    for m in METALS {
        for i in 0..3 {
            for c in cosines(&mut rng) {
                v.push((c, m.eta[i], m.k[i]));
            }
        }
    }
    for _ in 0..4000 {
        let (eta, k) = (0.05 + 2.95 * rng.uniform(), 8.0 * rng.uniform());
        for c in cosines(&mut rng) {
            v.push((c, eta, k));
            v.push((c, eta, 0.0));
        }
    }
    for arch in levels() {
        let worst = arch.dispatch(Check(v.clone()));
        eprintln!(
            "worst relative error {:.2e} at (cos, η, κ) = {:?}",
            worst.0, worst.1
        );
        assert!(worst.0 < 1e-4, "{worst:?}");
    }
}

#[test]
fn params_take_smooth_and_ggx_metals_and_leave_beckmann() {
    let c = Conductor::try_new(Vec3::splat(0.2), Vec3::splat(3.0), Vec3::ONE).unwrap();
    let p = ConductorParams::of(&Material::Conductor {
        bsdf: c,
        two_sided: true,
    })
    .unwrap();
    assert!(p.smooth && p.two_sided && p.k == V3::splat(3.0));
    let rough = |kind| {
        let d = MicrofacetDistribution::try_new(kind, 0.1, 0.3).unwrap();
        Material::RoughConductor {
            bsdf: RoughConductor::try_new(d, Vec3::ONE, Vec3::ONE, Vec3::splat(0.5)).unwrap(),
            two_sided: false,
        }
    };
    let p = ConductorParams::of(&rough(MicrofacetKind::Ggx)).unwrap();
    assert!(!p.smooth && !p.two_sided && (p.alpha_u, p.alpha_v) == (0.1, 0.3));
    assert_eq!(p.specular_reflectance, V3::splat(0.5));
    assert!(ConductorParams::of(&rough(MicrofacetKind::Beckmann)).is_none());
    assert!(ConductorParams::of(&Material::Black).is_none());
}
