//! Analytic refraction warps (Mukai et al.): move mesh vertices by Snell's law
//! so that straight primary rays see them where refraction would. Pure f64,
//! no Embree. This stop has the parallel plate and the exact hollow cylinder;
//! the paper's approximate method, `warp-points` and the primary-ray renderer
//! are still to come (issue 7).
pub mod cylinder;
pub mod plate;
pub mod points;

pub use cylinder::{CylImage, CylStatus, Family, HollowCylinder};
pub use plate::{Plate, PlateImage, PlateStatus};
