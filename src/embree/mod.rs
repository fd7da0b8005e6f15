//! The safe layer over Intel Embree 3: the only module of snell with `unsafe`.
//!
//! What it offers:
//! - [`Device`] with an error callback: Embree errors become [`EmbreeError`]s
//!   carrying Embree's message, never aborts and never silence.
//! - [`SceneBuilder`] → [`Scene`]: triangle meshes and user geometry
//!   ([`UserShape`]) for analytic shapes, flags, build quality, commit.
//! - Single-ray [`Scene::intersect`] / [`Scene::occluded`], and the filtered
//!   variants that run a Rust [`HitFilter`] as an Embree *context filter*
//!   through a trampoline, with the filter state carried in an extended
//!   `RTCIntersectContext` ([`FilterContext`], `#[repr(C)]`, Embree's context first).
//!
//! Soundness, in one place:
//! - Every handle (`RTCDevice`, `RTCScene`) is owned by exactly one RAII value
//!   and released once in `Drop`. A `Scene` keeps its device alive through an
//!   `Arc`, so the device is released after all its scenes.
//! - A committed scene is immutable; Embree documents `rtcIntersect1` /
//!   `rtcOccluded1` on a committed scene as thread-safe, hence `Scene: Send + Sync`.
//!   `SceneBuilder` is `Send` but not `Sync` (geometry edits are not thread-safe).
//! - User-geometry shapes are boxed and owned by the scene, so the pointers
//!   Embree hands back to our callbacks stay valid for the scene's life.
//! - No panic crosses `extern "C"`: every callback body runs in `catch_unwind`.
//!   A panicking filter is reported as `Err` after the query.

pub mod warp_ffi;
pub use crate::ray::{Hit, Ray};
use embree_sys as sys;
use glam::Vec3A as V3;
use std::any::Any;
use std::ffi::{c_char, c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::ptr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

/// `RTC_INVALID_GEOMETRY_ID` (a cast macro bindgen does not translate).
pub const INVALID_ID: u32 = u32::MAX;

/// Version of the Embree header snell was built against.
pub const EMBREE_VERSION: &str = sys::HEADER_VERSION;

/// Count of panics caught inside user-geometry callbacks (the query sees a
/// miss; `Scene::check` turns the count into an error).
static USER_GEOMETRY_PANICS: AtomicU64 = AtomicU64::new(0);
/// The first such panic's message.
static USER_GEOMETRY_PANIC_MESSAGE: Mutex<Option<String>> = Mutex::new(None);

/// Panics caught inside user-geometry callbacks since the process started.
pub fn user_geometry_panics() -> u64 {
    USER_GEOMETRY_PANICS.load(Ordering::Relaxed)
}

fn record_user_panic(p: &(dyn Any + Send)) {
    if USER_GEOMETRY_PANICS.fetch_add(1, Ordering::Relaxed) == 0 {
        if let Ok(mut m) = USER_GEOMETRY_PANIC_MESSAGE.lock() {
            *m = Some(panic_message(p));
        }
    }
}

/// An error reported by Embree (through the device error callback or
/// `rtcGetDeviceError`), or a filter that panicked during a query.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EmbreeError {
    /// Embree reported an error: its code name and its own message.
    #[error("Embree error {code}: {message}")]
    Embree { code: &'static str, message: String },
    /// A Rust filter panicked inside a query; the query result was discarded.
    #[error("a hit filter panicked during an Embree query: {0}")]
    FilterPanicked(String),
    /// An analytic shape's callback panicked: its query saw a miss, so the
    /// results since the last check are not to be trusted.
    #[error("an analytic shape's intersection callback panicked ({count} times since start): {message}")]
    UserGeometryPanicked { count: u64, message: String },
    /// A filtered query on a scene built without the context-filter flag
    /// (Debian's Embree would abort on it).
    #[error("a filtered query needs a scene built with SceneFlags::context_filter")]
    NoContextFilterFlag,
}

fn code_name(code: sys::RTCError) -> &'static str {
    match code {
        sys::RTC_ERROR_NONE => "RTC_ERROR_NONE",
        sys::RTC_ERROR_UNKNOWN => "RTC_ERROR_UNKNOWN",
        sys::RTC_ERROR_INVALID_ARGUMENT => "RTC_ERROR_INVALID_ARGUMENT",
        sys::RTC_ERROR_INVALID_OPERATION => "RTC_ERROR_INVALID_OPERATION",
        sys::RTC_ERROR_OUT_OF_MEMORY => "RTC_ERROR_OUT_OF_MEMORY",
        sys::RTC_ERROR_UNSUPPORTED_CPU => "RTC_ERROR_UNSUPPORTED_CPU",
        sys::RTC_ERROR_CANCELLED => "RTC_ERROR_CANCELLED",
        _ => "RTC_ERROR_(unrecognised)",
    }
}

