//! The surface points and normals of a packet's hits on the set, on f64
//! lanes.
use super::arith::{dot, splat3, v};
use super::primitive::{Primitive, Quadric};
use crate::embree::PacketRays;

/// The surface points of a packet's hits on the set's quadrics and rects,
/// in arrays (`AnalyticSet::surface_points`): what
/// `RenderScene::surface_point` makes of each, but the texture coordinates.
pub struct SurfaceLanes<const N: usize> {
    /// The hit point moved onto the surface (f64).
    pub pd: [[f64; N]; 3],
    /// The same point in f32.
    pub p: [[f32; N]; 3],
    /// The unit geometric normal (f32).
    pub ng: [[f32; N]; 3],
    /// Nonzero: the lane's hit is on one of those primitives, and the
    /// arrays hold its point.
    pub done: [f64; N],
}

impl<const N: usize> Default for SurfaceLanes<N> {
    fn default() -> Self {
        SurfaceLanes {
            pd: [[0.0; N]; 3],
            p: [[0.0; N]; 3],
            ng: [[0.0; N]; 3],
            done: [0.0; N],
        }
    }
}

/// [`AnalyticSet::surface_points`] at a vector level: each lane's f32 hit
/// point, moved onto the primitive it hit in f64 (`project`), and the
/// normal there (`normal`, `normalize_or_f64`), operation for operation.
pub(super) struct SurfaceKernel<'a, const N: usize> {
    pub(super) prims: &'a [Primitive],
    pub(super) rays: PacketRays<'a, N>,
    pub(super) out: &'a mut SurfaceLanes<N>,
}

