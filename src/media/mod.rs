//! Gradient-index media: index fields, ray-equation integrators, the paper's methods
//! for comparison, and chord casting (a curved ray sent through Embree as straight
//! chords whose deviation from the true arc is bounded by a tolerance).
//!
//! Pure f64, no Embree. See docs/grin.md for the derivations.
//!
//! Here the one error type; `method` says how a curved ray is integrated,
//! `medium` is a bounded region with its settings, `curved_ray` a ray traced
//! through it chord by chord.
pub mod atmosphere;
mod curved_ray;
pub mod exact;
pub mod field;
mod flight;
pub mod footprint;
pub mod grin_trace;
pub mod invariant_cast;
mod medium;
mod method;
pub mod mirage_study;
pub mod obstacles;
pub mod profile;
pub mod quadrature;
pub mod state;
pub mod stepper;
pub mod stratified;
pub mod sun_connect;

pub use atmosphere::Atmosphere;
pub use curved_ray::{fly_camera_rays, Chord, ChordStart, CurvedRay};
pub use field::{Aabb, FeatureScale, IndexField, Strata};
pub use footprint::{ChordTolerance, Footprint};
pub use grin_trace::grin_trace_json;
pub use medium::{
    Medium, DEFAULT_FLIGHT_PIXEL_TOLERANCE, DEFAULT_INDIRECT_TOLERANCE_SCALE, DEFAULT_PIXEL_TOLERANCE,
    MAX_INDEX,
};
pub use method::{check_method, Method};
pub use obstacles::Obstacles;

/// A user-facing error: the key (e.g. `medium.tolerance`) and what was expected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MediumError {
    /// A parameter is out of range; printed as `key: message`.
    #[error("{key}: {message}")]
    Invalid {
        /// Dotted key of the parameter, e.g. `medium.field.h0` or `queries[3].method`.
        key: String,
        /// What was expected and what was found.
        message: String,
    },
}

impl MediumError {
    /// A [`MediumError::Invalid`] at `key`.
    pub fn invalid(key: impl Into<String>, message: impl Into<String>) -> MediumError {
        MediumError::Invalid {
            key: key.into(),
            message: message.into(),
        }
    }
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod stratified_tests;

#[cfg(test)]
mod flight_tests;
