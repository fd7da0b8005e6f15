//! CPU time of threads, for benchmarks on a shared machine: a process that
//! waits for the processor while another job runs loses wall time but not
//! CPU time, so ratios of CPU times are far steadier than ratios of wall
//! times (which the benchmarks print beside them).
//!
//! Read from the C library's thread CPU clock (`embree::thread_cpu_s`, the
//! one FFI module): nanosecond resolution, where `getrusage`'s ticks are
//! 10 ms and Linux's `/proc/thread-self/schedstat` lags by up to a
//! scheduler tick.

/// CPU time of the calling thread so far, in seconds (`None` when the
/// clock fails).
pub fn thread_cpu_s() -> Option<f64> {
    crate::embree::thread_cpu_s()
}

/// The CPU time spent by `f` on the calling thread, in seconds, with `f`'s
/// result (`None` when [`thread_cpu_s`] is).
pub fn on_this_thread<R>(f: impl FnOnce() -> R) -> (R, Option<f64>) {
    let t0 = thread_cpu_s();
    let r = f();
    let dt = t0.zip(thread_cpu_s()).map(|(a, b)| (b - a).max(0.0));
    (r, dt)
}

/// The CPU time the threads of `pool` spent while `f` ran (`f` puts work
/// on the pool, e.g. through `pool.install`), in seconds, with `f`'s
/// result: each thread's clock is read before and after (`None` if any
/// reading is missing).
pub fn on_pool<R>(pool: &rayon::ThreadPool, f: impl FnOnce() -> R) -> (R, Option<f64>) {
    let before = pool.broadcast(|_| thread_cpu_s());
    let r = f();
    let after = pool.broadcast(|_| thread_cpu_s());
    (r, pool_delta(&before, &after))
}

/// The CPU time spent by every thread of a pool between two readings
/// `before` and `after` (one per thread, in thread order): their sum,
/// `None` if any reading is missing.
fn pool_delta(before: &[Option<f64>], after: &[Option<f64>]) -> Option<f64> {
    if before.len() != after.len() {
        return None;
    }
    before
        .iter()
        .zip(after)
        .map(|(a, b)| Some((b.as_ref()? - a.as_ref()?).max(0.0)))
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Spinning for 30 ms of wall time on this thread costs about that much
    /// CPU time; sleeping for 30 ms costs almost none (a wall clock would
    /// count both the same).
    #[test]
    fn spinning_counts_and_sleeping_does_not() {
        let Some(_) = thread_cpu_s() else {
            panic!("the thread CPU clock failed: the benchmarks need it");
        };
        let ((), spin) = on_this_thread(|| {
            let t = std::time::Instant::now();
            let mut x = 0u64;
            while t.elapsed().as_secs_f64() < 0.03 {
                x = std::hint::black_box(x.wrapping_add(1));
            }
        });
        let ((), sleep) = on_this_thread(|| std::thread::sleep(std::time::Duration::from_millis(30)));
        let (spin, sleep) = (spin.unwrap_or(0.0), sleep.unwrap_or(1.0));
        assert!(spin > 0.01, "spinning 30 ms measured {spin} s of CPU");
        assert!(sleep < 0.005, "sleeping 30 ms measured {sleep} s of CPU");
    }

    #[test]
    fn pool_delta_sums_threads_and_needs_every_reading() {
        assert_eq!(
            pool_delta(&[Some(1.0), Some(2.0)], &[Some(1.5), Some(3.0)]),
            Some(1.5)
        );
        assert_eq!(pool_delta(&[Some(1.0), None], &[Some(1.5), Some(3.0)]), None);
        assert_eq!(pool_delta(&[Some(1.0)], &[Some(1.5), Some(3.0)]), None);
    }
}