fn panic_message(p: &(dyn Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "non-string panic payload".to_string()
    }
}

/// Where the device error callback stores the first unreported error.
#[derive(Default)]
struct ErrorSink {
    first: Mutex<Option<(sys::RTCError, String)>>,
}

unsafe extern "C" fn error_callback(user: *mut c_void, code: sys::RTCError, msg: *const c_char) {
    let _ = catch_unwind(AssertUnwindSafe(|| {
        if user.is_null() {
            return;
        }
        // SAFETY: `user` is the `ErrorSink` registered in `Device::new`; it lives in
        // the `DeviceInner` box, which outlives every call Embree makes on the device.
        let sink = unsafe { &*(user as *const ErrorSink) };
        let message = if msg.is_null() {
            String::from("(no message)")
        } else {
            // SAFETY: Embree passes a NUL-terminated C string valid for this call.
            unsafe { CStr::from_ptr(msg) }.to_string_lossy().into_owned()
        };
        if let Ok(mut first) = sink.first.lock() {
            if first.is_none() {
                *first = Some((code, message));
            }
        }
    }));
}

struct DeviceInner {
    raw: sys::RTCDevice,
    sink: Box<ErrorSink>,
}

// SAFETY: Embree devices are thread-safe objects (the API may be called from any
// thread); the sink is behind a Mutex.
unsafe impl Send for DeviceInner {}
// SAFETY: as above.
unsafe impl Sync for DeviceInner {}

impl Drop for DeviceInner {
    fn drop(&mut self) {
        // SAFETY: `raw` is a valid device owned solely by this value; all scenes
        // hold an Arc to it, so none is alive any more.
        unsafe { sys::rtcReleaseDevice(self.raw) };
    }
}

impl DeviceInner {
    /// Take the first error reported since the last check.
    fn check(&self) -> Result<(), EmbreeError> {
        // SAFETY: valid device handle; rtcGetDeviceError only reads and resets its code.
        let code = unsafe { sys::rtcGetDeviceError(self.raw) };
        let stored = self.sink.first.lock().ok().and_then(|mut g| g.take());
        match (stored, code) {
            (Some((c, message)), _) => Err(EmbreeError::Embree {
                code: code_name(c),
                message,
            }),
            (None, sys::RTC_ERROR_NONE) => Ok(()),
            (None, c) => Err(EmbreeError::Embree {
                code: code_name(c),
                message: "(no message from Embree)".into(),
            }),
        }
    }
}

/// An Embree device (cheap to clone: shared ownership).
#[derive(Clone)]
pub struct Device {
    inner: Arc<DeviceInner>,
}

impl Device {
    /// Create a device with an Embree configuration string (e.g. `"threads=1"`;
    /// empty for defaults). Unknown or invalid configurations are errors.
    pub fn new(config: &str) -> Result<Device, EmbreeError> {
        let cfg = CString::new(config).map_err(|_| EmbreeError::Embree {
            code: "RTC_ERROR_INVALID_ARGUMENT",
            message: "device configuration contains a NUL byte".into(),
        })?;
        // SAFETY: `cfg` is a valid NUL-terminated string for the duration of the call.
        let raw = unsafe { sys::rtcNewDevice(cfg.as_ptr()) };
        if raw.is_null() {
            // SAFETY: rtcGetDeviceError(NULL) reports the error of failed device creation.
            let code = unsafe { sys::rtcGetDeviceError(ptr::null_mut()) };
            return Err(EmbreeError::Embree {
                code: code_name(code),
                message: format!("rtcNewDevice(\"{config}\") failed"),
            });
        }
        let sink = Box::<ErrorSink>::default();
        let user = &*sink as *const ErrorSink as *mut c_void;
        // SAFETY: `raw` is valid; `user` points into the box that `DeviceInner`
        // owns for as long as the device exists.
        unsafe { sys::rtcSetDeviceErrorFunction(raw, Some(error_callback), user) };
        Ok(Device {
            inner: Arc::new(DeviceInner { raw, sink }),
        })
    }

