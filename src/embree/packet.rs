//! Packets of rays for Embree's packet queries (`rtcIntersect8/16`,
//! `rtcOccluded8/16`): the path tracer's lanes, the warp renderer's primary
//! rays, and the ceiling's packet replay.
use super::{init_context, Hit, LaneRay, Scene, INVALID_ID};
use embree_sys as sys;
use glam::Vec3A as V3;

/// A packet of rays for Embree's packet queries (`rtcIntersect8/16`,
/// `rtcOccluded8/16`): `N` lanes, structure of arrays as Embree wants them.
/// [`Packet8`] and [`Packet16`] are the two widths.
pub trait RayPacket<const N: usize>: Default {
    /// Deactivate every lane.
    fn clear(&mut self);
    /// Set lane `i` (< N) to `ray` (tnear and tfar kept); an invalid ray
    /// ([`Ray::is_valid`](crate::ray::Ray::is_valid)) leaves the lane inactive.
    fn set_ray(&mut self, i: usize, ray: &crate::ray::Ray);
    /// Lanes `0..n` (`n` ≤ N) to the rays from `org` along `dir` over
    /// `[0, ∞)`, the others inactive (their entries copied all the same:
    /// whole arrays copy without a call); a ray with a non-finite component
    /// leaves its lane inactive.
    fn set_unbounded_rays(&mut self, org: [&[f32; N]; 3], dir: [&[f32; N]; 3], n: usize);
    /// Lane `i`'s ray mask (every lane's is `u32::MAX` until set: set it
    /// back after a query that needed another).
    fn set_mask(&mut self, i: usize, mask: u32);
    /// Lane `i`'s hit after [`intersect`](Self::intersect).
    fn hit(&self, i: usize) -> Option<Hit>;
    /// Was lane `i` occluded by the last [`occlude`](Self::occlude)?
    fn occluded(&self, i: usize) -> bool;
    /// Nearest hits of the active lanes (`coherent`: rays of nearly one origin
    /// and direction, e.g. a pixel's camera rays).
    fn intersect(&mut self, scene: &Scene, coherent: bool);
    /// Occlusion of the active lanes.
    fn occlude(&mut self, scene: &Scene, coherent: bool);
    /// [`intersect`](Self::intersect) against the scene's meshes alone
    /// ([`Scene::has_meshes_only`]; the whole scene when it has no such twin;
    /// no query at all, every lane missing, when the twin is empty).
    fn intersect_meshes(&mut self, scene: &Scene, coherent: bool);
    /// [`occlude`](Self::occlude) against the scene's meshes alone (as
    /// [`intersect_meshes`](Self::intersect_meshes)).
    fn occlude_meshes(&mut self, scene: &Scene, coherent: bool);
    /// Lane `i`'s ray as a query stands: `None` when the lane is inactive or
    /// (after [`occlude`](Self::occlude)) already occluded; its `tfar` is
    /// the nearest hit's t after [`intersect`](Self::intersect).
    fn lane(&self, i: usize) -> Option<LaneRay>;
    /// Make `hit` lane `i`'s hit (its t becomes the lane's tfar).
    fn set_hit(&mut self, i: usize, hit: &Hit);
    /// Mark lane `i` occluded.
    fn set_occluded(&mut self, i: usize);
    /// Every lane's ray as the packet holds them, arrays by component (for
    /// loops over lanes that the compiler vectorises).
    fn rays(&self) -> PacketRays<'_, N>;
}

