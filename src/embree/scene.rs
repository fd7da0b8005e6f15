//! Scenes: [`SceneBuilder`] (triangle meshes and user geometry, flags, build
//! quality) → [`Scene`] (committed, immutable, queried from many threads with
//! single rays, unfiltered or through a [`HitFilter`]).

use super::device::{Device, EmbreeError};
use super::filter::{init_context, FilterContext, HitFilter, SkipRanges};
use super::user_geometry::{
    check_user_panics, user_bounds, user_intersect, user_occluded, UserGeom, UserShape,
};
use super::INVALID_ID;
use crate::ray::{Hit, Ray};
use embree_sys as sys;
use glam::Vec3A as V3;
use std::ffi::c_void;
use std::ptr;

/// Embree build quality (`RTCBuildQuality`): how much time the BVH build
/// spends for faster traversal.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BuildQuality {
    /// `RTC_BUILD_QUALITY_LOW`: fastest build (for scenes rebuilt often).
    Low,
    /// `RTC_BUILD_QUALITY_MEDIUM`: Embree's default.
    Medium,
    /// `RTC_BUILD_QUALITY_HIGH`: slowest build, fastest traversal.
    High,
}

impl BuildQuality {
    /// Its name in stats (`low`, `medium`, `high`).
    pub fn name(self) -> &'static str {
        match self {
            BuildQuality::Low => "low",
            BuildQuality::Medium => "medium",
            BuildQuality::High => "high",
        }
    }
}

/// Scene flags that matter to snell.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SceneFlags {
    /// `RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION`: required for context filters.
    pub context_filter: bool,
    /// `RTC_SCENE_FLAG_ROBUST`: closes edge leaks at some cost.
    pub robust: bool,
}

/// A scene under construction: add geometry, then [`commit`](Self::commit).
/// Geometry ids are assigned in order of addition, from 0.
pub struct SceneBuilder {
    device: Device,
    raw: sys::RTCScene,
    /// The scene of the triangle meshes alone (null unless asked for by
    /// [`with_meshes_only`](Self::with_meshes_only)): each mesh is attached
    /// to both under the same geometry id.
    meshes_only: sys::RTCScene,
    /// Has a mesh been attached to `meshes_only`?
    any_mesh: bool,
    /// The build quality of both scenes.
    quality: sys::RTCBuildQuality,
    // Boxed so each UserGeom keeps its address (Embree holds pointers to it) when the Vec grows.
    #[allow(clippy::vec_box)]
    user: Vec<Box<UserGeom>>,
    context_filter: bool,
    /// What it was made with, for [`Scene::flags`] and [`Scene::build_quality`].
    flags: SceneFlags,
    build_quality: BuildQuality,
}

// SAFETY: a scene under construction may be moved to another thread; it is not
// shared (no Sync), which matches Embree's rule that edits are not thread-safe.
unsafe impl Send for SceneBuilder {}

impl Drop for SceneBuilder {
    fn drop(&mut self) {
        for s in [self.raw, self.meshes_only] {
            if !s.is_null() {
                // SAFETY: a valid scene owned by this builder (set to null when
                // ownership moves to a `Scene`).
                unsafe { sys::rtcReleaseScene(s) };
            }
        }
    }
}

impl SceneBuilder {
    /// A new, empty scene on `device`.
    ///
    /// # Errors
    /// [`EmbreeError::Embree`] when Embree cannot create the scene.
    pub fn new(device: &Device, flags: SceneFlags, quality: BuildQuality) -> Result<Self, EmbreeError> {
        // SAFETY: valid device handle.
        let raw = unsafe { sys::rtcNewScene(device.inner.raw) };
        device.inner.check()?;
        if raw.is_null() {
            return Err(EmbreeError::Embree {
                code: "RTC_ERROR_UNKNOWN",
                message: "rtcNewScene returned NULL".into(),
            });
        }
        let mut f = sys::RTC_SCENE_FLAG_NONE;
        if flags.context_filter {
            f |= sys::RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION;
        }
        if flags.robust {
            f |= sys::RTC_SCENE_FLAG_ROBUST;
        }
        let q = match quality {
            BuildQuality::Low => sys::RTC_BUILD_QUALITY_LOW,
            BuildQuality::Medium => sys::RTC_BUILD_QUALITY_MEDIUM,
            BuildQuality::High => sys::RTC_BUILD_QUALITY_HIGH,
        };
        let b = SceneBuilder {
            device: device.clone(),
            raw,
            meshes_only: ptr::null_mut(),
            any_mesh: false,
            quality: q,
            user: Vec::new(),
            context_filter: flags.context_filter,
            flags,
            build_quality: quality,
        };
        // SAFETY: valid scene handle; flags and quality are valid enum values.
        unsafe {
            sys::rtcSetSceneFlags(raw, f);
            sys::rtcSetSceneBuildQuality(raw, q);
        }
        b.device.inner.check()?;
        Ok(b)
    }