    /// Query a device property (`rtcGetDeviceProperty`), e.g. to provoke and
    /// test error reporting with an invalid property id.
    pub fn property(&self, prop: u32) -> Result<isize, EmbreeError> {
        // SAFETY: valid device handle; an invalid `prop` is reported through the
        // error callback, not undefined behaviour.
        let v = unsafe { sys::rtcGetDeviceProperty(self.inner.raw, prop as sys::RTCDeviceProperty) };
        self.inner.check()?;
        Ok(v as isize)
    }
}

/// Embree build quality.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BuildQuality {
    Low,
    Medium,
    High,
}

/// Scene flags that matter to snell.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SceneFlags {
    /// `RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION`: required for context filters.
    pub context_filter: bool,
    /// `RTC_SCENE_FLAG_ROBUST`: closes edge leaks at some cost.
    pub robust: bool,
}

/// Axis-aligned bounds of one user-geometry primitive.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bounds {
    pub lower: [f32; 3],
    pub upper: [f32; 3],
}

/// One candidate crossing of a ray with an analytic primitive.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Candidate {
    /// Ray parameter (distance along the ray for a unit direction).
    pub t: f32,
    /// Geometric normal (any length; orientation defined by the shape).
    pub ng: [f32; 3],
    pub u: f32,
    pub v: f32,
}

/// Up to four candidate crossings, in ascending `t`.
#[derive(Debug, Clone, Default)]
pub struct Candidates {
    items: [Candidate; 4],
    len: usize,
}

impl Candidates {
    /// Add a candidate; silently ignores more than four (no analytic shape of
    /// snell has more than two crossings per primitive).
    pub fn push(&mut self, c: Candidate) {
        if self.len < self.items.len() {
            self.items[self.len] = c;
            self.len += 1;
        }
    }
    pub fn as_slice(&self) -> &[Candidate] {
        &self.items[..self.len]
    }
    /// Insertion sort by t: at most four items (a generic slice sort cost
    /// 4% of a deep-nesting trace, by callgrind).
    #[inline]
    fn sort(&mut self) {
        for i in 1..self.len {
            let mut j = i;
            while j > 0 && self.items[j - 1].t > self.items[j].t {
                self.items.swap(j - 1, j);
                j -= 1;
            }
        }
    }
}

/// An analytic shape exposed to Embree as user geometry.
pub trait UserShape: Send + Sync + 'static {
    /// Number of primitives (e.g. a closed cylinder: tube + two caps).
    fn prim_count(&self) -> u32 {
        1
    }
    /// Bounds of primitive `prim`.
    fn bounds(&self, prim: u32) -> Bounds;
    /// All crossings of the ray `org + t·dir` with primitive `prim` (any t; the
    /// caller clips to the ray interval).
    fn intersect(&self, prim: u32, org: V3, dir: V3, out: &mut Candidates);
}

struct UserGeom {
    shape: Box<dyn UserShape>,
}

/// A scene under construction.
pub struct SceneBuilder {
    device: Device,
    raw: sys::RTCScene,
    // Boxed so each UserGeom keeps its address (Embree holds pointers to it) when the Vec grows.
    #[allow(clippy::vec_box)]
    user: Vec<Box<UserGeom>>,
    context_filter: bool,
}

// SAFETY: a scene under construction may be moved to another thread; it is not
// shared (no Sync), which matches Embree's rule that edits are not thread-safe.
unsafe impl Send for SceneBuilder {}

impl Drop for SceneBuilder {
    fn drop(&mut self) {
        if !self.raw.is_null() {
            // SAFETY: `raw` is a valid scene owned by this builder (set to null when
            // ownership moves to a `Scene`).
            unsafe { sys::rtcReleaseScene(self.raw) };
        }
    }
}

