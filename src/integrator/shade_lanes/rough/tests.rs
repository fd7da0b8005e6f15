//! The lanes against the scalar `Micro` of a `RoughDielectric`, lane by
//! lane at every vector level, and a known-wrong variant failing the same
//! thresholds.
use super::*;
use crate::bsdf::{MicrofacetDistribution, MicrofacetKind, RoughDielectric};
use crate::integrator::scatter::{Micro, MicroModel, MicroSample};
use crate::ray::front_facing;
use crate::sampling::{uniform_sphere, Rng};
use crate::vector_levels as levels;
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

/// What the lanes gave for a case.
struct Lane {
    wi: V3,
    weight: f32,
    pdf: f32,
    transmission: bool,
    valid: bool,
    eval: [(f32, f32); 2],
}

fn micro(c: &Case) -> Micro<'static> {
    let dist = MicrofacetDistribution::try_new(MicrofacetKind::Ggx, c.alpha_u, c.alpha_v).unwrap();
    let model = RoughDielectric::try_new(dist, c.n1, c.n2).unwrap();
    Micro::new(MicroModel::RoughDielectric(model), c.n, c.d, c.side, None)
}

fn random_dir(rng: &mut Rng) -> V3 {
    uniform_sphere(rng.uniform(), rng.uniform())
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
fn scalar(c: &Case) -> (Option<MicroSample>, [(f32, f32); 2]) {
    let m = micro(c);
    let s = m.sample(&mut Rng::new(c.seed));
    let e = c.at.map(|w| {
        let (f, pdf) = m.eval(w);
        (f.x, pdf)
    });
    (s, e)
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
            macro_rules! bits {
                ($m:expr) => {
                    st!(simd.select_f32s($m, simd.splat_f32s(1.0), simd.splat_f32s(0.0)))
                };
            }
            let lanes = RoughLanes::new(
                simd,
                ld3!(|x: &Case| x.d),
                ld3!(|x: &Case| x.n),
                ld3!(|x: &Case| x.side),
                ld!(|x| x.n1),
                ld!(|x| x.n2),
                ld!(|x| x.alpha_u),
                ld!(|x| x.alpha_v),
            );
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
                lanes.sample(simd, u(0), u(1), u(2))
            } else {
                lanes.sample_variant(simd, u(0), u(1), u(2), variant)
            };
            let (wx, wy, wz) = (st!(s.wi[0]), st!(s.wi[1]), st!(s.wi[2]));
            let (weight, pdf) = (st!(s.weight), st!(s.pdf));
            let (tr, valid) = (bits!(s.transmission), bits!(s.valid));
            let mut ev = Vec::new();
            for j in 0..2 {
                let at = ld3!(|x: &Case| x.at[j]);
                let (f, p) = if variant == Variant::Right {
                    lanes.eval(simd, at)
                } else {
                    lanes.eval_variant(simd, at, variant)
                };
                ev.push((st!(f), st!(p)));
            }
            for i in 0..k {
                out.push(Lane {
                    wi: V3::new(wx[i], wy[i], wz[i]),
                    weight: weight[i],
                    pdf: pdf[i],
                    transmission: tr[i] == 1.0,
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
    /// Samples both give, of the same lobe.
    compared: usize,
    /// Samples where one gives none or they pick different lobes.
    disagree: usize,
    /// The largest angle between the two directions, radians.
    angle: f64,
    /// The largest relative differences of weight and pdf.
    weight: f64,
    pdf: f64,
    /// Evaluations where one is zero and the other not.
    eval_disagree: usize,
    eval_compared: usize,
    /// The largest relative differences of f·|cos| and pdf.
    eval_f: f64,
    eval_pdf: f64,
    /// Of the compared values, how many are beyond the tolerances.
    beyond: usize,
    /// Coverage: hits whose shading normal leans past the incident ray
    /// (wo.z < 0), samples the scalar model gives none for, compared
    /// transmissions, compared reflections under total internal reflection.
    leaning: usize,
    none: usize,
    transmissions: usize,
    tir: usize,
}

/// Directions within 1e-4 rad, values within 1e-3 relative.
const ANGLE: f64 = 1e-4;
const REL: f64 = 1e-3;

fn rel(a: f32, b: f32) -> f64 {
    let (a, b) = (a as f64, b as f64);
    (a - b).abs() / b.abs().max(f64::MIN_POSITIVE)
}

fn parity(cases: &[Case], lanes: &[Lane]) -> Parity {
    let mut p = Parity {
        cases: cases.len(),
        ..Parity::default()
    };
    for (c, l) in cases.iter().zip(lanes) {
        let (s, e) = scalar(c);
        let m = micro(c);
        p.leaning += usize::from(m.wo.z < 0.0);
        p.none += usize::from(s.is_none());
        match s {
            Some(s) if l.valid && l.transmission == s.is_transmission => {
                p.compared += 1;
                p.transmissions += usize::from(s.is_transmission);
                // Coverage: reflections off a facet past the critical angle.
                let wo = m.wo;
                let wi = m.frame.to_local(glam::Vec3::from(s.wi));
                let h = (wo + wi).normalize();
                let (eta_o, eta_b) = if wo.z > 0.0 { (c.n1, c.n2) } else { (c.n2, c.n1) };
                let sin2 = (eta_o / eta_b).powi(2) * (1.0 - wo.dot(h).powi(2));
                p.tir += usize::from(!s.is_transmission && sin2 > 1.0);
                let angle = (l.wi.as_dvec3() - s.wi.as_dvec3()).length();
                let (w, pdf) = (rel(l.weight, s.weight.x), rel(l.pdf, s.pdf));
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
            if (sf > 0.0) != (lf > 0.0) || (sp > 0.0) != (lp > 0.0) {
                p.eval_disagree += 1;
                continue;
            }
            if sf == 0.0 && sp == 0.0 {
                continue;
            }
            p.eval_compared += 1;
            let (f, pdf) = (rel(lf, sf), rel(lp, sp));
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
    /// At most 0.2 % of the samples disagree on lobe or validity and of
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
fn rough_glass_lanes_agree_with_the_scalar_model_and_wrong_ones_do_not() {
    // ROUGH_CASES=131072 for a longer run.
    let count = std::env::var("ROUGH_CASES").map_or(8192, |v| v.parse().unwrap());
    let cases = cases(count, 17);
    let mut arches = levels();
    arches.push(pulp::Arch::new());
    for arch in arches {
        let width = arch.dispatch(Width);
        let got = parity(&cases, &arch.dispatch(Run(&cases, Variant::Right)));
        eprintln!("{width} lanes: {got:?}");
        assert!(got.passes(), "{width} lanes: {got:?}");
        // Enough of each kind was compared.
        assert!(got.compared > cases.len() * 3 / 4, "{got:?}");
        assert!(got.eval_compared > cases.len() * 3 / 4, "{got:?}");
        let some = cases.len() / 100;
        assert!(
            got.leaning > some / 4 && got.none > some && got.tir > some,
            "{got:?}"
        );
        assert!(got.transmissions > cases.len() / 4, "{got:?}");
        for wrong in [Variant::HalfFresnel, Variant::NoEta2] {
            let bad = parity(&cases, &arch.dispatch(Run(&cases, wrong)));
            eprintln!("{width} lanes, {wrong:?}: {bad:?}");
            assert!(!bad.passes(), "{width} lanes, {wrong:?}: {bad:?}");
        }
    }
}

#[test]
fn beckmann_stays_scalar() {
    let ggx = MicrofacetDistribution::try_new(MicrofacetKind::Ggx, 0.1, 0.3).unwrap();
    let beckmann = MicrofacetDistribution::isotropic(MicrofacetKind::Beckmann, 0.1).unwrap();
    assert!(supports(&ggx) && !supports(&beckmann));
}
