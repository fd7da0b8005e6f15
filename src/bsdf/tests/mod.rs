//! The BSDFs' statistical tests and their tools: a χ² goodness-of-fit test
//! of a sampler against its density (after Mitsuba 3's `chi2.py`), Monte
//! Carlo estimates with standard errors (white furnace, ∫ pdf), and the
//! directions they are run at.
//!
//! Every test is deterministic (fixed seeds). The χ² tests use Mitsuba's
//! rules: cells on a (cos θ, φ) grid over the whole sphere (equal-area
//! coordinates: dω = d(cos θ) dφ), expected counts from the density
//! integrated over each cell, cells expecting fewer than 5 samples pooled
//! in order of increasing expectation, an outright failure for a sample in
//! a cell of zero expectation, and the significance level 1% Šidák-corrected
//! for the number of χ² tests in this suite ([`CHI2_TESTS`]).
//!
//! Each known-wrong variant is a test-local copy of the one formula it gets
//! wrong, computed from the public API; the tests assert that it fails the
//! threshold the real BSDF passes, on the same samples.
use crate::bsdf::{BsdfSample, MicrofacetDistribution, MicrofacetKind, PlasticParams, RoughPlastic};
use crate::sampling::{uniform_sphere, Rng};
use glam::{DVec3, Vec2, Vec3};
use std::f64::consts::PI;
use std::sync::{Mutex, OnceLock};

mod conductor;
mod microfacet;
mod mitsuba;
mod plastic;
mod rough_dielectric;

/// An upper bound on the number of χ² tests run by this suite (correct
/// models and wrong variants; 70 at present), for the Šidák correction.
pub const CHI2_TESTS: f64 = 80.0;

/// A white rough plastic (ρ = 1, int_ior 1.5, ext_ior 1) of roughness
/// `alpha`, its coating tabulated once for the whole suite (a Beckmann
/// coating takes 0.6 s); other bases come from [`RoughPlastic::with_base`].
pub fn rough_plastic(kind: MicrofacetKind, alpha: f32) -> RoughPlastic {
    static CACHE: OnceLock<Mutex<Vec<(MicrofacetKind, u32, RoughPlastic)>>> = OnceLock::new();
    let cache = CACHE.get_or_init(|| Mutex::new(Vec::new()));
    let key = (kind, alpha.to_bits());
    if let Some(p) = cache.lock().unwrap().iter().find(|c| (c.0, c.1) == key) {
        return p.2.clone();
    }
    let params = PlasticParams {
        int_ior: 1.5,
        ext_ior: 1.0,
        diffuse_reflectance: Vec3::ONE,
        ..Default::default()
    };
    let p = RoughPlastic::try_new(&params, MicrofacetDistribution::isotropic(kind, alpha).unwrap()).unwrap();
    cache.lock().unwrap().push((kind, alpha.to_bits(), p.clone()));
    p
}

/// The significance level of one χ² test: 1% over the whole suite.
pub fn significance() -> f64 {
    1.0 - (1.0 - 0.01f64).powf(1.0 / CHI2_TESTS)
}

/// Two uniform numbers.
pub fn u2(rng: &mut Rng) -> Vec2 {
    Vec2::new(rng.uniform(), rng.uniform())
}

/// The unit direction at polar angle `theta_deg` from +z and azimuth `phi_deg`.
pub fn dir(theta_deg: f32, phi_deg: f32) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
}

/// A uniformly distributed unit direction.
pub fn sphere(rng: &mut Rng) -> Vec3 {
    uniform_sphere(rng.uniform(), rng.uniform()).into()
}

/// A Monte Carlo estimate per channel with its standard error.
#[derive(Debug, Clone, Copy)]
pub struct Estimate {
    pub mean: DVec3,
    pub stderr: DVec3,
}

/// The mean of `n` draws of `f` and its standard error.
pub fn estimate(n: usize, seed: u64, mut f: impl FnMut(&mut Rng) -> DVec3) -> Estimate {
    let mut rng = Rng::new(seed);
    let (mut s, mut s2) = (DVec3::ZERO, DVec3::ZERO);
    for _ in 0..n {
        let v = f(&mut rng);
        s += v;
        s2 += v * v;
    }
    let nf = n as f64;
    let mean = s / nf;
    let var = (s2 / nf - mean * mean).max(DVec3::ZERO);
    Estimate {
        mean,
        stderr: (var / nf).map(f64::sqrt),
    }
}

