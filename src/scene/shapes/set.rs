//! A scene's few analytic shapes, intersected for the lanes of a ray packet
//! by snell itself instead of through Embree's user-geometry callbacks.
//!
//! Why: an Embree packet query that reaches a user geometry pays a
//! traversal into its leaf, a callback per primitive and a lane loop that
//! gathers the active rays, and most callbacks have one to four active
//! lanes. With a handful of spheres, cylinders or rects it is cheaper to test every
//! active lane against every primitive here, in vector registers, after
//! Embree has answered the packet against the scene's meshes alone
//! ([`SceneBuilder::with_meshes_only`]).
//!
//! The answer is Embree's, bit for bit: lanes that miss a primitive's
//! bounds (the padded box Embree culls with) are left out, and for the
//! others the same f64 roots (spheres and walls about the y axis, and the
//! plane crossings of rects with their coordinates along the edges: the
//! scalar arithmetic in every vector lane; other primitives: their scalar
//! `intersect_in`) give the same candidates, sorted, clipped to the lane's
//! `[tnear, tfar]` with `tfar` the nearest hit so far, the first one kept.
//! Only a tie at exactly the same f32 distance between two primitives may
//! be broken otherwise (Embree's order is its traversal's; here it is the
//! primitives' order).
//!
//! [`SceneBuilder::with_meshes_only`]: crate::embree::SceneBuilder::with_meshes_only
use super::segment::{Roots, Segment};
use super::Analytic;
use crate::embree::{Candidates, PacketRays, RayPacket, UserShape};
use crate::ray::Hit;
use glam::DVec3;

/// The most primitives a scene may have for its analytic shapes to be
/// tested here (every lane meets every primitive: no hierarchy).
pub const MAX_SET_PRIMITIVES: usize = 8;

/// A quadric whose roots [`SetKernel`] finds for many lanes at once (or a
/// parallelogram: its one root, the plane's crossing, where it lies inside).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Quadric {
    /// `Sphere::roots`.
    Sphere { center: DVec3, radius: f64 },
    /// `Wall::roots` of a wall about the y axis (`AxisY`).
    WallY { base: DVec3, radius: f64 },
    /// `Rect::crossing` but the segment's interval (`t0`: the crossing;
    /// real only inside the parallelogram).
    Rect {
        corner: DVec3,
        normal: DVec3,
        to_a: DVec3,
        to_b: DVec3,
    },
}

/// One primitive of an analytic shape, with the geometry id Embree knows it
/// by, its bounds and (for the quadrics the kernel knows) its quadric.
#[derive(Debug, Clone, Copy)]
struct Primitive {
    geom: u32,
    prim: u32,
    shape: Analytic,
    /// Embree's padded box, as (low, high) corners.
    bounds: ([f64; 3], [f64; 3]),
    quadric: Option<Quadric>,
}

/// The analytic primitives of a scene (at most [`MAX_SET_PRIMITIVES`]).
#[derive(Debug, Clone)]
pub struct AnalyticSet {
    prims: Vec<Primitive>,
    /// The vector instructions the lane loops are compiled for.
    arch: pulp::Arch,
}

/// The active lanes' rays in f64 (what `Segment::new` makes of each), the
/// reciprocals of their directions and their intervals widened by far more
/// than f32 rounding (for the box test); lanes past the active ones have a
/// zero direction and an empty interval.
struct LaneArrays<const N: usize> {
    o: [[f64; N]; 3],
    d: [[f64; N]; 3],
    inv_d: [[f64; N]; 3],
    t_lo: [f64; N],
    t_hi: [f64; N],
}