/// The rays of a packet's `N` lanes as arrays ([`RayPacket::rays`]). Lane
/// `i` is active when `valid[i] != 0` and `tfar[i]` is not −∞ (the mark of
/// an occluded lane), as [`RayPacket::lane`] says; the arrays of the other
/// lanes hold whatever they last held.
pub struct PacketRays<'a, const N: usize> {
    /// Origins: x, y, z.
    pub org: [&'a [f32; N]; 3],
    /// Directions: x, y, z.
    pub dir: [&'a [f32; N]; 3],
    /// Starts of the intervals.
    pub tnear: &'a [f32; N],
    /// Ends of the intervals (a hit's t after a nearest-hit query).
    pub tfar: &'a [f32; N],
    /// The lanes' ray masks ([`RayPacket::set_mask`]).
    pub mask: &'a [u32; N],
    /// Embree's lane mask: −1 active, 0 not.
    pub valid: &'a [i32; N],
    /// The hits' geometry ids after a nearest-hit query (`INVALID_ID`:
    /// none).
    pub geom_id: &'a [u32; N],
    /// The hits' primitive ids.
    pub prim_id: &'a [u32; N],
}

impl<const N: usize> PacketRays<'_, N> {
    /// Is lane `i` active ([`RayPacket::lane`] is `Some`)?
    #[inline(always)]
    pub fn active(&self, i: usize) -> bool {
        self.valid[i] != 0 && self.tfar[i] != f32::NEG_INFINITY
    }
}

