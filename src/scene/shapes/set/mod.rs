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
//! `kernel_f32` answers instead, twice as many lanes per instruction: the same
//! primitive and crossing on every lane, t within the f32 arithmetic's
//! error bounds, the lanes it cannot be sure of answered as above.
//!
//! Here: the set, a thread's scratch and the queries. The rooms: `primitive`
//! (a primitive and its quadric), `lanes` (the rays and decisions per lane),
//! `arith` and `predicates` (the lane arithmetic, the keep and touch tests),
//! `kernel_f64`, `kernel_f32` and `surface` (the three kernels).
//!
//! [`SceneBuilder::with_meshes_only`]: crate::embree::SceneBuilder::with_meshes_only
mod arith;
mod kernel_f32;
mod kernel_f64;
mod lanes;
mod predicates;
mod primitive;
mod surface;

pub use surface::SurfaceLanes;

use super::segment::candidate;
use super::Analytic;
use crate::embree::{Candidate, Candidates, PacketRays, RayPacket, UserShape};
use crate::ray::Hit;
use glam::DVec3;
pub(in crate::scene) use kernel_f32::ERROR_SAFETY;
use kernel_f32::{PrimF32, SetKernelF32};
use kernel_f64::SetKernel;
use lanes::{LaneArrays, LaneValue, Resolved};
pub(in crate::scene) use primitive::Quadric;
use primitive::{Primitive, QuadricF32};
use surface::SurfaceKernel;

/// The most primitives a scene may have for its analytic shapes to be
/// tested here (every lane meets every primitive: no hierarchy).
pub const MAX_SET_PRIMITIVES: usize = 8;

/// The analytic primitives of a scene (at most [`MAX_SET_PRIMITIVES`]).
#[derive(Debug, Clone)]
pub struct AnalyticSet {
    pub(in crate::scene) prims: Vec<Primitive>,
    /// The same primitives for the f32 kernel.
    pub(in crate::scene) fast: Vec<PrimF32>,
    /// The vector instructions the lane loops are compiled for.
    pub(in crate::scene) arch: pulp::Arch,
    /// Take the kernel's answer for unsure lanes too (a known-wrong
    /// variant for the tests).
    #[cfg(test)]
    pub(in crate::scene) trust_kernel: bool,
    /// The f32 kernel's safety factor (tests widen it).
    #[cfg(test)]
    pub(in crate::scene) safety: f32,
}

/// A thread's working storage for [`AnalyticSet::intersect`] and
/// [`AnalyticSet::occlude`] on packets of `N` lanes: make one and pass it
/// to every query. The default's queries answer exactly as Embree's
/// callbacks; [`SetScratch::f32`]'s in f32 lanes (`kernel_f32`).
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
    /// grazing incidence (see `kernel_f32`).
    pub fn f32() -> Self {
        SetScratch {
            f32: true,
            ..SetScratch::default()
        }
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
                    rank: f32::INFINITY,
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
                rank: p.rank,
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

    /// Give the primitives of each geometry `geom` in `masked` (geometry
    /// id, rank) the geometry's Embree mask as Embree reads it: a ray whose
    /// mask leaves out the ranks below its P0 (`dielectric::trace`'s
    /// `ray_mask`: bit 31 and every bit from P0 up) does not see a solid
    /// ranked below P0, in the set's answers as in Embree's.
    pub fn hide_ranks(&mut self, masked: &[(u32, u32)]) {
        for (p, f) in self.prims.iter_mut().zip(&mut self.fast) {
            if let Some(&(_, rank)) = masked.iter().find(|(g, _)| *g == p.geom) {
                p.rank = rank as f32;
                f.rank = rank as f32;
            }
        }
    }

    /// This set with its lane loops compiled for `arch` (a lower level
    /// than the CPU's: the tests compare every level).
    #[cfg(test)]
    pub(in crate::scene) fn with_arch(self, arch: pulp::Arch) -> Self {
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