    /// Also build a second scene of the triangle meshes alone, every mesh
    /// under the geometry id it has in the whole scene ([`Scene::has_meshes_only`]):
    /// for queries that intersect the analytic shapes themselves. Call it
    /// before adding geometry; the meshes are shared, not copied (Embree
    /// attaches one geometry to several scenes), only the BVH is built twice.
    ///
    /// # Errors
    /// [`EmbreeError::Embree`] when Embree cannot create the scene.
    pub fn with_meshes_only(mut self) -> Result<Self, EmbreeError> {
        // SAFETY: valid device and scene handles; the new scene gets the
        // whole scene's flags and build quality.
        let raw = unsafe {
            let raw = sys::rtcNewScene(self.device.inner.raw);
            if !raw.is_null() {
                sys::rtcSetSceneFlags(raw, sys::rtcGetSceneFlags(self.raw));
            }
            raw
        };
        self.device.inner.check()?;
        if raw.is_null() {
            return Err(EmbreeError::Embree {
                code: "RTC_ERROR_UNKNOWN",
                message: "rtcNewScene returned NULL".into(),
            });
        }
        self.meshes_only = raw;
        // SAFETY: valid scene handle; the quality is a valid enum value.
        unsafe { sys::rtcSetSceneBuildQuality(raw, self.quality) };
        Ok(self)
    }

    /// Attach `geom` (and, for a mesh, to the meshes-only scene if there is one).
    fn attach(&mut self, geom: sys::RTCGeometry, mesh: bool) -> Result<u32, EmbreeError> {
        // SAFETY: `geom` was created on this device and is fully set up; attaching
        // transfers a reference to each scene, after which we drop ours. The id
        // is free in the meshes-only scene: it holds a subset of the whole
        // scene's geometries under the same ids.
        let id = unsafe {
            sys::rtcCommitGeometry(geom);
            let id = sys::rtcAttachGeometry(self.raw, geom);
            if mesh && !self.meshes_only.is_null() {
                sys::rtcAttachGeometryByID(self.meshes_only, geom, id);
            }
            sys::rtcReleaseGeometry(geom);
            id
        };
        self.any_mesh |= mesh;
        self.device.inner.check()?;
        Ok(id)
    }