impl<const N: usize> LaneArrays<N> {
    /// The lanes of `rays` up to the last active one (how many: the second
    /// value). Every lane is converted, active or not, so that the loops
    /// vectorise; an inactive lane gets an empty interval (and is skipped by
    /// the callers whatever its roots).
    #[inline(always)]
    fn of(rays: &PacketRays<'_, N>) -> (Self, usize) {
        let mut l = LaneArrays {
            o: [[0.0; N]; 3],
            d: [[0.0; N]; 3],
            inv_d: [[0.0; N]; 3],
            t_lo: [f64::INFINITY; N],
            t_hi: [f64::NEG_INFINITY; N],
        };
        for a in 0..3 {
            for k in 0..N {
                l.o[a][k] = rays.org[a][k] as f64;
                l.d[a][k] = rays.dir[a][k] as f64;
                l.inv_d[a][k] = 1.0 / rays.dir[a][k] as f64;
            }
        }
        // A crossing is kept when its t rounded to f32 is within the
        // interval: a relative 1e-6 covers that rounding many times over.
        for k in 0..N {
            let (tn, tf) = (rays.tnear[k] as f64, rays.tfar[k] as f64);
            l.t_lo[k] = tn - tn.abs() * 1e-6 - 1e-9;
            l.t_hi[k] = tf + tf.abs() * 1e-6 + 1e-9;
        }
        let mut m = 0;
        for k in 0..N {
            if rays.active(k) {
                m = k + 1;
            } else {
                (l.t_lo[k], l.t_hi[k]) = (f64::INFINITY, f64::NEG_INFINITY);
            }
        }
        (l, m)
    }
}

/// Every lane's roots with one primitive, in arrays (`real` is 0 for a
/// lane that misses the primitive's box; for a primitive without a
/// quadric, `real` 1 only says the lane meets the box).
#[derive(Clone, Copy)]
struct LaneRoots<const N: usize> {
    t0: [f64; N],
    t1: [f64; N],
    real: [f64; N],
}

impl<const N: usize> LaneRoots<N> {
    const NONE: LaneRoots<N> = LaneRoots {
        t0: [0.0; N],
        t1: [0.0; N],
        real: [0.0; N],
    };

    /// Lane `k`'s roots.
    #[inline(always)]
    fn get(&self, k: usize) -> Roots {
        Roots {
            t0: self.t0[k],
            t1: self.t1[k],
            real: self.real[k] != 0.0,
        }
    }
}

/// For every primitive of the set and the first `m` lanes, as many lanes
/// per instruction as the vector unit holds: which lanes meet its box in
/// their interval, and the roots of those with its quadric, handed to
/// `each(primitive, roots)`. Each lane's root arithmetic is the scalar
/// function's, operation for operation and unfused (tested bit for bit);
/// `min`/`max` differ from `f64::min`/`max` only for a NaN, which a lane
/// with real roots does not have.
struct SetKernel<'a, const N: usize, F> {
    prims: &'a [Primitive],
    lanes: &'a LaneArrays<N>,
    m: usize,
    each: F,
}

