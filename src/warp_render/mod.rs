//! The warp renderer (`snell warp-render`) and the exact trace it is judged
//! against.
//!
//! Warp: every mesh is subdivided to a screen-space tolerance, every vertex
//! is moved to each of its images (`plate`, `tube`, `approx_tube`), and the
//! triangles whose three vertices have an image in the same family form that
//! family's warped copy (one Embree scene each). A pixel casts one straight
//! primary ray at its centre into the copies its ray class names (the
//! paper's depth peeling, done analytically by `WarpGlass::classify`) and
//! into the direct copy before the glass; the nearest hit wins.
//!
//! A triangle whose vertices land in different families (or have no image)
//! is in no copy: along the seams between families, and at the tube's
//! silhouette, a strip up to one subdivided triangle wide shows the
//! background. `Comparison::mismatched` counts those pixels.
//!
//! Exact: the same primary ray follows the glass exactly (`exact_path`:
//! refraction, TIR where it happens, no reflection branches), and each straight
//! piece is cast against the unwarped meshes.
//!
//! Both shade the surface point they show with the same unshadowed local
//! model (emission + reflectance × (constant environment + directional and
//! point lights with |cos|)), so their difference is the warp's error alone.
//!
//! Files: `prepare` (the meshes, subdivided), `vertex_images` (the
//! solvers per vertex), `pipeline` (the renderer: copies kept across
//! frames, packets of sixteen rays), `oneshot` (per-frame copies and single
//! rays: the pipeline's reference), `exact` (the exact trace), `shade`,
//! `rays`, `tiles`, `frame`, `compare` (warp against exact) and `run`
//! (`snell warp-render` as a library call).
mod compare;
mod exact;
mod frame;
mod oneshot;
pub mod pipeline;
mod prepare;
mod rays;
mod run;
mod shade;
mod tiles;
mod vertex_images;

pub use compare::{compare, Comparison};
pub use exact::{build_originals, render_exact, render_exact_packets, Originals};
pub use frame::{Frame, Shown};
pub use oneshot::{render_warped, warp_scene, Warped, WarpedCopy};
pub use prepare::{grid_scene, prepare, subdivide_once, with_grid, Prepared, WarpObject, MAX_WARP_TRIANGLES};
pub use run::{run, WarpReport, WarpRunOptions};
pub use vertex_images::{vertex_images, VertexImages, VertexSolver, MAX_IMAGES};