    /// Attach a triangle mesh and return its geometry id. `indices` index into
    /// `vertices`; they are checked here (an out-of-range index would make
    /// Embree read out of bounds). A triangle's geometric normal is
    /// `(v1-v0)×(v2-v0)`: it faces the side from which the winding is
    /// counter-clockwise.
    ///
    /// # Errors
    /// [`EmbreeError::Embree`] for an empty mesh, an out-of-range index, or an
    /// error from Embree (e.g. out of memory).
    pub fn add_triangles(&mut self, vertices: &[[f32; 3]], indices: &[[u32; 3]]) -> Result<u32, EmbreeError> {
        let nv = vertices.len();
        if indices.is_empty() || nv == 0 {
            return Err(EmbreeError::Embree {
                code: "RTC_ERROR_INVALID_ARGUMENT",
                message: "a triangle mesh needs at least one triangle".into(),
            });
        }
        if let Some(bad) = indices.iter().flatten().find(|&&i| i as usize >= nv) {
            return Err(EmbreeError::Embree {
                code: "RTC_ERROR_INVALID_ARGUMENT",
                message: format!("triangle index {bad} out of range for {nv} vertices"),
            });
        }
        // SAFETY: valid device; the new geometry is released on every path below
        // (attach releases it; on error we release it).
        let geom = unsafe { sys::rtcNewGeometry(self.device.inner.raw, sys::RTC_GEOMETRY_TYPE_TRIANGLE) };
        self.device.inner.check()?;
        // SAFETY: Embree allocates buffers of the requested size (vertex buffer with
        // one float of padding as Embree requires for 16-byte loads); we write exactly
        // `nv*3` floats and `indices.len()*3` u32 into them.
        unsafe {
            let vb = sys::rtcSetNewGeometryBuffer(
                geom,
                sys::RTC_BUFFER_TYPE_VERTEX,
                0,
                sys::RTC_FORMAT_FLOAT3,
                12,
                nv,
            ) as *mut f32;
            let ib = sys::rtcSetNewGeometryBuffer(
                geom,
                sys::RTC_BUFFER_TYPE_INDEX,
                0,
                sys::RTC_FORMAT_UINT3,
                12,
                indices.len(),
            ) as *mut u32;
            if let Err(e) = self.device.inner.check() {
                sys::rtcReleaseGeometry(geom);
                return Err(e);
            }
            if vb.is_null() || ib.is_null() {
                sys::rtcReleaseGeometry(geom);
                return Err(EmbreeError::Embree {
                    code: "RTC_ERROR_OUT_OF_MEMORY",
                    message: "rtcSetNewGeometryBuffer returned NULL".into(),
                });
            }
            ptr::copy_nonoverlapping(vertices.as_ptr() as *const f32, vb, nv * 3);
            ptr::copy_nonoverlapping(indices.as_ptr() as *const u32, ib, indices.len() * 3);
        }
        self.attach(geom, true)
    }

    /// Attach an analytic shape as user geometry and return its geometry id.
    /// Its intersect callback calls `rtcFilterIntersection`, so filters see its
    /// hits as they see triangles'.
    ///
    /// # Errors
    /// [`EmbreeError::Embree`] when Embree refuses the geometry.
    pub fn add_user(&mut self, shape: Box<dyn UserShape>) -> Result<u32, EmbreeError> {
        self.add_user_masked(shape, u32::MAX)
    }

    /// [`add_user`](Self::add_user) with a geometry mask: a query whose ray
    /// mask shares no bit with `mask` does not see the shape (Embree tests
    /// the masks before calling the shape's intersect callback). Needs
    /// [`Device::ray_masks`]; every other geometry keeps Embree's default
    /// mask, all bits set.
    ///
    /// # Errors
    /// As [`add_user`](Self::add_user).
    pub fn add_user_masked(&mut self, shape: Box<dyn UserShape>, mask: u32) -> Result<u32, EmbreeError> {
        let data = Box::new(UserGeom::new(shape));
        let count = data.shape.prim_count();
        // SAFETY: valid device.
        let geom = unsafe { sys::rtcNewGeometry(self.device.inner.raw, sys::RTC_GEOMETRY_TYPE_USER) };
        self.device.inner.check()?;
        let user_ptr = &*data as *const UserGeom as *mut c_void;
        // SAFETY: `user_ptr` points into a box kept in `self.user` (then in `Scene`)
        // for the life of the scene; callbacks are `extern "C"` functions that
        // catch panics.
        unsafe {
            sys::rtcSetGeometryUserPrimitiveCount(geom, count);
            sys::rtcSetGeometryUserData(geom, user_ptr);
            sys::rtcSetGeometryBoundsFunction(geom, Some(user_bounds), ptr::null_mut());
            sys::rtcSetGeometryIntersectFunction(geom, Some(user_intersect));
            sys::rtcSetGeometryOccludedFunction(geom, Some(user_occluded));
            if mask != u32::MAX {
                sys::rtcSetGeometryMask(geom, mask);
            }
        }
        self.user.push(data);
        self.attach(geom, false)
    }

