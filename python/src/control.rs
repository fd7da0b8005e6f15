//! Cancellation and progress of one render, as the Python side drives them:
//! the render runs on its own thread with the GIL released, and the calling
//! thread polls Python's signals and reports progress between waits.
use snell::render::RenderOptions;
use std::sync::atomic::Ordering;

/// What the polling thread can do to the render it started.
pub struct RenderControl {
    _private: (),
}

/// A render's progress as the polling thread last saw it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    /// Tiles finished.
    pub tiles_done: u64,
    /// Tiles of the render.
    pub tiles_total: u64,
    /// Samples taken.
    pub samples_done: u64,
    /// Seconds since the tiles started.
    pub elapsed_s: f64,
}

impl RenderControl {
    /// A control for one render.
    pub fn new() -> Self {
        snell::render::INTERRUPT.store(false, Ordering::SeqCst);
        RenderControl { _private: () }
    }

    /// The render options that tie the render to this control.
    pub fn options(&self, threads: Option<usize>, want_aovs: bool) -> RenderOptions {
        RenderOptions {
            threads,
            quiet: true,
            want_aovs,
        }
    }

    /// Stop the render at the next tile (tiles in progress finish).
    pub fn cancel(&self) {
        snell::render::INTERRUPT.store(true, Ordering::SeqCst);
    }

    /// The latest progress, if the render reported any.
    pub fn progress(&self) -> Option<Progress> {
        None
    }
}

impl Drop for RenderControl {
    fn drop(&mut self) {
        snell::render::INTERRUPT.store(false, Ordering::SeqCst);
    }
}
