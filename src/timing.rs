//! The benchmarks' clocks and summaries: CPU time of a thread, of a thread
//! pool and of the process, and the median and spread of repeated timings.
//!
//! CPU time, because the benchmarks run on a shared machine: a process that
//! waits for the processor while another job runs loses wall time but not
//! CPU time, so ratios of CPU times are far steadier than ratios of wall
//! times (which the benchmarks print beside them). Read from the C library's
//! CPU clocks (`embree::libc_clock`, in the one FFI module): nanosecond
//! resolution, where `getrusage` and `/proc/self/stat` count scheduler ticks
//! and `/proc/thread-self/schedstat` lags by up to one.

/// CPU time of the calling thread so far, in seconds (`None` when the
/// clock fails).
pub fn thread_cpu_s() -> Option<f64> {
    crate::embree::thread_cpu_s()
}

/// CPU time of every thread of this process so far (user and system), in
/// seconds (`None` when the clock fails).
pub fn process_cpu_s() -> Option<f64> {
    crate::embree::process_cpu_s()
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

/// The median of `v`: its middle value, or the mean of the two middle
/// values when their number is even; NaN when `v` is empty.
pub fn median(v: &[f64]) -> f64 {
    median_min_max(v)[0]
}

/// The smallest and the largest of `v` (NaN when `v` is empty).
pub fn spread(v: &[f64]) -> [f64; 2] {
    let [_, lo, hi] = median_min_max(v);
    [lo, hi]
}

/// [`median`] and [`spread`] of `v` at once: median, min, max (NaNs when
/// `v` is empty).
pub fn median_min_max(v: &[f64]) -> [f64; 3] {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return [f64::NAN; 3];
    }
    let med = if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    };
    [med, v[0], v[n - 1]]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Spin on this thread until its CPU clock has advanced `cpu_s` (or 10 s
    /// of wall time have passed, on a machine too busy to give it that).
    fn spin_for(cpu_s: f64) {
        let (t0, wall) = (
            thread_cpu_s().expect("the thread CPU clock"),
            std::time::Instant::now(),
        );
        let mut x = 0u64;
        while thread_cpu_s().unwrap_or(f64::INFINITY) - t0 < cpu_s && wall.elapsed().as_secs() < 10 {
            for _ in 0..1000 {
                x = std::hint::black_box(x.wrapping_add(1));
            }
        }
    }

    /// Spinning costs CPU time, sleeping for 30 ms almost none (a wall
    /// clock would count both).
    #[test]
    fn spinning_counts_and_sleeping_does_not() {
        let ((), spin) = on_this_thread(|| spin_for(0.02));
        let ((), sleep) = on_this_thread(|| std::thread::sleep(std::time::Duration::from_millis(30)));
        let (spin, sleep) = (spin.unwrap_or(0.0), sleep.unwrap_or(1.0));
        assert!(spin >= 0.02, "spinning measured {spin} s of CPU");
        assert!(sleep < 0.005, "sleeping 30 ms measured {sleep} s of CPU");
    }

    /// The process clock counts the work of other threads too.
    #[test]
    fn the_process_clock_counts_every_thread() {
        let before = process_cpu_s().expect("the process CPU clock");
        let spun = std::thread::spawn(|| on_this_thread(|| spin_for(0.02)).1.unwrap_or(0.0))
            .join()
            .unwrap();
        let after = process_cpu_s().expect("the process CPU clock");
        assert!(spun >= 0.02, "the thread spun {spun} s");
        assert!(after - before >= spun, "{before} -> {after}, thread {spun}");
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

    #[test]
    fn median_of_odd_and_even_counts_and_of_none() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median(&[]).is_nan());
        assert_eq!(spread(&[3.0, 1.0, 2.0]), [1.0, 3.0]);
        assert_eq!(median_min_max(&[5.0, -1.0]), [2.0, -1.0, 5.0]);
    }
}
