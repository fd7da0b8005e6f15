//! What the lane models' tests share ([`super::conductor`],
//! [`super::plastic`], [`super::rough`]): random hits as `Bsdf::at`
//! orients them, and the comparison of a model's lanes with the scalar
//! `Micro` lane by lane, with its thresholds.
use super::ggx::ReflectionSample;
use crate::integrator::scatter::{Micro, MicroSample};
use crate::ray::front_facing;
use crate::sampling::{uniform_sphere, Rng};
use glam::Vec3A as V3;
use std::fmt::Debug;

pub(super) fn random_dir(rng: &mut Rng) -> V3 {
    uniform_sphere(rng.uniform(), rng.uniform())
}

/// A random hit as `Bsdf::at` orients it: the incident direction, the
/// shading normal on the incident side and the geometric one; half with
/// the shading normal tilted off the geometric one (so that it sometimes
/// leans past the incident ray). `None` for a ray along the surface.
pub(super) fn random_hit(rng: &mut Rng) -> Option<(V3, V3, V3)> {
    let ng = random_dir(rng);
    let d = random_dir(rng);
    if ng.dot(d) == 0.0 {
        return None;
    }
    let front = front_facing(ng, d);
    let side = if front { ng } else { -ng };
    let ns = if rng.uniform() < 0.5 {
        ng
    } else {
        (ng + 0.4 * random_dir(rng)).normalize()
    };
    Some((d, if front { ns } else { -ns }, side))
}

/// `Micro::sample`'s three uniform numbers from the generators of
/// `seeds`, in its order, as vectors.
#[inline(always)]
pub(super) fn micro_numbers<S: pulp::Simd>(simd: S, seeds: impl Iterator<Item = u64>) -> [S::f32s; 3] {
    let us: Vec<[f32; 3]> = seeds
        .map(|seed| {
            let mut r = Rng::new(seed);
            [r.uniform(), r.uniform(), r.uniform()]
        })
        .collect();
    [0, 1, 2].map(|j| load(simd, us.iter().map(|u| u[j])))
}

/// A case of a lane model's test: a hit and the directions it is evaluated at.
pub(super) trait LaneCase {
    /// The scalar model's answers.
    fn scalar(&self) -> Scalar;
}

/// The lanes against the scalar model, case by case (`flag`: the scalar
/// sample's lobe flag).
pub(super) fn parity<C: LaneCase>(cases: &[C], lanes: &[Lane], flag: fn(&MicroSample) -> bool) -> Parity {
    let mut p = Parity::default();
    for (c, l) in cases.iter().zip(lanes) {
        p.add(&c.scalar(), flag, l);
    }
    p
}

/// A lane model under test (with its variant): what the lanes answer for
/// a vector's worth of its cases.
pub(super) trait LaneModel {
    type Case;
    fn vectors<S: pulp::Simd>(&self, simd: S, cases: &[Self::Case]) -> LaneVectors<S>;
}

/// Every case through the model's lanes, at the level's width.
pub(super) struct Run<'a, M: LaneModel>(pub &'a [M::Case], pub M);

impl<M: LaneModel> pulp::WithSimd for Run<'_, M> {
    type Output = Vec<Lane>;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) -> Vec<Lane> {
        let Run(cases, model) = self;
        let mut out = Vec::with_capacity(cases.len());
        for c in cases.chunks(S::F32_LANES) {
            out.extend(model.vectors(simd, c).store(simd, c.len()));
        }
        out
    }
}

/// Where a case is evaluated: the direction `micro` samples from the
/// generator of `seed` (a random one where it gives none) and a random
/// direction.
pub(super) fn eval_dirs(rng: &mut Rng, micro: &Micro<'_>, seed: u64) -> [V3; 2] {
    let mut at = [random_dir(rng), random_dir(rng)];
    if let Some(s) = micro.sample(&mut Rng::new(seed)) {
        at[0] = s.wi;
    }
    at
}

