//! The f64 kernel: the scalar code's roots and decisions on f64 lanes,
//! Embree's answer bit for bit.
use super::arith::{dot, splat3, v, within};
use super::lanes::{LaneArrays, Resolved};
use super::predicates::{keeps, touches};
use super::primitive::{Primitive, Quadric};
use crate::embree::PacketRays;

/// For every primitive of the set and the first `m` lanes, as many lanes
/// per instruction as the vector unit holds: which lanes meet its box in
/// their interval, the roots of those with its quadric, and which of the
/// roots the query keeps (`occlusion`: any; else the nearest, each kept
/// crossing narrowing the lane's interval for the next primitive), into
/// `out`. A lane meeting a primitive without a quadric is unsure. Each
/// lane's arithmetic is the scalar functions', operation for operation and
/// unfused (tested bit for bit); `min`/`max` differ from `f64::min`/`max`
/// only for a NaN, which a lane with real roots does not have.
pub(super) struct SetKernel<'a, const N: usize> {
    pub(super) prims: &'a [Primitive],
    pub(super) rays: PacketRays<'a, N>,
    pub(super) occlusion: bool,
    pub(super) out: &'a mut Resolved<f64, N>,
    pub(super) lanes: &'a mut LaneArrays<N>,
}

impl<const N: usize> pulp::WithSimd for SetKernel<'_, N> {
    /// How many lanes the answer covers (up to the last active one).
    type Output = usize;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) -> usize {
        let SetKernel {
            prims,
            rays,
            occlusion,
            out,
            lanes,
        } = self;
        // Converted here, where the loops vectorise to the full width.
        let m = lanes.fill(&rays);
        if m == 0 {
            return 0;
        }
        let l = &*lanes;
        // Whole vectors over the first m lanes (N is a multiple of every width).
        let n = m.div_ceil(S::F64_LANES) * S::F64_LANES;
        let o = [
            S::as_simd_f64s(&l.o[0][..n]).0,
            S::as_simd_f64s(&l.o[1][..n]).0,
            S::as_simd_f64s(&l.o[2][..n]).0,
        ];
        let d = [
            S::as_simd_f64s(&l.d[0][..n]).0,
            S::as_simd_f64s(&l.d[1][..n]).0,
            S::as_simd_f64s(&l.d[2][..n]).0,
        ];
        let inv = [
            S::as_simd_f64s(&l.inv_d[0][..n]).0,
            S::as_simd_f64s(&l.inv_d[1][..n]).0,
            S::as_simd_f64s(&l.inv_d[2][..n]).0,
        ];
        let t_lo = S::as_simd_f64s(&l.t_lo[..n]).0;
        let p0 = S::as_simd_f64s(&l.p0[..n]).0;
        let t_hi = S::as_simd_f64s(&l.t_hi[..n]).0;
        let tn = S::as_simd_f64s(&l.tn[..n]).0;
        let mut lim_lanes = l.tf;
        let lim = S::as_mut_simd_f64s(&mut lim_lanes[..n]).0;
        let Resolved {
            t: best_t,
            geom1: best_g,
            prim: best_p,
            n: [best_x, best_y, best_z],
            unsure,
            boxes,
        } = out;
        let best_t = S::as_mut_simd_f64s(&mut best_t[..n]).0;
        let best_g = S::as_mut_simd_f64s(&mut best_g[..n]).0;
        let best_p = S::as_mut_simd_f64s(&mut best_p[..n]).0;
        let best_x = S::as_mut_simd_f64s(&mut best_x[..n]).0;
        let best_y = S::as_mut_simd_f64s(&mut best_y[..n]).0;
        let best_z = S::as_mut_simd_f64s(&mut best_z[..n]).0;
        let unsure = S::as_mut_simd_f64s(&mut unsure[..n]).0;
        let boxes = S::as_mut_simd_f64s(&mut boxes[..n]).0;
        let (zero, one) = (simd.splat_f64s(0.0), simd.splat_f64s(1.0));
        let no = v!(simd, less_than_f64s, one, zero);
        for (index, p) in prims.iter().enumerate() {
            let (lo, hi) = p.bounds;
            let bit = simd.splat_f64s((1u32 << index) as f64);
            for k in 0..o[0].len() {
                // The slab test. A ray parallel to a face and lying in its
                // plane (0·∞, NaN) may come out either way: the padded box
                // holds the shape strictly inside, so that ray misses it.
                let (mut near, mut far) = (t_lo[k], t_hi[k]);
                for a in 0..3 {
                    let ta = v!(
                        simd,
                        mul_f64s,
                        v!(simd, sub_f64s, simd.splat_f64s(lo[a]), o[a][k]),
                        inv[a][k]
                    );
                    let tb = v!(
                        simd,
                        mul_f64s,
                        v!(simd, sub_f64s, simd.splat_f64s(hi[a]), o[a][k]),
                        inv[a][k]
                    );
                    near = v!(simd, max_f64s, near, v!(simd, min_f64s, ta, tb));
                    far = v!(simd, min_f64s, far, v!(simd, max_f64s, ta, tb));
                }
                let meets = v!(simd, less_than_or_equal_f64s, near, far);
                // A masked solid below the lane's P0 is not there for it.
                let meets = if p.rank.is_finite() {
                    v!(
                        simd,
                        and_m64s,
                        meets,
                        v!(
                            simd,
                            greater_than_or_equal_f64s,
                            simd.splat_f64s(p.rank as f64),
                            p0[k]
                        )
                    )
                } else {
                    meets
                };
                if simd.first_true_m64s(meets) == S::F64_LANES {
                    continue;
                }
                boxes[k] = v!(simd, add_f64s, boxes[k], v!(simd, select_f64s, meets, bit, zero));
                // A lane occluded for sure needs no more answers.
                let open = if occlusion {
                    v!(simd, and_m64s, meets, v!(simd, equal_f64s, best_g[k], zero))
                } else {
                    meets
                };
                let Some(quadric) = p.quadric else {
                    unsure[k] = v!(simd, select_f64s, open, one, unsure[k]);
                    continue;
                };
                // The roots, which of them the lanes keep (e0, e1), and the
                // normal's parts that do not depend on the root.
                let (t0, t1, e0, e1, mut normal);
                match quadric {
                    Quadric::Rect {
                        corner, normal: nr, ..
                    }
                    | Quadric::Disk {
                        center: corner,
                        normal: nr,
                        ..
                    } => {
                        // t = (corner − o)·n / (d·n); p − corner = (o + d·t) − corner;
                        // inside a rect when both its coordinates are in [0, 1],
                        // inside a disk when |p − center|² is within the radii
                        // squared; never for d·n == 0 (a NaN is outside).
                        let (nx, ny, nz) = splat3!(simd, nr);
                        let (kx, ky, kz) = splat3!(simd, corner);
                        let dn = dot!(simd, d[0][k], d[1][k], d[2][k], nx, ny, nz);
                        let (cx, cy, cz) = (
                            v!(simd, sub_f64s, kx, o[0][k]),
                            v!(simd, sub_f64s, ky, o[1][k]),
                            v!(simd, sub_f64s, kz, o[2][k]),
                        );
                        let t = v!(simd, div_f64s, dot!(simd, cx, cy, cz, nx, ny, nz), dn);
                        let qx = v!(
                            simd,
                            sub_f64s,
                            v!(simd, add_f64s, o[0][k], v!(simd, mul_f64s, d[0][k], t)),
                            kx
                        );
                        let qy = v!(
                            simd,
                            sub_f64s,
                            v!(simd, add_f64s, o[1][k], v!(simd, mul_f64s, d[1][k], t)),
                            ky
                        );
                        let qz = v!(
                            simd,
                            sub_f64s,
                            v!(simd, add_f64s, o[2][k], v!(simd, mul_f64s, d[2][k], t)),
                            kz
                        );
                        let inside = match quadric {
                            Quadric::Rect { to_a, to_b, .. } => {
                                let (ax, ay, az) = splat3!(simd, to_a);
                                let (bx, by, bz) = splat3!(simd, to_b);
                                let a = dot!(simd, qx, qy, qz, ax, ay, az);
                                let b = dot!(simd, qx, qy, qz, bx, by, bz);
                                v!(
                                    simd,
                                    and_m64s,
                                    within!(simd, a, zero, one),
                                    within!(simd, b, zero, one)
                                )
                            }
                            Quadric::Disk { radius2, inner2, .. } => {
                                let q = dot!(simd, qx, qy, qz, qx, qy, qz);
                                within!(simd, q, simd.splat_f64s(inner2), simd.splat_f64s(radius2))
                            }
                            _ => no,
                        };
                        let inside = v!(
                            simd,
                            and_m64s,
                            inside,
                            v!(simd, not_m64s, v!(simd, equal_f64s, dn, zero))
                        );
                        // Only a crossing within the lane's widened interval
                        // can be one the scalar code keeps (as for the quadrics).
                        let real = v!(
                            simd,
                            and_m64s,
                            v!(simd, and_m64s, inside, within!(simd, t, t_lo[k], t_hi[k])),
                            open
                        );
                        let (kept, unsure_t) = keeps(simd, t, tn[k], lim[k]);
                        unsure[k] = v!(
                            simd,
                            select_f64s,
                            v!(simd, and_m64s, real, unsure_t),
                            one,
                            unsure[k]
                        );
                        (t0, t1) = (t, t);
                        (e0, e1) = (v!(simd, and_m64s, real, kept), no);
                        normal = match quadric {
                            Quadric::Disk { facing, .. } => [
                                simd.splat_f64s(facing.x),
                                simd.splat_f64s(facing.y),
                                simd.splat_f64s(facing.z),
                            ],
                            _ => [nx, ny, nz],
                        };
                    }
                    Quadric::Sphere { center, radius }
                    | Quadric::WallY {
                        base: center, radius, ..
                    } => {
                        // The quadric's offset from the origin and the
                        // direction: a sphere's whole, a wall's parts
                        // across the y axis (x, 0, z).
                        let wall = matches!(quadric, Quadric::WallY { .. });
                        let cx = v!(simd, sub_f64s, o[0][k], simd.splat_f64s(center.x));
                        let cy = v!(simd, sub_f64s, o[1][k], simd.splat_f64s(center.y));
                        let cz = v!(simd, sub_f64s, o[2][k], simd.splat_f64s(center.z));
                        let (qy, dy) = if wall { (zero, zero) } else { (cy, d[1][k]) };
                        let (dx, dz) = (d[0][k], d[2][k]);
                        let a = dot!(simd, dx, dy, dz, dx, dy, dz);
                        let b = dot!(simd, cx, qy, cz, dx, dy, dz);
                        let len = v!(simd, sqrt_f64s, dot!(simd, cx, qy, cz, cx, qy, cz));
                        let r = simd.splat_f64s(radius);
                        let c = v!(
                            simd,
                            mul_f64s,
                            v!(simd, sub_f64s, len, r),
                            v!(simd, add_f64s, len, r)
                        );
                        let disc = v!(simd, sub_f64s, v!(simd, mul_f64s, b, b), v!(simd, mul_f64s, a, c));
                        // !(disc < 0 || a == 0): a NaN discriminant counts as real, as in the scalar code.
                        let not_real = v!(
                            simd,
                            or_m64s,
                            v!(simd, less_than_f64s, disc, zero),
                            v!(simd, equal_f64s, a, zero)
                        );
                        let s = v!(simd, sqrt_f64s, disc);
                        let q = v!(
                            simd,
                            select_f64s,
                            v!(simd, greater_than_f64s, b, zero),
                            v!(simd, neg_f64s, v!(simd, add_f64s, b, s)),
                            v!(simd, add_f64s, v!(simd, neg_f64s, b), s)
                        );
                        let q_zero = v!(simd, equal_f64s, q, zero);
                        let r0 = v!(simd, select_f64s, q_zero, zero, v!(simd, div_f64s, q, a));
                        let r1 = v!(simd, select_f64s, q_zero, zero, v!(simd, div_f64s, c, q));
                        // The wall's roots stay in the quadratic's order.
                        (t0, t1) = if wall {
                            (r0, r1)
                        } else {
                            (v!(simd, min_f64s, r0, r1), v!(simd, max_f64s, r0, r1))
                        };
                        // A lane with neither root in its widened interval has no
                        // crossing the scalar code keeps (`Segment::keeps` compares
                        // within the exact one, which only narrows).
                        let inside = v!(
                            simd,
                            or_m64s,
                            within!(simd, t0, t_lo[k], t_hi[k]),
                            within!(simd, t1, t_lo[k], t_hi[k])
                        );
                        let real = v!(
                            simd,
                            and_m64s,
                            v!(simd, and_m64s, v!(simd, not_m64s, not_real), inside),
                            open
                        );
                        if simd.first_true_m64s(real) == S::F64_LANES {
                            continue;
                        }
                        // `push_crossings` / `Wall::emit`: the kept roots,
                        // unless the two are one touch.
                        let (k0, u0) = keeps(simd, t0, tn[k], lim[k]);
                        let (k1, u1) = keeps(simd, t1, tn[k], lim[k]);
                        let unsure_t = v!(simd, and_m64s, real, v!(simd, or_m64s, u0, u1));
                        unsure[k] = v!(simd, select_f64s, unsure_t, one, unsure[k]);
                        let touch = touches(
                            simd,
                            t0,
                            t1,
                            [o[0][k], o[1][k], o[2][k]],
                            [d[0][k], d[1][k], d[2][k]],
                        );
                        let crosses = v!(simd, and_m64s, real, v!(simd, not_m64s, touch));
                        (e0, e1) = match quadric {
                            Quadric::WallY { base, height, .. } => {
                                // Within [0, height] along the axis.
                                let oy = v!(simd, sub_f64s, o[1][k], simd.splat_f64s(base.y));
                                let h = simd.splat_f64s(height);
                                let y0 = v!(simd, add_f64s, oy, v!(simd, mul_f64s, d[1][k], t0));
                                let y1 = v!(simd, add_f64s, oy, v!(simd, mul_f64s, d[1][k], t1));
                                (
                                    v!(
                                        simd,
                                        and_m64s,
                                        v!(simd, and_m64s, crosses, k0),
                                        within!(simd, y0, zero, h)
                                    ),
                                    v!(
                                        simd,
                                        and_m64s,
                                        v!(simd, and_m64s, crosses, k1),
                                        within!(simd, y1, zero, h)
                                    ),
                                )
                            }
                            _ => (v!(simd, and_m64s, crosses, k0), v!(simd, and_m64s, crosses, k1)),
                        };
                        normal = [cx, cy, cz];
                    }
                }
                // The nearest crossing (roots at the same f32 would be a touch).
                let any = v!(simd, or_m64s, e0, e1);
                if simd.first_true_m64s(any) == S::F64_LANES {
                    continue;
                }
                let first = v!(
                    simd,
                    and_m64s,
                    e0,
                    v!(
                        simd,
                        or_m64s,
                        v!(simd, not_m64s, e1),
                        v!(simd, less_than_or_equal_f64s, t0, t1)
                    )
                );
                let t = v!(simd, select_f64s, first, t0, t1);
                best_p[k] = v!(simd, select_f64s, any, simd.splat_f64s(p.prim as f64), best_p[k]);
                best_g[k] = v!(
                    simd,
                    select_f64s,
                    any,
                    simd.splat_f64s(p.geom as f64 + 1.0),
                    best_g[k]
                );
                if occlusion {
                    continue;
                }
                // The candidate's normal at t: a sphere's (o + d·t) − center,
                // a wall's ((o − base) + d·t) across the axis (towards it
                // when flipped), a rect's own.
                match quadric {
                    Quadric::Sphere { center, .. } => {
                        normal = [
                            v!(
                                simd,
                                sub_f64s,
                                v!(simd, add_f64s, o[0][k], v!(simd, mul_f64s, d[0][k], t)),
                                simd.splat_f64s(center.x)
                            ),
                            v!(
                                simd,
                                sub_f64s,
                                v!(simd, add_f64s, o[1][k], v!(simd, mul_f64s, d[1][k], t)),
                                simd.splat_f64s(center.y)
                            ),
                            v!(
                                simd,
                                sub_f64s,
                                v!(simd, add_f64s, o[2][k], v!(simd, mul_f64s, d[2][k], t)),
                                simd.splat_f64s(center.z)
                            ),
                        ];
                    }
                    Quadric::WallY { flip, .. } => {
                        let x = v!(simd, add_f64s, normal[0], v!(simd, mul_f64s, d[0][k], t));
                        let z = v!(simd, add_f64s, normal[2], v!(simd, mul_f64s, d[2][k], t));
                        normal = if flip {
                            [
                                v!(simd, neg_f64s, x),
                                v!(simd, neg_f64s, zero),
                                v!(simd, neg_f64s, z),
                            ]
                        } else {
                            [x, zero, z]
                        };
                    }
                    Quadric::Rect { .. } | Quadric::Disk { .. } => {}
                }
                best_t[k] = v!(simd, select_f64s, any, t, best_t[k]);
                lim[k] = v!(simd, select_f64s, any, t, lim[k]);
                best_x[k] = v!(simd, select_f64s, any, normal[0], best_x[k]);
                best_y[k] = v!(simd, select_f64s, any, normal[1], best_y[k]);
                best_z[k] = v!(simd, select_f64s, any, normal[2], best_z[k]);
            }
        }
        m
    }
}
