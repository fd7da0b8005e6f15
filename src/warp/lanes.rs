//! The closed-form residual and Jacobian of `HollowCylinder::resid_jac`,
//! and the Newton step taken from it, for several (b, β) at once in the
//! f64 lanes of a vector register: the fast cylinder solver's Newton
//! polishes of many targets are stepped together.
//!
//! Each lane is the scalar `resid_jac` and `step` term by term (the same
//! operations in the same order, none fused into a multiply-add), so a
//! lane gives the scalar functions' bits (tested at every level; only a
//! NaN's sign and payload, which Rust leaves unspecified, may differ). The
//! four families are computed in every lane and the lane's own is selected
//! (blends instead of branches). The seven square roots and five divisions
//! of an evaluation, a dependent chain in the scalar code, then run four or
//! eight lanes per instruction; they bound its time (AMD's Zen 4 splits a
//! 512-bit square root or division in two halves), hence reciprocals
//! shared by products wherever the formulas divide.
//!
//! The vector code is written once, generic over `pulp::Simd`, and
//! monomorphised for AVX-512 (`pulp::x86::V4`, eight lanes) and AVX2 with
//! FMA (`V3`, four lanes); the widest level the CPU has is chosen at run
//! time, once per warper (`Consts`), and a caller may cap it
//! (`SimdLevel`). Without either (or off x86-64) each row is the scalar
//! `resid_jac` and `step`. pulp's level tokens exist only where the CPU
//! has the instructions and it enables them for the generic code, so this
//! module has no `unsafe`. Explicit vectors, because plain `[f64; 4]` code
//! left to LLVM is not enough: it vectorises it mostly in pairs and keeps
//! most square roots and divisions scalar, no faster than four scalar
//! calls.
use super::tube::{Family, HollowCylinder};
use glam::DVec2;

/// The instruction sets the cylinder warp's fast solver can evaluate its
/// Newton steps with, narrowest first (so `min` caps a level).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum SimdLevel {
    /// One evaluation at a time (any CPU).
    Scalar,
    /// AVX2 with FMA (x86-64-v3): four f64 lanes.
    Avx2,
    /// AVX-512 F/BW/CD/DQ/VL (x86-64-v4): eight f64 lanes.
    Avx512,
}

impl SimdLevel {
    /// The widest level this CPU has.
    pub fn detect() -> SimdLevel {
        Isa::new(SimdLevel::Avx512).level()
    }

    /// The f64 lanes of one evaluation.
    pub fn lanes(self) -> usize {
        match self {
            SimdLevel::Scalar => 1,
            SimdLevel::Avx2 => 4,
            SimdLevel::Avx512 => 8,
        }
    }
}

/// The level chosen: pulp's token, which proves the CPU has its
/// instructions.
#[derive(Clone, Copy, Debug)]
enum Isa {
    Scalar,
    #[cfg(target_arch = "x86_64")]
    V3(pulp::x86::V3),
    #[cfg(target_arch = "x86_64")]
    V4(pulp::x86::V4),
}

impl Isa {
    /// The widest level up to `max` that the CPU has.
    fn new(max: SimdLevel) -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            if max >= SimdLevel::Avx512 {
                if let Some(s) = pulp::x86::V4::try_new() {
                    return Isa::V4(s);
                }
            }
            if max >= SimdLevel::Avx2 {
                if let Some(s) = pulp::x86::V3::try_new() {
                    return Isa::V3(s);
                }
            }
        }
        let _ = max;
        Isa::Scalar
    }

    fn level(self) -> SimdLevel {
        match self {
            Isa::Scalar => SimdLevel::Scalar,
            #[cfg(target_arch = "x86_64")]
            Isa::V3(_) => SimdLevel::Avx2,
            #[cfg(target_arch = "x86_64")]
            Isa::V4(_) => SimdLevel::Avx512,
        }
    }
}

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
/// evaluation), and the instruction set to evaluate it with (detected
/// once).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Consts {
    cyl: HollowCylinder,
    e: DVec2,
    /// The eye's and the radii's terms of `resid_jac` (|e|, −e/|e|, its
    /// perpendicular, −1/|e|, 1/R, 1/r), computed as it computes them: in
    /// the vector loop they would be a chain of a square root and four
    /// divisions per evaluation, which the compiler does not hoist.
    rho: f64,
    inward: DVec2,
    perp_i: DVec2,
    neg_inv_rho: f64,
    inv_big: f64,
    inv_small: f64,
    isa: Isa,
    /// The tests' deliberately wrong variant: one multiply-add of the
    /// vector code fused, which the bit-for-bit tests must catch.
    #[cfg(test)]
    fused: bool,
}

impl Consts {
    /// The widest level the CPU has.
    pub fn new(c: &HollowCylinder, e: DVec2) -> Consts {
        Consts::with_level(c, e, SimdLevel::Avx512)
    }

