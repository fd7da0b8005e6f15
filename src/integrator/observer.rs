//! Watching the queries a render asks Embree for: the integrators report
//! each one to the [`RayObserver`] of their [`Tracer`](super::Tracer), if it
//! has one. [`RayRecorder`] keeps them, for `snell bench render`'s replay
//! through bare Embree (the ceiling of the same rays). Without an observer
//! a query costs one branch more.
use crate::ray::Ray;
use std::sync::Mutex;

/// A query the integrators asked Embree for.
#[derive(Debug, Clone, Copy)]
pub enum RayQuery {
    /// A nearest-hit query (a path segment or a chord; the nested rule's
    /// re-casts and filter calls are not separate entries).
    Nearest(Ray),
    /// A shadow ray.
    Shadow(Ray),
}

/// Told of every query of the renders it is given to (from the render's
/// threads, in no particular order across them).
pub trait RayObserver: Send + Sync {
    /// One query, before it is made.
    fn query(&self, q: RayQuery);
}

/// A [`RayObserver`] that keeps every query (from every thread) until
/// [`take`](RayRecorder::take)n.
#[derive(Debug, Default)]
pub struct RayRecorder {
    queries: Mutex<Vec<RayQuery>>,
}

impl RayRecorder {
    /// An empty recorder.
    pub fn new() -> Self {
        Self::default()
    }

    /// The queries recorded so far (the recorder is empty afterwards).
    pub fn take(&self) -> Vec<RayQuery> {
        match self.queries.lock() {
            Ok(mut q) => std::mem::take(&mut *q),
            // A thread panicked while pushing: what it pushed is whole.
            Err(poisoned) => std::mem::take(&mut *poisoned.into_inner()),
        }
    }
}

impl RayObserver for RayRecorder {
    fn query(&self, q: RayQuery) {
        match self.queries.lock() {
            Ok(mut v) => v.push(q),
            Err(poisoned) => poisoned.into_inner().push(q),
        }
    }
}
