//! The lanes against the scalar `Micro` of a `Conductor` or a GGX
//! `RoughConductor`, lane by lane at every vector level, and known-wrong
//! variants failing the same thresholds.
use super::*;
use crate::bsdf::{metals::METALS, MicrofacetDistribution, MicrofacetKind};
use crate::integrator::scatter::{Micro, MicroModel, MicroSample};
use crate::ray::front_facing;
use crate::sampling::{uniform_sphere, Rng};
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

/// What the lanes gave for a case.
struct Lane {
    wi: V3,
    weight: V3,
    pdf: f32,
    delta: bool,
    valid: bool,
    eval: [(V3, f32); 2],
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

fn random_dir(rng: &mut Rng) -> V3 {
    uniform_sphere(rng.uniform(), rng.uniform())
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
        let ng = random_dir(&mut rng);
        let d = random_dir(&mut rng);
        if ng.dot(d) == 0.0 {
            continue;
        }
        let front = front_facing(ng, d);
        let side = if front { ng } else { -ng };
        let ns = if rng.uniform() < 0.5 {
            ng
        } else {
            (ng + 0.4 * random_dir(&mut rng)).normalize()
        };
        let n = if front { ns } else { -ns };
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
            at: [random_dir(&mut rng), random_dir(&mut rng)],
        };
        if let Some(s) = micro(&c).sample(&mut Rng::new(seed)) {
            c.at[0] = s.wi;
        }
        out.push(c);
    }
    out
}

/// The scalar model's answers: the sample and (f·|cos|, pdf) at `at`.
fn scalar(c: &Case) -> (Option<MicroSample>, [(V3, f32); 2]) {
    let m = micro(c);
    let s = m.sample(&mut Rng::new(c.seed));
    (s, c.at.map(|w| m.eval(w)))
}

/// The level's number of f32 lanes.
struct Width;

impl pulp::WithSimd for Width {
    type Output = usize;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _: S) -> usize {
        S::F32_LANES
    }
}

/// Every case through the lanes under `variant`, at the level's width.
struct Run<'a>(&'a [Case], Variant);

impl pulp::WithSimd for Run<'_> {
    type Output = Vec<Lane>;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) -> Vec<Lane> {
        let Run(cases, variant) = self;
        let mut out = Vec::with_capacity(cases.len());
        for c in cases.chunks(S::F32_LANES) {
            let k = c.len();
            macro_rules! ld {
                ($f:expr) => {{
                    let v: Vec<f32> = c.iter().map($f).collect();
                    simd.partial_load_f32s(&v)
                }};
            }
            macro_rules! ld3 {
                ($f:expr) => {
                    [ld!(|x| $f(x).x), ld!(|x| $f(x).y), ld!(|x| $f(x).z)]
                };
            }
            macro_rules! st {
                ($v:expr) => {{
                    let mut a = vec![0.0f32; k];
                    simd.partial_store_f32s(&mut a, $v);
                    a
                }};
            }
            macro_rules! st3 {
                ($v:expr) => {{
                    let (x, y, z) = (st!($v[0]), st!($v[1]), st!($v[2]));
                    (0..k)
                        .map(|i| V3::new(x[i], y[i], z[i]))
                        .collect::<Vec<_>>()
                }};
            }
            macro_rules! bits {
                ($m:expr) => {
                    st!(simd.select_f32s($m, simd.splat_f32s(1.0), simd.splat_f32s(0.0)))
                };
            }
            // The caller's mask of smooth lanes, from a per-lane flag.
            let smooth =
                simd.greater_than_f32s(ld!(|x| if x.smooth { 1.0 } else { 0.0 }), simd.splat_f32s(0.5));
            let lanes = ConductorLanes::new(
                simd,
                ld3!(|x: &Case| x.d),
                ld3!(|x: &Case| x.n),
                ld3!(|x: &Case| x.side),
                ld3!(|x: &Case| x.eta),
                ld3!(|x: &Case| x.k),
                ld3!(|x: &Case| x.spec),
                // A smooth lane's roughness is not used: 1, as `ConductorParams`.
                ld!(|x| if x.smooth { 1.0 } else { x.alpha_u }),
                ld!(|x| if x.smooth { 1.0 } else { x.alpha_v }),
                smooth,
            );
            // `Micro::sample`'s order: the lobe's number (unused), then the facet's two.
            let us: Vec<[f32; 3]> = c
                .iter()
                .map(|x| {
                    let mut r = Rng::new(x.seed);
                    [r.uniform(), r.uniform(), r.uniform()]
                })
                .collect();
            let u = |j: usize| {
                let v: Vec<f32> = us.iter().map(|u| u[j]).collect();
                simd.partial_load_f32s(&v)
            };
            let s = if variant == Variant::Right {
                lanes.sample(simd, u(1), u(2))
            } else {
                lanes.sample_variant(simd, u(1), u(2), variant)
            };
            let (wi, weight, pdf) = (st3!(s.wi), st3!(s.weight), st!(s.pdf));
            let (delta, valid) = (bits!(s.delta), bits!(s.valid));
            let mut ev = Vec::new();
            for j in 0..2 {
                let at = ld3!(|x: &Case| x.at[j]);
                let (f, p) = if variant == Variant::Right {
                    lanes.eval(simd, at)
                } else {
                    lanes.eval_variant(simd, at, variant)
                };
                ev.push((st3!(f), st!(p)));
            }
            for i in 0..k {
                out.push(Lane {
                    wi: wi[i],
                    weight: weight[i],
                    pdf: pdf[i],
                    delta: delta[i] == 1.0,
                    valid: valid[i] == 1.0,
                    eval: [(ev[0].0[i], ev[0].1[i]), (ev[1].0[i], ev[1].1[i])],
                });
            }
        }
        out
    }
}

