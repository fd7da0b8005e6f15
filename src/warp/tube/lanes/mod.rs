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
use super::{Family, HollowCylinder};
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
#[cfg(target_arch = "x86_64")]
mod vector;

#[cfg(test)]
mod tests;
