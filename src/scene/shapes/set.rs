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
//! With the default [`SetScratch`] the answer is Embree's, bit for bit:
//! lanes that miss a primitive's
//! bounds (the padded box Embree culls with) are left out, and for the
//! others the same f64 roots (spheres and walls about the y axis, and the
//! plane crossings of rects, disks and caps: the scalar arithmetic in every
//! vector lane) give the same crossings, the touch test decides the same,
//! and the kept crossing nearest within the lane's `[tnear, tfar]` (`tfar`
//! narrowed by each primitive's hit in turn) becomes its hit, all in vector
//! registers. Where the f32 rounding of a root could decide whether it is
//! kept (a root within two f32 ulps of an end of the interval), or a lane
//! meets a primitive without a vector form (tubes, tilted walls), the lane
//! is answered again by the scalar `intersect_in`, one primitive at a
//! time. Only a tie at exactly the same f32 distance between two primitives
//! may be broken otherwise (Embree's order is its traversal's; here it is
//! the primitives' order).
//!
//! With [`SetScratch::f32`] (the renders' vector mode) the f32 kernel of
//! `set_f32` answers instead, twice as many lanes per instruction: the same
//! primitive and crossing on every lane, t within the f32 arithmetic's
//! error bounds, the lanes it cannot be sure of answered as above.
//!
//! [`SceneBuilder::with_meshes_only`]: crate::embree::SceneBuilder::with_meshes_only
use super::segment::candidate;
use super::set_f32::{split, PrimF32, SetKernelF32, ERROR_SAFETY};
use super::Analytic;
use crate::embree::{Candidate, Candidates, PacketRays, RayPacket, UserShape};
use crate::ray::Hit;
use glam::DVec3;

/// The most primitives a scene may have for its analytic shapes to be
/// tested here (every lane meets every primitive: no hierarchy).
pub const MAX_SET_PRIMITIVES: usize = 8;

/// A quadric whose roots [`SetKernel`] finds for many lanes at once (or a
/// parallelogram or disk: its one root, the plane's crossing, where it lies
/// inside).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Quadric {
    /// `Sphere::roots`.
    Sphere { center: DVec3, radius: f64 },
    /// `Wall::roots` of a wall about the y axis (`AxisY`), `height` long,
    /// its normals towards the axis when `flip`.
    WallY {
        base: DVec3,
        radius: f64,
        height: f64,
        flip: bool,
    },
    /// `Rect::crossing` but the segment's interval (`t0`: the crossing;
    /// real only inside the parallelogram).
    Rect {
        corner: DVec3,
        normal: DVec3,
        to_a: DVec3,
        to_b: DVec3,
    },
    /// `Disk::crossing` but the segment's interval (a disk, or a
    /// cylinder's cap): the plane's crossing, real only within the radii
    /// (squared); `facing` is the candidate's normal.
    Disk {
        center: DVec3,
        normal: DVec3,
        radius2: f64,
        inner2: f64,
        facing: DVec3,
    },
}

/// An f64 value as two f32s, `hi + lo` (see `set_f32::split`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Split {
    pub hi: f32,
    pub lo: f32,
}

/// A [`Quadric`] as the f32 kernel reads it (`set_f32`): positions as f32
/// pairs, a plane as the pair of its offset `normal·corner`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum QuadricF32 {
    Sphere {
        center: [Split; 3],
        radius: f32,
    },
    WallY {
        base: [Split; 3],
        radius: f32,
        height: f32,
        flip: bool,
    },
    Rect {
        plane: Split,
        normal: [f32; 3],
        corner: [Split; 3],
        to_a: [f32; 3],
        to_b: [f32; 3],
    },
    Disk {
        plane: Split,
        normal: [f32; 3],
        center: [Split; 3],
        radius2: f32,
        inner2: f32,
        facing: [f32; 3],
    },
}

impl QuadricF32 {
    fn of(q: &Quadric) -> QuadricF32 {
        let pair = |v: DVec3| [split(v.x), split(v.y), split(v.z)];
        let f32s = |v: DVec3| v.as_vec3().to_array();
        match *q {
            Quadric::Sphere { center, radius } => QuadricF32::Sphere {
                center: pair(center),
                radius: radius as f32,
            },
            Quadric::WallY {
                base,
                radius,
                height,
                flip,
            } => QuadricF32::WallY {
                base: pair(base),
                radius: radius as f32,
                height: height as f32,
                flip,
            },
            Quadric::Rect {
                corner,
                normal,
                to_a,
                to_b,
            } => QuadricF32::Rect {
                plane: split(normal.dot(corner)),
                normal: f32s(normal),
                corner: pair(corner),
                to_a: f32s(to_a),
                to_b: f32s(to_b),
            },
            Quadric::Disk {
                center,
                normal,
                radius2,
                inner2,
                facing,
            } => QuadricF32::Disk {
                plane: split(normal.dot(center)),
                normal: f32s(normal),
                center: pair(center),
                radius2: radius2 as f32,
                inner2: inner2 as f32,
                facing: f32s(facing),
            },
        }
    }
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
    /// The same primitives for the f32 kernel.
    fast: Vec<PrimF32>,
    /// The vector instructions the lane loops are compiled for.
    arch: pulp::Arch,
    /// Take the kernel's answer for unsure lanes too (a known-wrong
    /// variant for the tests).
    #[cfg(test)]
    trust_kernel: bool,
    /// The f32 kernel's safety factor (tests widen it).
    #[cfg(test)]
    safety: f32,
}

