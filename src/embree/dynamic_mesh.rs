//! A triangle mesh rewritten frame by frame, for the warp renderer:
//! [`DynamicMesh`] in its own scene, whose vertex and index arrays are Rust
//! `Vec`s shared with Embree (no copy). Every frame the caller rewrites them
//! in [`DynamicMesh::update`], which then commits: a *refit* of the existing
//! BVH when only vertices moved and the mesh was made with `refit = true`
//! (`RTC_SCENE_FLAG_DYNAMIC` + `RTC_BUILD_QUALITY_REFIT`), a rebuild
//! otherwise. Queries take packets ([`super::packet`]).
//!
//! Soundness: Embree keeps raw pointers into the shared `Vec`s. They are
//! (re)registered in `update` after the caller's closure returns, with one
//! spare element of capacity (Embree loads the last vertex with a 16-byte
//! read), and every index is checked against the vertex count first. Queries
//! take `&self` and `update` takes `&mut self`, so no query runs while the
//! arrays change; a mesh whose update did not finish (the closure panicked or
//! Embree reported an error) is marked stale and answers no hits until the
//! next successful update, so Embree never reads a freed or resized buffer.
use super::packet::{Packet16, Packet8};
use super::{Device, EmbreeError};
use embree_sys as sys;
use std::ffi::c_void;

/// A triangle mesh rewritten frame by frame (see the module notes).
pub struct DynamicMesh {
    device: Device,
    scene: sys::RTCScene,
    geom: sys::RTCGeometry,
    vertices: Vec<[f32; 3]>,
    indices: Vec<[u32; 3]>,
    refit: bool,
    /// The buffers Embree holds are current and committed.
    ready: bool,
    /// Triangle count last given to Embree (0: nothing attached).
    attached: usize,
}

// SAFETY: the handles are owned by this value; Embree scenes and geometries
// may be used from any thread. Mutation needs `&mut self`.
unsafe impl Send for DynamicMesh {}
// SAFETY: `&self` methods only query a committed scene, which Embree
// documents as thread-safe.
unsafe impl Sync for DynamicMesh {}

impl Drop for DynamicMesh {
    fn drop(&mut self) {
        // SAFETY: both handles are valid and owned by this value; the scene
        // holds its own reference to the geometry.
        unsafe {
            sys::rtcReleaseGeometry(self.geom);
            sys::rtcReleaseScene(self.scene);
        }
    }
}

/// How an update was committed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Committed {
    /// The BVH was refitted to the moved vertices.
    Refit,
    /// The BVH was built anew.
    Rebuilt,
    /// No triangles: nothing to build, queries miss.
    Empty,
}

impl DynamicMesh {
    /// An empty mesh. With `refit`, later updates that keep the triangles
    /// refit the BVH; without, every update rebuilds (Embree's fast builder).
    pub fn new(device: &Device, refit: bool) -> Result<DynamicMesh, EmbreeError> {
        // SAFETY: valid device handle.
        let scene = unsafe { sys::rtcNewScene(device.inner.raw) };
        device.inner.check()?;
        if scene.is_null() {
            return Err(EmbreeError::Embree {
                code: "RTC_ERROR_UNKNOWN",
                message: "rtcNewScene returned NULL".into(),
            });
        }
        // SAFETY: valid device; the scene is released on the error path.
        let geom = unsafe { sys::rtcNewGeometry(device.inner.raw, sys::RTC_GEOMETRY_TYPE_TRIANGLE) };
        if let Err(e) = device.inner.check() {
            // SAFETY: valid scene handle, released once.
            unsafe { sys::rtcReleaseScene(scene) };
            return Err(e);
        }
        // SAFETY: valid handles; flags and qualities are valid enum values.
        unsafe {
            if refit {
                sys::rtcSetSceneFlags(scene, sys::RTC_SCENE_FLAG_DYNAMIC);
                sys::rtcSetSceneBuildQuality(scene, sys::RTC_BUILD_QUALITY_LOW);
                sys::rtcSetGeometryBuildQuality(geom, sys::RTC_BUILD_QUALITY_REFIT);
            } else {
                sys::rtcSetSceneBuildQuality(scene, sys::RTC_BUILD_QUALITY_LOW);
                sys::rtcSetGeometryBuildQuality(geom, sys::RTC_BUILD_QUALITY_LOW);
            }
        }
        let m = DynamicMesh {
            device: device.clone(),
            scene,
            geom,
            vertices: Vec::new(),
            indices: Vec::new(),
            refit,
            ready: false,
            attached: 0,
        };
        m.device.inner.check()?;
        Ok(m)
    }

