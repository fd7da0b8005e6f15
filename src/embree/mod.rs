//! The safe layer over Intel Embree 3: the only module of snell with `unsafe`
//! (besides the FFI crate `embree-sys` itself).
//!
//! What it offers, file by file:
//! - `device.rs`: [`Device`] with an error callback: Embree errors become
//!   [`EmbreeError`]s carrying Embree's message, never aborts and never silence.
//! - `scene.rs`: [`SceneBuilder`] → [`Scene`]: triangle meshes and user geometry,
//!   [`SceneFlags`], [`BuildQuality`], commit; single-ray [`Scene::intersect`] /
//!   [`Scene::occluded`] and their filtered variants, and [`Scene::check`].
//! - `user_geometry.rs`: analytic shapes ([`UserShape`], [`Bounds`],
//!   [`Candidates`]) as Embree user geometry: the bounds/intersect/occluded
//!   callbacks (one lane loop for both queries); panics caught in them are
//!   counted per geometry and reported by [`Scene::check`].
//! - `filter.rs`: a Rust [`HitFilter`] run as an Embree *context filter*
//!   through a trampoline, with the filter state carried in an extended
//!   `RTCIntersectContext` ([`FilterContext`], `#[repr(C)]`, Embree's context
//!   first); the inline `rtcInitIntersectContext` in Rust.
//! - `packet.rs`: ray packets ([`Packet8`], [`Packet16`], the [`RayPacket`]
//!   trait) for the path tracer's lanes, the warp renderer and the ceiling.
//! - `dynamic_mesh.rs`: [`DynamicMesh`], a mesh refitted frame by frame (the
//!   warp renderer's copies).
//! - `libc_clock.rs`: the C library's CPU clocks (not Embree; here so that
//!   all FFI is in one module), for [`crate::timing`].
//!
//! Rays and hits are [`Ray`] and [`Hit`] of [`crate::ray`] (re-exported here):
//! `org + t·dir` with t in units of `|dir|` (`dir` need not be unit length);
//! geometric normals unnormalised and as the geometry reports them (triangles:
//! `(v1-v0)×(v2-v0)`; analytic shapes: their own, out of closed solids).
//!
//! Soundness, in one place:
//! - Every handle (`RTCDevice`, `RTCScene`) is owned by exactly one RAII value
//!   and released once in `Drop` (`DeviceInner` in `device.rs`; `SceneBuilder`
//!   until commit, then `Scene`, in `scene.rs`). A `Scene` keeps its device
//!   alive through an `Arc`, so the device is released after all its scenes.
//! - A committed scene is immutable; Embree documents `rtcIntersect1` /
//!   `rtcOccluded1` on a committed scene as thread-safe, hence `Scene: Send + Sync`.
//!   `SceneBuilder` is `Send` but not `Sync` (geometry edits are not thread-safe).
//! - User-geometry shapes are boxed and owned by the builder, then the scene,
//!   so the `geometryUserPtr` Embree hands back to the callbacks of
//!   `user_geometry.rs` stays valid for the scene's life.
//! - The context a filtered query passes to Embree points at the whole
//!   `#[repr(C)]` `FilterContext` (not at its first field), so the trampoline
//!   in `filter.rs` may cast it back and reach the filter behind it. Every
//!   context with a filter function is a `FilterContext`, whose first field
//!   is a `#[repr(C)]` `FilterHead` (Embree's context, then the query's skip
//!   ranges, borrowed for the query): the analytic shapes' intersect
//!   callback reads the ranges through it without knowing the filter's type.
//! - Rays that Embree's `ray.valid()` would abort on never reach Embree
//!   ([`Ray::is_valid`]); filtered queries on scenes without the
//!   context-filter flag are refused ([`EmbreeError::NoContextFilterFlag`]).
//! - No panic crosses `extern "C"`: every callback body runs in `catch_unwind`.
//!   A panicking filter is reported as `Err` after the query; a panicking
//!   shape makes its query see a miss and is reported by [`Scene::check`].

mod device;
mod dynamic_mesh;
mod filter;
mod libc_clock;
mod packet;
mod scene;
mod user_geometry;

pub use crate::ray::{Hit, Ray};
pub use device::{Device, EmbreeError};
pub use dynamic_mesh::{Committed, DynamicMesh};
use filter::init_context;
pub use filter::{FilterContext, FilterHit, HitFilter, SkipRanges};
pub(crate) use libc_clock::{process_cpu_s, thread_cpu_s};
pub use packet::{Packet16, Packet8, PacketRays, RayPacket};
pub use scene::{BuildQuality, Scene, SceneBuilder, SceneFlags};
pub use user_geometry::{Bounds, Candidate, Candidates, LaneRay, UserShape};

/// `RTC_INVALID_GEOMETRY_ID` (a cast macro bindgen does not translate): the
/// geometry id of "no hit".
pub const INVALID_ID: u32 = u32::MAX;

/// Version of the Embree header snell was built against.
pub const EMBREE_VERSION: &str = embree_sys::HEADER_VERSION;