/// The active lanes' rays in f64 (what `Segment::new` makes of each), the
/// reciprocals of their directions, their intervals (exact, and widened by
/// far more than f32 rounding for the box test) and what the touch test
/// reads of each ray; lanes past the active ones have a zero direction and
/// an empty interval.
struct LaneArrays<const N: usize> {
    o: [[f64; N]; 3],
    d: [[f64; N]; 3],
    inv_d: [[f64; N]; 3],
    t_lo: [f64; N],
    t_hi: [f64; N],
    /// The interval as the packet holds it (f32 values).
    tn: [f64; N],
    tf: [f64; N],
}

impl<const N: usize> LaneArrays<N> {
    const EMPTY: LaneArrays<N> = LaneArrays {
        o: [[0.0; N]; 3],
        d: [[0.0; N]; 3],
        inv_d: [[0.0; N]; 3],
        t_lo: [0.0; N],
        t_hi: [0.0; N],
        tn: [0.0; N],
        tf: [0.0; N],
    };

    /// The lanes of `rays` up to the last active one (how many: the
    /// value), made in place: in the caller's [`SetScratch`], so that
    /// neither a zeroed struct per query nor a returned copy is made (both
    /// showed in the profile). Every lane is converted, active or not, so
    /// that the loops vectorise; an inactive lane gets an empty interval
    /// (and is skipped by the callers whatever its roots).
    #[inline(always)]
    fn fill(&mut self, rays: &PacketRays<'_, N>) -> usize {
        let l = self;
        for a in 0..3 {
            for k in 0..N {
                l.o[a][k] = rays.org[a][k] as f64;
                l.d[a][k] = rays.dir[a][k] as f64;
                l.inv_d[a][k] = 1.0 / rays.dir[a][k] as f64;
            }
        }
        // A crossing is kept when its t rounded to f32 is within the
        // interval: a relative 1e-6 covers that rounding many times over.
        // Branch-free, so that the loop vectorises.
        let mut m = 0;
        for k in 0..N {
            let (tn, tf) = (rays.tnear[k] as f64, rays.tfar[k] as f64);
            let active = rays.active(k);
            (l.tn[k], l.tf[k]) = (tn, tf);
            l.t_lo[k] = if active {
                tn - tn.abs() * 1e-6 - 1e-9
            } else {
                f64::INFINITY
            };
            l.t_hi[k] = if active {
                tf + tf.abs() * 1e-6 + 1e-9
            } else {
                f64::NEG_INFINITY
            };
            m = if active { k + 1 } else { m };
        }
        m
    }
}

/// A thread's working storage for [`AnalyticSet::intersect`] and
/// [`AnalyticSet::occlude`] on packets of `N` lanes: make one and pass it
/// to every query. The default's queries answer exactly as Embree's
/// callbacks; [`SetScratch::f32`]'s in f32 lanes (`set_f32`).
pub struct SetScratch<const N: usize> {
    lanes: LaneArrays<N>,
    /// Lanes the kernels answered since the scratch was made.
    pub answered: u64,
    /// Those of them answered again by the scalar f64 code (unsure, or
    /// meeting a primitive without a vector form).
    pub replayed: u64,
    f32: bool,
    out64: Resolved<f64, N>,
    out32: Resolved<f32, N>,
}

impl<const N: usize> Default for SetScratch<N> {
    fn default() -> Self {
        SetScratch {
            lanes: LaneArrays::EMPTY,
            answered: 0,
            replayed: 0,
            f32: false,
            out64: Resolved::NONE,
            out32: Resolved::NONE,
        }
    }
}

impl<const N: usize> SetScratch<N> {
    /// Storage for queries answered in f32 lanes where the packet fills
    /// whole f32 vectors (else as the default): the same primitive and
    /// crossing as Embree's on each lane, the distance within a few f32
    /// ulps of its, or within the error bound of the f32 arithmetic at
    /// grazing incidence (see `set_f32`).
    pub fn f32() -> Self {
        SetScratch {
            f32: true,
            ..SetScratch::default()
        }
    }
}

/// What a kernel decides for each lane of a packet, in its own precision
/// `T` (f64: [`SetKernel`], as the scalar code would; f32: `set_f32`): its
/// nearest crossing among the set's primitives (a nearest-hit query) or
/// whether it has any (occlusion), unless rounding could tip a comparison
/// (`unsure`: the lane is replayed in scalar code).
pub(super) struct Resolved<T, const N: usize> {
    /// The crossing's t (its f32 is the hit's).
    pub t: [T; N],
    /// The crossing's geometry id plus one, 0 for none (in occlusion: the
    /// lane is occluded for sure). All zeros is no answer, an initial
    /// value the compiler writes without a copy.
    pub geom1: [T; N],
    /// Its primitive id.
    pub prim: [T; N],
    /// The crossing's normal before its conversion to f32.
    pub n: [[T; N]; 3],
    /// Nonzero: decide the lane in scalar code.
    pub unsure: [T; N],
    /// The primitives whose boxes the lane meets, bit `i` for the `i`th
    /// (what Embree would call back for).
    pub boxes: [T; N],
}

/// The lane types of [`Resolved`].
pub(super) trait LaneValue: Copy + Into<f64> {
    const ZERO: Self;
}

impl LaneValue for f32 {
    const ZERO: f32 = 0.0;
}

impl LaneValue for f64 {
    const ZERO: f64 = 0.0;
}

impl<T: LaneValue, const N: usize> Resolved<T, N> {
    pub const NONE: Resolved<T, N> = Resolved {
        t: [T::ZERO; N],
        geom1: [T::ZERO; N],
        prim: [T::ZERO; N],
        n: [[T::ZERO; N]; 3],
        unsure: [T::ZERO; N],
        boxes: [T::ZERO; N],
    };