/// ∫ f(wo, wi) |cos θi| dωi over the sphere by uniform sampling of wi.
pub fn furnace_uniform(n: usize, seed: u64, f: impl Fn(Vec3) -> Vec3) -> Estimate {
    estimate(n, seed, |rng| {
        let wi = sphere(rng);
        (f(wi) * wi.z.abs()).as_dvec3() * (4.0 * PI)
    })
}

/// The mean sample weight (0 for a failed sample) of `sample`: the same
/// integral, estimated through the BSDF's own sampling.
pub fn furnace_sampled(
    n: usize,
    seed: u64,
    mut sample: impl FnMut(&mut Rng) -> Option<BsdfSample>,
) -> Estimate {
    estimate(n, seed, |rng| {
        sample(rng).map_or(DVec3::ZERO, |s| s.weight.as_dvec3())
    })
}

/// `a` and `b` agree within `k` combined standard errors plus `abs` in every channel.
pub fn agree(a: &Estimate, b: &Estimate, k: f64, abs: f64) -> bool {
    let d = (a.mean - b.mean).abs();
    let s = (a.stderr * a.stderr + b.stderr * b.stderr).map(f64::sqrt);
    d.cmple(s * k + DVec3::splat(abs)).all()
}

/// Samples binned on an `n_cos` × `n_phi` grid over (cos θ, φ).
pub struct Histogram {
    pub n_cos: usize,
    pub n_phi: usize,
    pub counts: Vec<f64>,
    /// Calls of the sampler.
    pub draws: usize,
    /// Samples binned (the sampler returned a direction it also gives a density).
    pub binned: usize,
}

impl Histogram {
    fn cell(&self, w: Vec3) -> usize {
        let c = f64::from(w.z).clamp(-1.0, 1.0);
        let i = (((c + 1.0) * 0.5 * self.n_cos as f64) as usize).min(self.n_cos - 1);
        let phi = f64::from(w.y).atan2(f64::from(w.x));
        let j = (((phi + PI) / (2.0 * PI) * self.n_phi as f64) as usize).min(self.n_phi - 1);
        i * self.n_phi + j
    }

    /// The fraction of draws that were binned.
    pub fn fraction(&self) -> f64 {
        self.binned as f64 / self.draws as f64
    }
}

/// Draw `n` samples; those `sample` returns are binned. Delta samples are
/// left out (they have no density), but counted as draws.
pub fn histogram(
    n_cos: usize,
    n_phi: usize,
    n: usize,
    seed: u64,
    mut sample: impl FnMut(&mut Rng) -> Option<(Vec3, bool)>,
) -> Histogram {
    let mut h = Histogram {
        n_cos,
        n_phi,
        counts: vec![0.0; n_cos * n_phi],
        draws: n,
        binned: 0,
    };
    let mut rng = Rng::new(seed);
    for _ in 0..n {
        if let Some((w, false)) = sample(&mut rng) {
            let c = h.cell(w);
            h.counts[c] += 1.0;
            h.binned += 1;
        }
    }
    h
}

/// The 6-point Gauss–Legendre rule on [-1, 1].
fn gl6() -> &'static [(f64, f64); 6] {
    const R: [(f64, f64); 6] = [
        (-0.932_469_514_203_152, 0.171_324_492_379_170),
        (-0.661_209_386_466_265, 0.360_761_573_048_139),
        (-0.238_619_186_083_197, 0.467_913_934_572_691),
        (0.238_619_186_083_197, 0.467_913_934_572_691),
        (0.661_209_386_466_265, 0.360_761_573_048_139),
        (0.932_469_514_203_152, 0.171_324_492_379_170),
    ];
    &R
}

/// ∫ pdf over the patch [c0, c1] × [p0, p1] of (cos θ, φ), 6×6 Gauss–Legendre.
fn patch(pdf: &impl Fn(Vec3) -> f64, c0: f64, c1: f64, p0: f64, p1: f64) -> f64 {
    let (hc, hp) = (0.5 * (c1 - c0), 0.5 * (p1 - p0));
    let mut sum = 0.0;
    for &(xa, wa) in gl6() {
        let c = c0 + hc * (xa + 1.0);
        let s = (1.0 - c * c).max(0.0).sqrt();
        for &(xb, wb) in gl6() {
            let p = p0 + hp * (xb + 1.0);
            let w = DVec3::new(s * p.cos(), s * p.sin(), c).as_vec3();
            sum += wa * wb * pdf(w);
        }
    }
    sum * hc * hp
}