impl SceneBuilder {
    /// A new, empty scene on `device`.
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
            user: Vec::new(),
            context_filter: flags.context_filter,
        };
        // SAFETY: valid scene handle; flags and quality are valid enum values.
        unsafe {
            sys::rtcSetSceneFlags(raw, f);
            sys::rtcSetSceneBuildQuality(raw, q);
        }
        b.device.inner.check()?;
        Ok(b)
    }

    fn attach(&mut self, geom: sys::RTCGeometry) -> Result<u32, EmbreeError> {
        // SAFETY: `geom` was created on this device and is fully set up; attaching
        // transfers a reference to the scene, after which we drop ours.
        let id = unsafe {
            sys::rtcCommitGeometry(geom);
            let id = sys::rtcAttachGeometry(self.raw, geom);
            sys::rtcReleaseGeometry(geom);
            id
        };
        self.device.inner.check()?;
        Ok(id)
    }

    /// Attach a triangle mesh. `indices` index into `vertices`; they are checked
    /// here (an out-of-range index would make Embree read out of bounds).
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
        self.attach(geom)
    }

    /// Attach an analytic shape as user geometry. Its intersect callback calls
    /// `rtcFilterIntersection`, so filters see its hits as they see triangles'.
    pub fn add_user(&mut self, shape: Box<dyn UserShape>) -> Result<u32, EmbreeError> {
        let data = Box::new(UserGeom { shape });
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
        }
        self.user.push(data);
        self.attach(geom)
    }

    /// Build the acceleration structure. The result may be queried from many threads.
    pub fn commit(mut self) -> Result<Scene, EmbreeError> {
        // SAFETY: valid scene handle with committed geometries.
        unsafe { sys::rtcCommitScene(self.raw) };
        self.device.inner.check()?;
        let raw = std::mem::replace(&mut self.raw, ptr::null_mut());
        Ok(Scene {
            device: self.device.clone(),
            raw,
            context_filter: self.context_filter,
            user_panics_at_build: USER_GEOMETRY_PANICS.load(Ordering::Relaxed),
            _user: std::mem::take(&mut self.user),
        })
    }
}

unsafe extern "C" fn user_bounds(args: *const sys::RTCBoundsFunctionArguments) {
    let r = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: Embree passes valid arguments; geometryUserPtr is our UserGeom
        // (see `add_user`), bounds_o is writable.
        unsafe {
            let a = &*args;
            let g = &*(a.geometryUserPtr as *const UserGeom);
            let b = g.shape.bounds(a.primID);
            let o = &mut *a.bounds_o;
            o.lower_x = b.lower[0];
            o.lower_y = b.lower[1];
            o.lower_z = b.lower[2];
            o.upper_x = b.upper[0];
            o.upper_y = b.upper[1];
            o.upper_z = b.upper[2];
        }
    }));
    if let Err(p) = r {
        record_user_panic(&*p);
    }
}

/// Float index of field `k` of lane `i` in an SoA ray/hit block of width `n`.
#[inline]
fn soa(k: usize, i: usize, n: usize) -> usize {
    k * n + i
}

unsafe extern "C" fn user_intersect(args: *const sys::RTCIntersectFunctionNArguments) {
    let r = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: see `intersect_lanes`.
        unsafe { intersect_lanes(args) }
    }));
    if let Err(p) = r {
        record_user_panic(&*p);
    }
}

