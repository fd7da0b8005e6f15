//! The C library's CPU clocks (`clock_gettime`), for the benchmarks' CPU
//! times ([`crate::timing`]). Not Embree, but foreign: it lives here so that
//! every FFI call of snell is in this one module. Linux's
//! `/proc/thread-self/schedstat` needs no `unsafe`, but it is only brought up
//! to date at scheduler ticks; these clocks include the running slice.

/// `struct timespec` on 64-bit Linux (the only target snell builds for:
/// Embree from Debian's `libembree-dev`).
#[repr(C)]
struct Timespec {
    tv_sec: i64,
    tv_nsec: i64,
}

/// `CLOCK_PROCESS_CPUTIME_ID` in Linux's `<time.h>`.
const CLOCK_PROCESS_CPUTIME_ID: i32 = 2;
/// `CLOCK_THREAD_CPUTIME_ID` in Linux's `<time.h>`.
const CLOCK_THREAD_CPUTIME_ID: i32 = 3;

extern "C" {
    fn clock_gettime(clock: i32, tp: *mut Timespec) -> i32;
}

/// Seconds on `clock` (`None` if the clock fails).
fn read(clock: i32) -> Option<f64> {
    let mut ts = Timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `clock_gettime` writes one `struct timespec` (two 64-bit
    // integers on 64-bit Linux, matching `Timespec`'s `#[repr(C)]` layout)
    // through a pointer to a live, exclusively borrowed local, and keeps no
    // reference to it; an unknown clock makes it return -1, not misbehave.
    let rc = unsafe { clock_gettime(clock, &mut ts) };
    (rc == 0).then_some(ts.tv_sec as f64 + ts.tv_nsec as f64 * 1e-9)
}

/// CPU time of the calling thread so far, in seconds (`None` if the clock
/// fails).
pub(crate) fn thread_cpu_s() -> Option<f64> {
    read(CLOCK_THREAD_CPUTIME_ID)
}

/// CPU time of every thread of the process so far, in seconds (`None` if
/// the clock fails).
pub(crate) fn process_cpu_s() -> Option<f64> {
    read(CLOCK_PROCESS_CPUTIME_ID)
}
