//! snell: a ray tracer on Intel Embree 3 for refraction.
pub mod embree;
pub mod provenance;

/// The header line every benchmark prints first.
pub fn bench_header() -> String {
    format!("provenance: {}", provenance::line())
}