    /// Decide lane `k` in scalar code?
    #[inline(always)]
    fn unsure_at(&self, k: usize) -> bool {
        self.unsure[k].into() != 0.0
    }

    /// The primitives whose boxes lane `k` meets, bit `i` for the `i`th.
    #[inline(always)]
    fn boxes_at(&self, k: usize) -> u32 {
        self.boxes[k].into() as u32
    }

    /// Lane `k`'s nearest crossing: geometry and primitive ids, t, normal.
    #[inline(always)]
    fn crossing(&self, k: usize) -> Option<(u32, u32, f64, DVec3)> {
        let geom1: f64 = self.geom1[k].into();
        (geom1 > 0.0).then(|| {
            let n = DVec3::new(self.n[0][k].into(), self.n[1][k].into(), self.n[2][k].into());
            (geom1 as u32 - 1, self.prim[k].into() as u32, self.t[k].into(), n)
        })
    }

    /// Is lane `k` occluded for sure (an occlusion query's answer)?
    #[inline(always)]
    fn occluded(&self, k: usize) -> bool {
        self.geom1[k].into() > 0.0
    }
}

/// Relative and absolute slack around an interval's ends beyond which a
/// root's f32 rounding cannot move it across: twice an f32 ulp, and a few
/// of the smallest subnormals.
const SLACK_REL: f64 = 1.0 / (1u64 << 21) as f64;
const SLACK_ABS: f64 = 1e-44;

// The kernel's arithmetic is written with these macros, not closures: a
// closure is a function of its own, compiled without the vector unit's
// target features, and left out of line its intrinsics are calls.
macro_rules! v {
    ($simd:ident, $op:ident, $($arg:expr),+) => {
        $simd.$op($($arg),+)
    };
}

/// x·x' + y·y' + z·z', summed left to right as glam's `dot`.
macro_rules! dot {
    ($simd:ident, $x:expr, $y:expr, $z:expr, $x2:expr, $y2:expr, $z2:expr) => {
        v!(
            $simd,
            add_f64s,
            v!(
                $simd,
                add_f64s,
                v!($simd, mul_f64s, $x, $x2),
                v!($simd, mul_f64s, $y, $y2)
            ),
            v!($simd, mul_f64s, $z, $z2)
        )
    };
}

/// A vector's three components, each splat across the lanes.
macro_rules! splat3 {
    ($simd:ident, $v:expr) => {
        (
            $simd.splat_f64s($v.x),
            $simd.splat_f64s($v.y),
            $simd.splat_f64s($v.z),
        )
    };
}

/// Is `t` within `[lo, hi]`?
macro_rules! within {
    ($simd:ident, $t:expr, $lo:expr, $hi:expr) => {
        v!(
            $simd,
            and_m64s,
            v!($simd, greater_than_or_equal_f64s, $t, $lo),
            v!($simd, less_than_or_equal_f64s, $t, $hi)
        )
    };
}

/// Does `Segment::keeps` keep the root `t` of lanes whose interval is
/// `[tn, lim]` (`lim`: the f32 end, or a kept crossing's t whose f32 it
/// became)? As masks: kept for sure, and unsure. Exact where sure: `t >=
/// tn` implies `t as f32 >= tn` for an f32 `tn` (rounding is monotone), and
/// past the slack the rounding cannot reach the end.
#[inline(always)]
fn keeps<S: pulp::Simd>(simd: S, t: S::f64s, tn: S::f64s, lim: S::f64s) -> (S::m64s, S::m64s) {
    let (rel, abs) = (simd.splat_f64s(SLACK_REL), simd.splat_f64s(SLACK_ABS));
    let tn_slack = v!(
        simd,
        add_f64s,
        v!(simd, mul_f64s, v!(simd, abs_f64s, tn), rel),
        abs
    );
    let lim_slack = v!(
        simd,
        add_f64s,
        v!(simd, mul_f64s, v!(simd, abs_f64s, lim), rel),
        abs
    );
    let finite = v!(
        simd,
        less_than_f64s,
        v!(simd, abs_f64s, t),
        simd.splat_f64s(f64::INFINITY)
    );
    let kept = v!(simd, and_m64s, finite, within!(simd, t, tn, lim));
    let dropped = v!(
        simd,
        or_m64s,
        v!(simd, not_m64s, finite),
        v!(
            simd,
            or_m64s,
            v!(simd, less_than_f64s, t, v!(simd, sub_f64s, tn, tn_slack)),
            v!(simd, greater_than_f64s, t, v!(simd, add_f64s, lim, lim_slack))
        )
    );
    (kept, v!(simd, not_m64s, v!(simd, or_m64s, kept, dropped)))
}