    /// Build the acceleration structure. The result may be queried from many threads.
    ///
    /// # Errors
    /// [`EmbreeError::Embree`] when the build fails (e.g. out of memory);
    /// [`EmbreeError::UserGeometryPanicked`] when an analytic shape's bounds
    /// panicked during the build.
    pub fn commit(mut self) -> Result<Scene, EmbreeError> {
        // SAFETY: valid scene handle with committed geometries.
        unsafe { sys::rtcCommitScene(self.raw) };
        self.device.inner.check()?;
        // A shape's bounds callback that panicked left its box unset.
        check_user_panics(&self.user)?;
        if !self.meshes_only.is_null() {
            // SAFETY: valid scene handle whose geometries are committed.
            unsafe { sys::rtcCommitScene(self.meshes_only) };
            self.device.inner.check()?;
        }
        let raw = std::mem::replace(&mut self.raw, ptr::null_mut());
        let meshes_only = std::mem::replace(&mut self.meshes_only, ptr::null_mut());
        Ok(Scene {
            device: self.device.clone(),
            raw,
            meshes_only,
            no_meshes: !self.any_mesh,
            context_filter: self.context_filter,
            filter_table: std::sync::OnceLock::new(),
            user: std::mem::take(&mut self.user),
            flags: self.flags,
            build_quality: self.build_quality,
        })
    }
}

/// A committed scene: immutable, queryable from many threads. Queries take a
/// [`Ray`] (`org + t·dir`, `t ∈ [tnear, tfar]`, t in units of `|dir|`) and
/// report [`Hit`]s with the geometric normal as the geometry gives it
/// (triangles: winding; analytic shapes: theirs, out of closed solids).
pub struct Scene {
    device: Device,
    /// The scene handle (also used by the packet queries of `packet.rs`).
    pub(super) raw: sys::RTCScene,
    /// The meshes alone ([`SceneBuilder::with_meshes_only`]), or null.
    pub(super) meshes_only: sys::RTCScene,
    /// The scene holds no triangle mesh (its meshes-only twin is empty).
    no_meshes: bool,
    /// Built with `RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION`.
    context_filter: bool,
    /// [`Scene::filter_table`]'s table.
    filter_table: std::sync::OnceLock<Vec<(u32, u32)>>,
    /// The user geometries Embree's callbacks point into (boxed: their
    /// addresses must not move), with the panics caught in them.
    #[allow(clippy::vec_box)]
    user: Vec<Box<UserGeom>>,
    flags: SceneFlags,
    build_quality: BuildQuality,
}

// SAFETY: a committed Embree scene is immutable and Embree documents concurrent
// rtcIntersect1/rtcOccluded1 calls on it as thread-safe; the boxed user shapes
// are `Send + Sync` by the `UserShape` bound.
unsafe impl Send for Scene {}
// SAFETY: as above.
unsafe impl Sync for Scene {}

impl Drop for Scene {
    fn drop(&mut self) {
        // SAFETY: `raw` is a valid scene owned solely by this value.
        unsafe { sys::rtcReleaseScene(self.raw) };
        if !self.meshes_only.is_null() {
            // SAFETY: as `raw`.
            unsafe { sys::rtcReleaseScene(self.meshes_only) };
        }
    }
}

/// A single-ray query for Embree: every mask bit set, no hit yet.
#[inline]
fn to_rayhit(ray: &Ray) -> sys::RTCRayHit {
    sys::RTCRayHit {
        ray: sys::RTCRay {
            org_x: ray.org.x,
            org_y: ray.org.y,
            org_z: ray.org.z,
            tnear: ray.tnear,
            dir_x: ray.dir.x,
            dir_y: ray.dir.y,
            dir_z: ray.dir.z,
            time: 0.0,
            tfar: ray.tfar,
            mask: u32::MAX, // a zeroed mask hits nothing
            id: 0,
            flags: 0,
        },
        hit: sys::RTCHit {
            geomID: INVALID_ID,
            primID: INVALID_ID,
            instID: [INVALID_ID],
            ..Default::default()
        },
    }
}

/// The hit of an answered query, if any (t is the final tfar).
#[inline]
fn from_rayhit(rh: &sys::RTCRayHit) -> Option<Hit> {
    (rh.hit.geomID != INVALID_ID).then(|| Hit {
        geom_id: rh.hit.geomID,
        prim_id: rh.hit.primID,
        t: rh.ray.tfar,
        ng: V3::new(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z),
        u: rh.hit.u,
        v: rh.hit.v,
    })
}

impl Scene {
    /// Was a scene of the meshes alone built beside it ([`SceneBuilder::with_meshes_only`])?
    pub fn has_meshes_only(&self) -> bool {
        !self.meshes_only.is_null()
    }

