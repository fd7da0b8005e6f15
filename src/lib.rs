//! snell: a ray tracer on Intel Embree 3 for refraction that other renderers
//! get wrong or make slow: nested dielectrics with priorities (false hits
//! skipped inside an Embree filter), curved rays in gradient-index media, and
//! analytic refraction warps. See DESIGN.md and docs/.
#![deny(unsafe_code)]

pub mod accum;
pub mod audit;
pub mod bench;
pub mod camera;
pub mod counters;
pub mod dielectric;
#[allow(unsafe_code)] // the one FFI module: every unsafe block says why it is sound
pub mod embree;
pub mod error;
pub mod farm;
pub mod fuzz;
pub mod image_io;
pub mod integrator;
pub mod media;
pub mod merge;
pub mod optics;
pub mod overrides;
pub mod part;
pub mod provenance;
pub mod ray;
pub mod render;
pub mod report;
pub mod sampling;
pub mod scene;
pub mod warp;

pub use error::{Error, Result};

/// The header line every benchmark prints first.
pub fn bench_header() -> String {
    format!("provenance: {}", provenance::line())
}