/// `Segment::is_touch` of the lanes' roots `t0`, `t1` on the rays `o + t·d`,
/// operation for operation.
#[inline(always)]
fn touches<S: pulp::Simd>(simd: S, t0: S::f64s, t1: S::f64s, o: [S::f64s; 3], d: [S::f64s; 3]) -> S::m64s {
    // |o| and |d| by their largest components (`max_element` of `abs`).
    macro_rules! largest {
        ($v:expr) => {
            v!(
                simd,
                max_f64s,
                v!(simd, abs_f64s, $v[0]),
                v!(
                    simd,
                    max_f64s,
                    v!(simd, abs_f64s, $v[1]),
                    v!(simd, abs_f64s, $v[2])
                )
            )
        };
    }
    let (o_max, d_max) = (largest!(o), largest!(d));
    const K: f64 = 2.0 * crate::ray::OFFSET_ULPS as f64 * f32::EPSILON as f64;
    const KM: f64 = K * (1.0 + 1e-9);
    let gap = v!(simd, abs_f64s, v!(simd, sub_f64s, t1, t0));
    let a0 = v!(simd, abs_f64s, t0);
    let small = v!(
        simd,
        less_than_or_equal_f64s,
        gap,
        v!(
            simd,
            add_f64s,
            simd.splat_f64s(1e-6),
            v!(simd, mul_f64s, a0, simd.splat_f64s(4e-7))
        )
    );
    let t_max = v!(simd, max_f64s, a0, v!(simd, abs_f64s, t1));
    let km = simd.splat_f64s(KM);
    let beyond = v!(
        simd,
        greater_than_f64s,
        v!(
            simd,
            mul_f64s,
            v!(simd, sub_f64s, gap, v!(simd, mul_f64s, km, t_max)),
            d_max
        ),
        v!(
            simd,
            mul_f64s,
            km,
            v!(simd, add_f64s, o_max, simd.splat_f64s(0.5))
        )
    );
    // Only lanes neither small nor beyond need the window (a division).
    let near = v!(
        simd,
        and_m64s,
        v!(simd, not_m64s, small),
        v!(simd, not_m64s, beyond)
    );
    if simd.first_true_m64s(near) == S::F64_LANES {
        return small;
    }
    // `ray::crossing_window_f64(o, d, t_max)`, with glam's `length`.
    let d_len = v!(simd, sqrt_f64s, dot!(simd, d[0], d[1], d[2], d[0], d[1], d[2]));
    let sum = v!(
        simd,
        add_f64s,
        v!(simd, add_f64s, o_max, v!(simd, mul_f64s, t_max, d_len)),
        simd.splat_f64s(0.5)
    );
    let window = v!(simd, div_f64s, v!(simd, mul_f64s, simd.splat_f64s(K), sum), d_len);
    v!(
        simd,
        or_m64s,
        small,
        v!(
            simd,
            and_m64s,
            near,
            v!(simd, less_than_or_equal_f64s, gap, window)
        )
    )
}

/// For every primitive of the set and the first `m` lanes, as many lanes
/// per instruction as the vector unit holds: which lanes meet its box in
/// their interval, the roots of those with its quadric, and which of the
/// roots the query keeps (`occlusion`: any; else the nearest, each kept
/// crossing narrowing the lane's interval for the next primitive), into
/// `out`. A lane meeting a primitive without a quadric is unsure. Each
/// lane's arithmetic is the scalar functions', operation for operation and
/// unfused (tested bit for bit); `min`/`max` differ from `f64::min`/`max`
/// only for a NaN, which a lane with real roots does not have.
struct SetKernel<'a, const N: usize> {
    prims: &'a [Primitive],
    rays: PacketRays<'a, N>,
    occlusion: bool,
    out: &'a mut Resolved<f64, N>,
    lanes: &'a mut LaneArrays<N>,
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

/// A query at one vector level: by the f32 kernel where the scratch asks
/// for it and the packet fills whole f32 vectors, else by the f64 kernel.
struct SetQuery<'a, const N: usize> {
    set: &'a AnalyticSet,
    rays: PacketRays<'a, N>,
    occlusion: bool,
    scratch: &'a mut SetScratch<N>,
}

impl<const N: usize> pulp::WithSimd for SetQuery<'_, N> {
    type Output = (usize, bool);

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, simd: S) -> (usize, bool) {
        let SetQuery {
            set,
            rays,
            occlusion,
            scratch,
        } = self;
        if scratch.f32 && N.is_multiple_of(S::F32_LANES) {
            scratch.out32 = Resolved::NONE;
            #[cfg(test)]
            let safety = set.safety;
            #[cfg(not(test))]
            let safety = ERROR_SAFETY;
            let kernel = SetKernelF32 {
                prims: &set.fast,
                rays,
                occlusion,
                out: &mut scratch.out32,
                safety,
            };
            (kernel.with_simd(simd), true)
        } else {
            scratch.out64 = Resolved::NONE;
            let kernel = SetKernel {
                prims: &set.prims,
                rays,
                occlusion,
                out: &mut scratch.out64,
                lanes: &mut scratch.lanes,
            };
            (kernel.with_simd(simd), false)
        }
    }
}

/// The level whose f32 vectors a packet of `N` lanes fills: `arch`, or
/// AVX2's eight lanes for packets of eight under AVX-512, so that the f32
/// queries' answers do not depend on the packet's width (each lane's
/// arithmetic is the same at every width).
fn f32_level<const N: usize>(arch: pulp::Arch) -> pulp::Arch {
    #[cfg(target_arch = "x86_64")]
    if let pulp::Arch::V4(v4) = arch {
        if N < 16 {
            return pulp::Arch::V3(*v4);
        }
    }
    arch
}

