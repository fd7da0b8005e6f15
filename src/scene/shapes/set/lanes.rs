//! What the kernels read and write per lane: the packet's rays in f64,
//! and each lane's decision ([`Resolved`]).
use crate::embree::PacketRays;
use glam::DVec3;

/// The active lanes' rays in f64 (what `Segment::new` makes of each), the
/// reciprocals of their directions, their intervals (exact, and widened by
/// far more than f32 rounding for the box test) and what the touch test
/// reads of each ray; lanes past the active ones have a zero direction and
/// an empty interval.
pub(super) struct LaneArrays<const N: usize> {
    pub(super) o: [[f64; N]; 3],
    pub(super) d: [[f64; N]; 3],
    pub(super) inv_d: [[f64; N]; 3],
    pub(super) t_lo: [f64; N],
    pub(super) t_hi: [f64; N],
    /// The interval as the packet holds it (f32 values).
    pub(super) tn: [f64; N],
    pub(super) tf: [f64; N],
    /// [`lowest_ranks_seen`].
    pub(super) p0: [f64; N],
}

/// Per lane, the lowest rank of a masked solid its ray mask lets it see:
/// 0 for the full mask, P0 for `dielectric::trace`'s `ray_mask` (bit 31
/// and every bit from P0 up), 32 when it sees none.
#[inline(always)]
pub(super) fn lowest_ranks_seen<const N: usize>(rays: &PacketRays<'_, N>) -> [f32; N] {
    rays.mask.map(|m| (m & !(1 << 31)).trailing_zeros() as f32)
}

impl<const N: usize> LaneArrays<N> {
    pub(super) const EMPTY: LaneArrays<N> = LaneArrays {
        o: [[0.0; N]; 3],
        d: [[0.0; N]; 3],
        inv_d: [[0.0; N]; 3],
        t_lo: [0.0; N],
        t_hi: [0.0; N],
        tn: [0.0; N],
        tf: [0.0; N],
        p0: [0.0; N],
    };

    /// The lanes of `rays` up to the last active one (how many: the
    /// value), made in place: in the caller's [`SetScratch`], so that
    /// neither a zeroed struct per query nor a returned copy is made (both
    /// showed in the profile). Every lane is converted, active or not, so
    /// that the loops vectorise; an inactive lane gets an empty interval
    /// (and is skipped by the callers whatever its roots).
    #[inline(always)]
    pub(super) fn fill(&mut self, rays: &PacketRays<'_, N>) -> usize {
        let l = self;
        l.p0 = lowest_ranks_seen(rays).map(f64::from);
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

/// What a kernel decides for each lane of a packet, in its own precision
/// `T` (f64: [`SetKernel`](super::kernel_f64::SetKernel), as the scalar code would; f32: `kernel_f32`): its
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
    pub(super) fn unsure_at(&self, k: usize) -> bool {
        self.unsure[k].into() != 0.0
    }

    /// The primitives whose boxes lane `k` meets, bit `i` for the `i`th.
    #[inline(always)]
    pub(super) fn boxes_at(&self, k: usize) -> u32 {
        self.boxes[k].into() as u32
    }

    /// Lane `k`'s nearest crossing: geometry and primitive ids, t, normal.
    #[inline(always)]
    pub(super) fn crossing(&self, k: usize) -> Option<(u32, u32, f64, DVec3)> {
        let geom1: f64 = self.geom1[k].into();
        (geom1 > 0.0).then(|| {
            let n = DVec3::new(self.n[0][k].into(), self.n[1][k].into(), self.n[2][k].into());
            (geom1 as u32 - 1, self.prim[k].into() as u32, self.t[k].into(), n)
        })
    }

    /// Is lane `k` occluded for sure (an occlusion query's answer)?
    #[inline(always)]
    pub(super) fn occluded(&self, k: usize) -> bool {
        self.geom1[k].into() > 0.0
    }
}