/// ∫ pdf over a patch, subdividing (to depth 4) where the 6×6 rule and the
/// rule on four sub-patches disagree by more than 1e-5 relative: kinks in
/// the density (a critical angle, a lobe's edge) need it.
fn patch_adaptive(
    pdf: &impl Fn(Vec3) -> f64,
    c0: f64,
    c1: f64,
    p0: f64,
    p1: f64,
    whole: f64,
    depth: u32,
) -> f64 {
    let (cm, pm) = (0.5 * (c0 + c1), 0.5 * (p0 + p1));
    let q = [
        (c0, cm, p0, pm),
        (c0, cm, pm, p1),
        (cm, c1, p0, pm),
        (cm, c1, pm, p1),
    ];
    let parts = q.map(|(a, b, c, d)| patch(pdf, a, b, c, d));
    let fine: f64 = parts.iter().sum();
    if depth == 0 || (fine - whole).abs() <= 1e-5 * fine.abs() + 1e-12 {
        return fine;
    }
    q.iter()
        .zip(parts)
        .map(|(&(a, b, c, d), w)| patch_adaptive(pdf, a, b, c, d, w, depth - 1))
        .sum()
}

/// The probability mass of each cell of an `n_cos` × `n_phi` grid under `pdf`.
pub fn cell_masses(n_cos: usize, n_phi: usize, pdf: impl Fn(Vec3) -> f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(n_cos * n_phi);
    for i in 0..n_cos {
        let c0 = -1.0 + 2.0 * i as f64 / n_cos as f64;
        let c1 = -1.0 + 2.0 * (i + 1) as f64 / n_cos as f64;
        for j in 0..n_phi {
            let p0 = -PI + 2.0 * PI * j as f64 / n_phi as f64;
            let p1 = -PI + 2.0 * PI * (j + 1) as f64 / n_phi as f64;
            let whole = patch(&pdf, c0, c1, p0, p1);
            out.push(patch_adaptive(&pdf, c0, c1, p0, p1, whole, 4));
        }
    }
    out
}

/// A χ² test's outcome.
#[derive(Debug, Clone)]
pub struct Chi2 {
    pub statistic: f64,
    pub dof: usize,
    pub p_value: f64,
    /// Samples in cells the density gives no mass (an outright failure).
    pub in_empty_cells: f64,
    /// ∫ pdf over the sphere (the sum of the cell masses).
    pub pdf_mass: f64,
}

impl Chi2 {
    /// Passes at [`significance`].
    pub fn passes(&self) -> bool {
        self.in_empty_cells == 0.0 && self.dof >= 1 && self.p_value >= significance()
    }
}

/// Pearson's χ² of `hist` against the density `pdf` (per steradian, over
/// draws), with Mitsuba's pooling of cells expecting fewer than 5.
pub fn chi2(hist: &Histogram, pdf: impl Fn(Vec3) -> f64) -> Chi2 {
    let masses = cell_masses(hist.n_cos, hist.n_phi, pdf);
    let n = hist.draws as f64;
    let mut cells: Vec<(f64, f64)> = masses
        .iter()
        .map(|m| m * n)
        .zip(hist.counts.iter().copied())
        .collect();
    cells.sort_by(|a, b| a.0.total_cmp(&b.0));
    let in_empty_cells = cells.iter().filter(|(e, _)| *e <= 0.0).map(|(_, o)| o).sum();
    let (mut stat, mut dof) = (0.0, 0usize);
    let (mut pool_e, mut pool_o) = (0.0, 0.0);
    for &(e, o) in &cells {
        if e >= 5.0 {
            stat += (o - e) * (o - e) / e;
            dof += 1;
        } else if e > 0.0 || o > 0.0 {
            pool_e += e;
            pool_o += o;
            if pool_e > 5.0 {
                stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
                dof += 1;
                pool_e = 0.0;
                pool_o = 0.0;
            }
        }
    }
    let dof = dof.saturating_sub(1);
    let p_value = if dof >= 1 {
        1.0 - regularized_lower_gamma(dof as f64 / 2.0, stat / 2.0)
    } else {
        0.0
    };
    Chi2 {
        statistic: stat,
        dof,
        p_value,
        in_empty_cells,
        pdf_mass: masses.iter().sum(),
    }
}