/// The surface points of a packet's hits on the set's quadrics and rects,
/// in arrays ([`AnalyticSet::surface_points`]): what
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
struct SurfaceKernel<'a, const N: usize> {
    prims: &'a [Primitive],
    rays: PacketRays<'a, N>,
    out: &'a mut SurfaceLanes<N>,
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
fn unit_scale<S: pulp::Simd>(simd: S, rcp: S::f64s) -> S::m64s {
    v!(
        simd,
        and_m64s,
        v!(simd, greater_than_f64s, rcp, simd.splat_f64s(0.0)),
        v!(simd, less_than_or_equal_f64s, rcp, simd.splat_f64s(f64::MAX))
    )
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
                        height: c.height,
                        flip: c.inward,
                    }),
                    Analytic::Cylinder(c) if prim > 0 => {
                        let cap = c.cap(prim);
                        Some(Quadric::Disk {
                            center: cap.center,
                            normal: cap.normal,
                            radius2: cap.radius * cap.radius,
                            inner2: cap.inner * cap.inner,
                            facing: c.normal(prim, cap.center),
                        })
                    }
                    Analytic::Disk(k) => Some(Quadric::Disk {
                        center: k.center,
                        normal: k.normal,
                        radius2: k.radius * k.radius,
                        inner2: k.inner * k.inner,
                        facing: k.normal,
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
        let fast = prims
            .iter()
            .map(|p| PrimF32 {
                geom: p.geom,
                prim: p.prim,
                // f32 values widened to f64: exact back in f32.
                bounds: (p.bounds.0.map(|x| x as f32), p.bounds.1.map(|x| x as f32)),
                quadric: p.quadric.as_ref().map(QuadricF32::of),
            })
            .collect();
        (!prims.is_empty()).then(|| AnalyticSet {
            prims,
            fast,
            arch: pulp::Arch::new(),
            #[cfg(test)]
            trust_kernel: false,
            #[cfg(test)]
            safety: ERROR_SAFETY,
        })
    }

    /// This set with its lane loops compiled for `arch` (a lower level
    /// than the CPU's: the tests compare every level).
    #[cfg(test)]
    fn with_arch(self, arch: pulp::Arch) -> Self {
        AnalyticSet { arch, ..self }
    }

    /// Is lane `k` of the kernel's answer `r` one to replay in scalar code?
    #[inline(always)]
    fn unsure<T: LaneValue, const N: usize>(&self, r: &Resolved<T, N>, k: usize) -> bool {
        #[cfg(test)]
        if self.trust_kernel {
            return false;
        }
        r.unsure_at(k)
    }

    /// Number of primitives.
    pub fn len(&self) -> usize {
        self.prims.len()
    }

    /// Is the set empty (never, for a set of [`try_new`](Self::try_new))?
    pub fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }

    /// The kernel's answer for the active lanes of `packet`, in `scratch`:
    /// how many lanes it covers, and whether it is the f32 kernel's
    /// (`out32`) or the f64 one's (`out64`).
    #[inline(always)]
    fn resolve<const N: usize, P: RayPacket<N>>(
        &self,
        packet: &P,
        occlusion: bool,
        scratch: &mut SetScratch<N>,
    ) -> (usize, bool) {
        let arch = if scratch.f32 {
            f32_level::<N>(self.arch)
        } else {
            self.arch
        };
        arch.dispatch(SetQuery {
            set: self,
            rays: packet.rays(),
            occlusion,
            scratch,
        })
    }

    /// Lane `k` of `packet` answered one primitive at a time as Embree's
    /// callbacks would (`boxes`: the primitives whose box it meets): each
    /// primitive's crossings with the lane as it stands then, sorted by t,
    /// to `each(packet, primitive, crossings)`, which may narrow it.
    #[inline(never)]
    fn replay<const N: usize, P: RayPacket<N>>(
        &self,
        packet: &mut P,
        k: usize,
        boxes: u32,
        mut each: impl FnMut(&mut P, &Primitive, &Candidates),
    ) {
        for (i, p) in self.prims.iter().enumerate() {
            if boxes & (1 << i) == 0 {
                continue;
            }
            let Some(r) = packet.lane(k) else { return };
            let mut c = Candidates::default();
            p.shape
                .intersect_in(p.prim, r.org, r.dir, r.tnear, r.tfar, &mut c);
            if !c.as_slice().is_empty() {
                c.sort();
                each(packet, p, &c);
            }
        }
    }

    /// Complete a nearest-hit query of `packet` that Embree answered against
    /// the meshes alone: a lane whose nearest crossing with a primitive of
    /// the set lies within `[tnear, tfar]` (tfar: the mesh hit, if any) gets
    /// that crossing as its hit.
    /// Whether any lane's hit is now on the set.
    pub fn intersect<const N: usize, P: RayPacket<N>>(
        &self,
        packet: &mut P,
        scratch: &mut SetScratch<N>,
    ) -> bool {
        let (m, f32) = self.resolve(packet, false, scratch);
        let (any, replayed) = if f32 {
            self.take_hits(packet, &scratch.out32, m)
        } else {
            self.take_hits(packet, &scratch.out64, m)
        };
        scratch.answered += m as u64;
        scratch.replayed += replayed;
        any
    }

    /// [`Self::intersect`] with the kernel's answer `r` for the first `m`
    /// lanes: whether any lane hit the set, and how many were replayed.
    #[inline(always)]
    fn take_hits<const N: usize, P: RayPacket<N>, T: LaneValue>(
        &self,
        packet: &mut P,
        r: &Resolved<T, N>,
        m: usize,
    ) -> (bool, u64) {
        let (mut any, mut replayed) = (false, 0);
        for k in 0..m {
            if self.unsure(r, k) {
                replayed += 1;
                self.replay(packet, k, r.boxes_at(k), |packet, p, c| {
                    let rays = packet.rays();
                    let (tnear, tfar) = (rays.tnear[k], rays.tfar[k]);
                    // Sorted: the first crossing within the interval is the nearest.
                    if let Some(c) = c.as_slice().iter().find(|c| c.t >= tnear && c.t <= tfar) {
                        packet.set_hit(k, &hit(p.geom, p.prim, c));
                        any = true;
                    }
                });
            } else if let Some((geom, prim, t, n)) = r.crossing(k) {
                packet.set_hit(k, &hit(geom, prim, &candidate(t, n)));
                any = true;
            }
        }
        (any, replayed)
    }

    /// Complete an occlusion query of `packet` that Embree answered against
    /// the meshes alone: a lane not yet occluded that crosses a primitive of
    /// the set within `[tnear, tfar]` becomes occluded.
    pub fn occlude<const N: usize, P: RayPacket<N>>(&self, packet: &mut P, scratch: &mut SetScratch<N>) {
        let (m, f32) = self.resolve(packet, true, scratch);
        let replayed = if f32 {
            self.take_occlusion(packet, &scratch.out32, m)
        } else {
            self.take_occlusion(packet, &scratch.out64, m)
        };
        scratch.answered += m as u64;
        scratch.replayed += replayed;
    }

    /// [`Self::occlude`] with the kernel's answer `r` for the first `m`
    /// lanes: how many were replayed.
    #[inline(always)]
    fn take_occlusion<const N: usize, P: RayPacket<N>, T: LaneValue>(
        &self,
        packet: &mut P,
        r: &Resolved<T, N>,
        m: usize,
    ) -> u64 {
        let mut replayed = 0;
        for k in 0..m {
            if r.occluded(k) {
                packet.set_occluded(k);
            } else if self.unsure(r, k) {
                replayed += 1;
                self.replay(packet, k, r.boxes_at(k), |packet, _, c| {
                    let rays = packet.rays();
                    let (tnear, tfar) = (rays.tnear[k], rays.tfar[k]);
                    if c.as_slice().iter().any(|c| c.t >= tnear && c.t <= tfar) {
                        // Later primitives skip the lane (`RayPacket::lane`).
                        packet.set_occluded(k);
                    }
                });
            }
        }
        replayed
    }
}