impl<'a, const N: usize, F: FnMut(&Primitive, &LaneRoots<N>)> pulp::WithSimd for SetKernel<'a, N, F> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) {
        let SetKernel {
            prims,
            lanes: l,
            m,
            mut each,
        } = self;
        // Whole vectors over the first m lanes (N is a multiple of every width).
        let n = m.div_ceil(S::F64_LANES) * S::F64_LANES;
        let vectors = |a: &'a [f64; N]| S::as_simd_f64s(&a[..n]).0;
        let xyz = |a: &'a [[f64; N]; 3]| [vectors(&a[0]), vectors(&a[1]), vectors(&a[2])];
        let (o, d, inv) = (xyz(&l.o), xyz(&l.d), xyz(&l.inv_d));
        let (t_lo, t_hi) = (vectors(&l.t_lo), vectors(&l.t_hi));
        let mut out = LaneRoots::<N>::NONE;
        let splat = |x: f64| simd.splat_f64s(x);
        let (zero, one) = (splat(0.0), splat(1.0));
        let add = |a, b| simd.add_f64s(a, b);
        let sub = |a, b| simd.sub_f64s(a, b);
        let mul = |a, b| simd.mul_f64s(a, b);
        // x·x' + y·y' + z·z', summed left to right as glam's `dot`.
        let dot = |x, y, z, x2, y2, z2| add(add(mul(x, x2), mul(y, y2)), mul(z, z2));
        for p in prims {
            let (lo, hi) = p.bounds;
            let (t0s, _) = S::as_mut_simd_f64s(&mut out.t0[..n]);
            let (t1s, _) = S::as_mut_simd_f64s(&mut out.t1[..n]);
            let (reals, _) = S::as_mut_simd_f64s(&mut out.real[..n]);
            let mut any = false;
            for k in 0..o[0].len() {
                // The slab test. A ray parallel to a face and lying in its
                // plane (0·∞, NaN) may come out either way: the padded box
                // holds the shape strictly inside, so that ray misses it.
                let (mut near, mut far) = (t_lo[k], t_hi[k]);
                for a in 0..3 {
                    let ta = mul(sub(splat(lo[a]), o[a][k]), inv[a][k]);
                    let tb = mul(sub(splat(hi[a]), o[a][k]), inv[a][k]);
                    near = simd.max_f64s(near, simd.min_f64s(ta, tb));
                    far = simd.min_f64s(far, simd.max_f64s(ta, tb));
                }
                let misses = simd.greater_than_f64s(near, far);
                if simd.first_true_m64s(simd.not_m64s(misses)) == S::F64_LANES {
                    reals[k] = zero;
                    continue;
                }
                any = true;
                let Some(quadric) = p.quadric else {
                    reals[k] = simd.select_f64s(misses, zero, one);
                    continue;
                };
                // The quadric's offset from the origin and the direction: a
                // sphere's whole, a wall's parts across the y axis (x, 0, z).
                let (off, dir, radius) = match quadric {
                    Quadric::Sphere { center, radius } => (
                        [0, 1, 2].map(|a| sub(o[a][k], splat(center[a]))),
                        [d[0][k], d[1][k], d[2][k]],
                        radius,
                    ),
                    Quadric::WallY { base, radius } => (
                        [sub(o[0][k], splat(base.x)), zero, sub(o[2][k], splat(base.z))],
                        [d[0][k], zero, d[2][k]],
                        radius,
                    ),
                    Quadric::Rect {
                        corner,
                        normal,
                        to_a,
                        to_b,
                    } => {
                        // t = (corner − o)·n / (d·n); p − corner = (o + d·t) − corner;
                        // inside when both its coordinates are in [0, 1], and never
                        // for d·n == 0 (a NaN coordinate is outside). Written out:
                        // closures and array maps here are not inlined into the
                        // vector code.
                        let (nx, ny, nz) = (splat(normal.x), splat(normal.y), splat(normal.z));
                        let (kx, ky, kz) = (splat(corner.x), splat(corner.y), splat(corner.z));
                        let dn = dot(d[0][k], d[1][k], d[2][k], nx, ny, nz);
                        let (cx, cy, cz) = (sub(kx, o[0][k]), sub(ky, o[1][k]), sub(kz, o[2][k]));
                        let t = simd.div_f64s(dot(cx, cy, cz, nx, ny, nz), dn);
                        let qx = sub(add(o[0][k], mul(d[0][k], t)), kx);
                        let qy = sub(add(o[1][k], mul(d[1][k], t)), ky);
                        let qz = sub(add(o[2][k], mul(d[2][k], t)), kz);
                        let a = dot(qx, qy, qz, splat(to_a.x), splat(to_a.y), splat(to_a.z));
                        let b = dot(qx, qy, qz, splat(to_b.x), splat(to_b.y), splat(to_b.z));
                        let a_in = simd.and_m64s(
                            simd.greater_than_or_equal_f64s(a, zero),
                            simd.less_than_or_equal_f64s(a, one),
                        );
                        let b_in = simd.and_m64s(
                            simd.greater_than_or_equal_f64s(b, zero),
                            simd.less_than_or_equal_f64s(b, one),
                        );
                        let inside = simd.and_m64s(
                            simd.and_m64s(a_in, b_in),
                            simd.not_m64s(simd.equal_f64s(dn, zero)),
                        );
                        // Only a crossing within the lane's widened interval
                        // can be one the scalar code keeps (as for the quadrics).
                        let kept = simd.and_m64s(
                            simd.greater_than_or_equal_f64s(t, t_lo[k]),
                            simd.less_than_or_equal_f64s(t, t_hi[k]),
                        );
                        t0s[k] = t;
                        reals[k] = simd.select_f64s(
                            simd.and_m64s(simd.and_m64s(inside, kept), simd.not_m64s(misses)),
                            one,
                            zero,
                        );
                        continue;
                    }
                };
                let [cx, cy, cz] = off;
                let [dx, dy, dz] = dir;
                let a = dot(dx, dy, dz, dx, dy, dz);
                let b = dot(cx, cy, cz, dx, dy, dz);
                let len = simd.sqrt_f64s(dot(cx, cy, cz, cx, cy, cz));
                let r = splat(radius);
                let c = mul(sub(len, r), add(len, r));
                let disc = sub(mul(b, b), mul(a, c));
                // !(disc < 0 || a == 0): a NaN discriminant counts as real, as in the scalar code.
                let not_real = simd.or_m64s(simd.less_than_f64s(disc, zero), simd.equal_f64s(a, zero));
                let s = simd.sqrt_f64s(disc);
                let q = simd.select_f64s(
                    simd.greater_than_f64s(b, zero),
                    simd.neg_f64s(add(b, s)),
                    add(simd.neg_f64s(b), s),
                );
                let q_zero = simd.equal_f64s(q, zero);
                let t0 = simd.select_f64s(q_zero, zero, simd.div_f64s(q, a));
                let t1 = simd.select_f64s(q_zero, zero, simd.div_f64s(c, q));
                (t0s[k], t1s[k]) = match quadric {
                    Quadric::Sphere { .. } => (simd.min_f64s(t0, t1), simd.max_f64s(t0, t1)),
                    // The wall's roots stay in the quadratic's order.
                    Quadric::WallY { .. } | Quadric::Rect { .. } => (t0, t1),
                };
                // A lane with neither root in its widened interval has no
                // crossing the scalar code keeps (`Segment::keeps` compares
                // within the exact one, which only narrows): not passed on.
                let within = |t| {
                    simd.and_m64s(
                        simd.greater_than_or_equal_f64s(t, t_lo[k]),
                        simd.less_than_or_equal_f64s(t, t_hi[k]),
                    )
                };
                let outside = simd.not_m64s(simd.or_m64s(within(t0s[k]), within(t1s[k])));
                reals[k] = simd.select_f64s(simd.or_m64s(simd.or_m64s(not_real, misses), outside), zero, one);
            }
            if any {
                each(p, &out);
            }
        }
    }
}