    /// The current vertex positions (world space).
    pub fn vertices(&self) -> &[[f32; 3]] {
        &self.vertices
    }

    /// The triangles (indices into `vertices`).
    pub fn indices(&self) -> &[[u32; 3]] {
        &self.indices
    }

    /// Rewrite the arrays with `f`, which returns whether the triangles
    /// (the index array) changed, then commit: refit when they did not and
    /// the mesh refits, rebuild otherwise.
    pub fn update<F>(&mut self, f: F) -> Result<Committed, EmbreeError>
    where
        F: FnOnce(&mut Vec<[f32; 3]>, &mut Vec<[u32; 3]>) -> bool,
    {
        let was_ready = self.ready;
        self.ready = false;
        let old_ptrs = (self.vertices.as_ptr(), self.indices.as_ptr());
        let old_lens = (self.vertices.len(), self.indices.len());
        let mut topology = f(&mut self.vertices, &mut self.indices);
        let nv = self.vertices.len();
        if self.indices.iter().flatten().any(|&i| i as usize >= nv) {
            return Err(EmbreeError::Embree {
                code: "RTC_ERROR_INVALID_ARGUMENT",
                message: format!("a triangle index is out of range for {nv} vertices"),
            });
        }
        if !self.vertices.iter().flatten().all(|x| x.is_finite()) {
            return Err(EmbreeError::Embree {
                code: "RTC_ERROR_INVALID_ARGUMENT",
                message: "a vertex is not finite".into(),
            });
        }
        // Embree reads the last vertex with a 16-byte load: keep a spare
        // element (and one after the triangles, for the same reason).
        self.vertices.reserve(1);
        self.indices.reserve(1);
        let vertices_moved = old_ptrs.0 != self.vertices.as_ptr() || old_lens.0 != nv;
        topology |= !was_ready
            || old_ptrs.1 != self.indices.as_ptr()
            || old_lens.1 != self.indices.len()
            || self.attached == 0;
        let nt = self.indices.len();
        if nt == 0 {
            if self.attached != 0 {
                // SAFETY: valid scene; the geometry is attached with id 0.
                unsafe {
                    sys::rtcDetachGeometry(self.scene, 0);
                    sys::rtcCommitScene(self.scene);
                }
                self.attached = 0;
            }
            self.device.inner.check()?;
            self.ready = true;
            return Ok(Committed::Empty);
        }
        // SAFETY: the buffers point at live Vec storage of `nv` (+1 spare)
        // vertices and `nt` triangles whose indices were checked above; they
        // stay unchanged until the next `update` (which needs `&mut self`) and
        // are re-registered there before any query. Handles are valid.
        unsafe {
            if topology || vertices_moved {
                // A new vertex array (e.g. swapped in by the caller) with the
                // same triangles is still a refit for Embree.
                sys::rtcSetSharedGeometryBuffer(
                    self.geom,
                    sys::RTC_BUFFER_TYPE_VERTEX,
                    0,
                    sys::RTC_FORMAT_FLOAT3,
                    self.vertices.as_ptr() as *const c_void,
                    0,
                    12,
                    nv,
                );
            } else {
                sys::rtcUpdateGeometryBuffer(self.geom, sys::RTC_BUFFER_TYPE_VERTEX, 0);
            }
            if topology {
                sys::rtcSetSharedGeometryBuffer(
                    self.geom,
                    sys::RTC_BUFFER_TYPE_INDEX,
                    0,
                    sys::RTC_FORMAT_UINT3,
                    self.indices.as_ptr() as *const c_void,
                    0,
                    12,
                    nt,
                );
            }
            sys::rtcCommitGeometry(self.geom);
            if self.attached == 0 {
                sys::rtcAttachGeometryByID(self.scene, self.geom, 0);
            }
            sys::rtcCommitScene(self.scene);
        }
        self.device.inner.check()?;
        self.attached = nt;
        self.ready = true;
        Ok(if topology || !self.refit {
            Committed::Rebuilt
        } else {
            Committed::Refit
        })
    }

    /// Trace a packet against the mesh (no hits while the mesh is stale or empty).
    pub fn intersect8(&self, p: &mut Packet8) {
        if self.ready && self.attached > 0 {
            p.query(self.scene, true, false);
        }
    }