/// A lane model's check at every vector level (and at pulp's widest on
/// this machine): under `right`, `parity` passes and `coverage` holds
/// (enough of each kind was compared; `T`: the test's own counts); under
/// each of `wrongs`, it fails.
pub(super) fn at_every_level<V: Copy + Debug, T: Debug>(
    right: V,
    wrongs: &[V],
    parity: impl Fn(pulp::Arch, V) -> (Parity, T),
    coverage: impl Fn(&Parity, &T) -> bool,
) {
    let mut arches = crate::vector_levels();
    arches.push(pulp::Arch::new());
    for arch in arches {
        let width = arch.dispatch(Width);
        let (got, counts) = parity(arch, right);
        eprintln!("{width} lanes: {got:?} {counts:?}");
        assert!(got.passes(), "{width} lanes: {got:?}");
        assert!(
            coverage(&got, &counts),
            "{width} lanes, too few compared: {got:?} {counts:?}"
        );
        for &wrong in wrongs {
            let (bad, _) = parity(arch, wrong);
            eprintln!("{width} lanes, {wrong:?}: {bad:?}");
            assert!(!bad.passes(), "{width} lanes, {wrong:?}: {bad:?}");
        }
    }
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

/// What the lanes gave for a case.
pub(super) struct Lane {
    pub wi: V3,
    /// Per RGB channel (a grey model's in all three).
    pub weight: V3,
    pub pdf: f32,
    /// The lobe flag the model reports (a delta reflection, a
    /// transmission), compared with the scalar sample's.
    pub flag: bool,
    pub valid: bool,
    /// f·|cos| and pdf at the case's two directions.
    pub eval: [(V3, f32); 2],
}

/// The scalar model's answers for a case: its sample, its (f·|cos|, pdf)
/// at the two directions, and whether its shading normal leans past the
/// incident ray (wo.z < 0).
pub(super) struct Scalar {
    pub sample: Option<MicroSample>,
    pub eval: [(V3, f32); 2],
    pub leaning: bool,
}

impl Scalar {
    /// `micro`'s sample from the generator of `seed` and its evaluation at `at`.
    pub fn of(micro: &Micro<'_>, seed: u64, at: [V3; 2]) -> Scalar {
        Scalar {
            sample: micro.sample(&mut Rng::new(seed)),
            eval: at.map(|w| micro.eval(w)),
            leaning: micro.wo.z < 0.0,
        }
    }
}

/// How far the lanes are from the scalar model.
#[derive(Debug, Default)]
pub(super) struct Parity {
    pub cases: usize,
    /// Samples both give, of the same lobe (of them, with the flag set).
    pub compared: usize,
    pub flagged: usize,
    /// Samples where one gives none or they disagree on the lobe flag.
    pub disagree: usize,
    /// The largest angle between the two directions, radians.
    pub angle: f64,
    /// The largest relative differences of weight (any channel) and pdf.
    pub weight: f64,
    pub pdf: f64,
    /// Evaluations where one is zero and the other not.
    pub eval_disagree: usize,
    pub eval_compared: usize,
    /// The largest relative differences of f·|cos| (any channel) and pdf.
    pub eval_f: f64,
    pub eval_pdf: f64,
    /// Of the compared values, how many are beyond the tolerances.
    pub beyond: usize,
    /// Coverage: hits whose shading normal leans past the incident ray,
    /// samples the scalar model gives none for.
    pub leaning: usize,
    pub none: usize,
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

impl Parity {
    /// Adds a case: the scalar's answers `s` (its sample's lobe flag
    /// `flag`) against the lane's `l`. Returns the scalar sample where the
    /// two were compared.
    pub fn add<'s>(
        &mut self,
        s: &'s Scalar,
        flag: impl Fn(&MicroSample) -> bool,
        l: &Lane,
    ) -> Option<&'s MicroSample> {
        self.cases += 1;
        self.leaning += usize::from(s.leaning);
        self.none += usize::from(s.sample.is_none());
        let mut compared = None;
        match &s.sample {
            Some(x) if l.valid && l.flag == flag(x) => {
                self.compared += 1;
                self.flagged += usize::from(l.flag);
                let angle = (l.wi.as_dvec3() - x.wi.as_dvec3()).length();
                let (w, pdf) = (rel3(l.weight, x.weight), rel(l.pdf, x.pdf));
                self.angle = self.angle.max(angle);
                self.weight = self.weight.max(w);
                self.pdf = self.pdf.max(pdf);
                if angle > ANGLE || w > REL || pdf > REL {
                    self.beyond += 1;
                }
                compared = Some(x);
            }
            None if !l.valid => {}
            _ => self.disagree += 1,
        }
        for (&(sf, sp), &(lf, lp)) in s.eval.iter().zip(&l.eval) {
            let nonzero = |f: V3| f.max_element() > 0.0;
            if nonzero(sf) != nonzero(lf) || (sp > 0.0) != (lp > 0.0) {
                self.eval_disagree += 1;
                continue;
            }
            if !nonzero(sf) && sp == 0.0 {
                continue;
            }
            self.eval_compared += 1;
            let (f, pdf) = (rel3(lf, sf), rel(lp, sp));
            self.eval_f = self.eval_f.max(f);
            self.eval_pdf = self.eval_pdf.max(pdf);
            if f > REL || pdf > REL {
                self.beyond += 1;
            }
        }
        compared
    }

    /// Enough of each kind was compared: more than `samples` samples (of
    /// them more than `flagged` with the lobe flag) and `evals`
    /// evaluations, hits whose shading normal leans past the ray (0.25 %)
    /// and samples the scalar model gives none for (1 %).
    pub fn covers(&self, samples: usize, flagged: usize, evals: usize) -> bool {
        let some = self.cases / 100;
        self.compared > samples
            && self.flagged > flagged
            && self.eval_compared > evals
            && self.leaning > some / 4
            && self.none > some
    }

    /// At most 0.2 % of the samples disagree on validity or lobe and of
    /// the evaluations on zero; at most 0.2 % of the compared values are
    /// beyond the tolerances.
    pub fn passes(&self) -> bool {
        let samples = self.disagree * 500 <= self.cases;
        let evals = self.eval_disagree * 500 <= 2 * self.cases;
        let values = self.beyond * 500 <= self.compared + self.eval_compared;
        samples && evals && values
    }
}