impl AnalyticSet {
    /// The set of `shapes` (geometry id, shape); `None` when they have more
    /// than [`MAX_SET_PRIMITIVES`] primitives together, or none.
    pub fn try_new(shapes: impl IntoIterator<Item = (u32, Analytic)>) -> Option<AnalyticSet> {
        let mut prims = Vec::new();
        for (geom, shape) in shapes {
            for prim in 0..shape.prims() {
                let b = shape.bounds(prim);
                let quadric = match &shape {
                    Analytic::Sphere(s) => Some(Quadric::Sphere {
                        center: s.center,
                        radius: s.radius,
                    }),
                    Analytic::Cylinder(c) if prim == 0 && c.axis == DVec3::Y => Some(Quadric::WallY {
                        base: c.p0,
                        radius: c.radius,
                    }),
                    Analytic::Rect(r) => {
                        let (to_a, to_b) = r.dual();
                        Some(Quadric::Rect {
                            corner: r.corner,
                            normal: r.normal,
                            to_a,
                            to_b,
                        })
                    }
                    _ => None,
                };
                prims.push(Primitive {
                    geom,
                    prim,
                    shape,
                    bounds: (b.lower.map(f64::from), b.upper.map(f64::from)),
                    quadric,
                });
                if prims.len() > MAX_SET_PRIMITIVES {
                    return None;
                }
            }
        }
        (!prims.is_empty()).then(|| AnalyticSet {
            prims,
            arch: pulp::Arch::new(),
        })
    }

    /// This set with its lane loops compiled for `arch` (a lower level
    /// than the CPU's: the tests compare every level).
    #[cfg(test)]
    fn with_arch(self, arch: pulp::Arch) -> Self {
        AnalyticSet { arch, ..self }
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.prims.len()
    }

