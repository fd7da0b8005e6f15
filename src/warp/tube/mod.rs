//! The hollow-cylinder warp (a thick glass tube, infinitely tall), exact in
//! 3-D (Mukai et al. work in 2-D).
//!
//! Reduction (a departure from the paper, which ignores the vertical
//! component): refraction at a vertical cylinder conserves `β = n·d_v` (the
//! index times the direction's component along the axis), because the normal
//! is horizontal. The horizontal projection then refracts like a 2-D ray with
//! effective indices `m = √(n² − β²)` (air: `√(1 − β²)`), and a horizontal
//! run `ℓ` in a medium climbs `ℓ·β/m`. In a rotationally symmetric medium the
//! 2-D "angular momentum" `m·b` (index × impact parameter) is conserved, so
//! the family of a ray follows from its impact parameter `b` in air
//! (`Family`). For a target P the unknowns are `b` and `β`, with two
//! equations: the final 2-D ray passes through P, and the path climbs to
//! P's height.
//!
//! Files, bottom up: `geometry` (the tube, its frame, the eye and target
//! descriptions), `family`, `path` (the final 2-D ray in closed form),
//! `image` (images from a solved (b, β)), `jacobian` (the residuals' closed
//! form Jacobian), `newton` (the damped Newton), `scan` (brackets from
//! sampled residuals), `robust` (`HollowCylinder::images`: one target, no
//! tables); the fast solver for many targets: `table`, `plan` (the
//! inverse table), `lanes` (the Newton steps in vector lanes, which
//! `polish` drives), `warper` (`CylinderWarper`). The solver's tests against
//! the exact 3-D trace are in `warp::tube_tests`.
mod family;
mod geometry;
mod image;
mod jacobian;
mod lanes;
mod newton;
mod path;
mod plan;
#[cfg(test)]
mod plan_tests;
mod polish;
mod robust;
mod scan;
mod table;
mod warper;

#[cfg(test)]
pub(crate) mod test_rng;

pub use family::Family;
pub(crate) use geometry::circle;
pub use geometry::HollowCylinder;
pub use image::{CylImage, CylStatus};
pub use lanes::SimdLevel;
pub use warper::CylinderWarper;