/// A model's answers for a vector of cases.
pub(super) struct LaneVectors<S: pulp::Simd> {
    pub wi: [S::f32s; 3],
    pub weight: [S::f32s; 3],
    pub pdf: S::f32s,
    pub flag: S::m32s,
    pub valid: S::m32s,
    /// (f·|cos|, pdf) at the cases' two directions.
    pub eval: [([S::f32s; 3], S::f32s); 2],
}

impl<S: pulp::Simd> LaneVectors<S> {
    /// A model's sample of reflections (the flag: a delta lobe) and its
    /// evaluations.
    #[inline(always)]
    pub fn reflection(s: ReflectionSample<S>, eval: [([S::f32s; 3], S::f32s); 2]) -> Self {
        LaneVectors {
            wi: s.wi,
            weight: s.weight,
            pdf: s.pdf,
            flag: s.delta,
            valid: s.valid,
            eval,
        }
    }

    /// The first `k` lanes.
    #[inline(always)]
    pub fn store(self, simd: S, k: usize) -> Vec<Lane> {
        let flag = store_mask(simd, k, self.flag);
        let valid = store_mask(simd, k, self.valid);
        let (wi, weight, pdf) = (
            store3(simd, k, self.wi),
            store3(simd, k, self.weight),
            store(simd, k, self.pdf),
        );
        let eval = self.eval.map(|(f, p)| (store3(simd, k, f), store(simd, k, p)));
        (0..k)
            .map(|i| Lane {
                wi: wi[i],
                weight: weight[i],
                pdf: pdf[i],
                flag: flag[i],
                valid: valid[i],
                eval: [(eval[0].0[i], eval[0].1[i]), (eval[1].0[i], eval[1].1[i])],
            })
            .collect()
    }
}

/// The first `k` lanes of `v`.
#[inline(always)]
fn store<S: pulp::Simd>(simd: S, k: usize, v: S::f32s) -> Vec<f32> {
    let mut a = vec![0.0f32; k];
    simd.partial_store_f32s(&mut a, v);
    a
}

#[inline(always)]
fn store3<S: pulp::Simd>(simd: S, k: usize, v: [S::f32s; 3]) -> Vec<V3> {
    let (x, y, z) = (store(simd, k, v[0]), store(simd, k, v[1]), store(simd, k, v[2]));
    (0..k).map(|i| V3::new(x[i], y[i], z[i])).collect()
}

#[inline(always)]
fn store_mask<S: pulp::Simd>(simd: S, k: usize, m: S::m32s) -> Vec<bool> {
    let v = simd.select_f32s(m, simd.splat_f32s(1.0), simd.splat_f32s(0.0));
    store(simd, k, v).into_iter().map(|x| x == 1.0).collect()
}

/// A vector of the values `v` (the lanes past them 0).
#[inline(always)]
pub(super) fn load<S: pulp::Simd>(simd: S, v: impl Iterator<Item = f32>) -> S::f32s {
    let v: Vec<f32> = v.collect();
    simd.partial_load_f32s(&v)
}

/// Vectors of the values `v`, component by component.
#[inline(always)]
pub(super) fn load3<S: pulp::Simd>(simd: S, v: impl Iterator<Item = V3> + Clone) -> [S::f32s; 3] {
    [
        load(simd, v.clone().map(|x| x.x)),
        load(simd, v.clone().map(|x| x.y)),
        load(simd, v.map(|x| x.z)),
    ]
}

/// A mask of the lanes where `v` holds.
#[inline(always)]
pub(super) fn load_mask<S: pulp::Simd>(simd: S, v: impl Iterator<Item = bool>) -> S::m32s {
    let v = load(simd, v.map(|b| if b { 1.0 } else { 0.0 }));
    simd.greater_than_f32s(v, simd.splat_f32s(0.5))
}
