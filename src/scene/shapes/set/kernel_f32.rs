//! The analytic set's queries in f32 lanes: twice the lanes per
//! instruction of the f64 kernel (`SetKernel`), and f32 square roots and
//! divisions, which cost a fraction of f64's.
//!
//! The f64 kernel gives Embree's answer bit for bit. This one gives, for
//! each lane it is sure of, the same primitive and the same crossing, its
//! t within the error bounds below of the f64 root; a lane it is not sure
//! of is `unsure` and answered by the scalar f64 code, as the f64 kernel's
//! unsure lanes are. A lane is unsure when a root lies within its error
//! bound of an end of the lane's interval (the start, `tfar`, or a nearer
//! primitive's crossing), when the discriminant is within its error of
//! zero, when the two roots are within their error of the touch window
//! (`Segment::is_touch`), or when a crossing lies within its error of the
//! edge of a rect, disk or wall. Elsewhere the f32 answer decides as the
//! f64 one does (tested against it at every vector level, with a
//! known-wrong variant that trusts every lane).
//!
//! The error bounds. Each primitive's position is held as f32 pairs (hi,
//! lo), so that `o − c` is the f32 origin less the f64 position rounded
//! once or twice: a few ulps of `|o − c|`, not of the position's distance
//! from the world's origin. From there each quantity's error is bounded by
//! the rounding of the operations that make it, times a safety factor
//! (`ERROR_SAFETY`; the analysis gives about 2): b = c·d; the line's
//! offset f from the center at its closest approach and h = r² − |f|²
//! (Hearn and Baker's discriminant, without the cancellation of b² − a·c
//! for distant origins); s = |d|·√h; q = −(b + sign(b)·s); the roots q/a
//! and c'/q (c' = |o − c|² − r²). Near grazing incidence (h → 0) the
//! bounds grow as 1/√h. A plane's crossing is (w − n·o)/(n·d) with
//! w = n·corner as a pair: n·o's rounding over |n·d|. A ray spawned off a
//! surface starts `OFFSET_ULPS` ulps of its position away from it, several
//! times the bound of the root at that surface, so that root is decided
//! for sure: a render's unsure lanes are a few in a million.
use super::lanes::{lowest_ranks_seen, Resolved};
use super::primitive::QuadricF32;
use crate::embree::PacketRays;
use crate::simd3::select;

/// The safety factor of the error bounds (the analysis gives about 2).
pub(in crate::scene) const ERROR_SAFETY: f32 = 4.0;

/// One primitive as the kernel reads it.
#[derive(Debug, Clone, Copy)]
pub(in crate::scene) struct PrimF32 {
    pub(super) geom: u32,
    pub(super) prim: u32,
    pub(super) bounds: ([f32; 3], [f32; 3]),
    /// None: a primitive without a vector form (a lane meeting its box is
    /// unsure).
    pub(super) quadric: Option<QuadricF32>,
    /// `Primitive::rank`.
    pub(super) rank: f32,
}

/// The set's query for the first `m` lanes at one vector level (see the
/// module's documentation), into `out` (which holds `Resolved::NONE`).
pub(super) struct SetKernelF32<'a, const N: usize> {
    pub prims: &'a [PrimF32],
    pub rays: PacketRays<'a, N>,
    pub occlusion: bool,
    pub out: &'a mut Resolved<f32, N>,
    /// The error bounds' safety factor ([`ERROR_SAFETY`]; the tests widen
    /// it to show what loose bounds cost).
    pub safety: f32,
}

// Arithmetic on the lanes, written with macros rather than closures (see
// `crate::simd3`).
macro_rules! v {
    ($simd:ident, $op:ident, $($arg:expr),+) => {
        $simd.$op($($arg),+)
    };
}

/// `a·b + c·d + e·f`, summed left to right.
macro_rules! dot {
    ($simd:ident, $x:expr, $y:expr, $z:expr, $x2:expr, $y2:expr, $z2:expr) => {
        v!(
            $simd,
            add_f32s,
            v!(
                $simd,
                add_f32s,
                v!($simd, mul_f32s, $x, $x2),
                v!($simd, mul_f32s, $y, $y2)
            ),
            v!($simd, mul_f32s, $z, $z2)
        )
    };
}

