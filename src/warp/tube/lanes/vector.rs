//! The vector code, generic over pulp's levels: `F` and `M` wrap a vector
//! of f64 and a lane mask with the level's token, so that the formulas
//! read as the scalar ones (each operator one vector instruction, in the
//! scalar code's order: Rust's operators associate to the left as the
//! scalar expressions do).
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
    pub(super) fn new(k: &'a Consts, rows: &'a mut Rows, status: &'a mut [u8], range: Range<usize>) -> Self {
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
                (ok[l] == 1.0).then(|| ([g[l], r1[l]], [[g_b[l], g_beta[l]], [climb_b[l], climb_beta[l]]]))
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
