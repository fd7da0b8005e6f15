//! One primitive of the set and the quadric the kernels intersect it as,
//! in f64 and as f32 pairs.
use super::super::Analytic;
use glam::DVec3;

/// A quadric whose roots [`SetKernel`](super::kernel_f64::SetKernel) finds for many lanes at once (or a
/// parallelogram or disk: its one root, the plane's crossing, where it lies
/// inside).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(in crate::scene) enum Quadric {
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

/// An f64 value as two f32s, `hi + lo` (see [`split`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Split {
    pub hi: f32,
    pub lo: f32,
}

/// A [`Quadric`] as the f32 kernel reads it (`kernel_f32`): positions as f32
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
    pub(super) fn of(q: &Quadric) -> QuadricF32 {
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
pub(in crate::scene) struct Primitive {
    pub(in crate::scene) geom: u32,
    pub(in crate::scene) prim: u32,
    pub(in crate::scene) shape: Analytic,
    /// Embree's padded box, as (low, high) corners.
    pub(in crate::scene) bounds: ([f64; 3], [f64; 3]),
    pub(in crate::scene) quadric: Option<Quadric>,
    /// The rank of the masked solid it bounds ([`AnalyticSet::hide_ranks`]):
    /// a lane whose ray mask leaves out ranks below P0 > `rank` does not see
    /// it. +∞ for a primitive every lane sees.
    ///
    /// [`AnalyticSet::hide_ranks`]: super::AnalyticSet::hide_ranks
    pub(in crate::scene) rank: f32,
}

/// `x` as an f32 pair: `hi + lo` is `x` to about 2⁻⁴⁸ of it.
pub(super) fn split(x: f64) -> Split {
    let hi = x as f32;
    Split {
        hi,
        lo: (x - hi as f64) as f32,
    }
}