/// The origin's offset from an f32 pair: `(o − hi) − lo`.
macro_rules! off {
    ($simd:ident, $o:expr, $s:expr) => {
        v!(
            $simd,
            sub_f32s,
            v!($simd, sub_f32s, $o, $simd.splat_f32s($s.hi)),
            $simd.splat_f32s($s.lo)
        )
    };
}

/// Is `x` surely in `[lo, hi]`, and is it unsure (within `e` of an end)?
#[inline(always)]
fn band<S: pulp::Simd>(simd: S, x: S::f32s, lo: S::f32s, hi: S::f32s, e: S::f32s) -> (S::m32s, S::m32s) {
    let inside = v!(
        simd,
        and_m32s,
        v!(simd, greater_than_or_equal_f32s, x, v!(simd, add_f32s, lo, e)),
        v!(simd, less_than_or_equal_f32s, x, v!(simd, sub_f32s, hi, e))
    );
    let outside = v!(
        simd,
        or_m32s,
        v!(simd, less_than_f32s, x, v!(simd, sub_f32s, lo, e)),
        v!(simd, greater_than_f32s, x, v!(simd, add_f32s, hi, e))
    );
    // A NaN is neither: unsure.
    (inside, v!(simd, not_m32s, v!(simd, or_m32s, inside, outside)))
}

/// Is the root `t` surely kept in `[tn, lim]`, surely not (beyond the band,
/// or not finite), or unsure? As (kept, unsure).
#[inline(always)]
fn keeps<S: pulp::Simd>(simd: S, t: S::f32s, tn: S::f32s, lim: S::f32s, e: S::f32s) -> (S::m32s, S::m32s) {
    let finite = v!(
        simd,
        less_than_f32s,
        v!(simd, abs_f32s, t),
        simd.splat_f32s(f32::INFINITY)
    );
    let (kept, unsure) = band(simd, t, tn, lim, e);
    (
        v!(simd, and_m32s, finite, kept),
        v!(simd, and_m32s, finite, unsure),
    )
}

