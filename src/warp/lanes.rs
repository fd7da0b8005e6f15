//! The closed-form residual and Jacobian of `HollowCylinder::resid_jac`
//! for four (b, β) at once, in the four f64 lanes of an AVX register: the
//! fast cylinder solver's Newton polishes of several targets are
//! evaluated together.
//!
//! Each lane is the scalar `resid_jac` term by term (the same operations
//! in the same order, none fused), so a lane gives the scalar function's
//! bits (tested). The four families are computed in every lane and the
//! lane's own is selected (blends instead of branches). The dozen square
//! roots and divisions of an evaluation, a dependent chain in the scalar
//! code, then run four lanes per instruction.
//!
//! AVX2 is checked at run time; without it (or off x86-64) each lane is
//! the scalar `resid_jac`. Intrinsics, because plain `[f64; 4]` code
//! compiled for AVX2 is not enough: LLVM vectorises it mostly in pairs and
//! keeps most square roots and divisions scalar, no faster than four scalar
//! calls. This module and `src/embree/`
//! are the crate's only `unsafe` (the dispatch, reading the lanes out and
//! loading four rows of `Rows` into a register).
#![allow(unsafe_code)]
use super::tube::{Family, HollowCylinder};
use glam::DVec2;

/// Lanes per evaluation.
pub(crate) const LANES: usize = 4;

/// One lane's problem: the family, the target's 2-D position and height
/// above the eye, and the point (b, β).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneIn {
    pub fam: Family,
    pub p: DVec2,
    pub dv: f64,
    pub b: f64,
    pub beta: f64,
}

/// One lane's answer: `resid_jac`'s `Some((r, J))`, or `None`.
pub(crate) type LaneOut = Option<([f64; 2], [[f64; 2]; 2])>;

/// What `resid_jac` needs of the tube and the eye (per warper, not per
/// evaluation), and whether the CPU has AVX2 (checked once).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Consts {
    cyl: HollowCylinder,
    e: DVec2,
    avx2: bool,
}

impl Consts {
    pub fn new(c: &HollowCylinder, e: DVec2) -> Consts {
        #[cfg(target_arch = "x86_64")]
        let avx2 = std::arch::is_x86_feature_detected!("avx2");
        #[cfg(not(target_arch = "x86_64"))]
        let avx2 = false;
        Consts { cyl: *c, e, avx2 }
    }

    /// The same without the vector path (the tests' comparison).
    #[cfg(test)]
    fn scalar(mut self) -> Consts {
        self.avx2 = false;
        self
    }
}

/// `resid_jac` of each lane. Every lane's target is outside the hollow
/// for through4, tir2 and wall2 and inside it for hollow2, as the fast
/// solver's jobs are. Unused lanes may repeat a used one.
#[cfg(test)]
pub(crate) fn resid_jac4(k: &Consts, lanes: &[LaneIn; LANES]) -> [LaneOut; LANES] {
    #[cfg(target_arch = "x86_64")]
    if k.avx2 {
        // SAFETY: `avx::resid_jac4` requires AVX2, which `Consts::new`
        // found with `is_x86_feature_detected!`; it reads only its
        // arguments.
        return unsafe { avx::resid_jac4(k, lanes) };
    }
    lanes.map(|l| k.cyl.resid_jac(l.fam, k.e, l.p, l.dv, l.b, l.beta))
}

/// A Newton step's outcome (`step`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Step {
    /// Outside the family, a singular Jacobian, or β out of range.
    Fail,
    /// The residual is within the tolerance at the current point.
    Root,
    /// The next (b, β).
    Next(f64, f64),
}

/// One Newton step in (b, β) from `resid_jac`'s answer `ev` at (b, β):
/// the convergence test (max |r| ≤ tol, the max written as the vector
/// max computes it, which differs from `f64::max` only for a NaN), then
/// −J⁻¹·r (failed on a singular J or |β| ≥ 0.999999).
pub(crate) fn step(ev: LaneOut, b: f64, beta: f64, tol: f64) -> Step {
    let Some((r, j)) = ev else {
        return Step::Fail;
    };
    let (r0, r1) = (r[0].abs(), r[1].abs());
    let norm = if r0 > r1 { r0 } else { r1 };
    if norm <= tol {
        return Step::Root;
    }
    let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
    if det == 0.0 || !det.is_finite() {
        return Step::Fail;
    }
    let nb = b - (r[0] * j[1][1] - r[1] * j[0][1]) / det;
    let nbeta = beta - (j[0][0] * r[1] - j[1][0] * r[0]) / det;
    if nbeta.is_nan() || nbeta.abs() >= 0.999_999 {
        return Step::Fail;
    }
    Step::Next(nb, nbeta)
}