    /// The widest level up to `max` that the CPU has (the tests and the
    /// bench compare the levels).
    pub fn with_level(c: &HollowCylinder, e: DVec2, max: SimdLevel) -> Consts {
        let rho = e.length();
        let inward = -e / rho;
        Consts {
            cyl: *c,
            e,
            rho,
            inward,
            perp_i: DVec2::new(-inward.y, inward.x),
            neg_inv_rho: -1.0 / rho,
            inv_big: 1.0 / c.outer_radius,
            inv_small: 1.0 / c.inner_radius,
            isa: Isa::new(max),
            #[cfg(test)]
            fused: false,
        }
    }

    /// The level the evaluations run at.
    pub fn level(&self) -> SimdLevel {
        self.isa.level()
    }

    /// Rows per evaluation (a batch's size scales with it).
    pub fn lanes(&self) -> usize {
        self.level().lanes()
    }
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
/// code computes it, which differs from `f64::max` only for a NaN), then
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
    // One division (the vector lanes' scarcest unit) for both components.
    let idet = 1.0 / det;
    let nb = b - (r[0] * j[1][1] - r[1] * j[0][1]) * idet;
    let nbeta = beta - (j[0][0] * r[1] - j[1][0] * r[0]) * idet;
    if nbeta.is_nan() || nbeta.abs() >= 0.999_999 {
        return Step::Fail;
    }
    Step::Next(nb, nbeta)
}

/// `Rows::pad`'s multiple: AVX2's lanes (AVX-512 runs the last four rows
/// of an odd count of fours in them).
pub(crate) const PAD: usize = 4;

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

