//! The Embree device and its errors: [`Device`] owns an `RTCDevice` whose
//! error callback stores Embree's first unreported error in an [`ErrorSink`];
//! [`DeviceInner::check`] turns it into an [`EmbreeError`].

use embree_sys as sys;
use std::any::Any;
use std::ffi::{c_char, c_void, CStr, CString};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::ptr;
use std::sync::{Arc, Mutex};

/// An error reported by Embree (through the device error callback or
/// `rtcGetDeviceError`), a Rust callback that panicked during a query, or a
/// query that Embree would abort the process on.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EmbreeError {
    /// Embree reported an error: its code name and its own message.
    #[error("Embree error {code}: {message}")]
    Embree {
        /// The `RTCError` constant's name, e.g. `"RTC_ERROR_INVALID_ARGUMENT"`.
        code: &'static str,
        /// Embree's message (or snell's, when snell refused the call first).
        message: String,
    },
    /// A Rust filter panicked inside a query; the query result was discarded.
    #[error("a hit filter panicked during an Embree query: {0}")]
    FilterPanicked(String),
    /// An analytic shape's callback panicked: its query saw a miss, so the
    /// results since the last check are not to be trusted.
    #[error("an analytic shape's callback panicked ({count} times in this scene): {message}")]
    UserGeometryPanicked {
        /// Panics in the scene's user-geometry callbacks.
        count: u64,
        /// The first such panic's message.
        message: String,
    },
    /// A filtered query on a scene built without the context-filter flag
    /// (Debian's Embree would abort on it).
    #[error("a filtered query needs a scene built with SceneFlags::context_filter")]
    NoContextFilterFlag,
}

/// The name of an `RTCError` code.
pub(super) fn code_name(code: sys::RTCError) -> &'static str {
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

/// The message of a caught panic's payload (`&str` or `String`).
pub(super) fn panic_message(p: &(dyn Any + Send)) -> String {
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
pub(super) struct ErrorSink {
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

/// The device handle and its error sink, shared by the [`Device`] clones and
/// every scene built on it.
pub(super) struct DeviceInner {
    /// The device handle, valid until this value is dropped.
    pub(super) raw: sys::RTCDevice,
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
    pub(super) fn check(&self) -> Result<(), EmbreeError> {
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

/// An Embree device: the root of all Embree objects (cheap to clone: shared
/// ownership). Released when the last clone and the last scene built on it
/// are dropped.
#[derive(Clone)]
pub struct Device {
    /// Shared with every scene built on this device (`raw` for FFI calls in
    /// this module tree, `check()` after them).
    pub(super) inner: Arc<DeviceInner>,
}

impl Device {
    /// Create a device with an Embree configuration string (e.g. `"threads=1"`;
    /// empty for defaults).
    ///
    /// # Errors
    /// [`EmbreeError::Embree`] when the configuration contains a NUL byte or
    /// Embree refuses it (unknown or invalid configuration, unsupported CPU).
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

    /// Does this Embree build test ray masks against geometry masks
    /// (`RTC_DEVICE_PROPERTY_RAY_MASK_SUPPORTED`; a compile-time option of
    /// Embree, on in Debian's)?
    pub fn ray_masks(&self) -> bool {
        self.property(sys::RTC_DEVICE_PROPERTY_RAY_MASK_SUPPORTED)
            .map(|v| v != 0)
            .unwrap_or(false)
    }

    /// Are 16-wide packet queries native on this CPU
    /// (`RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED`: Embree has an AVX-512
    /// kernel for them and the CPU runs it), rather than two 8-wide ones?
    pub fn native_packet16(&self) -> bool {
        self.property(sys::RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED)
            .map(|v| v != 0)
            .unwrap_or(false)
    }

    /// Query a device property (`rtcGetDeviceProperty`; `prop` is an
    /// `RTCDeviceProperty` value), e.g. to provoke and test error reporting
    /// with an invalid property id.
    ///
    /// # Errors
    /// [`EmbreeError::Embree`] with Embree's message when `prop` is not a
    /// valid property.
    pub fn property(&self, prop: u32) -> Result<isize, EmbreeError> {
        // SAFETY: valid device handle; an invalid `prop` is reported through the
        // error callback, not undefined behaviour.
        let v = unsafe { sys::rtcGetDeviceProperty(self.inner.raw, prop as sys::RTCDeviceProperty) };
        self.inner.check()?;
        Ok(v as isize)
    }
}