/// `step` of each lane from its own point, with tolerances `tol` (the
/// tests' reference for the vector step; the solver calls `newton_rows`).
#[cfg(test)]
pub(crate) fn newton4(k: &Consts, lanes: &[LaneIn; LANES], tol: [f64; LANES]) -> [Step; LANES] {
    #[cfg(target_arch = "x86_64")]
    if k.avx2 {
        // SAFETY: as in `resid_jac4`.
        return unsafe { avx::newton4(k, lanes, tol) };
    }
    std::array::from_fn(|i| {
        let l = &lanes[i];
        let ev = k.cyl.resid_jac(l.fam, k.e, l.p, l.dv, l.b, l.beta);
        step(ev, l.b, l.beta, tol[i])
    })
}

/// A family as a lane's code (`Rows::fam`, the vector code's blends).
#[inline]
pub(crate) fn fam_code(f: Family) -> f64 {
    match f {
        Family::Wall2 => 1.0,
        Family::Tir2 => 2.0,
        Family::Hollow2 => 3.0,
        _ => 0.0,
    }
}

fn fam_of(code: f64) -> Family {
    match code as u8 {
        1 => Family::Wall2,
        2 => Family::Tir2,
        3 => Family::Hollow2,
        _ => Family::Through4,
    }
}

/// `newton_rows`' outcomes of a row: it stepped (its b, β are the next
/// point), its residual is within the tolerance at its (unchanged) point,
/// or it failed (`step`'s `Next`, `Root`, `Fail`).
pub(crate) const NEXT: u8 = 0;
pub(crate) const ROOT: u8 = 1;
pub(crate) const FAIL: u8 = 2;

/// Running Newton polishes as a struct of arrays, one row each: the four
/// lanes of an evaluation are loaded from four consecutive rows as
/// vectors, and the next point is stored back the same way, instead of
/// gathering each lane from a polish and scattering the step into it. The
/// rows' count is kept a multiple of `LANES` (`pad`); padding rows repeat
/// the last real one and are ignored.
#[derive(Clone, Default)]
pub(crate) struct Rows {
    pub fam: Vec<f64>,
    pub px: Vec<f64>,
    pub py: Vec<f64>,
    pub dv: Vec<f64>,
    pub b: Vec<f64>,
    pub beta: Vec<f64>,
    pub tol: Vec<f64>,
}

impl Rows {
    pub fn clear(&mut self) {
        for v in self.cols_mut() {
            v.clear();
        }
    }

    fn cols_mut(&mut self) -> [&mut Vec<f64>; 7] {
        [
            &mut self.fam,
            &mut self.px,
            &mut self.py,
            &mut self.dv,
            &mut self.b,
            &mut self.beta,
            &mut self.tol,
        ]
    }

    #[inline]
    pub fn push(&mut self, l: &LaneIn, tol: f64) {
        self.fam.push(fam_code(l.fam));
        self.px.push(l.p.x);
        self.py.push(l.p.y);
        self.dv.push(l.dv);
        self.b.push(l.b);
        self.beta.push(l.beta);
        self.tol.push(tol);
    }

    /// Keeps the first `n` rows and pads them to a multiple of `LANES`
    /// with copies of the last one.
    pub fn pad(&mut self, n: usize) {
        let m = n.div_ceil(LANES) * LANES;
        for v in self.cols_mut() {
            v.truncate(n);
            if n > 0 {
                let last = v[n - 1];
                v.resize(m, last);
            }
        }
    }

    /// Moves row `from` to row `to` (compaction).
    #[inline]
    pub fn mov(&mut self, from: usize, to: usize) {
        for v in self.cols_mut() {
            v[to] = v[from];
        }
    }

    /// Row `i` as a lane.
    fn lane(&self, i: usize) -> LaneIn {
        LaneIn {
            fam: fam_of(self.fam[i]),
            p: DVec2::new(self.px[i], self.py[i]),
            dv: self.dv[i],
            b: self.b[i],
            beta: self.beta[i],
        }
    }
}