/// Running Newton polishes as a struct of arrays, one row each: the lanes
/// of an evaluation are loaded from consecutive rows as vectors, and the
/// next point is stored back the same way, instead of gathering each lane
/// from a polish and scattering the step into it. The rows' count is kept
/// a multiple of `PAD` (`pad`); padding rows repeat the last real one and
/// are ignored.
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

    /// Keeps the first `n` rows and pads them to a multiple of `PAD` with
    /// copies of the last one.
    pub fn pad(&mut self, n: usize) {
        let m = n.div_ceil(PAD) * PAD;
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
/// point into its b and β. Rows are evaluated eight (AVX-512) or four
/// (AVX2) at a time in vector registers (each lane `resid_jac` and `step`
/// bit for bit), or one at a time with `resid_jac` and `step` at the
/// scalar level. With AVX-512 a last group of four rows runs in AVX2's
/// four lanes, so that the rows need padding to four only: a batch of one
/// target (`images`) has one or two polishes.
pub(crate) fn newton_rows(k: &Consts, rows: &mut Rows, status: &mut [u8]) {
    let n = rows.b.len();
    match k.isa {
        #[cfg(target_arch = "x86_64")]
        Isa::V4(s) => {
            let eights = n / 8 * 8;
            if eights > 0 {
                pulp::Simd::vectorize(s, vector::NewtonRows::new(k, rows, status, 0..eights));
            }
            if eights < n {
                pulp::Simd::vectorize(*s, vector::NewtonRows::new(k, rows, status, eights..n));
            }
        }
        #[cfg(target_arch = "x86_64")]
        Isa::V3(s) => pulp::Simd::vectorize(s, vector::NewtonRows::new(k, rows, status, 0..n)),
        Isa::Scalar => {
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
    }
}

/// `resid_jac` of every row (`rows` padded), evaluated as `newton_rows`
/// evaluates it (the tests' view of the vector evaluation).
#[cfg(test)]
pub(crate) fn resid_jac_rows(k: &Consts, rows: &Rows) -> Vec<LaneOut> {
    let n = rows.b.len();
    match k.isa {
        #[cfg(target_arch = "x86_64")]
        Isa::V4(s) => {
            let eights = n / 8 * 8;
            let mut out = pulp::Simd::vectorize(
                s,
                vector::EvalRows {
                    k,
                    rows,
                    range: 0..eights,
                },
            );
            out.extend(pulp::Simd::vectorize(
                *s,
                vector::EvalRows {
                    k,
                    rows,
                    range: eights..n,
                },
            ));
            out
        }
        #[cfg(target_arch = "x86_64")]
        Isa::V3(s) => pulp::Simd::vectorize(s, vector::EvalRows { k, rows, range: 0..n }),
        Isa::Scalar => (0..rows.b.len())
            .map(|i| {
                let l = rows.lane(i);
                k.cyl.resid_jac(l.fam, k.e, l.p, l.dv, l.b, l.beta)
            })
            .collect(),
    }
}

/// The vector code, generic over pulp's levels: `F` and `M` wrap a vector
/// of f64 and a lane mask with the level's token, so that the formulas
/// read as the scalar ones (each operator one vector instruction, in the
/// scalar code's order: Rust's operators associate to the left as the
/// scalar expressions do).
#[cfg(target_arch = "x86_64")]
mod vector {
    use super::{Consts, Rows, FAIL, NEXT, ROOT};
    use pulp::{Simd, WithSimd};
    use std::ops::{Add, BitAnd, BitOr, Div, Mul, Neg, Not, Range, Sub};

    /// The widest level's lanes (the buffers of a vector's lanes).
    const MAX_LANES: usize = 8;

    /// f64 lanes.
    #[derive(Clone, Copy)]
    struct F<S: Simd>(S, S::f64s);

    /// A lane mask (all lanes' comparisons are IEEE: ordered ones false
    /// for a NaN, their negations true).
    #[derive(Clone, Copy)]
    struct M<S: Simd>(S, S::m64s);

    macro_rules! binop {
        ($tr:ident, $f:ident, $op:ident) => {
            impl<S: Simd> $tr for F<S> {
                type Output = F<S>;
                #[inline(always)]
                fn $f(self, o: F<S>) -> F<S> {
                    F(self.0, self.0.$op(self.1, o.1))
                }
            }
        };
    }
    binop!(Add, add, add_f64s);
    binop!(Sub, sub, sub_f64s);
    binop!(Mul, mul, mul_f64s);
    binop!(Div, div, div_f64s);

    impl<S: Simd> Neg for F<S> {
        type Output = F<S>;
        /// The sign bit flipped, as the scalar `-x`.
        #[inline(always)]
        fn neg(self) -> F<S> {
            F(self.0, self.0.neg_f64s(self.1))
        }
    }

    impl<S: Simd> F<S> {
        #[inline(always)]
        fn splat(s: S, x: f64) -> F<S> {
            F(s, s.splat_f64s(x))
        }
        #[inline(always)]
        fn sqrt(self) -> F<S> {
            F(self.0, self.0.sqrt_f64s(self.1))
        }
        /// The sign bit cleared, as `f64::abs`.
        #[inline(always)]
        fn abs(self) -> F<S> {
            F(self.0, self.0.abs_f64s(self.1))
        }
        #[inline(always)]
        fn eq(self, o: F<S>) -> M<S> {
            M(self.0, self.0.equal_f64s(self.1, o.1))
        }
        #[inline(always)]
        fn lt(self, o: F<S>) -> M<S> {
            M(self.0, self.0.less_than_f64s(self.1, o.1))
        }
        #[inline(always)]
        fn le(self, o: F<S>) -> M<S> {
            M(self.0, self.0.less_than_or_equal_f64s(self.1, o.1))
        }
        #[inline(always)]
        fn gt(self, o: F<S>) -> M<S> {
            M(self.0, self.0.greater_than_f64s(self.1, o.1))
        }
        #[inline(always)]
        fn ge(self, o: F<S>) -> M<S> {
            M(self.0, self.0.greater_than_or_equal_f64s(self.1, o.1))
        }
        /// The scalar `a > b { a } else { b }` (not `f64::max`: the
        /// second operand for a NaN in either).
        #[inline(always)]
        fn max(self, o: F<S>) -> F<S> {
            self.gt(o).sel(self, o)
        }
        /// `self` from the `n` rows of `v` from `i` (`n` the lanes).
        #[inline(always)]
        fn load(s: S, v: &[f64], i: usize) -> F<S> {
            F(s, S::as_simd_f64s(&v[i..i + S::F64_LANES]).0[0])
        }
        /// Into the rows of `v` from `i`.
        #[inline(always)]
        fn store(self, v: &mut [f64], i: usize) {
            S::as_mut_simd_f64s(&mut v[i..i + S::F64_LANES]).0[0] = self.1;
        }
        /// The lanes (the first `S::F64_LANES` of the array).
        #[inline(always)]
        fn lanes(self) -> [f64; MAX_LANES] {
            let mut a = [0.0; MAX_LANES];
            self.store(&mut a, 0);
            a
        }
    }

    impl<S: Simd> BitAnd for M<S> {
        type Output = M<S>;
        #[inline(always)]
        fn bitand(self, o: M<S>) -> M<S> {
            M(self.0, self.0.and_m64s(self.1, o.1))
        }
    }
    impl<S: Simd> BitOr for M<S> {
        type Output = M<S>;
        #[inline(always)]
        fn bitor(self, o: M<S>) -> M<S> {
            M(self.0, self.0.or_m64s(self.1, o.1))
        }
    }
    impl<S: Simd> Not for M<S> {
        type Output = M<S>;
        #[inline(always)]
        fn not(self) -> M<S> {
            M(self.0, self.0.not_m64s(self.1))
        }
    }
    impl<S: Simd> M<S> {
        /// `a` where the mask is set, else `b`, lane by lane.
        #[inline(always)]
        fn sel(self, a: F<S>, b: F<S>) -> F<S> {
            F(self.0, self.0.select_f64s(self.1, a.1, b.1))
        }
    }

    type V2<S> = (F<S>, F<S>);

    /// The product of unit complex numbers (x, y) (rotations composed).
    #[inline(always)]
    fn cmul<S: Simd>(a: V2<S>, b: V2<S>) -> V2<S> {
        (a.0 * b.0 - a.1 * b.1, a.0 * b.1 + a.1 * b.0)
    }

    /// `resid_jac`'s answer in the lanes: `ok` (where it is `Some`), the
    /// residual and the Jacobian.
    struct Eval<S: Simd> {
        ok: M<S>,
        g: F<S>,
        r1: F<S>,
        g_b: F<S>,
        g_beta: F<S>,
        climb_b: F<S>,
        climb_beta: F<S>,
    }

    /// One evaluation's rows, loaded.
    struct In<S: Simd> {
        fam: F<S>,
        b: F<S>,
        beta: F<S>,
        px: F<S>,
        py: F<S>,
        dv: F<S>,
    }

    impl<S: Simd> In<S> {
        #[inline(always)]
        fn load(s: S, rows: &Rows, i: usize) -> In<S> {
            In {
                fam: F::load(s, &rows.fam, i),
                b: F::load(s, &rows.b, i),
                beta: F::load(s, &rows.beta, i),
                px: F::load(s, &rows.px, i),
                py: F::load(s, &rows.py, i),
                dv: F::load(s, &rows.dv, i),
            }
        }
    }

    /// `super::newton_rows` of the rows of `range` (a multiple of the
    /// lanes long) at level `S`.
    pub(super) struct NewtonRows<'a> {
        k: &'a Consts,
        rows: &'a mut Rows,
        status: &'a mut [u8],
        range: Range<usize>,
    }

    impl<'a> NewtonRows<'a> {
        pub(super) fn new(
            k: &'a Consts,
            rows: &'a mut Rows,
            status: &'a mut [u8],
            range: Range<usize>,
        ) -> Self {
            NewtonRows {
                k,
                rows,
                status,
                range,
            }
        }
    }

    impl WithSimd for NewtonRows<'_> {
        type Output = ();
        #[inline(always)]
        fn with_simd<S: Simd>(self, s: S) {
            let NewtonRows {
                k,
                rows,
                status,
                range,
            } = self;
            let n = S::F64_LANES;
            let sp = |x: f64| F::splat(s, x);
            let mut i = range.start;
            while i + n <= range.end {
                let x = In::load(s, rows, i);
                let v = eval(s, k, &x);
                let (nb, nbeta, st) = step(s, &v, x.b, x.beta, F::load(s, &rows.tol, i));
                // Only lanes that step move (a root keeps its point).
                let moves = st.eq(sp(f64::from(NEXT)));
                moves.sel(nb, x.b).store(&mut rows.b, i);
                moves.sel(nbeta, x.beta).store(&mut rows.beta, i);
                let st = st.lanes();
                for (o, c) in status[i..i + n].iter_mut().zip(st) {
                    *o = c as u8;
                }
                i += n;
            }
        }
    }

    /// `super::resid_jac_rows` at level `S`.
    #[cfg(test)]
    pub(super) struct EvalRows<'a> {
        pub k: &'a Consts,
        pub rows: &'a Rows,
        pub range: Range<usize>,
    }

    #[cfg(test)]
    impl WithSimd for EvalRows<'_> {
        type Output = Vec<super::LaneOut>;
        #[inline(always)]
        fn with_simd<S: Simd>(self, s: S) -> Vec<super::LaneOut> {
            let EvalRows { k, rows, range } = self;
            let n = S::F64_LANES;
            let mut out = Vec::new();
            let mut i = range.start;
            while i + n <= range.end {
                let v = eval(s, k, &In::load(s, rows, i));
                let ok = v.ok.sel(F::splat(s, 1.0), F::splat(s, 0.0)).lanes();
                let [g, r1, g_b, g_beta, climb_b, climb_beta] =
                    [v.g, v.r1, v.g_b, v.g_beta, v.climb_b, v.climb_beta].map(F::lanes);
                out.extend((0..n).map(|l| {
                    (ok[l] == 1.0)
                        .then(|| ([g[l], r1[l]], [[g_b[l], g_beta[l]], [climb_b[l], climb_beta[l]]]))
                }));
                i += n;
            }
            out
        }
    }

    /// `super::step` in the lanes: the next (b, β), and the outcome as a
    /// lane's value (`NEXT`, `ROOT`, `FAIL`).
    #[inline(always)]
    fn step<S: Simd>(s: S, v: &Eval<S>, b: F<S>, beta: F<S>, tol: F<S>) -> (F<S>, F<S>, F<S>) {
        let sp = |x: f64| F::splat(s, x);
        let (ag, ar1) = (v.g.abs(), v.r1.abs());
        // `step`'s `if r0 > r1 { r0 } else { r1 }`.
        let norm = ag.max(ar1);
        let root = norm.le(tol);
        let det = v.g_b * v.climb_beta - v.g_beta * v.climb_b;
        // det == 0 or not finite (a NaN or an infinity).
        let bad_det = det.eq(sp(0.0)) | !det.abs().lt(sp(f64::INFINITY));
        let idet = sp(1.0) / det;
        let nb = b - (v.g * v.climb_beta - v.r1 * v.g_beta) * idet;
        let nbeta = beta - (v.g_b * v.r1 - v.climb_b * v.g) * idet;
        // A NaN or |β| ≥ 0.999999.
        let bad_beta = !nbeta.abs().lt(sp(0.999_999));
        let (next, root_c, fail) = (sp(f64::from(NEXT)), sp(f64::from(ROOT)), sp(f64::from(FAIL)));
        let st =
            v.ok.sel(root.sel(root_c, (bad_det | bad_beta).sel(fail, next)), fail);
        (nb, nbeta, st)
    }

    /// `HollowCylinder::resid_jac` in the lanes (see there for the
    /// formulas; the names are the same). The comparisons of its early
    /// returns are negated as written there: `!(a >= b)` is true for a NaN.
    #[inline(always)]
    fn eval<S: Simd>(s: S, k: &Consts, x: &In<S>) -> Eval<S> {
        let sp = |x: f64| F::splat(s, x);
        let In {
            fam,
            b,
            beta,
            px,
            py,
            dv,
        } = *x;
        let wall = fam.eq(sp(1.0));
        let tir = fam.eq(sp(2.0));
        let hollow = fam.eq(sp(3.0));
        let c = &k.cyl;
        let (big, small) = (sp(c.outer_radius), sp(c.inner_radius));
        let (inv_big, inv_small) = (sp(k.inv_big), sp(k.inv_small));
        let (one, two, zero) = (sp(1.0), sp(2.0), sp(0.0));
        let ab = b.abs();
        let mut ok = !ab.ge(big) & !ab.ge(sp(k.rho));
        let bb = beta * beta;
        let ma = (one - bb).sqrt();
        let mg = (sp(c.ior * c.ior) - bb).sqrt();
        let r_m = one / (ma * mg);
        let (ima, img) = (mg * r_m, ma * r_m);
        let kk = ma * img;
        let k_beta = kk * beta * (img * img - ima * ima);
        let al = ab * kk;
        let sg = b.lt(zero).sel(sp(-1.0), one);
        let (al_b, al_beta) = (sg * kk, ab * k_beta);
        let (inward, perp_i) = (k.inward, k.perp_i);
        let x = b * sp(k.neg_inv_rho);
        let cx = (one - x * x).sqrt();
        let h0 = (
            sp(inward.x) * cx + sp(perp_i.x) * x,
            sp(inward.y) * cx + sp(perp_i.y) * x,
        );
        let s1 = ab * inv_big;
        let c1 = (one - s1 * s1).sqrt();
        let s2 = al * inv_big;
        let c2 = (one - s2 * s2).sqrt();
        let cx_c1 = cx * c1;
        let r_c = one / (cx_c1 * c2);
        let (icx, ic1, ic2) = (c1 * c2 * r_c, cx * c2 * r_c, cx_c1 * r_c);
        let q = -x * icx;
        let m_rho = sp(k.neg_inv_rho);
        let h0_b = (
            (sp(inward.x) * q + sp(perp_i.x)) * m_rho,
            (sp(inward.y) * q + sp(perp_i.y)) * m_rho,
        );
        let psi0_b = h0_b.0 * -h0.1 + h0_b.1 * h0.0;
        let rot12 = (c1 * c2 + s1 * s2, s1 * c2 - c1 * s2);
        let (ex, ey) = (sp(k.e.x), sp(k.e.y));
        let air0 = -(ex * h0.0 + ey * h0.1) - big * c1;
        ok = ok & !air0.le(zero);
        let air0_b = -(ex * h0_b.0 + ey * h0_b.1) + sg * s1 * ic1;
        let t1 = inv_big * ic1;
        let t2 = inv_big * ic2;
        // Every family's terms in every lane (NaN where the lane's own
        // family does not need them), then the lane's own selected.
        let s3 = al * inv_small;
        let c3 = (one - s3 * s3).sqrt();
        let ic3 = one / c3;
        let t3 = inv_small * ic3;
        let s4 = ab * inv_small;
        let c4 = (one - s4 * s4).sqrt();
        let ic4 = one / c4;
        let t4 = inv_small * ic4;
        let r2 = cmul(rot12, rot12);
        let s2c2 = s2 * ic2;
        let s3c3 = s3 * ic3;
        // wall2
        let w_ok = !al.lt(small);
        let w_glass = sp(2.0 * c.outer_radius) * c2;
        let w_glass_al = sp(-2.0) * s2 * ic2;
        let w_tb = two * t1;
        let w_tl = sp(-2.0) * t2;
        // tir2
        let t_ok = !ab.le(small) & !al.ge(small);
        let refl = (-(one - two * s3 * s3), sp(-2.0) * s3 * c3);
        let t_turn = cmul(r2, refl);
        let t_glass = two * (big * c2 - small * c3);
        let t_glass_al = two * (-s2c2 + s3c3);
        let t_tl = sp(-2.0) * t2 + two * t3;
        // through4 and hollow2
        let f_ok = !ab.ge(small);
        let rot43 = (c4 * c3 + s4 * s3, -(s4 * c3 - c4 * s3));
        let half = cmul(rot12, rot43);
        let g1 = big * c2 - small * c3;
        let g1_al = -s2c2 + s3c3;
        let h_tb = t1 - t4;
        let h_tl = -t2 + t3;
        let f_turn = cmul(half, half);
        let f_air = air0 + sp(2.0 * c.inner_radius) * c4;
        let f_air_b = air0_b - two * sg * s4 * ic4;
        // The lane's own family: wall2, tir2, hollow2, else through4 (the
        // codes exclude each other).
        let pick = |w: F<S>, t: F<S>, h: F<S>, f: F<S>| wall.sel(w, tir.sel(t, hollow.sel(h, f)));
        ok = ok & ((wall & w_ok) | (tir & t_ok) | (!(wall | tir) & f_ok));
        let turn = (
            pick(r2.0, t_turn.0, half.0, f_turn.0),
            pick(r2.1, t_turn.1, half.1, f_turn.1),
        );
        let air = pick(air0, air0, air0, f_air);
        let air_b = pick(air0_b, air0_b, air0_b, f_air_b);
        let glass = pick(w_glass, t_glass, g1, two * g1);
        let glass_al = pick(w_glass_al, t_glass_al, g1_al, two * g1_al);
        let tb = pick(w_tb, w_tb, h_tb, two * h_tb);
        let tl = pick(w_tl, t_tl, h_tl, two * h_tl);
        let turn = (turn.0, sg * turn.1);
        let hf = cmul(h0, turn);
        let perp = (-hf.1, hf.0);
        let psi_b = psi0_b + tb + tl * kk;
        let psi_beta = sg * tl * al_beta;
        // hc = ρ_f·cos θ of the final circle, and 1/hc.
        let hc = hollow.sel(small * c4, big * c1);
        let ihc = hollow.sel(t4, t1);
        let sigma = hollow.sel(sp(-1.0), one);
        let shc = sigma * hc;
        let nb = -b;
        let origin = (perp.0 * nb + hf.0 * shc, perp.1 * nb + hf.1 * shc);
        let swing = (hf.0 * b + perp.0 * shc, hf.1 * b + perp.1 * shc);
        let sbh = sigma * b * ihc;
        let o_b = (
            swing.0 * psi_b - perp.0 - hf.0 * sbh,
            swing.1 * psi_b - perp.1 - hf.1 * sbh,
        );
        let o_beta = (swing.0 * psi_beta, swing.1 * psi_beta);
        let rel = (px - origin.0, py - origin.1);
        let along = rel.0 * hf.0 + rel.1 * hf.1;
        ok = ok & !along.le(zero);
        // a.perp_dot(b) = a.x·b.y − a.y·b.x; a.dot(b) = a.x·b.x + a.y·b.y.
        let perp_dot = |a: V2<S>, b: V2<S>| a.0 * b.1 - a.1 * b.0;
        let dot = |a: V2<S>, b: V2<S>| a.0 * b.0 + a.1 * b.1;
        let g = perp_dot(hf, rel);
        #[cfg(test)]
        let g = if k.fused {
            F(s, s.mul_add_f64s(hf.0 .1, rel.1 .1, (-(hf.1 * rel.0)).1))
        } else {
            g
        };
        let g_b = -along * psi_b - perp_dot(hf, o_b);
        let g_beta = -along * psi_beta - perp_dot(hf, o_beta);
        let along_b = g * psi_b - dot(hf, o_b);
        let along_beta = g * psi_beta - dot(hf, o_beta);
        let glass_b = glass_al * al_b;
        let glass_beta = glass_al * al_beta;
        let aa = air + along;
        let run = aa * ima + glass * img;
        let climb = beta * run;
        let climb_b = beta * ((air_b + along_b) * ima + glass_b * img);
        let climb_beta = run
            + beta
                * (along_beta * ima
                    + aa * beta * (ima * ima * ima)
                    + glass_beta * img
                    + glass * beta * (img * img * img));
        Eval {
            ok,
            g,
            r1: climb - dv,
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

    const FAMS: [Family; 4] = [Family::Through4, Family::Tir2, Family::Wall2, Family::Hollow2];

    /// Every level this CPU has, widest first (the scalar level always).
    fn levels() -> Vec<SimdLevel> {
        [SimdLevel::Avx512, SimdLevel::Avx2, SimdLevel::Scalar]
            .into_iter()
            .filter(|&l| SimdLevel::detect() >= l)
            .collect()
    }

    /// A random lane: every family, with targets and points in and out of
    /// their domains, so that about half the evaluations are `None`.
    fn random_lane(rng: &mut Lcg, r_in: f64) -> LaneIn {
        let fam = FAMS[(rng.next() * 4.0) as usize % 4];
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
    }

    /// The edges of the domains: b on the radii, at ±0 and at the eye's
    /// distance, β at 0, at the step's bound and beyond 1, NaNs, and a
    /// target on the axis; every family for each.
    fn edge_lanes(r_in: f64, rho: f64) -> Vec<LaneIn> {
        let bs = [
            0.0,
            -0.0,
            r_in,
            -r_in,
            1.0,
            -1.0,
            rho,
            f64::MIN_POSITIVE,
            r_in * (1.0 - f64::EPSILON),
            1.0 - f64::EPSILON,
            f64::NAN,
            f64::INFINITY,
        ];
        let betas = [0.0, -0.0, 0.999_999, -0.999_999, 0.5, 1.0, 1.2, f64::NAN];
        let ps = [DVec2::ZERO, DVec2::new(r_in * 0.5, 0.1), DVec2::new(3.0, -2.0)];
        let mut out = Vec::new();
        for &fam in &FAMS {
            for &b in &bs {
                for &beta in &betas {
                    for &p in &ps {
                        out.push(LaneIn {
                            fam,
                            p,
                            dv: 0.7,
                            b,
                            beta,
                        });
                    }
                }
            }
        }
        out
    }

    /// `lanes` as padded rows, with their tolerances.
    fn rows_of(lanes: &[LaneIn], tol: impl Fn(usize) -> f64) -> Rows {
        let mut rows = Rows::default();
        for (i, l) in lanes.iter().enumerate() {
            rows.push(l, tol(i));
        }
        rows.pad(lanes.len());
        assert_eq!(rows.b.len() % PAD, 0);
        rows
    }

    /// The bits of `x`, but one for every NaN: Rust leaves a NaN result's
    /// sign and payload unspecified (x86 propagates the first operand's
    /// NaN, and LLVM may swap the operands of a commutative operation), so
    /// only NaN-ness is the function's answer; every other bit, the sign
    /// of a zero included, must agree.
    fn canon(x: f64) -> u64 {
        if x.is_nan() {
            f64::NAN.to_bits()
        } else {
            x.to_bits()
        }
    }

    fn bits(o: &LaneOut) -> Option<[u64; 6]> {
        o.map(|(r, j)| [r[0], r[1], j[0][0], j[0][1], j[1][0], j[1][1]].map(canon))
    }

    fn step_bits(s: Step) -> Option<(u64, u64)> {
        match s {
            Step::Next(b, beta) => Some((canon(b), canon(beta))),
            Step::Root => Some((0, 1)),
            Step::Fail => None,
        }
    }

    /// The lanes whose evaluation at `k`'s level differs from the scalar
    /// `resid_jac` in any bit (or in being `None`).
    fn mismatches(k: &Consts, c: &HollowCylinder, eye: DVec2, lanes: &[LaneIn]) -> usize {
        let rows = rows_of(lanes, |_| 0.0);
        let got = resid_jac_rows(k, &rows);
        assert_eq!(got.len(), rows.b.len());
        lanes
            .iter()
            .zip(&got)
            .filter(|(l, g)| bits(g) != bits(&c.resid_jac(l.fam, eye, l.p, l.dv, l.b, l.beta)))
            .count()
    }

    /// This CPU's levels are pulp's tokens: AVX-512 where it has AVX-512
    /// F/BW/CD/DQ/VL, AVX2 where it has AVX2 and FMA, and a cap is obeyed.
    #[test]
    fn the_level_follows_the_cpu_and_the_cap() {
        let c = HollowCylinder::try_new(glam::DVec3::ZERO, glam::DVec3::Y, 1.0, 0.8, 1.5).unwrap();
        let e = DVec2::new(0.3, 4.0);
        #[cfg(target_arch = "x86_64")]
        let (v3, v4) = {
            use std::arch::is_x86_feature_detected as has;
            let v3 = has!("avx2") && has!("fma") && has!("bmi1") && has!("bmi2") && has!("lzcnt");
            let v4 = v3
                && has!("avx512f")
                && has!("avx512bw")
                && has!("avx512cd")
                && has!("avx512dq")
                && has!("avx512vl");
            (v3, v4)
        };
        #[cfg(not(target_arch = "x86_64"))]
        let (v3, v4) = (false, false);
        let best = if v4 {
            SimdLevel::Avx512
        } else if v3 {
            SimdLevel::Avx2
        } else {
            SimdLevel::Scalar
        };
        assert_eq!(SimdLevel::detect(), best);
        assert_eq!(Consts::new(&c, e).level(), best);
        for cap in [SimdLevel::Avx512, SimdLevel::Avx2, SimdLevel::Scalar] {
            let k = Consts::with_level(&c, e, cap);
            assert_eq!(k.level(), cap.min(best), "{cap:?}");
            assert_eq!(k.lanes(), cap.min(best).lanes());
        }
        println!("this CPU: {best:?}, levels tested {:?}", levels());
    }

    /// Every lane at every level this CPU has is the scalar `resid_jac`,
    /// bit for bit, for every family, in and out of its domain (the `None`s
    /// too) and on its edges, with the families mixed across the lanes.
    #[test]
    fn every_level_equals_the_scalar_resid_jac() {
        let mut rng = Lcg(7);
        for (r_in, eye) in [(0.8, DVec2::new(0.3, 4.0)), (0.5, DVec2::new(-2.5, -1.5))] {
            let c = HollowCylinder::try_new(glam::DVec3::ZERO, glam::DVec3::Y, 1.0, r_in, 1.5).unwrap();
            let mut lanes: Vec<LaneIn> = (0..20_000).map(|_| random_lane(&mut rng, r_in)).collect();
            let some = lanes
                .iter()
                .filter(|l| c.resid_jac(l.fam, eye, l.p, l.dv, l.b, l.beta).is_some())
                .count();
            assert!(some > 2000 && lanes.len() - some > 2000, "{some}");
            let edges = edge_lanes(r_in, eye.length());
            let edge_some = edges
                .iter()
                .filter(|l| c.resid_jac(l.fam, eye, l.p, l.dv, l.b, l.beta).is_some())
                .count();
            assert!(edge_some > 20 && edges.len() - edge_some > 20, "{edge_some}");
            lanes.extend(edges);
            // An odd count: the last evaluation is padded.
            lanes.push(random_lane(&mut rng, r_in));
            for level in levels() {
                let k = Consts::with_level(&c, eye, level);
                assert_eq!(k.level(), level);
                assert_eq!(mismatches(&k, &c, eye, &lanes), 0, "{level:?}");
            }
        }
    }

    /// The bit-for-bit comparison has the power to see a change of the
    /// operations: with one product-difference of the residual fused into
    /// a multiply-add (one rounding less), many lanes at every vector
    /// level differ from the scalar function.
    #[test]
    fn a_fused_multiply_add_is_caught() {
        let mut rng = Lcg(11);
        let eye = DVec2::new(0.3, 4.0);
        let c = HollowCylinder::try_new(glam::DVec3::ZERO, glam::DVec3::Y, 1.0, 0.8, 1.5).unwrap();
        let lanes: Vec<LaneIn> = (0..4000).map(|_| random_lane(&mut rng, 0.8)).collect();
        for level in levels() {
            let mut k = Consts::with_level(&c, eye, level);
            assert_eq!(mismatches(&k, &c, eye, &lanes), 0, "{level:?}");
            k.fused = true;
            let bad = mismatches(&k, &c, eye, &lanes);
            println!("{level:?}: {bad} of {} lanes differ when fused", lanes.len());
            if level == SimdLevel::Scalar {
                // The scalar level is the scalar function itself.
                assert_eq!(bad, 0);
            } else {
                assert!(bad > 100, "{level:?}: {bad}");
            }
        }
    }

    /// `newton_rows` at every level (the rows loaded as vectors, the next
    /// point stored back) is `step` of each row bit for bit, padding
    /// included, edges too, and leaves a row that does not step where it
    /// was.
    #[test]
    fn every_level_steps_as_the_scalar_step() {
        let mut rng = Lcg(13);
        let c = HollowCylinder::try_new(glam::DVec3::ZERO, glam::DVec3::Y, 1.0, 0.5, 1.5).unwrap();
        let eye = DVec2::new(0.3, 4.0);
        let mut seen = [0; 3];
        let mut sizes: Vec<usize> = vec![1, 3, 4, 7, 8, 9, 64, 101, 5000];
        let edges = edge_lanes(0.5, eye.length());
        sizes.push(edges.len());
        for (si, &n) in sizes.iter().enumerate() {
            let lanes: Vec<LaneIn> = if si == sizes.len() - 1 {
                edges.clone()
            } else {
                (0..n).map(|_| random_lane(&mut rng, 0.5)).collect()
            };
            // Some tolerances above any residual (roots), most tiny.
            let tols: Vec<f64> = (0..n)
                .map(|_| {
                    if rng.next() < 0.2 {
                        1e3
                    } else {
                        rng.next().powi(8) * 4.0
                    }
                })
                .collect();
            let want: Vec<Step> = lanes
                .iter()
                .zip(&tols)
                .map(|(l, &tol)| step(c.resid_jac(l.fam, eye, l.p, l.dv, l.b, l.beta), l.b, l.beta, tol))
                .collect();
            for level in levels() {
                let k = Consts::with_level(&c, eye, level);
                let mut rows = rows_of(&lanes, |i| tols[i]);
                let mut status = vec![NEXT; rows.b.len()];
                newton_rows(&k, &mut rows, &mut status);
                for (i, (l, w)) in lanes.iter().zip(&want).enumerate() {
                    let got = match status[i] {
                        FAIL => Step::Fail,
                        ROOT => Step::Root,
                        _ => Step::Next(rows.b[i], rows.beta[i]),
                    };
                    assert_eq!(step_bits(got), step_bits(*w), "{level:?} {l:?}");
                    if status[i] != NEXT {
                        assert_eq!(
                            (canon(rows.b[i]), canon(rows.beta[i])),
                            (canon(l.b), canon(l.beta))
                        );
                    }
                    seen[status[i] as usize] += 1;
                }
            }
        }
        assert!(seen.iter().all(|&n| n > 100), "{seen:?}");
    }
}