/// How far the lanes are from the scalar model.
#[derive(Debug, Default)]
struct Parity {
    cases: usize,
    /// Samples both give (smooth ones of them).
    compared: usize,
    smooth: usize,
    /// Samples where one gives none or they disagree on the delta flag.
    disagree: usize,
    /// The largest angle between the two directions, radians.
    angle: f64,
    /// The largest relative differences of weight (any channel) and pdf.
    weight: f64,
    pdf: f64,
    /// Evaluations where one is zero and the other not.
    eval_disagree: usize,
    eval_compared: usize,
    /// The largest relative differences of f·|cos| (any channel) and pdf.
    eval_f: f64,
    eval_pdf: f64,
    /// Of the compared values, how many are beyond the tolerances.
    beyond: usize,
    /// Coverage: hits whose shading normal leans past the incident ray
    /// (wo.z < 0), samples the scalar model gives none for.
    leaning: usize,
    none: usize,
}

/// Directions within 1e-4 rad, values within 1e-3 relative.
const ANGLE: f64 = 1e-4;
const REL: f64 = 1e-3;

fn rel(a: f32, b: f32) -> f64 {
    let (a, b) = (a as f64, b as f64);
    (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
}

fn rel3(a: V3, b: V3) -> f64 {
    (0..3).map(|i| rel(a[i], b[i])).fold(0.0, f64::max)
}

fn parity(cases: &[Case], lanes: &[Lane]) -> Parity {
    let mut p = Parity {
        cases: cases.len(),
        ..Parity::default()
    };
    for (c, l) in cases.iter().zip(lanes) {
        let (s, e) = scalar(c);
        p.leaning += usize::from(micro(c).wo.z < 0.0);
        p.none += usize::from(s.is_none());
        match s {
            Some(s) if l.valid && l.delta == s.is_delta => {
                p.compared += 1;
                p.smooth += usize::from(s.is_delta);
                let angle = (l.wi.as_dvec3() - s.wi.as_dvec3()).length();
                let (w, pdf) = (rel3(l.weight, s.weight), rel(l.pdf, s.pdf));
                p.angle = p.angle.max(angle);
                p.weight = p.weight.max(w);
                p.pdf = p.pdf.max(pdf);
                if angle > ANGLE || w > REL || pdf > REL {
                    p.beyond += 1;
                }
            }
            None if !l.valid => {}
            _ => p.disagree += 1,
        }
        for (&(sf, sp), &(lf, lp)) in e.iter().zip(&l.eval) {
            let nonzero = |f: V3| f.max_element() > 0.0;
            if nonzero(sf) != nonzero(lf) || (sp > 0.0) != (lp > 0.0) {
                p.eval_disagree += 1;
                continue;
            }
            if !nonzero(sf) && sp == 0.0 {
                continue;
            }
            p.eval_compared += 1;
            let (f, pdf) = (rel3(lf, sf), rel(lp, sp));
            p.eval_f = p.eval_f.max(f);
            p.eval_pdf = p.eval_pdf.max(pdf);
            if f > REL || pdf > REL {
                p.beyond += 1;
            }
        }
    }
    p
}

impl Parity {
    /// At most 0.2 % of the samples disagree on validity or lobe and of
    /// the evaluations on zero; at most 0.2 % of the compared values are
    /// beyond the tolerances.
    fn passes(&self) -> bool {
        let samples = self.disagree * 500 <= self.cases;
        let evals = self.eval_disagree * 500 <= 2 * self.cases;
        let values = self.beyond * 500 <= self.compared + self.eval_compared;
        samples && evals && values
    }
}

#[test]
fn metal_lanes_agree_with_the_scalar_model_and_wrong_ones_do_not() {
    // CONDUCTOR_CASES=131072 for a longer run.
    let count = std::env::var("CONDUCTOR_CASES").map_or(8192, |v| v.parse().unwrap());
    let cases = cases(count, 23);
    let mut arches = levels();
    arches.push(pulp::Arch::new());
    for arch in arches {
        let width = arch.dispatch(Width);
        let got = parity(&cases, &arch.dispatch(Run(&cases, Variant::Right)));
        eprintln!("{width} lanes: {got:?}");
        assert!(got.passes(), "{width} lanes: {got:?}");
        // Enough of each kind was compared.
        assert!(got.compared > cases.len() / 2, "{got:?}");
        assert!(got.smooth > cases.len() / 8, "{got:?}");
        assert!(got.eval_compared > cases.len() / 2, "{got:?}");
        let some = cases.len() / 100;
        assert!(got.leaning > some / 4 && got.none > some, "{got:?}");
        for wrong in [Variant::NoAbsorption, Variant::OneG1] {
            let bad = parity(&cases, &arch.dispatch(Run(&cases, wrong)));
            eprintln!("{width} lanes, {wrong:?}: {bad:?}");
            assert!(!bad.passes(), "{width} lanes, {wrong:?}: {bad:?}");
        }
    }
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