/// One Newton step of every row (`rows` padded, `status` as long): the
/// outcome of `step` into `status`, and for a row that steps its next
/// point into its b and β. Rows are evaluated four at a time in AVX2
/// registers where the CPU has it (the same bits as `newton4`, which is
/// `step` bit for bit), else one at a time with `resid_jac` and `step`.
pub(crate) fn newton_rows(k: &Consts, rows: &mut Rows, status: &mut [u8]) {
    #[cfg(target_arch = "x86_64")]
    if k.avx2 {
        // SAFETY: as in `resid_jac4`; it reads and writes only its
        // arguments.
        return unsafe { avx::newton_rows(k, rows, status) };
    }
    for (i, st) in status.iter_mut().enumerate().take(rows.b.len()) {
        let l = rows.lane(i);
        let ev = k.cyl.resid_jac(l.fam, k.e, l.p, l.dv, l.b, l.beta);
        *st = match step(ev, l.b, l.beta, rows.tol[i]) {
            Step::Fail => FAIL,
            Step::Root => ROOT,
            Step::Next(b, beta) => {
                (rows.b[i], rows.beta[i]) = (b, beta);
                NEXT
            }
        };
    }
}

#[cfg(target_arch = "x86_64")]
mod avx {
    #[cfg(test)]
    use super::{fam_code, LaneIn, Step};
    use super::{Consts, DVec2, LANES};
    use std::arch::x86_64::*;

    macro_rules! sp {
        ($x:expr) => {
            _mm256_set1_pd($x)
        };
    }
    macro_rules! add {
        ($a:expr, $b:expr) => {
            _mm256_add_pd($a, $b)
        };
    }
    macro_rules! sub {
        ($a:expr, $b:expr) => {
            _mm256_sub_pd($a, $b)
        };
    }
    macro_rules! mul {
        ($a:expr, $b:expr) => {
            _mm256_mul_pd($a, $b)
        };
    }
    macro_rules! div {
        ($a:expr, $b:expr) => {
            _mm256_div_pd($a, $b)
        };
    }
    macro_rules! sqrt {
        ($a:expr) => {
            _mm256_sqrt_pd($a)
        };
    }
    macro_rules! neg {
        ($a:expr) => {
            _mm256_xor_pd($a, sp!(-0.0))
        };
    }
    // Comparisons as the scalar code's tests: NGE = !(a >= b) and
    // NLE = !(a <= b) (true for a NaN), NLT = !(a < b), LT = a < b.
    macro_rules! cmp {
        ($op:ident, $a:expr, $b:expr) => {
            _mm256_cmp_pd::<$op>($a, $b)
        };
    }
    macro_rules! and {
        ($a:expr, $b:expr) => {
            _mm256_and_pd($a, $b)
        };
    }
    // m ? a : b, lane by lane.
    macro_rules! sel {
        ($m:expr, $a:expr, $b:expr) => {
            _mm256_blendv_pd($b, $a, $m)
        };
    }
    // The product of unit complex numbers (x, y) (rotations composed).
    macro_rules! cmul {
        ($a:expr, $b:expr) => {{
            let (a, b) = ($a, $b);
            (
                sub!(mul!(a.0, b.0), mul!(a.1, b.1)),
                add!(mul!(a.0, b.1), mul!(a.1, b.0)),
            )
        }};
    }

    /// `resid_jac`'s answer in four lanes: `ok` (all ones where it is
    /// `Some`), the residual and the Jacobian.
    struct Eval {
        ok: __m256d,
        g: __m256d,
        r1: __m256d,
        g_b: __m256d,
        g_beta: __m256d,
        climb_b: __m256d,
        climb_beta: __m256d,
    }

    /// The lanes of a vector.
    #[target_feature(enable = "avx2")]
    #[inline]
    fn out(v: __m256d) -> [f64; LANES] {
        // SAFETY: __m256d and [f64; 4] are both 32 bytes of plain data,
        // every bit pattern valid for both.
        unsafe { std::mem::transmute::<__m256d, [f64; LANES]>(v) }
    }

    /// `HollowCylinder::resid_jac` of each lane.
    #[cfg(test)]
    #[target_feature(enable = "avx2")]
    pub(super) fn resid_jac4(k: &Consts, lanes: &[LaneIn; LANES]) -> [super::LaneOut; LANES] {
        let v = eval(k, lanes);
        let mask = _mm256_movemask_pd(v.ok);
        let (g, r1, g_b, g_beta, climb_b, climb_beta) = (
            out(v.g),
            out(v.r1),
            out(v.g_b),
            out(v.g_beta),
            out(v.climb_b),
            out(v.climb_beta),
        );
        std::array::from_fn(|i| {
            (mask & (1 << i) != 0)
                .then(|| ([g[i], r1[i]], [[g_b[i], g_beta[i]], [climb_b[i], climb_beta[i]]]))
        })
    }