/// # Safety
/// `args` must be the arguments Embree passes to an intersect callback of a
/// geometry created by `add_user`.
unsafe fn intersect_lanes(args: *const sys::RTCIntersectFunctionNArguments) {
    // SAFETY: guaranteed by the caller (Embree's callback contract): `args`, its
    // valid mask of N ints and its RTCRayHitN of N lanes are valid for this call;
    // geometryUserPtr is our UserGeom.
    unsafe {
        let a = &*args;
        let n = a.N as usize;
        let g = &*(a.geometryUserPtr as *const UserGeom);
        let rh = a.rayhit as *mut f32;
        let hit_base = rh.add(12 * n); // RTCHitN follows the 12 ray fields
        for i in 0..n {
            if *a.valid.add(i) == 0 {
                continue;
            }
            let org = V3::new(
                *rh.add(soa(0, i, n)),
                *rh.add(soa(1, i, n)),
                *rh.add(soa(2, i, n)),
            );
            let tnear = *rh.add(soa(3, i, n));
            let dir = V3::new(
                *rh.add(soa(4, i, n)),
                *rh.add(soa(5, i, n)),
                *rh.add(soa(6, i, n)),
            );
            let mut cands = Candidates::default();
            g.shape.intersect(a.primID, org, dir, &mut cands);
            cands.sort();
            for c in cands.as_slice() {
                let tfar_ptr = rh.add(soa(8, i, n));
                let tfar = *tfar_ptr;
                if !(c.t >= tnear && c.t <= tfar) {
                    continue;
                }
                // Potential hit in single-lane layout; filters read t from ray.tfar.
                let mut potential = sys::RTCHit {
                    Ng_x: c.ng[0],
                    Ng_y: c.ng[1],
                    Ng_z: c.ng[2],
                    u: c.u,
                    v: c.v,
                    primID: a.primID,
                    geomID: a.geomID,
                    instID: [(*a.context).instID[0]],
                };
                let mut lane_valid: i32 = -1;
                // Without a context filter there is nothing to call: user
                // geometries never get per-geometry filters (`add_user`), so
                // rtcFilterIntersection would accept the hit anyway.
                if n == 1 && (*a.context).filter.is_some() {
                    let fargs = sys::RTCFilterFunctionNArguments {
                        valid: &mut lane_valid,
                        geometryUserPtr: a.geometryUserPtr,
                        context: a.context,
                        ray: a.rayhit as *mut sys::RTCRayN,
                        hit: &mut potential as *mut sys::RTCHit as *mut sys::RTCHitN,
                        N: 1,
                    };
                    *tfar_ptr = c.t;
                    sys::rtcFilterIntersection(args, &fargs);
                    if lane_valid == 0 {
                        *tfar_ptr = tfar;
                        continue;
                    }
                } else {
                    // Wide queries are not used by snell's filters; accept directly.
                    *tfar_ptr = c.t;
                }
                let h = [
                    potential.Ng_x,
                    potential.Ng_y,
                    potential.Ng_z,
                    potential.u,
                    potential.v,
                    f32::from_bits(potential.primID),
                    f32::from_bits(potential.geomID),
                    f32::from_bits(potential.instID[0]),
                ];
                for (k, v) in h.iter().enumerate() {
                    *hit_base.add(soa(k, i, n)) = *v;
                }
                break; // candidates are sorted: the first accepted one is nearest
            }
        }
    }
}

unsafe extern "C" fn user_occluded(args: *const sys::RTCOccludedFunctionNArguments) {
    let r = catch_unwind(AssertUnwindSafe(|| {
        // SAFETY: Embree's occluded-callback contract: args, valid mask and RTCRayN
        // of N lanes are valid for this call; geometryUserPtr is our UserGeom.
        unsafe {
            let a = &*args;
            let n = a.N as usize;
            let g = &*(a.geometryUserPtr as *const UserGeom);
            let r = a.ray as *mut f32;
            for i in 0..n {
                if *a.valid.add(i) == 0 {
                    continue;
                }
                let org = V3::new(*r.add(soa(0, i, n)), *r.add(soa(1, i, n)), *r.add(soa(2, i, n)));
                let tnear = *r.add(soa(3, i, n));
                let dir = V3::new(*r.add(soa(4, i, n)), *r.add(soa(5, i, n)), *r.add(soa(6, i, n)));
                let mut cands = Candidates::default();
                g.shape.intersect(a.primID, org, dir, &mut cands);
                cands.sort();
                for c in cands.as_slice() {
                    let tfar_ptr = r.add(soa(8, i, n));
                    let tfar = *tfar_ptr;
                    if !(c.t >= tnear && c.t <= tfar) {
                        continue;
                    }
                    let mut potential = sys::RTCHit {
                        Ng_x: c.ng[0],
                        Ng_y: c.ng[1],
                        Ng_z: c.ng[2],
                        u: c.u,
                        v: c.v,
                        primID: a.primID,
                        geomID: a.geomID,
                        instID: [(*a.context).instID[0]],
                    };
                    let mut lane_valid: i32 = -1;
                    // As in `intersect_lanes`: no context filter, nothing to call.
                    if n == 1 && (*a.context).filter.is_some() {
                        let fargs = sys::RTCFilterFunctionNArguments {
                            valid: &mut lane_valid,
                            geometryUserPtr: a.geometryUserPtr,
                            context: a.context,
                            ray: a.ray,
                            hit: &mut potential as *mut sys::RTCHit as *mut sys::RTCHitN,
                            N: 1,
                        };
                        *tfar_ptr = c.t;
                        sys::rtcFilterOcclusion(args, &fargs);
                        if lane_valid == 0 {
                            *tfar_ptr = tfar;
                            continue;
                        }
                    }
                    *tfar_ptr = f32::NEG_INFINITY; // occluded
                    break;
                }
            }
        }
    }));
    if let Err(p) = r {
        record_user_panic(&*p);
    }
}

