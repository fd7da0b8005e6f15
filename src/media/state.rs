//! The state of a curved ray at one point, shared by the numerical steppers
//! (stepper.rs) and the closed form for linear fields (exact.rs).
use super::field::IndexField;
use glam::DVec3;

/// The state of a ray at one point: position, unit tangent, v = n·t, and n, ∇n there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct State {
    /// Position, world metres.
    pub r: DVec3,
    /// Unit tangent (direction of travel).
    pub t: DVec3,
    /// v = n·t, the variable the ray equation integrates (|v| = n).
    pub v: DVec3,
    /// Index of refraction at `r`.
    pub n: f64,
    /// ∇n at `r`, per metre.
    pub g: DVec3,
    /// Arc length travelled since the launch.
    pub s: f64,
}

impl State {
    /// A state at p with unit direction d (evaluates the field once, counted in
    /// `evals`); arc length 0.
    ///
    /// # Errors
    ///
    /// A message naming the point when n at `p` is not finite or not > 0.
    pub fn new(field: &IndexField, p: DVec3, d: DVec3, evals: &mut u64) -> Result<State, String> {
        let (n, g) = field.eval(p);
        *evals += 1;
        check_n(n, p)?;
        Ok(State {
            r: p,
            t: d,
            v: d * n,
            n,
            g,
            s: 0.0,
        })
    }

    /// Radius of curvature n/|∇n ⊥ t| (infinite when the ray is locally straight).
    pub fn radius(&self) -> f64 {
        let gp = self.g - self.t * self.g.dot(self.t);
        let k = gp.length();
        if k > 0.0 {
            self.n / k
        } else {
            f64::INFINITY
        }
    }
}

pub(crate) fn check_n(n: f64, p: DVec3) -> Result<(), String> {
    if n.is_finite() && n > 0.0 {
        Ok(())
    } else {
        Err(format!(
            "index of refraction {n} at ({:.6}, {:.6}, {:.6}): expected a finite n > 0 along the ray",
            p.x, p.y, p.z
        ))
    }
}