    /// `super::step` of each lane (the same operations: bit for bit).
    #[cfg(test)]
    #[target_feature(enable = "avx2")]
    pub(super) fn newton4(k: &Consts, lanes: &[LaneIn; LANES], tol: [f64; LANES]) -> [Step; LANES] {
        let v = eval(k, lanes);
        let b = _mm256_setr_pd(lanes[0].b, lanes[1].b, lanes[2].b, lanes[3].b);
        let beta = _mm256_setr_pd(lanes[0].beta, lanes[1].beta, lanes[2].beta, lanes[3].beta);
        let tol = _mm256_setr_pd(tol[0], tol[1], tol[2], tol[3]);
        let (nb, nbeta, ok, root, bad) = step_v(&v, b, beta, tol);
        let (nb, nbeta) = (out(nb), out(nbeta));
        std::array::from_fn(|i| {
            let bit = 1 << i;
            if ok & bit == 0 {
                Step::Fail
            } else if root & bit != 0 {
                Step::Root
            } else if bad & bit != 0 {
                Step::Fail
            } else {
                Step::Next(nb[i], nbeta[i])
            }
        })
    }

    /// `super::newton_rows`, four rows at a time (each group loaded and
    /// stored as vectors): b and β of a lane that steps are overwritten
    /// with the next point, and the lane's outcome goes to `status`.
    #[target_feature(enable = "avx2")]
    pub(super) fn newton_rows(k: &Consts, rows: &mut super::Rows, status: &mut [u8]) {
        let n = rows.b.len();
        let mut i = 0;
        while i + LANES <= n {
            let ld = |v: &[f64]| {
                let a: &[f64; LANES] = v[i..i + LANES].try_into().expect("four rows");
                // SAFETY: `a` is four readable f64 (`loadu` needs no
                // alignment).
                unsafe { _mm256_loadu_pd(a.as_ptr()) }
            };
            let (b, beta) = (ld(&rows.b), ld(&rows.beta));
            let v = eval_v(
                k,
                ld(&rows.fam),
                b,
                beta,
                ld(&rows.px),
                ld(&rows.py),
                ld(&rows.dv),
            );
            let (nb, nbeta, ok, root, bad) = step_v(&v, b, beta, ld(&rows.tol));
            // Only lanes that step move (a root keeps its point).
            let moves = !root & ok & !bad & 0xf;
            let m = _mm256_castsi256_pd(_mm256_setr_epi64x(
                -((moves & 1) as i64),
                -((moves >> 1 & 1) as i64),
                -((moves >> 2 & 1) as i64),
                -((moves >> 3 & 1) as i64),
            ));
            let (nb, nbeta) = (out(sel!(m, nb, b)), out(sel!(m, nbeta, beta)));
            rows.b[i..i + LANES].copy_from_slice(&nb);
            rows.beta[i..i + LANES].copy_from_slice(&nbeta);
            for l in 0..LANES {
                let bit = 1 << l;
                status[i + l] = if ok & bit == 0 {
                    super::FAIL
                } else if root & bit != 0 {
                    super::ROOT
                } else if bad & bit != 0 {
                    super::FAIL
                } else {
                    super::NEXT
                };
            }
            i += LANES;
        }
    }