/// A committed scene: immutable, queryable from many threads.
pub struct Scene {
    device: Device,
    raw: sys::RTCScene,
    /// Built with `RTC_SCENE_FLAG_CONTEXT_FILTER_FUNCTION`.
    context_filter: bool,
    /// `user_geometry_panics()` when the scene was committed.
    user_panics_at_build: u64,
    #[allow(clippy::vec_box)]
    _user: Vec<Box<UserGeom>>,
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
    }
}

/// A hit as a filter sees it, before it is accepted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FilterHit {
    pub geom_id: u32,
    pub prim_id: u32,
    pub t: f32,
    pub ng: V3,
    pub org: V3,
    pub dir: V3,
    /// Barycentric coordinates (triangles) or the shape's own (user geometry).
    pub u: f32,
    pub v: f32,
}

/// A Rust intersection filter, run as an Embree context filter. Embree calls it
/// in traversal order (not nearest first), possibly for hits beyond the final
/// nearest one, and possibly more than once for the same surface crossing.
pub trait HitFilter {
    /// Return `false` to reject the hit (Embree then continues the traversal).
    fn accept(&mut self, hit: &FilterHit) -> bool;
}

/// The extended intersection context: Embree's context first, then our payload.
/// Embree hands the pointer to `base` back to the trampoline, which casts it to
/// the whole struct; `#[repr(C)]` with `base` first makes that cast valid.
#[repr(C)]
pub struct FilterContext<'a, F: HitFilter> {
    base: sys::RTCIntersectContext,
    filter: &'a mut F,
    panic: Option<String>,
}

/// `rtcInitIntersectContext` is an inline C function; this is its body for
/// Embree 3.13 (flags incoherent, no filter, instance stack invalid).
fn init_context(filter: sys::RTCFilterFunctionN) -> sys::RTCIntersectContext {
    let mut ctx = sys::RTCIntersectContext {
        flags: sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT,
        filter,
        ..Default::default()
    };
    for id in ctx.instID.iter_mut() {
        *id = INVALID_ID;
    }
    ctx
}