    /// Is the set empty (never, for a set of [`try_new`](Self::try_new))?
    pub fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }

    /// For each primitive, the crossings of each active lane of `packet`
    /// that has any, sorted by t, to `each(packet, primitive, lane,
    /// crossings)`: what the user-geometry callback would offer Embree for
    /// the lane's interval as it stands then (`each` may narrow it).
    #[inline(always)]
    fn crossings<const N: usize, P: RayPacket<N>>(
        &self,
        packet: &mut P,
        mut each: impl FnMut(&mut P, &Primitive, usize, &Candidates),
    ) {
        let (lanes, m) = LaneArrays::<N>::of(&packet.rays());
        if m == 0 {
            return;
        }
        self.arch.dispatch(SetKernel {
            prims: &self.prims,
            lanes: &lanes,
            m,
            each: |p: &Primitive, roots: &LaneRoots<N>| {
                for k in 0..m {
                    let lane_roots = roots.get(k);
                    if !lane_roots.real {
                        continue;
                    }
                    // The lane as it stands (an earlier primitive may have
                    // narrowed it, or occluded it).
                    let Some(r) = packet.lane(k) else { continue };
                    let mut c = Candidates::default();
                    match (&p.shape, p.quadric) {
                        (Analytic::Sphere(s), Some(_)) => {
                            s.push_crossings(&Segment::of(&r), lane_roots, &mut c)
                        }
                        (Analytic::Cylinder(cyl), Some(_)) => cyl.wall().push_crossings_about_y(
                            cyl.inward,
                            &Segment::of(&r),
                            lane_roots,
                            &mut c,
                        ),
                        (Analytic::Rect(rect), Some(_)) => {
                            rect.push_crossing_at(&Segment::of(&r), lane_roots.t0, &mut c)
                        }
                        (shape, _) => shape.intersect_in(p.prim, r.org, r.dir, r.tnear, r.tfar, &mut c),
                    }
                    if !c.as_slice().is_empty() {
                        c.sort();
                        each(packet, p, k, &c);
                    }
                }
            },
        });
    }

    /// Complete a nearest-hit query of `packet` that Embree answered against
    /// the meshes alone: a lane whose nearest crossing with a primitive of
    /// the set lies within `[tnear, tfar]` (tfar: the mesh hit, if any) gets
    /// that crossing as its hit.
    pub fn intersect<const N: usize, P: RayPacket<N>>(&self, packet: &mut P) {
        self.crossings::<N, P>(packet, |packet, p, k, c| {
            let rays = packet.rays();
            let (tnear, tfar) = (rays.tnear[k], rays.tfar[k]);
            // Sorted: the first crossing within the interval is the nearest.
            if let Some(c) = c.as_slice().iter().find(|c| c.t >= tnear && c.t <= tfar) {
                packet.set_hit(
                    k,
                    &Hit {
                        geom_id: p.geom,
                        prim_id: p.prim,
                        t: c.t,
                        ng: c.ng.into(),
                        u: c.u,
                        v: c.v,
                    },
                );
            }
        });
    }

    /// Complete an occlusion query of `packet` that Embree answered against
    /// the meshes alone: a lane not yet occluded that crosses a primitive of
    /// the set within `[tnear, tfar]` becomes occluded.
    pub fn occlude<const N: usize, P: RayPacket<N>>(&self, packet: &mut P) {
        self.crossings::<N, P>(packet, |packet, _, k, c| {
            let rays = packet.rays();
            let (tnear, tfar) = (rays.tnear[k], rays.tfar[k]);
            if c.as_slice().iter().any(|c| c.t >= tnear && c.t <= tfar) {
                // Later primitives skip the lane (`RayPacket::lane`).
                packet.set_occluded(k);
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::embree::{Packet8, Ray};
    use crate::scene::{load_scene_str, BuildOptions, RenderScene, Shape};
    use glam::Vec3A as V3;

    /// Every vector level this CPU runs, the scalar one first.
    fn levels() -> Vec<pulp::Arch> {
        #[cfg(target_arch = "x86_64")]
        {
            let mut v = vec![pulp::Arch::Scalar];
            v.extend(pulp::x86::V3::try_new().map(pulp::Arch::V3));
            v.extend(pulp::x86::V4::try_new().map(pulp::Arch::V4));
            v
        }
        #[cfg(not(target_arch = "x86_64"))]
        vec![pulp::Arch::new()]
    }

    fn scene(objects: &str, analytic_set: bool) -> RenderScene {
        let text = format!(
            r#"
[camera]
position = [0.0, 1.0, 6.0]
target = [0.0, 0.5, 0.0]
fov = 40.0
[film]
width = 8
height = 8
spp = 1
[[objects]]
name = "ground"
shape = {{ type = "rect", center = [0.0, -1.2, 0.0], normal = [0.0, 1.0, 0.0], u_axis = [1.0, 0.0, 0.0], size = [8.0, 8.0] }}
material = {{ type = "diffuse", reflectance = [0.5, 0.5, 0.5] }}
{objects}"#
        );
        let opts = BuildOptions {
            analytic_set,
            ..BuildOptions::default()
        };
        load_scene_str("set_test.toml", &text, std::path::Path::new("."), &opts).unwrap()
    }

    const SETS: [&str; 2] = [
        r#"
[[objects]]
name = "ball"
shape = { type = "sphere", center = [0.3, 0.6, -0.2], radius = 0.6 }
material = { type = "dielectric", int_ior = 1.5, ext_ior = 1.0 }
[[objects]]
name = "pipe"
shape = { type = "cylinder", p0 = [0.0, -1.0, 0.0], p1 = [0.0, 1.0, 0.0], radius = 1.0, normal = "in" }
material = { type = "dielectric", int_ior = 1.5, ext_ior = 1.0 }
[[objects]]
name = "tilted"
shape = { type = "cylinder", p0 = [0.1, -1.0, 0.2], p1 = [0.5, 1.0, 0.4], radius = 0.7, caps = true }
material = { type = "dielectric", int_ior = 1.5, ext_ior = 1.0 }
[[objects]]
name = "disk"
shape = { type = "disk", center = [0.0, 1.2, 0.0], normal = [0.0, 1.0, 0.0], radius = 0.5 }
material = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }
[[objects]]
name = "card"
shape = { type = "rect", center = [0.0, 0.0, 0.0], normal = [0.0, 0.0, 1.0], u_axis = [1.0, 0.0, 0.0], size = [1.2, 0.8] }
transform = [{ matrix = [[1.0, 0.4, 0.0, -0.6], [0.0, 1.0, 0.3, 0.2], [0.2, 0.0, 1.0, 0.8], [0.0, 0.0, 0.0, 1.0]] }]
material = { type = "diffuse", reflectance = [0.5, 0.5, 0.5] }
"#,
        r#"
[[objects]]
name = "tube"
shape = { type = "tube", p0 = [0.0, -1.0, 0.0], p1 = [0.0, 1.0, 0.0], outer_radius = 1.0, inner_radius = 0.8 }
material = { type = "dielectric", int_ior = 1.5, ext_ior = 1.0 }
[[objects]]
name = "ball"
shape = { type = "sphere", center = [0.0, 0.2, 0.0], radius = 0.5 }
material = { type = "dielectric", int_ior = 1.3, ext_ior = 1.0 }
[[objects]]
name = "can"
shape = { type = "cylinder", p0 = [1.5, -1.0, 0.0], p1 = [1.5, 1.0, 0.0], radius = 0.4, caps = true }
material = { type = "dielectric", int_ior = 1.5, ext_ior = 1.0 }
"#,
    ];

    /// Packets of rays aimed near the shapes (grazing ones included), with
    /// any interval.
    fn packets(seed: u64, count: usize) -> Vec<[Ray; 8]> {
        let mut rng = crate::sampling::Rng::new(seed);
        let mut u = move || rng.uniform();
        (0..count)
            .map(|_| {
                std::array::from_fn(|_| {
                    let org = V3::new(u(), u(), u()) * 6.0 - V3::splat(3.0);
                    let aim = V3::new(u(), u(), u()) * 2.4 - V3::splat(1.2);
                    let mut dir = aim - org;
                    if u() < 0.2 {
                        dir = dir.cross(V3::new(0.3, 1.0, -0.2));
                    }
                    let mut r = Ray::new(org, dir);
                    r.tnear = if u() < 0.5 { 0.0 } else { u() };
                    r.tfar = if u() < 0.5 {
                        f32::INFINITY
                    } else {
                        r.tnear + 4.0 * u()
                    };
                    r
                })
            })
            .collect()
    }

    /// Bit patterns of a hit, for exact comparison.
    fn bits(p: &Packet8, i: usize) -> Option<(u32, u32, u32, [u32; 3], u32, u32)> {
        p.hit(i).map(|h| {
            (
                h.geom_id,
                h.prim_id,
                h.t.to_bits(),
                h.ng.to_array().map(f32::to_bits),
                h.u.to_bits(),
                h.v.to_bits(),
            )
        })
    }

    /// Lanes of `rays` where `set` (with the meshes from Embree) answers
    /// otherwise than Embree with its callbacks in the whole scene, nearest
    /// hits and occlusion.
    fn disagreements(set: &AnalyticSet, with: &RenderScene, rays: &[[Ray; 8]]) -> usize {
        let mut bad = 0;
        for batch in rays {
            let (mut a, mut b) = (Packet8::new(), Packet8::new());
            for (i, r) in batch.iter().enumerate() {
                a.set_ray(i, r);
                b.set_ray(i, r);
            }
            a.intersect_meshes(&with.embree, false);
            set.intersect(&mut a);
            b.intersect(&with.embree, false);
            bad += (0..8).filter(|&i| bits(&a, i) != bits(&b, i)).count();
            for (i, r) in batch.iter().enumerate() {
                a.set_ray(i, r);
                b.set_ray(i, r);
            }
            a.occlude_meshes(&with.embree, false);
            set.occlude(&mut a);
            b.occlude(&with.embree, false);
            bad += (0..8).filter(|&i| a.occluded(i) != b.occluded(i)).count();
        }
        bad
    }

    /// The set answers packet queries as Embree's user-geometry callbacks
    /// do, bit for bit (hit distance, normal, ids; occlusion), at every
    /// vector level the CPU has: spheres, walls about y and other axes,
    /// caps, disks, tubes and rects (the ground and a sheared card, when
    /// they fit in the set: the first scene; the second keeps its ground a
    /// mesh), rays grazing them, any interval. A sphere larger by a
    /// relative 1e-7 is caught, and so are rects with their edges swapped.
    #[test]
    fn set_answers_as_embree_at_every_level() {
        let rays = packets(3, 4000);
        for (n, objects) in SETS.iter().enumerate() {
            let with = scene(objects, true);
            let without = scene(objects, false);
            assert!(with.embree.has_meshes_only() && !without.embree.has_meshes_only());
            let set = with.analytic_set.clone().expect("a set of few shapes");
            assert!(without.analytic_set.is_none());
            let rects = |s: &RenderScene| {
                s.geoms
                    .iter()
                    .filter(|g| matches!(g.shape, Shape::Analytic(Analytic::Rect(_))))
                    .count()
            };
            assert_eq!(rects(&with), [2, 0][n], "set {n}: analytic rects");
            assert_eq!(rects(&without), 0, "set {n}: no set, no analytic rects");
            let hits: usize = rays
                .iter()
                .map(|batch| {
                    let mut p = Packet8::new();
                    for (i, r) in batch.iter().enumerate() {
                        p.set_ray(i, r);
                    }
                    p.intersect(&without.embree, false);
                    (0..8)
                        .filter(|&i| p.hit(i).is_some_and(|h| h.geom_id > 0))
                        .count()
                })
                .sum();
            assert!(
                hits > 8000,
                "set {n}: {hits} analytic hits: the rays should meet the shapes"
            );
            for arch in levels() {
                let set = set.clone().with_arch(arch);
                assert_eq!(disagreements(&set, &with, &rays), 0, "set {n}, {arch:?}");
            }
            // Power: every sphere a relative 1e-7 larger; every rect with its
            // edges swapped (facing the other way).
            let grown =
                |grow: &dyn Fn(&Analytic) -> Option<Analytic>| {
                    AnalyticSet::try_new(with.geoms.iter().enumerate().filter_map(
                        |(g, rec)| match &rec.shape {
                            Shape::Analytic(a) => Some((g as u32, grow(a).unwrap_or(*a))),
                            Shape::Mesh(_) => None,
                        },
                    ))
                    .unwrap()
                };
            let spheres = grown(&|a| match a {
                Analytic::Sphere(s) => Some(Analytic::Sphere(crate::scene::shapes::Sphere {
                    radius: s.radius * (1.0 + 1e-7),
                    ..*s
                })),
                _ => None,
            });
            let bad = disagreements(&spheres, &with, &rays);
            assert!(bad > 0, "set {n}: a grown sphere went unnoticed");
            if rects(&with) > 0 {
                let swapped = grown(&|a| match a {
                    Analytic::Rect(r) => {
                        let flip = r.normal.dot(r.edge_u.cross(r.edge_v)) < 0.0;
                        crate::scene::shapes::Rect::new(r.corner, r.edge_v, r.edge_u, flip)
                            .map(Analytic::Rect)
                    }
                    _ => None,
                });
                let bad = disagreements(&swapped, &with, &rays);
                assert!(bad > 0, "set {n}: rects with swapped edges went unnoticed");
            }
        }
    }

    /// Too many primitives, or none: no set.
    #[test]
    fn a_set_holds_one_to_eight_primitives() {
        let ball = Analytic::Sphere(crate::scene::shapes::Sphere {
            center: DVec3::ZERO,
            radius: 1.0,
        });
        assert!(AnalyticSet::try_new([]).is_none());
        assert_eq!(
            AnalyticSet::try_new((0..8).map(|g| (g, ball))).map(|s| s.len()),
            Some(8)
        );
        assert!(AnalyticSet::try_new((0..9).map(|g| (g, ball))).is_none());
    }
}