    /// The meshes-only twin if there is one, else the whole scene; `None`
    /// when the twin is empty: a query of it could only miss, and Embree
    /// would still be entered for every packet.
    pub(super) fn meshes_or_all(&self) -> Option<sys::RTCScene> {
        if self.meshes_only.is_null() {
            Some(self.raw)
        } else {
            (!self.no_meshes).then_some(self.meshes_only)
        }
    }

    /// The flags the scene was built with.
    pub fn flags(&self) -> SceneFlags {
        self.flags
    }

    /// The build quality of its BVH (and of its meshes-only twin's).
    pub fn build_quality(&self) -> BuildQuality {
        self.build_quality
    }

    /// How many user geometries (analytic shapes behind callbacks) it holds.
    pub fn user_geometries(&self) -> usize {
        self.user.len()
    }

    /// The device this scene was built on.
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// Nearest hit along `ray` in `[tnear, tfar]`, no filter. An invalid ray
    /// ([`Ray::is_valid`]) is a miss.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.intersect_masked(ray, u32::MAX)
    }

    /// [`intersect`](Self::intersect) with a ray mask: geometries whose mask
    /// shares no bit with `mask` are not seen at all (see
    /// [`SceneBuilder::add_user_masked`]).
    pub fn intersect_masked(&self, ray: &Ray, mask: u32) -> Option<Hit> {
        if !ray.is_valid() {
            return None; // an invalid ray would abort the process inside Embree
        }
        let mut ctx = init_context(None);
        let mut rh = to_rayhit(ray);
        rh.ray.mask = mask;
        // SAFETY: committed scene; `ctx` and `rh` are valid, properly initialised
        // and (RTCRayHit is 16-byte aligned by its bindgen definition) aligned.
        unsafe { sys::rtcIntersect1(self.raw, &mut ctx, &mut rh) };
        from_rayhit(&rh)
    }

    /// Is anything hit along `ray` in `[tnear, tfar]`? No filter. An invalid
    /// ray is not occluded.
    pub fn occluded(&self, ray: &Ray) -> bool {
        if !ray.is_valid() {
            return false;
        }
        let mut ctx = init_context(None);
        let mut r = to_rayhit(ray).ray;
        // SAFETY: as in `intersect`.
        unsafe { sys::rtcOccluded1(self.raw, &mut ctx, &mut r) };
        r.tfar == f32::NEG_INFINITY
    }

    /// Nearest hit accepted by `filter`. The scene must have been built with
    /// `SceneFlags::context_filter` (Debian's Embree asserts otherwise). An
    /// invalid ray is a miss, and the filter is not called.
    ///
    /// # Errors
    /// [`EmbreeError::NoContextFilterFlag`] when it was not;
    /// [`EmbreeError::FilterPanicked`] when the filter panicked (the query's
    /// result is discarded).
    pub fn intersect_filtered<F: HitFilter>(
        &self,
        ray: &Ray,
        filter: &mut F,
    ) -> Result<Option<Hit>, EmbreeError> {
        self.intersect_filtered_skipping(ray, filter, SkipRanges::NONE)
    }

    /// [`intersect_filtered`](Self::intersect_filtered), accepting the hits
    /// on the geometries `skip` names without calling `filter` (for them the
    /// query costs about what an unfiltered one does).
    ///
    /// # Errors
    /// As [`intersect_filtered`](Self::intersect_filtered).
    #[inline]
    pub fn intersect_filtered_skipping<F: HitFilter>(
        &self,
        ray: &Ray,
        filter: &mut F,
        skip: SkipRanges<'_>,
    ) -> Result<Option<Hit>, EmbreeError> {
        self.intersect_filtered_masked(ray, filter, skip, u32::MAX)
    }

    /// [`intersect_filtered_skipping`](Self::intersect_filtered_skipping)
    /// with a ray mask: geometries whose mask shares no bit with `mask`
    /// are not seen at all (see [`SceneBuilder::add_user_masked`]).
    ///
    /// # Errors
    /// As [`intersect_filtered`](Self::intersect_filtered).
    #[inline]
    pub fn intersect_filtered_masked<F: HitFilter>(
        &self,
        ray: &Ray,
        filter: &mut F,
        skip: SkipRanges<'_>,
        mask: u32,
    ) -> Result<Option<Hit>, EmbreeError> {
        if !self.context_filter {
            return Err(EmbreeError::NoContextFilterFlag);
        }
        if !ray.is_valid() {
            return Ok(None); // an invalid ray would abort the process inside Embree
        }
        let mut ctx = FilterContext::new(filter, skip);
        let mut rh = to_rayhit(ray);
        rh.ray.mask = mask;
        // SAFETY: `as_raw` points at the #[repr(C)] FilterContext (its `base`
        // first), which outlives the call, so the trampoline's cast back is
        // valid; the skip ranges it points at are borrowed for the call.
        unsafe { sys::rtcIntersect1(self.raw, ctx.as_raw(), &mut rh) };
        ctx.finish()?;
        Ok(from_rayhit(&rh))
    }

    /// A per-geometry table computed once per scene by `init` (on the first
    /// call; later calls return it): for filters whose skip ranges
    /// ([`SkipRanges`]) depend on the scene alone. One table per scene,
    /// whatever `init` later calls pass.
    #[inline]
    pub fn filter_table(&self, init: impl FnOnce() -> Vec<(u32, u32)>) -> &[(u32, u32)] {
        self.filter_table.get_or_init(init)
    }

    /// Occlusion with `filter` (see [`intersect_filtered`](Self::intersect_filtered)).
    ///
    /// # Errors
    /// As [`intersect_filtered`](Self::intersect_filtered).
    pub fn occluded_filtered<F: HitFilter>(&self, ray: &Ray, filter: &mut F) -> Result<bool, EmbreeError> {
        if !self.context_filter {
            return Err(EmbreeError::NoContextFilterFlag);
        }
        if !ray.is_valid() {
            return Ok(false);
        }
        let mut ctx = FilterContext::new(filter, SkipRanges::NONE);
        let mut r = to_rayhit(ray).ray;
        // SAFETY: as in `intersect_filtered`.
        unsafe { sys::rtcOccluded1(self.raw, ctx.as_raw(), &mut r) };
        ctx.finish()?;
        Ok(r.tfar == f32::NEG_INFINITY)
    }

    /// Errors since the last check: Embree's own (e.g. from queries), and
    /// panics inside this scene's analytic shapes' callbacks since it was
    /// built (those queries saw a miss). Renders call it after every tile.
    ///
    /// # Errors
    /// The first error Embree reported ([`EmbreeError::Embree`]), or
    /// [`EmbreeError::UserGeometryPanicked`].
    pub fn check(&self) -> Result<(), EmbreeError> {
        self.device.inner.check()?;
        check_user_panics(&self.user)
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::embree::UserShape;

    /// A square z = `z` (|x|, |y| < 1) as an analytic shape (the packets'
    /// tests use it too).
    pub(in crate::embree) struct Plane(pub(in crate::embree) f32);

    impl UserShape for Plane {
        fn bounds(&self, _: u32) -> super::super::Bounds {
            super::super::Bounds {
                lower: [-1.0, -1.0, self.0],
                upper: [1.0, 1.0, self.0],
            }
        }
        fn intersect(&self, _: u32, o: V3, d: V3, out: &mut super::super::Candidates) {
            let t = (self.0 - o.z) / d.z;
            let p = o + d * t;
            if t.is_finite() && p.x.abs() < 1.0 && p.y.abs() < 1.0 {
                out.push(super::super::Candidate {
                    t,
                    ng: [0.0, 0.0, 1.0],
                    u: 0.0,
                    v: 0.0,
                });
            }
        }
    }

    /// Rejects every hit it sees and remembers their geometries.
    struct RejectAll(Vec<u32>);

    impl HitFilter for RejectAll {
        fn accept(&mut self, h: &super::super::FilterHit) -> bool {
            self.0.push(h.geom_id);
            false
        }
    }

    #[test]
    fn skipped_geometries_are_accepted_unseen_by_the_filter() {
        // Geometry 0: triangles at z = 1; 1: analytic plane at z = 2;
        // 2: triangles at z = 3; 3: analytic plane at z = 4.
        let d = Device::new("").unwrap();
        let flags = SceneFlags {
            context_filter: true,
            robust: false,
        };
        let mut b = SceneBuilder::new(&d, flags, BuildQuality::Medium).unwrap();
        let quad = |z: f32| {
            let v = [[-1.0, -1.0, z], [1.0, -1.0, z], [1.0, 1.0, z], [-1.0, 1.0, z]];
            (v, [[0, 1, 2], [0, 2, 3]])
        };
        let (v, i) = quad(1.0);
        assert_eq!(b.add_triangles(&v, &i).unwrap(), 0);
        assert_eq!(b.add_user(Box::new(Plane(2.0))).unwrap(), 1);
        let (v, i) = quad(3.0);
        assert_eq!(b.add_triangles(&v, &i).unwrap(), 2);
        assert_eq!(b.add_user(Box::new(Plane(4.0))).unwrap(), 3);
        let s = b.commit().unwrap();
        let ray = Ray::new(V3::new(0.1, 0.2, 0.0), V3::Z);
        // Triangles skipped for keys 5..=9, the analytic plane for 0..=5 (geometry 3: never).
        let ranges = [(9, 0), (0, 5), (5, 9), (9, 0)];
        let cases = [
            // key, nearest hit, geometries the filter must see (those before the hit)
            (5, Some(1), vec![0]),
            (7, Some(2), vec![0, 1]),
            (2, Some(1), vec![0]),
            (12, None, vec![0, 1, 2, 3]),
        ];
        for (key, want, seen) in cases {
            let mut f = RejectAll(Vec::new());
            let skip = SkipRanges { ranges: &ranges, key };
            let h = s.intersect_filtered_skipping(&ray, &mut f, skip).unwrap();
            assert_eq!(h.map(|h| h.geom_id), want, "key {key}");
            let saw = f.0;
            // Never a skipped geometry (Embree may report the others beyond the hit).
            let skipped = |g: u32| ranges[g as usize].0 <= key && key <= ranges[g as usize].1;
            assert!(saw.iter().all(|&g| !skipped(g)), "key {key}: saw {saw:?}");
            assert!(seen.iter().all(|g| saw.contains(g)), "key {key}: saw {saw:?}");
        }
        // Without skip ranges the filter sees every geometry.
        let mut f = RejectAll(Vec::new());
        assert_eq!(s.intersect_filtered(&ray, &mut f).unwrap(), None);
        f.0.sort_unstable();
        f.0.dedup();
        assert_eq!(f.0, vec![0, 1, 2, 3]);
    }

    #[test]
    fn a_ray_mask_leaves_masked_shapes_unseen() {
        // Geometry 0: analytic plane at z = 2 with mask bit 0; 1: analytic
        // plane at z = 4 with the default mask (all bits).
        let d = Device::new("").unwrap();
        assert!(d.ray_masks(), "Debian's Embree is built with ray masks");
        let flags = SceneFlags {
            context_filter: true,
            robust: false,
        };
        let mut b = SceneBuilder::new(&d, flags, BuildQuality::Medium).unwrap();
        assert_eq!(b.add_user_masked(Box::new(Plane(2.0)), 1).unwrap(), 0);
        assert_eq!(b.add_user(Box::new(Plane(4.0))).unwrap(), 1);
        let s = b.commit().unwrap();
        let ray = Ray::new(V3::new(0.1, 0.2, 0.0), V3::Z);
        for (mask, want, seen) in [(u32::MAX, 0, vec![0]), (1 << 31, 1, vec![1]), (1, 0, vec![0])] {
            let mut f = RejectAll(Vec::new());
            let h = s
                .intersect_filtered_masked(&ray, &mut f, SkipRanges::NONE, mask)
                .unwrap();
            assert_eq!(h, None, "the filter rejects all");
            f.0.dedup();
            // The known-wrong expectation would be [0, 1] for mask 1 << 31.
            assert_eq!(f.0[0], want, "mask {mask:#x}: nearest seen");
            assert!(
                seen.iter().all(|g| f.0.contains(g)),
                "mask {mask:#x}: saw {:?}",
                f.0
            );
            if mask == 1 << 31 {
                assert!(!f.0.contains(&0), "the masked plane was seen: {:?}", f.0);
            }
        }
    }

    #[test]
    fn out_of_range_index_is_an_error() {
        let d = Device::new("").unwrap();
        let mut b = SceneBuilder::new(&d, SceneFlags::default(), BuildQuality::Medium).unwrap();
        let e = b.add_triangles(&[[0.0; 3]; 3], &[[0, 1, 3]]).unwrap_err();
        assert!(e.to_string().contains("out of range"), "{e}");
    }
}