/// The regularized lower incomplete gamma function P(a, x) (Cephes `igam`,
/// as Mitsuba's `rlgamma`): a series for x ≤ max(1, a), else a continued
/// fraction for the complement.
pub fn regularized_lower_gamma(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let ax = a * x.ln() - x - libm::lgamma(a);
    if ax < -709.782_712_893_384 {
        return if a < x { 1.0 } else { 0.0 };
    }
    const EPS: f64 = 1e-15;
    if x <= 1.0 || x <= a {
        let (mut r, mut c, mut sum) = (a, 1.0, 1.0);
        loop {
            r += 1.0;
            c *= x / r;
            sum += c;
            if c / sum <= EPS {
                break;
            }
        }
        return ax.exp() * sum / a;
    }
    const BIG: f64 = 4.503_599_627_370_496e15;
    let mut y = 1.0 - a;
    let mut z = x + y + 1.0;
    let mut c = 0.0;
    let (mut p3, mut q3, mut p2, mut q2) = (1.0, x, x + 1.0, z * x);
    let mut ans = p2 / q2;
    loop {
        c += 1.0;
        y += 1.0;
        z += 2.0;
        let yc = y * c;
        let p = p2 * z - p3 * yc;
        let q = q2 * z - q3 * yc;
        let err = if q != 0.0 {
            let next = p / q;
            let e = ((ans - next) / next).abs();
            ans = next;
            e
        } else {
            1.0
        };
        (p3, p2, q3, q2) = (p2, p, q2, q);
        if p.abs() > BIG {
            p3 /= BIG;
            p2 /= BIG;
            q3 /= BIG;
            q2 /= BIG;
        }
        if err <= EPS {
            break;
        }
    }
    1.0 - ax.exp() * ans
}

/// What the suite checks of one sampler and its density, besides χ².
pub struct Consistency {
    /// Largest relative difference between a sample's pdf and `pdf(wo, wi)`.
    pub pdf_error: f64,
    /// Largest relative difference between a sample's weight and f |cos| / pdf.
    pub weight_error: f64,
}

/// Compare `n` samples' pdfs and weights with the `pdf` and `f` functions.
pub fn consistency(
    n: usize,
    seed: u64,
    mut sample: impl FnMut(&mut Rng) -> Option<BsdfSample>,
    f: impl Fn(Vec3) -> Vec3,
    pdf: impl Fn(Vec3) -> f32,
) -> Consistency {
    let mut rng = Rng::new(seed);
    let (mut pdf_error, mut weight_error, mut checked) = (0.0f64, 0.0f64, 0usize);
    for _ in 0..n {
        let Some(s) = sample(&mut rng) else { continue };
        if s.is_delta {
            continue;
        }
        checked += 1;
        let p = f64::from(pdf(s.wi));
        pdf_error = pdf_error.max((p - f64::from(s.pdf)).abs() / p.max(1e-30));
        let w = (f(s.wi) * s.wi.z.abs() / s.pdf).as_dvec3();
        let rel = (w - s.weight.as_dvec3()).abs().max_element() / w.abs().max_element().max(1e-6);
        weight_error = weight_error.max(rel);
    }
    // A check of nothing would pass: most draws must have been compared.
    assert!(checked * 10 >= n, "only {checked} of {n} samples had a density");
    Consistency {
        pdf_error,
        weight_error,
    }
}

#[test]
fn the_gamma_function_and_the_significance_are_right() {
    // P(1, x) = 1 − e^{−x}; P(a, x) for a χ² with 2 degrees of freedom.
    for x in [0.1f64, 1.0, 3.0, 20.0] {
        assert!(
            (regularized_lower_gamma(1.0, x) - (1.0 - (-x).exp())).abs() < 1e-13,
            "{x}"
        );
    }
    // P(1/2, x) = erf(√x).
    for x in [0.01f64, 0.5, 2.0, 8.0] {
        assert!(
            (regularized_lower_gamma(0.5, x) - libm::erf(x.sqrt())).abs() < 1e-13,
            "{x}"
        );
    }
    // The χ² median with k = 1000 degrees of freedom is ≈ k (1 − 2/(9k))³.
    let k = 1000.0f64;
    let median = k * (1.0 - 2.0 / (9.0 * k)).powi(3);
    assert!((regularized_lower_gamma(k / 2.0, median / 2.0) - 0.5).abs() < 1e-3);
    let a = significance();
    assert!(a > 1e-4 && a < 1.3e-4, "{a}");
}

#[test]
fn frames_are_orthonormal_and_round_trip() {
    use crate::bsdf::Frame;
    let mut rng = Rng::new(12);
    for _ in 0..1000 {
        let n = sphere(&mut rng);
        let f = Frame::from_normal(n);
        for (a, b) in [(f.s, f.t), (f.t, f.n), (f.n, f.s)] {
            assert!(a.dot(b).abs() < 1e-5);
        }
        assert!((f.s.cross(f.t) - n).length() < 1e-5, "right-handed");
        assert!((f.to_local(n) - Vec3::Z).length() < 1e-5);
        let v = sphere(&mut rng);
        assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        assert!((f.to_local(v).z - v.dot(n)).abs() < 1e-6);
    }
}