impl<const N: usize> pulp::WithSimd for SurfaceKernel<'_, N> {
    type Output = ();

    // Lanes indexed in parallel arrays, in loops the compiler vectorises.
    #[allow(clippy::needless_range_loop)]
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) {
        let SurfaceKernel { prims, rays, out } = self;
        // The f32 hit point `org + dir·t` (unfused, as glam's vectors
        // compute it) and the hit's ids, in f64; plain loops, vectorised here.
        let mut pf = [[0.0f64; N]; 3];
        let (mut gid, mut pid) = ([0.0f64; N], [0.0f64; N]);
        for a in 0..3 {
            for k in 0..N {
                pf[a][k] = (rays.org[a][k] + rays.dir[a][k] * rays.tfar[k]) as f64;
            }
        }
        for k in 0..N {
            gid[k] = rays.geom_id[k] as f64;
            pid[k] = rays.prim_id[k] as f64;
        }
        let mut nd = [[0.0f64; N]; 3];
        {
            let [px, py, pz] = &pf;
            let (px, py, pz) = (
                S::as_simd_f64s(px).0,
                S::as_simd_f64s(py).0,
                S::as_simd_f64s(pz).0,
            );
            let (gid, pid) = (S::as_simd_f64s(&gid).0, S::as_simd_f64s(&pid).0);
            let [ox, oy, oz] = &mut out.pd;
            let (ox, oy, oz) = (
                S::as_mut_simd_f64s(ox).0,
                S::as_mut_simd_f64s(oy).0,
                S::as_mut_simd_f64s(oz).0,
            );
            let [nx_out, ny_out, nz_out] = &mut nd;
            let (nx_out, ny_out, nz_out) = (
                S::as_mut_simd_f64s(nx_out).0,
                S::as_mut_simd_f64s(ny_out).0,
                S::as_mut_simd_f64s(nz_out).0,
            );
            let done = S::as_mut_simd_f64s(&mut out.done).0;
            let (zero, one) = (simd.splat_f64s(0.0), simd.splat_f64s(1.0));
            done.fill(zero);
            for p in prims {
                let Some(quadric) = p.quadric else { continue };
                let (g, pr) = (simd.splat_f64s(p.geom as f64), simd.splat_f64s(p.prim as f64));
                for k in 0..done.len() {
                    let on = v!(
                        simd,
                        and_m64s,
                        v!(simd, equal_f64s, gid[k], g),
                        v!(simd, equal_f64s, pid[k], pr)
                    );
                    if simd.first_true_m64s(on) == S::F64_LANES {
                        continue;
                    }
                    let (x, y, z) = (px[k], py[k], pz[k]);
                    let (sx, sy, sz, mut nx, mut ny, mut nz);
                    match quadric {
                        Quadric::Sphere { center, radius }
                        | Quadric::WallY {
                            base: center, radius, ..
                        } => {
                            // `Sphere::project`: center + q·(r/|q|), q = p − center;
                            // `Wall::project_about` (y axis): (base.x, base.y + q.y,
                            // base.z) + (qx, 0, qz)·(r/l), l = |(qx, 0, qz)|.
                            let wall = matches!(quadric, Quadric::WallY { .. });
                            let (cx, cy, cz) = splat3!(simd, center);
                            let (qx, qy, qz) = (
                                v!(simd, sub_f64s, x, cx),
                                v!(simd, sub_f64s, y, cy),
                                v!(simd, sub_f64s, z, cz),
                            );
                            let ry = if wall { zero } else { qy };
                            let l = v!(simd, sqrt_f64s, dot!(simd, qx, ry, qz, qx, ry, qz));
                            let s = v!(simd, div_f64s, simd.splat_f64s(radius), l);
                            let pos = v!(simd, greater_than_f64s, l, zero);
                            // c + q·s, where the radius is positive, else the point.
                            macro_rules! onto {
                                ($c:expr, $q:expr, $p:expr) => {
                                    v!(
                                        simd,
                                        select_f64s,
                                        pos,
                                        v!(simd, add_f64s, $c, v!(simd, mul_f64s, $q, s)),
                                        $p
                                    )
                                };
                            }
                            sx = onto!(cx, qx, x);
                            sy = if wall {
                                onto!(v!(simd, add_f64s, cy, qy), zero, y)
                            } else {
                                onto!(cy, qy, y)
                            };
                            sz = onto!(cz, qz, z);
                            // `Sphere::normal`: normalize_or_f64(pd − center, y);
                            // the wall's (`Cylinder::normal`): of (pd − base)
                            // across the axis, x as the fallback, negated
                            // towards the axis.
                            let (vx, vz) = (v!(simd, sub_f64s, sx, cx), v!(simd, sub_f64s, sz, cz));
                            let vy = if wall { zero } else { v!(simd, sub_f64s, sy, cy) };
                            let rcp = v!(
                                simd,
                                div_f64s,
                                one,
                                v!(simd, sqrt_f64s, dot!(simd, vx, vy, vz, vx, vy, vz))
                            );
                            let ok = unit_scale(simd, rcp);
                            let (fx, fy) = if wall { (one, zero) } else { (zero, one) };
                            (nx, ny, nz) = (
                                v!(simd, select_f64s, ok, v!(simd, mul_f64s, vx, rcp), fx),
                                v!(simd, select_f64s, ok, v!(simd, mul_f64s, vy, rcp), fy),
                                v!(simd, select_f64s, ok, v!(simd, mul_f64s, vz, rcp), zero),
                            );
                            if let Quadric::WallY { flip: true, .. } = quadric {
                                (nx, ny, nz) = (
                                    v!(simd, neg_f64s, nx),
                                    v!(simd, neg_f64s, ny),
                                    v!(simd, neg_f64s, nz),
                                );
                            }
                        }
                        Quadric::Rect { corner, normal, .. }
                        | Quadric::Disk {
                            center: corner,
                            normal,
                            ..
                        } => {
                            // `Rect::project`, `Disk::project`: p − n·((p − corner)·n).
                            let (kx, ky, kz) = splat3!(simd, normal);
                            let d = dot!(
                                simd,
                                v!(simd, sub_f64s, x, simd.splat_f64s(corner.x)),
                                v!(simd, sub_f64s, y, simd.splat_f64s(corner.y)),
                                v!(simd, sub_f64s, z, simd.splat_f64s(corner.z)),
                                kx,
                                ky,
                                kz
                            );
                            sx = v!(simd, sub_f64s, x, v!(simd, mul_f64s, kx, d));
                            sy = v!(simd, sub_f64s, y, v!(simd, mul_f64s, ky, d));
                            sz = v!(simd, sub_f64s, z, v!(simd, mul_f64s, kz, d));
                            (nx, ny, nz) = match quadric {
                                Quadric::Disk { facing, .. } => splat3!(simd, facing),
                                _ => (kx, ky, kz),
                            };
                        }
                    }
                    ox[k] = v!(simd, select_f64s, on, sx, ox[k]);
                    oy[k] = v!(simd, select_f64s, on, sy, oy[k]);
                    oz[k] = v!(simd, select_f64s, on, sz, oz[k]);
                    nx_out[k] = v!(simd, select_f64s, on, nx, nx_out[k]);
                    ny_out[k] = v!(simd, select_f64s, on, ny, ny_out[k]);
                    nz_out[k] = v!(simd, select_f64s, on, nz, nz_out[k]);
                    done[k] = v!(simd, select_f64s, on, one, done[k]);
                }
            }
        }
        for a in 0..3 {
            for k in 0..N {
                out.p[a][k] = out.pd[a][k] as f32;
                out.ng[a][k] = nd[a][k] as f32;
            }
        }
    }
}

/// Is `rcp` (a reciprocal length) one `normalize_or_f64` scales by:
/// positive, not zero, finite?
#[inline(always)]
pub(super) fn unit_scale<S: pulp::Simd>(simd: S, rcp: S::f64s) -> S::m64s {
    v!(
        simd,
        and_m64s,
        v!(simd, greater_than_f64s, rcp, simd.splat_f64s(0.0)),
        v!(simd, less_than_or_equal_f64s, rcp, simd.splat_f64s(f64::MAX))
    )
}