unsafe extern "C" fn filter_trampoline<F: HitFilter>(args: *const sys::RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes valid arguments; `context` is the `base` field of a
    // live `FilterContext<F>` (only `intersect_filtered`/`occluded_filtered`
    // install this trampoline, and only on such contexts).
    let a = unsafe { &*args };
    // SAFETY: as above; `base` is the first field of the #[repr(C)] struct.
    let ctx = unsafe { &mut *(a.context as *mut FilterContext<'_, F>) };
    if ctx.panic.is_some() {
        // A previous call panicked: reject everything, the query result is discarded.
        for i in 0..a.N as usize {
            // SAFETY: `valid` has N entries.
            unsafe { *a.valid.add(i) = 0 };
        }
        return;
    }
    let n = a.N as usize;
    let ray = a.ray as *const f32;
    let hit = a.hit as *const f32;
    for i in 0..n {
        // SAFETY: valid mask, ray and hit blocks have N lanes (Embree contract).
        let fh = unsafe {
            if *a.valid.add(i) == 0 {
                continue;
            }
            FilterHit {
                org: V3::new(
                    *ray.add(soa(0, i, n)),
                    *ray.add(soa(1, i, n)),
                    *ray.add(soa(2, i, n)),
                ),
                dir: V3::new(
                    *ray.add(soa(4, i, n)),
                    *ray.add(soa(5, i, n)),
                    *ray.add(soa(6, i, n)),
                ),
                t: *ray.add(soa(8, i, n)),
                ng: V3::new(
                    *hit.add(soa(0, i, n)),
                    *hit.add(soa(1, i, n)),
                    *hit.add(soa(2, i, n)),
                ),
                prim_id: (*hit.add(soa(5, i, n))).to_bits(),
                u: *hit.add(soa(3, i, n)),
                v: *hit.add(soa(4, i, n)),
                geom_id: (*hit.add(soa(6, i, n))).to_bits(),
            }
        };
        let filter = &mut *ctx.filter;
        match catch_unwind(AssertUnwindSafe(|| filter.accept(&fh))) {
            Ok(true) => {}
            Ok(false) => {
                // SAFETY: lane i of the N-entry valid mask.
                unsafe { *a.valid.add(i) = 0 };
            }
            Err(p) => {
                ctx.panic = Some(panic_message(&*p));
                // SAFETY: lane i of the N-entry valid mask.
                unsafe { *a.valid.add(i) = 0 };
            }
        }
    }
}

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
    /// The device this scene was built on.
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// Nearest hit along `ray`, no filter.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if !ray.is_valid() {
            return None; // an invalid ray would abort the process inside Embree
        }
        let mut ctx = init_context(None);
        let mut rh = to_rayhit(ray);
        // SAFETY: committed scene; `ctx` and `rh` are valid, properly initialised
        // and (RTCRayHit is 16-byte aligned by its bindgen definition) aligned.
        unsafe { sys::rtcIntersect1(self.raw, &mut ctx, &mut rh) };
        from_rayhit(&rh)
    }

    /// Is anything hit along `ray` in `[tnear, tfar]`? No filter.
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
    /// `SceneFlags::context_filter` (Debian's Embree asserts otherwise).
    ///
    /// # Errors
    /// `NoContextFilterFlag` when it was not; `FilterPanicked` when the filter
    /// panicked (the query's result is discarded).
    pub fn intersect_filtered<F: HitFilter>(
        &self,
        ray: &Ray,
        filter: &mut F,
    ) -> Result<Option<Hit>, EmbreeError> {
        if !self.context_filter {
            return Err(EmbreeError::NoContextFilterFlag);
        }
        if !ray.is_valid() {
            return Ok(None); // an invalid ray would abort the process inside Embree
        }
        let mut ctx = FilterContext {
            base: init_context(Some(filter_trampoline::<F>)),
            filter,
            panic: None,
        };
        let mut rh = to_rayhit(ray);
        // SAFETY: `ctx.base` is the first field of the #[repr(C)] FilterContext,
        // which outlives the call, so the trampoline's cast back is valid.
        unsafe { sys::rtcIntersect1(self.raw, &mut ctx.base, &mut rh) };
        match ctx.panic {
            Some(p) => Err(EmbreeError::FilterPanicked(p)),
            None => Ok(from_rayhit(&rh)),
        }
    }

    /// Occlusion with `filter` (see `intersect_filtered`).
    ///
    /// # Errors
    /// As `intersect_filtered`.
    pub fn occluded_filtered<F: HitFilter>(&self, ray: &Ray, filter: &mut F) -> Result<bool, EmbreeError> {
        if !self.context_filter {
            return Err(EmbreeError::NoContextFilterFlag);
        }
        if !ray.is_valid() {
            return Ok(false);
        }
        let mut ctx = FilterContext {
            base: init_context(Some(filter_trampoline::<F>)),
            filter,
            panic: None,
        };
        let mut r = to_rayhit(ray).ray;
        // SAFETY: as in `intersect_filtered`.
        unsafe { sys::rtcOccluded1(self.raw, &mut ctx.base, &mut r) };
        match ctx.panic {
            Some(p) => Err(EmbreeError::FilterPanicked(p)),
            None => Ok(r.tfar == f32::NEG_INFINITY),
        }
    }

    /// Errors since the last check: Embree's own (e.g. from queries), and
    /// panics inside analytic shapes' callbacks since the scene was built
    /// (those queries saw a miss). Renders call it after every tile.
    ///
    /// # Errors
    /// The first error Embree reported, or `UserGeometryPanicked`.
    pub fn check(&self) -> Result<(), EmbreeError> {
        self.device.inner.check()?;
        let count = USER_GEOMETRY_PANICS.load(Ordering::Relaxed);
        if count > self.user_panics_at_build {
            let message = USER_GEOMETRY_PANIC_MESSAGE
                .lock()
                .ok()
                .and_then(|m| m.clone())
                .unwrap_or_default();
            return Err(EmbreeError::UserGeometryPanicked { count, message });
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn init_context_matches_inline_c() {
        let c = init_context(None);
        assert_eq!(c.flags, sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT);
        assert!(c.filter.is_none());
        assert!(c.instID.iter().all(|&i| i == INVALID_ID));
    }

    #[test]
    fn out_of_range_index_is_an_error() {
        let d = Device::new("").unwrap();
        let mut b = SceneBuilder::new(&d, SceneFlags::default(), BuildQuality::Medium).unwrap();
        let e = b.add_triangles(&[[0.0; 3]; 3], &[[0, 1, 3]]).unwrap_err();
        assert!(e.to_string().contains("out of range"), "{e}");
    }
}
