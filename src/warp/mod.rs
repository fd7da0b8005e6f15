//! Analytic refraction warps (Mukai et al.): move mesh vertices by Snell's law
//! so that straight primary rays see them where refraction would. The solvers
//! (`plate`, `tube`, `approx_tube`) are pure f64 with no Embree; the
//! primary-ray renderer on Embree and the exact trace it is judged against
//! are in `warp_render` (above the scene layer; these solvers are below it).
pub mod approx_tube;
pub mod glass;
pub mod plate;
pub mod points;
pub mod tube;
#[cfg(test)]
mod tube_tests;

pub use glass::{CopyKey, ExactPath, RayClass, Segment, WarpGlass};
pub use plate::{Plate, PlateImage, PlateStatus};
pub use tube::{CylImage, CylStatus, CylinderWarper, Family, HollowCylinder, SimdLevel};

/// How vertex images are found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WarpMethod {
    /// The exact 3-D solvers.
    Exact,
    /// Mukai et al.'s approximation (moving the eye C→B→A); the cylinder only.
    Paper,
}

/// A scene's `[warp]` table, validated.
#[derive(Debug, Clone)]
pub struct WarpSpec {
    /// The glass.
    pub glass: WarpGlass,
    /// The glass's own geometries in the render scene (skipped by the warp renderer).
    pub glass_geoms: Vec<u32>,
    /// Longest projected edge after subdivision, in pixels.
    pub subdivide: f64,
    /// Weight pixels by the Fresnel transmittance of their paths.
    pub fresnel: bool,
    /// How vertex images are found.
    pub method: WarpMethod,
}