macro_rules! ray_packet {
    ($name:ident, $n:literal, $rayhit:ident, $intersect:ident, $occluded:ident, $doc:literal) => {
        #[doc = $doc]
        pub struct $name {
            rh: sys::$rayhit,
            valid: [i32; $n],
        }

        impl Default for $name {
            fn default() -> Self {
                $name::new()
            }
        }

        impl $name {
            /// All lanes inactive.
            pub fn new() -> $name {
                // Fields no query writes (mask, time, flags; the instance id,
                // which Embree sets to the context's: none here) are set
                // once, here, not per ray.
                let mut rh = sys::$rayhit::default();
                rh.ray.mask = [u32::MAX; $n];
                rh.hit.instID[0] = [INVALID_ID; $n];
                $name { rh, valid: [0; $n] }
            }

            /// Deactivate every lane and clear the hits.
            pub fn clear(&mut self) {
                self.valid = [0; $n];
            }

            /// Set lane `i` to a ray from `org` along `dir` over `[0, tfar]`;
            /// an invalid ray (non-finite, tfar < 0) leaves the lane inactive.
            #[inline]
            pub fn set(&mut self, i: usize, org: V3, dir: V3, tfar: f32) {
                self.write(i, org, dir, 0.0, tfar);
                let ok = org.is_finite() && dir.is_finite() && !tfar.is_nan() && tfar >= 0.0;
                self.valid[i] = if ok { -1 } else { 0 };
            }

            /// Lane `i`'s ray and an empty hit, its validity left to the caller.
            #[inline(always)]
            fn write(&mut self, i: usize, org: V3, dir: V3, tnear: f32, tfar: f32) {
                let r = &mut self.rh.ray;
                r.org_x[i] = org.x;
                r.org_y[i] = org.y;
                r.org_z[i] = org.z;
                r.dir_x[i] = dir.x;
                r.dir_y[i] = dir.y;
                r.dir_z[i] = dir.z;
                r.tnear[i] = tnear;
                r.tfar[i] = tfar;
                self.rh.hit.geomID[i] = INVALID_ID;
                self.rh.hit.primID[i] = INVALID_ID;
            }

            /// Lane `i`'s hit after a query (its `tfar` becomes the hit distance).
            #[inline]
            pub fn hit(&self, i: usize) -> Option<Hit> {
                let h = &self.rh.hit;
                (self.valid[i] != 0 && h.geomID[i] != INVALID_ID).then(|| Hit {
                    geom_id: h.geomID[i],
                    prim_id: h.primID[i],
                    t: self.rh.ray.tfar[i],
                    ng: V3::new(h.Ng_x[i], h.Ng_y[i], h.Ng_z[i]),
                    u: h.u[i],
                    v: h.v[i],
                })
            }

            /// Is any lane of the packet valid?
            pub fn any_active(&self) -> bool {
                self.valid.iter().any(|&v| v != 0)
            }

            /// Query `scene` (a committed one) with the active lanes.
            pub(super) fn query(&mut self, scene: sys::RTCScene, coherent: bool, occlusion: bool) {
                if !self.any_active() {
                    return;
                }
                let mut ctx = init_context(None);
                if coherent {
                    ctx.flags = sys::RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
                }
                // SAFETY: a committed scene; `valid` has N entries; `rh` is an
                // aligned (by its bindgen type) RTCRayHitN whose active lanes
                // hold valid rays (checked in `set`/`set_ray`); its `ray` part
                // is the RTCRayN an occlusion query takes.
                unsafe {
                    if occlusion {
                        sys::$occluded(self.valid.as_ptr(), scene, &mut ctx, &mut self.rh.ray);
                    } else {
                        sys::$intersect(self.valid.as_ptr(), scene, &mut ctx, &mut self.rh);
                    }
                }
            }
        }

        impl RayPacket<$n> for $name {
            fn clear(&mut self) {
                $name::clear(self)
            }
            #[inline]
            fn set_ray(&mut self, i: usize, ray: &crate::ray::Ray) {
                self.write(i, ray.org, ray.dir, ray.tnear, ray.tfar);
                // `is_valid` covers `set`'s test too (0 <= tnear <= tfar).
                self.valid[i] = if ray.is_valid() { -1 } else { 0 };
            }
            #[inline]
            fn set_unbounded_rays(&mut self, org: [&[f32; $n]; 3], dir: [&[f32; $n]; 3], n: usize) {
                assert!(n <= $n);
                let r = &mut self.rh.ray;
                r.org_x = *org[0];
                r.org_y = *org[1];
                r.org_z = *org[2];
                r.dir_x = *dir[0];
                r.dir_y = *dir[1];
                r.dir_z = *dir[2];
                r.tnear = [0.0; $n];
                r.tfar = [f32::INFINITY; $n];
                self.rh.hit.geomID = [INVALID_ID; $n];
                self.rh.hit.primID = [INVALID_ID; $n];
                // One pass over the lanes for `Ray::is_valid` (tnear and
                // tfar are valid by construction).
                for i in 0..$n {
                    let finite = i < n
                        && r.org_x[i].is_finite()
                        && r.org_y[i].is_finite()
                        && r.org_z[i].is_finite()
                        && r.dir_x[i].is_finite()
                        && r.dir_y[i].is_finite()
                        && r.dir_z[i].is_finite();
                    self.valid[i] = if finite { -1 } else { 0 };
                }
            }
            #[inline]
            fn set_mask(&mut self, i: usize, mask: u32) {
                self.rh.ray.mask[i] = mask;
            }
            #[inline]
            fn hit(&self, i: usize) -> Option<Hit> {
                $name::hit(self, i)
            }
            #[inline]
            fn occluded(&self, i: usize) -> bool {
                self.valid[i] != 0 && self.rh.ray.tfar[i] == f32::NEG_INFINITY
            }
            fn intersect(&mut self, scene: &Scene, coherent: bool) {
                self.query(scene.raw, coherent, false);
            }
            fn occlude(&mut self, scene: &Scene, coherent: bool) {
                self.query(scene.raw, coherent, true);
            }
            fn intersect_meshes(&mut self, scene: &Scene, coherent: bool) {
                if let Some(s) = scene.meshes_or_all() {
                    self.query(s, coherent, false);
                }
            }
            fn occlude_meshes(&mut self, scene: &Scene, coherent: bool) {
                if let Some(s) = scene.meshes_or_all() {
                    self.query(s, coherent, true);
                }
            }
            #[inline]
            fn lane(&self, i: usize) -> Option<LaneRay> {
                let r = &self.rh.ray;
                (self.valid[i] != 0 && r.tfar[i] != f32::NEG_INFINITY).then(|| LaneRay {
                    org: V3::new(r.org_x[i], r.org_y[i], r.org_z[i]),
                    dir: V3::new(r.dir_x[i], r.dir_y[i], r.dir_z[i]),
                    tnear: r.tnear[i],
                    tfar: r.tfar[i],
                })
            }
            #[inline]
            fn set_hit(&mut self, i: usize, hit: &Hit) {
                let h = &mut self.rh.hit;
                self.rh.ray.tfar[i] = hit.t;
                h.Ng_x[i] = hit.ng.x;
                h.Ng_y[i] = hit.ng.y;
                h.Ng_z[i] = hit.ng.z;
                h.u[i] = hit.u;
                h.v[i] = hit.v;
                h.primID[i] = hit.prim_id;
                h.geomID[i] = hit.geom_id;
            }
            #[inline]
            fn set_occluded(&mut self, i: usize) {
                self.rh.ray.tfar[i] = f32::NEG_INFINITY;
            }
            #[inline(always)]
            fn rays(&self) -> PacketRays<'_, $n> {
                let r = &self.rh.ray;
                PacketRays {
                    org: [&r.org_x, &r.org_y, &r.org_z],
                    dir: [&r.dir_x, &r.dir_y, &r.dir_z],
                    tnear: &r.tnear,
                    tfar: &r.tfar,
                    mask: &r.mask,
                    valid: &self.valid,
                    geom_id: &self.rh.hit.geomID,
                    prim_id: &self.rh.hit.primID,
                }
            }
        }
    };
}