impl AnalyticSet {
    /// The surface points of the hits of `packet` (after a nearest-hit
    /// query) on the set's spheres, walls about the y axis and rects, into
    /// `out`, side by side: as `RenderScene::surface_point` makes them,
    /// bit for bit, but for the texture coordinates (`done` says which
    /// lanes; the others' hits are elsewhere, or on other primitives).
    pub fn surface_points<const N: usize, P: RayPacket<N>>(&self, packet: &P, out: &mut SurfaceLanes<N>) {
        self.arch.dispatch(SurfaceKernel {
            prims: &self.prims,
            rays: packet.rays(),
            out,
        })
    }
}

/// The hit of a primitive (ids) at the crossing `c`.
#[inline(always)]
fn hit(geom_id: u32, prim_id: u32, c: &Candidate) -> Hit {
    Hit {
        geom_id,
        prim_id,
        t: c.t,
        ng: c.ng.into(),
        u: c.u,
        v: c.v,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::embree::{Packet8, Ray, RayPacket};
    use crate::scene::{load_scene_str, BuildOptions, RenderScene, Shape, SurfacePoint};
    use glam::Vec3A as V3;

    use crate::vector_levels as levels;

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

    /// `SETS[0]` with every primitive in a vector form: its tilted capped
    /// cylinder upright.
    fn vector_forms() -> String {
        let tilted = "p1 = [0.5, 1.0, 0.4]";
        assert!(SETS[0].contains(tilted));
        SETS[0].replace(tilted, "p1 = [0.1, 1.0, 0.2]")
    }

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
            set.intersect(&mut a, &mut SetScratch::default());
            b.intersect(&with.embree, false);
            bad += (0..8).filter(|&i| bits(&a, i) != bits(&b, i)).count();
            for (i, r) in batch.iter().enumerate() {
                a.set_ray(i, r);
                b.set_ray(i, r);
            }
            a.occlude_meshes(&with.embree, false);
            set.occlude(&mut a, &mut SetScratch::default());
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

    /// Rays whose interval starts or ends exactly at the f32 distance of a
    /// crossing (Embree's hit in the whole scene): where the rounding of a
    /// root to f32 decides whether it is kept, the kernel is unsure and the
    /// lane is answered in scalar code, as Embree answers it at every
    /// level. Trusting the kernel's answer for those lanes instead is
    /// caught.
    #[test]
    fn lanes_at_a_crossing_are_replayed() {
        let with = scene(SETS[0], true);
        let without = scene(SETS[0], false);
        let mut rays = packets(5, 2000);
        for batch in rays.iter_mut() {
            let mut p = Packet8::new();
            for (i, r) in batch.iter().enumerate() {
                p.set_ray(i, r);
            }
            p.intersect(&without.embree, false);
            for (i, r) in batch.iter_mut().enumerate() {
                if let Some(h) = p.hit(i) {
                    if i % 2 == 0 {
                        r.tfar = h.t;
                    } else {
                        r.tnear = h.t;
                    }
                }
            }
        }
        let set = with.analytic_set.clone().expect("a set of few shapes");
        for arch in levels() {
            let set = set.clone().with_arch(arch);
            assert_eq!(disagreements(&set, &with, &rays), 0, "{arch:?}");
        }
        let trusting = AnalyticSet {
            trust_kernel: true,
            ..set
        };
        let bad = disagreements(&trusting, &with, &rays);
        assert!(
            bad > 500,
            "trusting the kernel at the interval's ends: {bad} disagreements"
        );
    }

    /// What [`f32_against_embree`] found.
    #[derive(Debug, Default)]
    struct F32Check {
        /// Lanes (nearest-hit and occlusion queries) answered otherwise
        /// than by Embree: another primitive, a hit for a miss, or the
        /// other occlusion.
        wrong: usize,
        /// The largest |t − Embree's t| / max(1, |t|) of the same hits.
        t_err: f64,
        /// The largest distance of a hit point `o + t·d` (f64) from its
        /// f64 shape: the f32 queries' and Embree's.
        point_err: (f64, f64),
        /// The nearest-hit lanes that hit a primitive of the set.
        hits: usize,
        /// The share of the lanes (both queries) answered again in f64.
        replayed: f64,
    }

    /// Distance of `p` from the surface of quadric `q`.
    fn surface_distance(q: &Quadric, p: DVec3) -> f64 {
        match *q {
            Quadric::Sphere { center, radius } => ((p - center).length() - radius).abs(),
            Quadric::WallY { base, radius, .. } => {
                let v = p - base;
                (DVec3::new(v.x, 0.0, v.z).length() - radius).abs()
            }
            Quadric::Rect { corner, normal, .. } => (p - corner).dot(normal).abs(),
            Quadric::Disk { center, normal, .. } => (p - center).dot(normal).abs(),
        }
    }

    /// `rays` in packets of `N`, nearest hits and occlusion: the set's f32
    /// queries (`SetScratch::f32`, or with `trust` every lane taken from the
    /// kernel) against Embree's callbacks in the whole scene.
    fn f32_against_embree<const N: usize, P: RayPacket<N>>(
        set: &AnalyticSet,
        with: &RenderScene,
        rays: &[Ray],
        new: impl Fn() -> P,
    ) -> F32Check {
        let mut c = F32Check::default();
        let scratch = &mut SetScratch::<N>::f32();
        for batch in rays.chunks(N) {
            let (mut a, mut b) = (new(), new());
            for (i, r) in batch.iter().enumerate() {
                a.set_ray(i, r);
                b.set_ray(i, r);
            }
            a.intersect_meshes(&with.embree, false);
            set.intersect(&mut a, scratch);
            b.intersect(&with.embree, false);
            for (i, r) in batch.iter().enumerate() {
                let (ha, hb) = (a.hit(i), b.hit(i));
                let (Some(ha), Some(hb)) = (ha, hb) else {
                    c.wrong += usize::from(ha.is_some() != hb.is_some());
                    continue;
                };
                if (ha.geom_id, ha.prim_id) != (hb.geom_id, hb.prim_id) {
                    c.wrong += 1;
                    continue;
                }
                let (ta, tb) = (ha.t as f64, hb.t as f64);
                c.t_err = c.t_err.max((ta - tb).abs() / tb.abs().max(1.0));
                let prim = set
                    .prims
                    .iter()
                    .find(|p| p.geom == ha.geom_id && p.prim == ha.prim_id);
                if let Some(q) = prim.and_then(|p| p.quadric) {
                    c.hits += 1;
                    let at = |t: f64| r.org.as_dvec3() + r.dir.as_dvec3() * t;
                    c.point_err.0 = c.point_err.0.max(surface_distance(&q, at(ta)));
                    c.point_err.1 = c.point_err.1.max(surface_distance(&q, at(tb)));
                }
            }
            for (i, r) in batch.iter().enumerate() {
                a.set_ray(i, r);
                b.set_ray(i, r);
            }
            a.occlude_meshes(&with.embree, false);
            set.occlude(&mut a, scratch);
            b.occlude(&with.embree, false);
            c.wrong += (0..batch.len())
                .filter(|&i| a.occluded(i) != b.occluded(i))
                .count();
        }
        c.replayed = scratch.replayed as f64 / scratch.answered.max(1) as f64;
        c
    }

    /// Rays for the f32 queries: the random ones of [`packets`] and rays
    /// spawned off the surfaces those hit (offset as the integrator offsets
    /// them, to either side, in random directions); and apart, rays whose
    /// interval starts or ends exactly at a crossing.
    fn f32_rays(without: &RenderScene) -> (Vec<Ray>, Vec<Ray>) {
        let random: Vec<Ray> = packets(11, 1500).into_iter().flatten().collect();
        let mut rng = crate::sampling::Rng::new(12);
        let (mut spawned, mut at_ends) = (Vec::new(), Vec::new());
        for batch in random.chunks(8) {
            let mut p = Packet8::new();
            for (i, r) in batch.iter().enumerate() {
                p.set_ray(i, r);
            }
            p.intersect(&without.embree, false);
            for (i, r) in batch.iter().enumerate() {
                let Some(h) = p.hit(i) else { continue };
                let point = r.org + r.dir * h.t;
                let n = h.ng.normalize();
                for _ in 0..2 {
                    let side = if rng.uniform() < 0.5 { n } else { -n };
                    let mut d = V3::new(rng.uniform(), rng.uniform(), rng.uniform()) * 2.0 - V3::ONE;
                    if d.dot(side) < 0.0 {
                        d -= 2.0 * d.dot(side) * side;
                    }
                    let mut s = Ray::new(crate::ray::offset_origin(point, side), d);
                    if rng.uniform() < 0.3 {
                        s.tfar = 4.0 * rng.uniform();
                    }
                    spawned.push(s);
                }
                let mut e = *r;
                if i % 2 == 0 {
                    e.tfar = h.t;
                } else {
                    e.tnear = h.t;
                }
                at_ends.push(e);
            }
        }
        assert!(spawned.len() > 10_000 && at_ends.len() > 5_000);
        ([random, spawned].concat(), at_ends)
    }

    /// The f32 queries answer as Embree's callbacks on every lane, at every
    /// vector level and in packets of 8 and 16: the same primitive hit (or
    /// none) and the same occlusion, on random rays, rays grazing the
    /// shapes, rays spawned off the surfaces and rays whose interval ends at
    /// a crossing (where the kernel is unsure and the lane is answered in
    /// f64). Their hit points lie within 10⁻⁵ of the f64 shapes (Embree's
    /// within the f32 rounding of t), and t within a relative 10⁻³ of
    /// Embree's (larger only at grazing incidence, where a tiny move of the
    /// point is a long one along the ray; the other root of the same
    /// primitive is much farther). Trusting the kernel on the lanes it is
    /// unsure of is caught on the same rays. Away from the intervals' ends,
    /// with every primitive in a vector form, fewer than 0.2 % of the lanes
    /// are replayed in f64, where bounds a hundred times looser replay more.
    #[test]
    fn f32_queries_agree_with_embree() {
        let with = scene(SETS[0], true);
        let without = scene(SETS[0], false);
        let set = with.analytic_set.clone().expect("a set of few shapes");
        let (free, at_ends) = f32_rays(&without);
        let rays = [free.as_slice(), at_ends.as_slice()].concat();
        for arch in levels() {
            let set = set.clone().with_arch(arch);
            for (width, c) in [
                (8, f32_against_embree::<8, _>(&set, &with, &rays, Packet8::new)),
                (
                    16,
                    f32_against_embree::<16, _>(&set, &with, &rays, crate::embree::Packet16::new),
                ),
            ] {
                eprintln!("{arch:?}, packets of {width}: {c:?}");
                assert!(c.hits > 20_000, "{arch:?} {width}: {} hits", c.hits);
                assert_eq!(c.wrong, 0, "{arch:?} {width}: {c:?}");
                assert!(c.t_err <= 1e-3, "{arch:?} {width}: {c:?}");
                assert!(c.point_err.0 <= 1e-5, "{arch:?} {width}: {c:?}");
            }
        }
        let trusting = AnalyticSet {
            trust_kernel: true,
            ..set.clone()
        };
        let c = f32_against_embree::<16, _>(&trusting, &with, &rays, crate::embree::Packet16::new);
        eprintln!("trusting every lane: {c:?}");
        assert!(c.wrong > 500, "trusting the f32 kernel went unnoticed: {c:?}");
        // Away from the intervals' ends, on primitives that all have a
        // vector form (no tilted wall, whose lanes are always replayed), the
        // kernel is sure of nearly every lane (renders replay a few in a
        // million); bounds a hundred times looser, still right, replay many.
        let with = scene(&vector_forms(), true);
        let set = with.analytic_set.clone().expect("a set of few shapes");
        let (free, _) = f32_rays(&scene(&vector_forms(), false));
        let free_share = |set: &AnalyticSet| {
            let c = f32_against_embree::<16, _>(set, &with, &free, crate::embree::Packet16::new);
            assert_eq!(c.wrong, 0);
            c.replayed
        };
        let (tight, loose) = (
            free_share(&set),
            free_share(&AnalyticSet {
                safety: 100.0 * ERROR_SAFETY,
                ..set.clone()
            }),
        );
        eprintln!("replayed lanes: {tight:.2e}, with bounds 100x looser {loose:.2e}");
        assert!(tight < 2e-3, "replayed {tight}");
        assert!(loose >= 2e-3, "looser bounds replayed only {loose}");
    }

    /// The surface points of a packet's hits on the set's spheres, walls
    /// about y and rects are `RenderScene::surface_point`'s bit for bit (point,
    /// normals, texture coordinates) at every vector level; hits on other
    /// primitives are left to it. Taking the hit point unprojected instead is
    /// caught by the same comparison.
    #[test]
    fn surface_points_are_the_scenes() {
        let with = scene(SETS[0], true);
        let set = with.analytic_set.clone().expect("a set of few shapes");
        let rays = packets(9, 3000);
        let bits = |sp: &SurfacePoint| {
            (
                sp.p.to_array().map(f32::to_bits),
                sp.ng.to_array().map(f32::to_bits),
                sp.ns.to_array().map(f32::to_bits),
                sp.uv.map(f32::to_bits),
            )
        };
        for arch in levels() {
            let set = set.clone().with_arch(arch);
            let (mut solved, mut bad, mut unprojected) = (0, 0, 0);
            for batch in &rays {
                let mut p = Packet8::new();
                for (i, r) in batch.iter().enumerate() {
                    p.set_ray(i, r);
                }
                p.intersect_meshes(&with.embree, false);
                set.intersect(&mut p, &mut SetScratch::default());
                let mut s = SurfaceLanes::<8>::default();
                set.surface_points(&p, &mut s);
                for (i, r) in batch.iter().enumerate() {
                    let Some(h) = p.hit(i) else {
                        assert_eq!(s.done[i], 0.0, "{arch:?}: a lane without a hit");
                        continue;
                    };
                    let quadric = set
                        .prims
                        .iter()
                        .any(|q| q.geom == h.geom_id && q.prim == h.prim_id && q.quadric.is_some());
                    assert_eq!(s.done[i] != 0.0, quadric, "{arch:?}: lane {i}, hit {h:?}");
                    if !quadric {
                        continue;
                    }
                    solved += 1;
                    let pd = DVec3::new(s.pd[0][i], s.pd[1][i], s.pd[2][i]);
                    let point = V3::new(s.p[0][i], s.p[1][i], s.p[2][i]);
                    let ng = V3::new(s.ng[0][i], s.ng[1][i], s.ng[2][i]);
                    let got = with
                        .analytic_surface_point(&h, pd, point, ng)
                        .expect("an analytic hit");
                    let want = with.surface_point(r, &h);
                    bad += (bits(&got) != bits(&want)) as usize;
                    // The wrong variant: the hit point as found, not projected.
                    let raw = (r.org + r.dir * h.t).as_dvec3();
                    let wrong = with.analytic_surface_point(&h, raw, raw.as_vec3a(), ng).unwrap();
                    unprojected += (bits(&wrong) != bits(&want)) as usize;
                }
            }
            assert!(solved > 5000, "{arch:?}: {solved} lanes solved");
            assert_eq!(bad, 0, "{arch:?}: {bad} of {solved} differ");
            assert!(
                unprojected > solved / 10,
                "{arch:?}: unprojected points: {unprojected} of {solved} differ"
            );
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
