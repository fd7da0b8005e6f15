//! Cancellation and progress of one render, as the Python side drives them:
//! the render runs on its own thread with the GIL released, and the calling
//! thread polls Python's signals and reports progress between waits.
use snell::render::{CancelToken, ProgressSink, RenderOptions, RenderProgress};
use std::sync::{Arc, Mutex};

/// A render's progress as the polling thread last saw it.
pub type Progress = RenderProgress;

/// What the polling thread can do to the render it started: cancel it (its
/// own token, so other renders go on), and read its latest progress.
pub struct RenderControl {
    cancel: CancelToken,
    latest: Arc<Mutex<Option<RenderProgress>>>,
}

impl RenderControl {
    /// A control for one render.
    pub fn new() -> Self {
        RenderControl {
            cancel: CancelToken::new(),
            latest: Arc::default(),
        }
    }

    /// The render options that tie the render to this control.
    pub fn options(&self, threads: Option<usize>, want_aovs: bool) -> RenderOptions {
        let latest = Arc::clone(&self.latest);
        RenderOptions {
            threads,
            want_aovs,
            cancel: self.cancel.clone(),
            // Called from the render's threads after every tile: keep the
            // latest only; the polling thread hands it to Python.
            progress: ProgressSink::Callback(Arc::new(move |p: &RenderProgress| {
                if let Ok(mut l) = latest.lock() {
                    *l = Some(*p);
                }
            })),
            ..RenderOptions::default()
        }
    }

    /// Stop the render at the next tile (tiles in progress finish).
    pub fn cancel(&self) {
        self.cancel.cancel();
    }

    /// The latest progress, if the render reported any.
    pub fn progress(&self) -> Option<Progress> {
        self.latest.lock().ok().and_then(|l| *l)
    }
}