ray_packet!(
    Packet8,
    8,
    RTCRayHit8,
    rtcIntersect8,
    rtcOccluded8,
    "Eight rays for `rtcIntersect8` / `rtcOccluded8` (32-byte aligned by the bindgen type)."
);
ray_packet!(
    Packet16,
    16,
    RTCRayHit16,
    rtcIntersect16,
    rtcOccluded16,
    "Sixteen rays for `rtcIntersect16` / `rtcOccluded16` (64-byte aligned by the bindgen type)."
);

impl Scene {
    /// Trace a packet of up to eight rays (coherent primary rays).
    pub fn intersect8(&self, p: &mut Packet8) {
        p.query(self.raw, true, false);
    }

    /// Trace a packet of up to sixteen rays (coherent primary rays).
    pub fn intersect16(&self, p: &mut Packet16) {
        p.query(self.raw, true, false);
    }
}

#[cfg(test)]
mod tests {
    use super::super::scene::tests::Plane;
    use super::super::{BuildQuality, Device, Ray, SceneBuilder, SceneFlags};
    use super::*;
    use glam::Vec3A as V3;

    /// A meshes-only twin without meshes is never queried (a packet's
    /// lanes all miss without entering Embree); one with meshes is, and
    /// without a twin the whole scene is.
    #[test]
    fn an_empty_meshes_only_twin_is_not_queried() {
        let d = Device::new("").unwrap();
        let quad = [
            [-1.0, -1.0, 1.0],
            [1.0, -1.0, 1.0],
            [1.0, 1.0, 1.0],
            [-1.0, 1.0, 1.0],
        ];
        let ray = Ray::new(V3::new(0.1, 0.2, 0.0), V3::Z);
        for (twin, mesh) in [(true, false), (true, true), (false, false)] {
            let mut b = SceneBuilder::new(&d, SceneFlags::default(), BuildQuality::Medium).unwrap();
            if twin {
                b = b.with_meshes_only().unwrap();
            }
            b.add_user(Box::new(Plane(2.0))).unwrap();
            if mesh {
                b.add_triangles(&quad, &[[0, 1, 2], [0, 2, 3]]).unwrap();
            }
            let s = b.commit().unwrap();
            let queried = s.meshes_or_all();
            assert_eq!(queried.is_some(), mesh || !twin, "twin {twin}, mesh {mesh}");
            let mut p = Packet8::new();
            p.set_ray(3, &ray);
            p.intersect_meshes(&s, false);
            // The mesh at z = 1 if queried with it, the plane at z = 2 if
            // queried without a twin, nothing when not queried.
            let want = match (twin, mesh) {
                (_, true) => Some(1),
                (false, false) => Some(0),
                (true, false) => None,
            };
            assert_eq!(p.hit(3).map(|h| h.geom_id), want, "twin {twin}, mesh {mesh}");
            p.set_ray(3, &ray);
            p.occlude_meshes(&s, false);
            assert_eq!(p.occluded(3), want.is_some(), "twin {twin}, mesh {mesh}");
        }
    }
}