impl<const N: usize> pulp::WithSimd for SetKernelF32<'_, N> {
    /// How many lanes the answer covers (up to the last active one).
    type Output = usize;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) -> usize {
        let SetKernelF32 {
            prims,
            rays,
            occlusion,
            out,
            safety,
        } = self;
        // m: the lanes up to the last active one.
        let mut act = [0.0f32; N];
        let mut m = 0;
        for (k, a) in act.iter_mut().enumerate() {
            if rays.active(k) {
                *a = 1.0;
                m = k + 1;
            }
        }
        let p0 = lowest_ranks_seen(&rays);
        if m == 0 {
            return 0;
        }
        let n = m.div_ceil(S::F32_LANES) * S::F32_LANES;
        macro_rules! lanes {
            ($a:expr) => {
                S::as_simd_f32s(&$a[..n]).0
            };
        }
        macro_rules! lanes_mut {
            ($a:expr) => {
                S::as_mut_simd_f32s(&mut $a[..n]).0
            };
        }
        let o = [lanes!(rays.org[0]), lanes!(rays.org[1]), lanes!(rays.org[2])];
        let d = [lanes!(rays.dir[0]), lanes!(rays.dir[1]), lanes!(rays.dir[2])];
        let (tn, tf, act) = (lanes!(rays.tnear), lanes!(rays.tfar), lanes!(act));
        let p0 = lanes!(p0);
        let (zero, one) = (simd.splat_f32s(0.0), simd.splat_f32s(1.0));
        // Per lane, for every primitive: the directions' reciprocals, the
        // box test's interval (widened past the f64 kernel's; empty for an
        // inactive lane), |d|², 1/|d|² and 1/|d|, the same of (dx, 0, dz)
        // for walls, and |o|'s largest component (the touch window's).
        let walls = prims
            .iter()
            .any(|p| matches!(p.quadric, Some(QuadricF32::WallY { .. })));
        let mut inv = [[zero; N]; 3];
        let (mut box_lo, mut box_hi, mut lim) = ([zero; N], [zero; N], [zero; N]);
        let (mut aa, mut inv_a, mut inv_len) = ([zero; N], [zero; N], [zero; N]);
        let (mut aa_xz, mut inv_a_xz, mut inv_len_xz) = ([zero; N], [zero; N], [zero; N]);
        let mut o_max = [zero; N];
        let (widen, floor) = (simd.splat_f32s(2e-6), simd.splat_f32s(2e-9));
        for k in 0..o[0].len() {
            for a in 0..3 {
                inv[a][k] = v!(simd, div_f32s, one, d[a][k]);
            }
            let active = v!(simd, equal_f32s, act[k], one);
            let lo = v!(
                simd,
                sub_f32s,
                v!(
                    simd,
                    sub_f32s,
                    tn[k],
                    v!(simd, mul_f32s, v!(simd, abs_f32s, tn[k]), widen)
                ),
                floor
            );
            let hi = v!(
                simd,
                add_f32s,
                v!(
                    simd,
                    add_f32s,
                    tf[k],
                    v!(simd, mul_f32s, v!(simd, abs_f32s, tf[k]), widen)
                ),
                floor
            );
            box_lo[k] = v!(simd, select_f32s, active, lo, simd.splat_f32s(f32::INFINITY));
            box_hi[k] = v!(simd, select_f32s, active, hi, simd.splat_f32s(f32::NEG_INFINITY));
            lim[k] = tf[k];
            let a = dot!(simd, d[0][k], d[1][k], d[2][k], d[0][k], d[1][k], d[2][k]);
            aa[k] = a;
            inv_a[k] = v!(simd, div_f32s, one, a);
            inv_len[k] = v!(simd, sqrt_f32s, inv_a[k]);
            if walls {
                let a = v!(
                    simd,
                    add_f32s,
                    v!(simd, mul_f32s, d[0][k], d[0][k]),
                    v!(simd, mul_f32s, d[2][k], d[2][k])
                );
                aa_xz[k] = a;
                inv_a_xz[k] = v!(simd, div_f32s, one, a);
                inv_len_xz[k] = v!(simd, sqrt_f32s, inv_a_xz[k]);
            }
            o_max[k] = v!(
                simd,
                max_f32s,
                v!(simd, abs_f32s, o[0][k]),
                v!(
                    simd,
                    max_f32s,
                    v!(simd, abs_f32s, o[1][k]),
                    v!(simd, abs_f32s, o[2][k])
                )
            );
        }
        let Resolved {
            t: best_t,
            geom1: best_g,
            prim: best_p,
            n: [best_x, best_y, best_z],
            unsure,
            boxes,
        } = out;
        let (best_t, best_g, best_p) = (lanes_mut!(best_t), lanes_mut!(best_g), lanes_mut!(best_p));
        let (best_x, best_y, best_z) = (lanes_mut!(best_x), lanes_mut!(best_y), lanes_mut!(best_z));
        let (unsure, boxes) = (lanes_mut!(unsure), lanes_mut!(boxes));
        let no = v!(simd, less_than_f32s, one, zero);
        let eps = simd.splat_f32s(safety * f32::EPSILON);
        // `Segment::is_touch`'s window coefficient; the slab ends' widening
        // (past their f32 rounding, 1.5 ulps).
        let window_k = simd.splat_f32s(2.0 * crate::ray::OFFSET_ULPS * f32::EPSILON);
        let w = simd.splat_f32s(4.0 * f32::EPSILON);
        for (index, p) in prims.iter().enumerate() {
            let (lo, hi) = p.bounds;
            let bit = simd.splat_f32s((1u32 << index) as f32);
            for k in 0..o[0].len() {
                // The slab test, conservative as the interval is widened.
                let (mut near, mut far) = (box_lo[k], box_hi[k]);
                for a in 0..3 {
                    let ta = v!(
                        simd,
                        mul_f32s,
                        v!(simd, sub_f32s, simd.splat_f32s(lo[a]), o[a][k]),
                        inv[a][k]
                    );
                    let tb = v!(
                        simd,
                        mul_f32s,
                        v!(simd, sub_f32s, simd.splat_f32s(hi[a]), o[a][k]),
                        inv[a][k]
                    );
                    near = v!(simd, max_f32s, near, v!(simd, min_f32s, ta, tb));
                    far = v!(simd, min_f32s, far, v!(simd, max_f32s, ta, tb));
                }
                let meets = v!(
                    simd,
                    less_than_or_equal_f32s,
                    v!(
                        simd,
                        sub_f32s,
                        near,
                        v!(simd, mul_f32s, v!(simd, abs_f32s, near), w)
                    ),
                    v!(
                        simd,
                        add_f32s,
                        far,
                        v!(simd, mul_f32s, v!(simd, abs_f32s, far), w)
                    )
                );
                // A masked solid below the lane's P0 is not there for it.
                let meets = if p.rank.is_finite() {
                    v!(
                        simd,
                        and_m32s,
                        meets,
                        v!(simd, greater_than_or_equal_f32s, simd.splat_f32s(p.rank), p0[k])
                    )
                } else {
                    meets
                };
                if simd.first_true_m32s(meets) == S::F32_LANES {
                    continue;
                }
                boxes[k] = v!(simd, add_f32s, boxes[k], v!(simd, select_f32s, meets, bit, zero));
                let open = if occlusion {
                    v!(simd, and_m32s, meets, v!(simd, equal_f32s, best_g[k], zero))
                } else {
                    meets
                };
                let Some(quadric) = &p.quadric else {
                    unsure[k] = v!(simd, select_f32s, open, one, unsure[k]);
                    continue;
                };
                // The roots, which of them are surely kept (e0, e1), the
                // lanes not sure of them, and the normal at each.
                let (t0, t1, e0, e1, doubt, normal0, normal1);
                match quadric {
                    QuadricF32::Sphere { center, radius }
                    | QuadricF32::WallY {
                        base: center, radius, ..
                    } => {
                        let wall = matches!(quadric, QuadricF32::WallY { .. });
                        let cx = off!(simd, o[0][k], center[0]);
                        let cy = if wall {
                            zero
                        } else {
                            off!(simd, o[1][k], center[1])
                        };
                        let cz = off!(simd, o[2][k], center[2]);
                        let dy = if wall { zero } else { d[1][k] };
                        let (a, ia, il) = if wall {
                            (aa_xz[k], inv_a_xz[k], inv_len_xz[k])
                        } else {
                            (aa[k], inv_a[k], inv_len[k])
                        };
                        let r = simd.splat_f32s(*radius);
                        let r2 = simd.splat_f32s(radius * radius);
                        let b = dot!(simd, cx, cy, cz, d[0][k], dy, d[2][k]);
                        // The line's closest approach and the offset f there.
                        let tc = v!(simd, neg_f32s, v!(simd, mul_f32s, b, ia));
                        let fx = v!(simd, add_f32s, cx, v!(simd, mul_f32s, d[0][k], tc));
                        let fy = v!(simd, add_f32s, cy, v!(simd, mul_f32s, dy, tc));
                        let fz = v!(simd, add_f32s, cz, v!(simd, mul_f32s, d[2][k], tc));
                        let h = v!(simd, sub_f32s, r2, dot!(simd, fx, fy, fz, fx, fy, fz));
                        let cc = dot!(simd, cx, cy, cz, cx, cy, cz);
                        let cq = v!(simd, sub_f32s, cc, r2);
                        // Error bounds (each a multiple of `eps`, k·ε): of
                        // the offset c (a few ulps of each component), of
                        // b = c·d, of h through f (its error: c's, and the
                        // closest approach's tc·|d|), of s = |d|·√h, of q,
                        // and of each root.
                        let c1 = v!(
                            simd,
                            add_f32s,
                            v!(simd, add_f32s, v!(simd, abs_f32s, cx), v!(simd, abs_f32s, cy)),
                            v!(simd, abs_f32s, cz)
                        );
                        let len = v!(simd, mul_f32s, a, il);
                        let eb = v!(simd, mul_f32s, eps, v!(simd, mul_f32s, c1, len));
                        let fe = v!(
                            simd,
                            mul_f32s,
                            eps,
                            v!(
                                simd,
                                add_f32s,
                                c1,
                                v!(simd, mul_f32s, v!(simd, abs_f32s, tc), len)
                            )
                        );
                        let eh = v!(
                            simd,
                            add_f32s,
                            v!(simd, mul_f32s, v!(simd, add_f32s, r, r), fe),
                            v!(simd, mul_f32s, eps, r2)
                        );
                        let real = v!(simd, greater_than_f32s, h, eh);
                        let unsure_h = v!(
                            simd,
                            and_m32s,
                            v!(simd, greater_than_or_equal_f32s, h, v!(simd, neg_f32s, eh)),
                            v!(simd, not_m32s, real)
                        );
                        let real = v!(simd, and_m32s, real, open);
                        let unsure_h = v!(simd, and_m32s, unsure_h, open);
                        if simd.first_true_m32s(v!(simd, or_m32s, real, unsure_h)) == S::F32_LANES {
                            continue;
                        }
                        let hs = v!(simd, max_f32s, h, eh);
                        let sh = v!(simd, sqrt_f32s, hs);
                        let s = v!(simd, mul_f32s, sh, len);
                        // The stable pair: q = −(b + sign(b)·s), roots q/a, c/q.
                        let q = v!(
                            simd,
                            select_f32s,
                            v!(simd, greater_than_f32s, b, zero),
                            v!(simd, neg_f32s, v!(simd, add_f32s, b, s)),
                            v!(simd, sub_f32s, s, b)
                        );
                        let r0 = v!(simd, mul_f32s, q, ia);
                        let r1 = v!(simd, div_f32s, cq, q);
                        let es = v!(
                            simd,
                            add_f32s,
                            v!(
                                simd,
                                mul_f32s,
                                v!(simd, mul_f32s, len, eh),
                                v!(simd, div_f32s, simd.splat_f32s(0.5), sh)
                            ),
                            v!(simd, mul_f32s, eps, s)
                        );
                        let eq = v!(simd, add_f32s, eb, es);
                        let inv_q = v!(simd, div_f32s, one, v!(simd, abs_f32s, q));
                        let ecq = v!(simd, mul_f32s, eps, v!(simd, add_f32s, cc, r2));
                        let e_r0 = v!(
                            simd,
                            add_f32s,
                            v!(simd, mul_f32s, eq, ia),
                            v!(simd, mul_f32s, eps, v!(simd, abs_f32s, r0))
                        );
                        let e_r1 = v!(
                            simd,
                            add_f32s,
                            v!(
                                simd,
                                mul_f32s,
                                v!(
                                    simd,
                                    add_f32s,
                                    ecq,
                                    v!(simd, mul_f32s, v!(simd, abs_f32s, r1), eq)
                                ),
                                inv_q
                            ),
                            v!(simd, mul_f32s, eps, v!(simd, abs_f32s, r1))
                        );
                        let swap = v!(simd, less_than_f32s, r1, r0);
                        t0 = v!(simd, select_f32s, swap, r1, r0);
                        t1 = v!(simd, select_f32s, swap, r0, r1);
                        let e0_t = v!(simd, select_f32s, swap, e_r1, e_r0);
                        let e1_t = v!(simd, select_f32s, swap, e_r0, e_r1);
                        let et = v!(simd, max_f32s, e0_t, e1_t);
                        let t_abs = v!(simd, max_f32s, v!(simd, abs_f32s, t0), v!(simd, abs_f32s, t1));
                        let (k0, u0) = keeps(simd, t0, tn[k], lim[k], e0_t);
                        let (k1, u1) = keeps(simd, t1, tn[k], lim[k], e1_t);
                        // Two roots near the touch window: a touch or not,
                        // unsure (rare: grazing rays).
                        let gap = v!(simd, sub_f32s, t1, t0);
                        let window = v!(
                            simd,
                            mul_f32s,
                            window_k,
                            v!(
                                simd,
                                add_f32s,
                                v!(
                                    simd,
                                    mul_f32s,
                                    v!(simd, add_f32s, o_max[k], simd.splat_f32s(0.5)),
                                    inv_len[k]
                                ),
                                t_abs
                            )
                        );
                        let floor = v!(
                            simd,
                            add_f32s,
                            simd.splat_f32s(1e-6),
                            v!(simd, mul_f32s, v!(simd, abs_f32s, t0), simd.splat_f32s(4e-7))
                        );
                        let near_touch = v!(
                            simd,
                            less_than_or_equal_f32s,
                            gap,
                            v!(
                                simd,
                                add_f32s,
                                v!(simd, max_f32s, window, floor),
                                v!(simd, add_f32s, et, et)
                            )
                        );
                        let maybe = v!(
                            simd,
                            or_m32s,
                            v!(simd, or_m32s, k0, k1),
                            v!(simd, or_m32s, u0, u1)
                        );
                        let crosses = v!(simd, and_m32s, real, v!(simd, not_m32s, near_touch));
                        let mut d_lanes = v!(
                            simd,
                            or_m32s,
                            unsure_h,
                            v!(
                                simd,
                                and_m32s,
                                real,
                                v!(
                                    simd,
                                    or_m32s,
                                    v!(simd, or_m32s, u0, u1),
                                    v!(simd, and_m32s, near_touch, maybe)
                                )
                            )
                        );
                        let (mut s0, mut s1) =
                            (v!(simd, and_m32s, crosses, k0), v!(simd, and_m32s, crosses, k1));
                        // A wall's crossings within [0, height] along the axis.
                        if let QuadricF32::WallY { base, height, .. } = quadric {
                            let oy = off!(simd, o[1][k], base[1]);
                            let hgt = simd.splat_f32s(*height);
                            let ey_base = v!(
                                simd,
                                mul_f32s,
                                eps,
                                v!(simd, add_f32s, v!(simd, abs_f32s, oy), hgt)
                            );
                            let dy_abs = v!(simd, abs_f32s, d[1][k]);
                            let ey = v!(
                                simd,
                                add_f32s,
                                ey_base,
                                v!(
                                    simd,
                                    mul_f32s,
                                    dy_abs,
                                    v!(simd, add_f32s, et, v!(simd, mul_f32s, eps, t_abs))
                                )
                            );
                            let y0 = v!(simd, add_f32s, oy, v!(simd, mul_f32s, d[1][k], t0));
                            let y1 = v!(simd, add_f32s, oy, v!(simd, mul_f32s, d[1][k], t1));
                            let (in0, uy0) = band(simd, y0, zero, hgt, ey);
                            let (in1, uy1) = band(simd, y1, zero, hgt, ey);
                            d_lanes = v!(
                                simd,
                                or_m32s,
                                d_lanes,
                                v!(
                                    simd,
                                    and_m32s,
                                    crosses,
                                    v!(
                                        simd,
                                        or_m32s,
                                        v!(simd, and_m32s, k0, uy0),
                                        v!(simd, and_m32s, k1, uy1)
                                    )
                                )
                            );
                            s0 = v!(simd, and_m32s, s0, in0);
                            s1 = v!(simd, and_m32s, s1, in1);
                        }
                        (e0, e1, doubt) = (s0, s1, d_lanes);
                        // Normals at each root: o + d·t − c (across the
                        // axis for a wall, towards it when flipped).
                        let flip = matches!(quadric, QuadricF32::WallY { flip: true, .. });
                        let sign = simd.splat_f32s(if flip { -1.0 } else { 1.0 });
                        macro_rules! normal_at {
                            ($t:expr) => {
                                [
                                    v!(
                                        simd,
                                        mul_f32s,
                                        sign,
                                        v!(simd, add_f32s, cx, v!(simd, mul_f32s, d[0][k], $t))
                                    ),
                                    v!(
                                        simd,
                                        mul_f32s,
                                        sign,
                                        v!(simd, add_f32s, cy, v!(simd, mul_f32s, dy, $t))
                                    ),
                                    v!(
                                        simd,
                                        mul_f32s,
                                        sign,
                                        v!(simd, add_f32s, cz, v!(simd, mul_f32s, d[2][k], $t))
                                    ),
                                ]
                            };
                        }
                        normal0 = normal_at!(t0);
                        normal1 = normal_at!(t1);
                    }
                    QuadricF32::Rect {
                        plane,
                        normal: nr,
                        corner,
                        ..
                    }
                    | QuadricF32::Disk {
                        plane,
                        normal: nr,
                        center: corner,
                        ..
                    } => {
                        // t = (w − n·o)/(n·d), w = n·corner (an f32 pair).
                        let (nx, ny, nz) = (
                            simd.splat_f32s(nr[0]),
                            simd.splat_f32s(nr[1]),
                            simd.splat_f32s(nr[2]),
                        );
                        let dn = dot!(simd, d[0][k], d[1][k], d[2][k], nx, ny, nz);
                        let no_ = dot!(simd, o[0][k], o[1][k], o[2][k], nx, ny, nz);
                        let num = v!(
                            simd,
                            add_f32s,
                            v!(simd, sub_f32s, simd.splat_f32s(plane.hi), no_),
                            simd.splat_f32s(plane.lo)
                        );
                        let t = v!(simd, div_f32s, num, dn);
                        let no_abs = dot!(
                            simd,
                            v!(simd, abs_f32s, o[0][k]),
                            v!(simd, abs_f32s, o[1][k]),
                            v!(simd, abs_f32s, o[2][k]),
                            simd.splat_f32s(nr[0].abs()),
                            simd.splat_f32s(nr[1].abs()),
                            simd.splat_f32s(nr[2].abs())
                        );
                        // w's pair is exact to 2⁻⁴⁸: the error is n·o's.
                        let pos = v!(simd, mul_f32s, eps, no_abs);
                        let t_abs = v!(simd, abs_f32s, t);
                        let et = v!(
                            simd,
                            add_f32s,
                            v!(simd, div_f32s, pos, v!(simd, abs_f32s, dn)),
                            v!(simd, mul_f32s, eps, t_abs)
                        );
                        // The crossing's offset from the corner (center) and
                        // its error.
                        let qx = v!(
                            simd,
                            add_f32s,
                            off!(simd, o[0][k], corner[0]),
                            v!(simd, mul_f32s, d[0][k], t)
                        );
                        let qy = v!(
                            simd,
                            add_f32s,
                            off!(simd, o[1][k], corner[1]),
                            v!(simd, mul_f32s, d[1][k], t)
                        );
                        let qz = v!(
                            simd,
                            add_f32s,
                            off!(simd, o[2][k], corner[2]),
                            v!(simd, mul_f32s, d[2][k], t)
                        );
                        let q1 = v!(
                            simd,
                            add_f32s,
                            v!(simd, add_f32s, v!(simd, abs_f32s, qx), v!(simd, abs_f32s, qy)),
                            v!(simd, abs_f32s, qz)
                        );
                        let len = v!(simd, mul_f32s, aa[k], inv_len[k]);
                        let eq = v!(
                            simd,
                            add_f32s,
                            v!(
                                simd,
                                mul_f32s,
                                eps,
                                v!(simd, add_f32s, q1, v!(simd, mul_f32s, t_abs, len))
                            ),
                            v!(simd, mul_f32s, len, et)
                        );
                        let (inside, unsure_in) = match quadric {
                            QuadricF32::Rect { to_a, to_b, .. } => {
                                // The crossing's coordinate along an edge's
                                // dual, in [0, 1] inside: (surely, unsure).
                                macro_rules! coordinate {
                                    ($e:expr) => {{
                                        let e = $e;
                                        let c = dot!(
                                            simd,
                                            qx,
                                            qy,
                                            qz,
                                            simd.splat_f32s(e[0]),
                                            simd.splat_f32s(e[1]),
                                            simd.splat_f32s(e[2])
                                        );
                                        let err = simd.splat_f32s(e[0].abs() + e[1].abs() + e[2].abs());
                                        band(simd, c, zero, one, v!(simd, mul_f32s, eq, err))
                                    }};
                                }
                                let ((in_a, unsure_a), (in_b, unsure_b)) =
                                    (coordinate!(to_a), coordinate!(to_b));
                                // Unsure of one and surely outside neither.
                                let outside = v!(
                                    simd,
                                    or_m32s,
                                    v!(simd, not_m32s, v!(simd, or_m32s, in_a, unsure_a)),
                                    v!(simd, not_m32s, v!(simd, or_m32s, in_b, unsure_b))
                                );
                                (
                                    v!(simd, and_m32s, in_a, in_b),
                                    v!(
                                        simd,
                                        and_m32s,
                                        v!(simd, or_m32s, unsure_a, unsure_b),
                                        v!(simd, not_m32s, outside)
                                    ),
                                )
                            }
                            QuadricF32::Disk { radius2, inner2, .. } => {
                                let qq = dot!(simd, qx, qy, qz, qx, qy, qz);
                                let e2 = v!(
                                    simd,
                                    add_f32s,
                                    v!(
                                        simd,
                                        mul_f32s,
                                        simd.splat_f32s(2.0),
                                        v!(simd, mul_f32s, v!(simd, sqrt_f32s, qq), eq)
                                    ),
                                    v!(simd, mul_f32s, eps, qq)
                                );
                                band(simd, qq, simd.splat_f32s(*inner2), simd.splat_f32s(*radius2), e2)
                            }
                            _ => (no, no),
                        };
                        let (kept, unsure_t) = keeps(simd, t, tn[k], lim[k], et);
                        let could = v!(simd, and_m32s, open, v!(simd, or_m32s, kept, unsure_t));
                        doubt = v!(
                            simd,
                            and_m32s,
                            could,
                            v!(
                                simd,
                                or_m32s,
                                v!(simd, and_m32s, unsure_t, v!(simd, or_m32s, inside, unsure_in)),
                                unsure_in
                            )
                        );
                        (t0, t1) = (t, t);
                        (e0, e1) = (v!(simd, and_m32s, v!(simd, and_m32s, open, kept), inside), no);
                        let facing = match quadric {
                            QuadricF32::Disk { facing, .. } => *facing,
                            _ => *nr,
                        };
                        normal0 = [
                            simd.splat_f32s(facing[0]),
                            simd.splat_f32s(facing[1]),
                            simd.splat_f32s(facing[2]),
                        ];
                        normal1 = normal0;
                    }
                }
                unsure[k] = v!(simd, select_f32s, doubt, one, unsure[k]);
                let any = v!(simd, or_m32s, e0, e1);
                if simd.first_true_m32s(any) == S::F32_LANES {
                    continue;
                }
                let first = v!(
                    simd,
                    and_m32s,
                    e0,
                    v!(
                        simd,
                        or_m32s,
                        v!(simd, not_m32s, e1),
                        v!(simd, less_than_or_equal_f32s, t0, t1)
                    )
                );
                let t = v!(simd, select_f32s, first, t0, t1);
                best_p[k] = v!(simd, select_f32s, any, simd.splat_f32s(p.prim as f32), best_p[k]);
                best_g[k] = v!(
                    simd,
                    select_f32s,
                    any,
                    simd.splat_f32s(p.geom as f32 + 1.0),
                    best_g[k]
                );
                if occlusion {
                    continue;
                }
                best_t[k] = v!(simd, select_f32s, any, t, best_t[k]);
                lim[k] = v!(simd, select_f32s, any, t, lim[k]);
                let normal = select(simd, first, normal0, normal1);
                best_x[k] = v!(simd, select_f32s, any, normal[0], best_x[k]);
                best_y[k] = v!(simd, select_f32s, any, normal[1], best_y[k]);
                best_z[k] = v!(simd, select_f32s, any, normal[2], best_z[k]);
            }
        }
        m
    }
}
