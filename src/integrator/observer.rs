//! Watching the queries a render asks Embree for: the integrators report
//! each one to the [`RayObserver`] of their [`Tracer`](super::Tracer), if it
//! has one. [`RayRecorder`] keeps them, for `snell bench render`'s replay
//! through bare Embree (the ceiling of the same rays). Without an observer
//! a query costs one branch more.
use crate::ray::Ray;
use std::collections::HashMap;
use std::sync::Mutex;
use std::thread::ThreadId;

/// A query the integrators asked Embree for.
#[derive(Debug, Clone, Copy)]
pub enum RayQuery {
    /// A nearest-hit query (a path segment or a chord; the nested rule's
    /// re-casts and filter calls are not separate entries).
    Nearest(Ray),
    /// A nearest-hit query that a path tracer's packet answered for a path
    /// that has met only smooth surfaces (a camera ray, or its mirror and
    /// dielectric continuations): one of a pixel's nearly parallel rays,
    /// which Embree's coherent packets suit.
    Coherent(Ray),
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
/// [`take`](RayRecorder::take)n, each thread's in the order it asked them.
#[derive(Debug, Default)]
pub struct RayRecorder {
    queries: Mutex<HashMap<ThreadId, Vec<RayQuery>>>,
}

impl RayRecorder {
    /// An empty recorder.
    pub fn new() -> Self {
        Self::default()
    }

    /// The queries recorded so far, one thread's after another's, each
    /// thread's in its order (the recorder is empty afterwards).
    pub fn take(&self) -> Vec<RayQuery> {
        let logs = match self.queries.lock() {
            Ok(mut q) => std::mem::take(&mut *q),
            // A thread panicked while pushing: what it pushed is whole.
            Err(poisoned) => std::mem::take(&mut *poisoned.into_inner()),
        };
        logs.into_values().flatten().collect()
    }
}

impl RayObserver for RayRecorder {
    fn query(&self, q: RayQuery) {
        let id = std::thread::current().id();
        match self.queries.lock() {
            Ok(mut v) => v.entry(id).or_default().push(q),
            Err(poisoned) => poisoned.into_inner().entry(id).or_default().push(q),
        }
    }
}