    /// `super::step` in four lanes: the next (b, β), and the bit masks of
    /// the lanes where the evaluation exists (`ok`), the residual is
    /// within `tol` (`root`) and the step fails (`bad`).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn step_v(v: &Eval, b: __m256d, beta: __m256d, tol: __m256d) -> (__m256d, __m256d, i32, i32, i32) {
        let (ag, ar1) = (
            _mm256_andnot_pd(sp!(-0.0), v.g),
            _mm256_andnot_pd(sp!(-0.0), v.r1),
        );
        // `step`'s `if r0 > r1 { r0 } else { r1 }`.
        let norm = _mm256_max_pd(ag, ar1);
        let root = _mm256_movemask_pd(cmp!(_CMP_LE_OQ, norm, tol));
        let det = sub!(mul!(v.g_b, v.climb_beta), mul!(v.g_beta, v.climb_b));
        let bad_det = _mm256_or_pd(
            cmp!(_CMP_EQ_OQ, det, sp!(0.0)),
            cmp!(_CMP_NLT_UQ, _mm256_andnot_pd(sp!(-0.0), det), sp!(f64::INFINITY)),
        );
        let nb = sub!(b, div!(sub!(mul!(v.g, v.climb_beta), mul!(v.r1, v.g_beta)), det));
        let nbeta = sub!(beta, div!(sub!(mul!(v.g_b, v.r1), mul!(v.climb_b, v.g)), det));
        let bad_beta = cmp!(_CMP_NLT_UQ, _mm256_andnot_pd(sp!(-0.0), nbeta), sp!(0.999_999));
        let ok = _mm256_movemask_pd(v.ok);
        let bad = _mm256_movemask_pd(_mm256_or_pd(bad_det, bad_beta));
        (nb, nbeta, ok, root, bad)
    }

    /// `HollowCylinder::resid_jac` in four lanes (see there for the
    /// formulas; the names are the same). Intrinsics are safe to call
    /// here (the function enables AVX2); the macros only abbreviate them.
    #[cfg(test)]
    #[target_feature(enable = "avx2")]
    #[inline]
    fn eval(k: &Consts, lanes: &[LaneIn; LANES]) -> Eval {
        let get =
            |f: fn(&LaneIn) -> f64| _mm256_setr_pd(f(&lanes[0]), f(&lanes[1]), f(&lanes[2]), f(&lanes[3]));
        let fam = _mm256_setr_pd(
            fam_code(lanes[0].fam),
            fam_code(lanes[1].fam),
            fam_code(lanes[2].fam),
            fam_code(lanes[3].fam),
        );
        eval_v(
            k,
            fam,
            get(|l| l.b),
            get(|l| l.beta),
            get(|l| l.p.x),
            get(|l| l.p.y),
            get(|l| l.dv),
        )
    }

    /// `eval` of lanes already in registers (`fam` the codes of
    /// `fam_code`).
    #[target_feature(enable = "avx2")]
    #[inline]
    fn eval_v(
        k: &Consts,
        fam: __m256d,
        b: __m256d,
        beta: __m256d,
        px: __m256d,
        py: __m256d,
        dv: __m256d,
    ) -> Eval {
        let wall = cmp!(_CMP_EQ_OQ, fam, sp!(1.0));
        let tir = cmp!(_CMP_EQ_OQ, fam, sp!(2.0));
        let hollow = cmp!(_CMP_EQ_OQ, fam, sp!(3.0));
        let c = &k.cyl;
        let (big, small) = (sp!(c.outer_radius), sp!(c.inner_radius));
        let (one, two, zero) = (sp!(1.0), sp!(2.0), sp!(0.0));
        let ab = _mm256_andnot_pd(sp!(-0.0), b);
        let rho = k.e.length();
        let mut ok = and!(cmp!(_CMP_NGE_UQ, ab, big), cmp!(_CMP_NGE_UQ, ab, sp!(rho)));
        let bb = mul!(beta, beta);
        let ma = sqrt!(sub!(one, bb));
        let mg = sqrt!(sub!(sp!(c.ior * c.ior), bb));
        let kk = div!(ma, mg);
        let k_beta = mul!(
            mul!(kk, beta),
            sub!(div!(one, mul!(mg, mg)), div!(one, mul!(ma, ma)))
        );
        let al = mul!(ab, kk);
        let sg = sel!(cmp!(_CMP_LT_OQ, b, zero), sp!(-1.0), one);
        let (al_b, al_beta) = (mul!(sg, kk), mul!(ab, k_beta));
        let inward = -k.e / rho;
        let perp_i = DVec2::new(-inward.y, inward.x);
        let x = neg!(div!(b, sp!(rho)));
        let cx = sqrt!(sub!(one, mul!(x, x)));
        let h0 = (
            add!(mul!(sp!(inward.x), cx), mul!(sp!(perp_i.x), x)),
            add!(mul!(sp!(inward.y), cx), mul!(sp!(perp_i.y), x)),
        );
        let q = div!(neg!(x), cx);
        let m_rho = sp!(-1.0 / rho);
        let h0_b = (
            mul!(add!(mul!(sp!(inward.x), q), sp!(perp_i.x)), m_rho),
            mul!(add!(mul!(sp!(inward.y), q), sp!(perp_i.y)), m_rho),
        );
        let psi0_b = add!(mul!(h0_b.0, neg!(h0.1)), mul!(h0_b.1, h0.0));
        let s1 = div!(ab, big);
        let c1 = sqrt!(sub!(one, mul!(s1, s1)));
        let s2 = div!(al, big);
        let c2 = sqrt!(sub!(one, mul!(s2, s2)));
        let rot12 = (add!(mul!(c1, c2), mul!(s1, s2)), sub!(mul!(s1, c2), mul!(c1, s2)));
        let (ex, ey) = (sp!(k.e.x), sp!(k.e.y));
        let air0 = sub!(neg!(add!(mul!(ex, h0.0), mul!(ey, h0.1))), mul!(big, c1));
        ok = and!(ok, cmp!(_CMP_NLE_UQ, air0, zero));
        let air0_b = add!(
            neg!(add!(mul!(ex, h0_b.0), mul!(ey, h0_b.1))),
            div!(mul!(sg, s1), c1)
        );
        let t1 = div!(one, mul!(big, c1));
        let t2 = div!(one, mul!(big, c2));
        // Every family's terms in every lane (NaN where the lane's own
        // family does not need them), then the lane's own selected.
        let s3 = div!(al, small);
        let c3 = sqrt!(sub!(one, mul!(s3, s3)));
        let t3 = div!(one, mul!(small, c3));
        let s4 = div!(ab, small);
        let c4 = sqrt!(sub!(one, mul!(s4, s4)));
        let t4 = div!(one, mul!(small, c4));
        let r2 = cmul!(rot12, rot12);
        let s2c2 = div!(s2, c2);
        let s3c3 = div!(s3, c3);
        // wall2
        let w_ok = cmp!(_CMP_NLT_UQ, al, small);
        let w_glass = mul!(sp!(2.0 * c.outer_radius), c2);
        let w_glass_al = div!(mul!(sp!(-2.0), s2), c2);
        let w_tb = mul!(two, t1);
        let w_tl = mul!(sp!(-2.0), t2);
        // tir2
        let t_ok = and!(cmp!(_CMP_NLE_UQ, ab, small), cmp!(_CMP_NGE_UQ, al, small));
        let refl = (
            neg!(sub!(one, mul!(mul!(two, s3), s3))),
            mul!(mul!(sp!(-2.0), s3), c3),
        );
        let t_turn = cmul!(r2, refl);
        let t_glass = mul!(two, sub!(mul!(big, c2), mul!(small, c3)));
        let t_glass_al = mul!(two, add!(neg!(s2c2), s3c3));
        let t_tl = add!(mul!(sp!(-2.0), t2), mul!(two, t3));
        // through4 and hollow2
        let f_ok = cmp!(_CMP_NGE_UQ, ab, small);
        let rot43 = (
            add!(mul!(c4, c3), mul!(s4, s3)),
            neg!(sub!(mul!(s4, c3), mul!(c4, s3))),
        );
        let half = cmul!(rot12, rot43);
        let g1 = sub!(mul!(big, c2), mul!(small, c3));
        let g1_al = add!(neg!(s2c2), s3c3);
        let h_tb = sub!(t1, t4);
        let h_tl = add!(neg!(t2), t3);
        let f_turn = cmul!(half, half);
        let f_air = add!(air0, mul!(sp!(2.0 * c.inner_radius), c4));
        let f_air_b = sub!(air0_b, div!(mul!(mul!(two, sg), s4), c4));
        // The lane's own family: wall2, tir2, hollow2, else through4.
        let pick = |w: __m256d, t: __m256d, h: __m256d, f: __m256d| {
            _mm256_blendv_pd(_mm256_blendv_pd(_mm256_blendv_pd(f, h, hollow), t, tir), w, wall)
        };
        ok = and!(ok, pick(w_ok, t_ok, f_ok, f_ok));
        let turn = (
            pick(r2.0, t_turn.0, half.0, f_turn.0),
            pick(r2.1, t_turn.1, half.1, f_turn.1),
        );
        let final_radius = sel!(hollow, small, big);
        let air = pick(air0, air0, air0, f_air);
        let air_b = pick(air0_b, air0_b, air0_b, f_air_b);
        let glass = pick(w_glass, t_glass, g1, mul!(two, g1));
        let glass_al = pick(w_glass_al, t_glass_al, g1_al, mul!(two, g1_al));
        let tb = pick(w_tb, w_tb, h_tb, mul!(two, h_tb));
        let tl = pick(w_tl, t_tl, h_tl, mul!(two, h_tl));
        let turn = (turn.0, mul!(sg, turn.1));
        let hf = cmul!(h0, turn);
        let perp = (neg!(hf.1), hf.0);
        let psi_b = add!(add!(psi0_b, tb), mul!(tl, kk));
        let psi_beta = mul!(mul!(sg, tl), al_beta);
        let hc = sqrt!(_mm256_max_pd(
            sub!(mul!(final_radius, final_radius), mul!(b, b)),
            zero
        ));
        let sigma = sel!(hollow, sp!(-1.0), one);
        let shc = mul!(sigma, hc);
        let nb = neg!(b);
        let origin = (
            add!(mul!(perp.0, nb), mul!(hf.0, shc)),
            add!(mul!(perp.1, nb), mul!(hf.1, shc)),
        );
        let swing = (
            add!(mul!(hf.0, b), mul!(perp.0, shc)),
            add!(mul!(hf.1, b), mul!(perp.1, shc)),
        );
        let sbh = div!(mul!(sigma, b), hc);
        let o_b = (
            sub!(sub!(mul!(swing.0, psi_b), perp.0), mul!(hf.0, sbh)),
            sub!(sub!(mul!(swing.1, psi_b), perp.1), mul!(hf.1, sbh)),
        );
        let o_beta = (mul!(swing.0, psi_beta), mul!(swing.1, psi_beta));
        let rel = (sub!(px, origin.0), sub!(py, origin.1));
        let along = add!(mul!(rel.0, hf.0), mul!(rel.1, hf.1));
        ok = and!(ok, cmp!(_CMP_NLE_UQ, along, zero));
        // a.perp_dot(b) = a.x·b.y − a.y·b.x; a.dot(b) = a.x·b.x + a.y·b.y.
        macro_rules! perp_dot {
            ($a:expr, $b:expr) => {
                sub!(mul!($a.0, $b.1), mul!($a.1, $b.0))
            };
        }
        macro_rules! dot {
            ($a:expr, $b:expr) => {
                add!(mul!($a.0, $b.0), mul!($a.1, $b.1))
            };
        }
        let g = perp_dot!(hf, rel);
        let g_b = sub!(mul!(neg!(along), psi_b), perp_dot!(hf, o_b));
        let g_beta = sub!(mul!(neg!(along), psi_beta), perp_dot!(hf, o_beta));
        let along_b = sub!(mul!(g, psi_b), dot!(hf, o_b));
        let along_beta = sub!(mul!(g, psi_beta), dot!(hf, o_beta));
        let glass_b = mul!(glass_al, al_b);
        let glass_beta = mul!(glass_al, al_beta);
        let aa = add!(air, along);
        let run = add!(div!(aa, ma), div!(glass, mg));
        let climb = mul!(beta, run);
        let climb_b = mul!(beta, add!(div!(add!(air_b, along_b), ma), div!(glass_b, mg)));
        let climb_beta = add!(
            run,
            mul!(
                beta,
                add!(
                    add!(
                        add!(div!(along_beta, ma), div!(mul!(aa, beta), mul!(mul!(ma, ma), ma))),
                        div!(glass_beta, mg)
                    ),
                    div!(mul!(glass, beta), mul!(mul!(mg, mg), mg))
                )
            )
        );
        Eval {
            ok,
            g,
            r1: sub!(climb, dv),
            g_b,
            g_beta,
            climb_b,
            climb_beta,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::warp::tube::test_rng::Lcg;

    /// Every lane is the scalar `resid_jac`, bit for bit, for every family,
    /// in and out of its domain (the `None`s too), with the families mixed
    /// across the lanes, and so is the Newton step taken from it (`newton4`
    /// against `step`); on a CPU without AVX2 this compares the scalar
    /// path with itself.
    #[test]
    fn lanes_equal_the_scalar_resid_jac() {
        let mut rng = Lcg(7);
        for (r_in, eye) in [(0.8, DVec2::new(0.3, 4.0)), (0.5, DVec2::new(-2.5, -1.5))] {
            let c = HollowCylinder::try_new(glam::DVec3::ZERO, glam::DVec3::Y, 1.0, r_in, 1.5).unwrap();
            let k = Consts::new(&c, eye);
            let fams = [Family::Through4, Family::Tir2, Family::Wall2, Family::Hollow2];
            let (mut some, mut none) = (0, 0);
            let mut steps = [0; 3];
            for _ in 0..4000 {
                let lanes: [LaneIn; LANES] = std::array::from_fn(|_| {
                    let fam = fams[(rng.next() * 4.0) as usize % 4];
                    let p = if fam == Family::Hollow2 {
                        DVec2::new(rng.next() - 0.5, rng.next() - 0.5) * r_in
                    } else {
                        DVec2::new(rng.next() * 12.0 - 6.0, rng.next() * 12.0 - 6.0)
                    };
                    LaneIn {
                        fam,
                        p,
                        dv: rng.next() * 6.0 - 3.0,
                        b: rng.next() * 2.2 - 1.1,
                        beta: rng.next() * 1.8 - 0.9,
                    }
                });
                let got = resid_jac4(&k, &lanes);
                let plain = resid_jac4(&k.scalar(), &lanes);
                for (l, (g, q)) in lanes.iter().zip(got.iter().zip(&plain)) {
                    let want = c.resid_jac(l.fam, eye, l.p, l.dv, l.b, l.beta);
                    let bits = |o: &LaneOut| {
                        o.map(|(r, j)| [r[0], r[1], j[0][0], j[0][1], j[1][0], j[1][1]].map(f64::to_bits))
                    };
                    assert_eq!(bits(g), bits(&want), "{l:?}");
                    assert_eq!(bits(q), bits(&want), "{l:?}");
                    // The step from it, in lanes and alone.
                    let tol = rng.next().powi(8) * 4.0;
                    let st = newton4(&k, &[*l; LANES], [tol; LANES]);
                    let alone = step(want, l.b, l.beta, tol);
                    let sbits = |s: Step| match s {
                        Step::Next(b, beta) => Some((b.to_bits(), beta.to_bits())),
                        Step::Root => Some((0, 1)),
                        Step::Fail => None,
                    };
                    assert!(
                        st.iter().all(|&s| sbits(s) == sbits(alone)),
                        "{l:?} {st:?} {alone:?}"
                    );
                    steps[match alone {
                        Step::Fail => 0,
                        Step::Root => 1,
                        Step::Next(..) => 2,
                    }] += 1;
                    if want.is_some() {
                        some += 1;
                    } else {
                        none += 1;
                    }
                }
            }
            assert!(some > 1000 && none > 1000, "{some} {none}");
            assert!(steps.iter().all(|&n| n > 100), "{steps:?}");
        }
    }

    /// `newton_rows` (the rows loaded as vectors, the next point stored
    /// back) is `step` of each row bit for bit, padding included, and
    /// leaves a row that does not step where it was.
    #[test]
    fn rows_equal_the_scalar_step() {
        let mut rng = Lcg(13);
        let c = HollowCylinder::try_new(glam::DVec3::ZERO, glam::DVec3::Y, 1.0, 0.5, 1.5).unwrap();
        let eye = DVec2::new(0.3, 4.0);
        let k = Consts::new(&c, eye);
        let fams = [Family::Through4, Family::Tir2, Family::Wall2, Family::Hollow2];
        let mut seen = [0; 3];
        for n in [1usize, 3, 4, 7, 64, 101] {
            let mut rows = Rows::default();
            let mut lanes = Vec::new();
            for _ in 0..n {
                let fam = fams[(rng.next() * 4.0) as usize % 4];
                let p = if fam == Family::Hollow2 {
                    DVec2::new(rng.next() - 0.5, rng.next() - 0.5) * 0.5
                } else {
                    DVec2::new(rng.next() * 12.0 - 6.0, rng.next() * 12.0 - 6.0)
                };
                let l = LaneIn {
                    fam,
                    p,
                    dv: rng.next() * 6.0 - 3.0,
                    b: rng.next() * 2.2 - 1.1,
                    beta: rng.next() * 1.8 - 0.9,
                };
                // Some tolerances above any residual (roots), most tiny.
                let tol = if rng.next() < 0.2 {
                    1e3
                } else {
                    rng.next().powi(8) * 4.0
                };
                rows.push(&l, tol);
                lanes.push((l, tol));
            }
            rows.pad(n);
            assert_eq!(rows.b.len() % LANES, 0);
            // The scalar path (no AVX2) gives the same rows.
            let mut plain = rows.clone();
            let mut plain_status = vec![NEXT; rows.b.len()];
            newton_rows(&k.scalar(), &mut plain, &mut plain_status);
            let mut status = vec![NEXT; rows.b.len()];
            newton_rows(&k, &mut rows, &mut status);
            assert_eq!(status, plain_status);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                (bits(&rows.b), bits(&rows.beta)),
                (bits(&plain.b), bits(&plain.beta))
            );
            for (i, (l, tol)) in lanes.iter().enumerate() {
                let want = step(c.resid_jac(l.fam, eye, l.p, l.dv, l.b, l.beta), l.b, l.beta, *tol);
                let got = match status[i] {
                    FAIL => Step::Fail,
                    ROOT => Step::Root,
                    _ => Step::Next(rows.b[i], rows.beta[i]),
                };
                let bits = |s: Step| match s {
                    Step::Next(b, beta) => Some((b.to_bits(), beta.to_bits())),
                    Step::Root => Some((0, 1)),
                    Step::Fail => None,
                };
                assert_eq!(bits(got), bits(want), "{l:?}");
                if status[i] != NEXT {
                    assert_eq!(
                        (rows.b[i].to_bits(), rows.beta[i].to_bits()),
                        (l.b.to_bits(), l.beta.to_bits())
                    );
                }
                seen[status[i] as usize] += 1;
            }
        }
        assert!(seen.iter().all(|&n| n > 5), "{seen:?}");
    }
}