    /// [`intersect8`](Self::intersect8) for sixteen rays.
    pub fn intersect16(&self, p: &mut Packet16) {
        if self.ready && self.attached > 0 {
            p.query(self.scene, true, false);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A as V3;

    fn quad(z: f32) -> (Vec<[f32; 3]>, Vec<[u32; 3]>) {
        (
            vec![[-1.0, -1.0, z], [1.0, -1.0, z], [1.0, 1.0, z], [-1.0, 1.0, z]],
            vec![[0, 1, 2], [0, 2, 3]],
        )
    }

    /// Packets agree with single rays; a refit sees moved vertices; a new
    /// topology rebuilds; bad indices are refused and leave the mesh silent.
    #[test]
    fn dynamic_mesh_refit_rebuild_and_packets() {
        let d = Device::new("").unwrap();
        let mut m = DynamicMesh::new(&d, true).unwrap();
        let (v, i) = quad(-2.0);
        let c = m
            .update(|vs, is| {
                *vs = v.clone();
                *is = i.clone();
                true
            })
            .unwrap();
        assert_eq!(c, Committed::Rebuilt);
        let mut p = Packet8::new();
        for k in 0..8 {
            let x = -1.2 + 0.3 * k as f32;
            p.set(k, V3::ZERO, V3::new(x * 0.5, 0.0, -1.0), f32::INFINITY);
        }
        m.intersect8(&mut p);
        for k in 0..8 {
            let x = (-1.2 + 0.3 * k as f32) * 0.5 * 2.0;
            assert_eq!(p.hit(k).is_some(), x.abs() < 1.0, "lane {k} x {x}");
            if let Some(h) = p.hit(k) {
                // Directions are not unit: t counts |dir|, and dir.z = −1.
                assert!((h.t - 2.0).abs() < 1e-5, "{}", h.t);
            }
        }
        // Move the quad back to z = −3: a refit.
        let c = m
            .update(|vs, _| {
                for p in vs.iter_mut() {
                    p[2] = -3.0;
                }
                false
            })
            .unwrap();
        assert_eq!(c, Committed::Refit);
        let mut p = Packet8::new();
        p.set(3, V3::ZERO, V3::new(0.0, 0.0, -1.0), f32::INFINITY);
        m.intersect8(&mut p);
        assert!((p.hit(3).unwrap().t - 3.0).abs() < 1e-5);
        assert!(p.hit(0).is_none());
        // A new vertex array (z = −4), same triangles: still a refit.
        let c = m
            .update(|vs, _| {
                *vs = vs.iter().map(|p| [p[0], p[1], -4.0]).collect();
                false
            })
            .unwrap();
        assert_eq!(c, Committed::Refit);
        let mut p = Packet8::new();
        p.set(5, V3::ZERO, V3::new(0.0, 0.0, -1.0), f32::INFINITY);
        m.intersect8(&mut p);
        assert!((p.hit(5).unwrap().t - 4.0).abs() < 1e-5);
        // One triangle only: a rebuild.
        let c = m.update(|_, is| {
            is.truncate(1);
            true
        });
        assert_eq!(c.unwrap(), Committed::Rebuilt);
        let bad = m.update(|_, is| {
            is[0] = [0, 1, 9];
            true
        });
        assert!(bad.is_err());
        let mut p = Packet8::new();
        p.set(0, V3::ZERO, V3::new(0.1, -0.1, -1.0), f32::INFINITY);
        m.intersect8(&mut p);
        assert!(p.hit(0).is_none(), "a stale mesh answers no hits");
        // Packets on a committed static scene agree with single rays.
        let mut b =
            super::super::SceneBuilder::new(&d, Default::default(), super::super::BuildQuality::Low).unwrap();
        let (v, i) = quad(-2.0);
        b.add_triangles(&v, &i).unwrap();
        let s = b.commit().unwrap();
        let mut p = Packet8::new();
        for k in 0..8 {
            p.set(k, V3::ZERO, V3::new(-0.7 + 0.2 * k as f32, 0.13, -1.0), 10.0);
        }
        s.intersect8(&mut p);
        for k in 0..8 {
            let single = s.intersect(&super::super::Ray {
                org: V3::ZERO,
                dir: V3::new(-0.7 + 0.2 * k as f32, 0.13, -1.0),
                tnear: 0.0,
                tfar: 10.0,
            });
            assert_eq!(p.hit(k).map(|h| h.prim_id), single.map(|h| h.prim_id), "lane {k}");
        }
        let m2 = DynamicMesh::new(&d, false).unwrap();
        let mut p = Packet8::new();
        p.set(0, V3::ZERO, V3::Z, 1.0);
        m2.intersect8(&mut p);
        assert!(p.hit(0).is_none());
    }
}
