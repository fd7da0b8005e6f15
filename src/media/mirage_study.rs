//! The four methods of the CS 348b mirage study, reproduced as written (see
//! docs/grin.md). They assume a stratified field; the ray lives in the vertical plane
//! spanned by `up` and its horizontal direction `e`. In the paper's own variables the
//! independent variable x is the *height* (its eq. 4 evaluates the index "at height
//! x_{n+1}", its exact formula has a = n0 + m·x), y is the horizontal distance and Φ
//! the angle from the vertical, conserved as b = n·sinΦ (Snell).
//!
//! - `euler`: x_{k+1} = x_k ± h, Φ_{k+1} = asin(b/n(x_{k+1})), y += h·tan Φ_{k+1}.
//!   asin of more than 1 at a turning point is NaN in the paper: reported as an error.
//! - `slab`: horizontal layers of thickness h on a grid from `base`, each with the
//!   index at its upper boundary; Snell at every boundary, total internal reflection
//!   when Snell has no solution. For a rising ray launched on a boundary it is the
//!   Euler method step for step (the paper's table has identical columns).
//! - `length`: straight pieces of length h; Snell between the indices at the two ends
//!   of each piece (reflection when it has no solution).
//! - `paper_rk4`: the printed Runge–Kutta: k3 and k4 take x_n where y_n belongs (harmless:
//!   f = tan(asin(b/n(x))) does not depend on y) and the weights are 1/6, 1/6, 1/6, 1/6
//!   (they sum to 2/3: every horizontal advance is 2/3 of what it should be).
//!
//! All four keep b = n·sinΦ, so an exactly horizontal ray (Φ = 90°) is a fixed point:
//! it "stays straight forever" (returned as [`Seg::Forever`]).
use glam::DVec3;

use super::field::IndexField;
use super::stepper::State;
use super::Method;

/// One native step of a paper method.
#[derive(Debug, Clone, Copy)]
pub enum Seg {
    /// A straight piece to this state.
    To(State),
    /// The ray is horizontal: the method never changes it again.
    Forever,
}

fn snap(q: f64) -> f64 {
    let r = q.round();
    if (q - r).abs() < 1e-9 {
        r
    } else {
        q
    }
}

/// One step of `method` (slab, length, euler or paper_rk4) of size `h` from `st`.
///
/// # Errors
///
/// A message when the field is not stratified, `method` is not one of the four,
/// euler or paper_rk4 meet a turning point (asin of more than 1), the slab method
/// meets total internal reflection both ways, or n is not finite or not > 0 along
/// the step.
pub fn segment(
    field: &IndexField,
    method: Method,
    h: f64,
    st: &State,
    evals: &mut u64,
) -> Result<Seg, String> {
    let strata = field
        .strata()
        .ok_or_else(|| format!("method {method} needs a stratified field, not {}", field.kind()))?;
    let up = strata.up;
    let nh = |x: f64, evals: &mut u64| -> Result<f64, String> {
        *evals += 1;
        let n = field.n_h(x).map_or(f64::NAN, |v| v.0);
        if n.is_finite() && n > 0.0 {
            Ok(n)
        } else {
            Err(format!(
                "{method}: index {n} at height {x}: expected a finite n > 0"
            ))
        }
    };
    let x = st.r.dot(up) - strata.base;
    let tv = st.t.dot(up);
    let th = st.t - up * tv;
    let sin_phi = th.length().min(1.0);
    let e = if sin_phi > 0.0 {
        th / sin_phi
    } else {
        up.any_orthonormal_vector()
    };
    if tv == 0.0 {
        return Ok(Seg::Forever);
    }
    let sigma = tv.signum();
    let b = st.n * sin_phi;
    let dir = |sin_t: f64, sigma: f64| e * sin_t + up * (sigma * (1.0 - sin_t * sin_t).max(0.0).sqrt());
    let turning = |x: f64, arg: f64| {
        format!("{method}: turning point at height {x}: asin({arg}) is NaN (Snell has no solution; the paper's method cannot turn)")
    };
    let out = |r: DVec3, t: DVec3, n: f64| {
        let r0 = st.r;
        State {
            r,
            t,
            v: t * n,
            n,
            g: DVec3::ZERO,
            s: st.s + (r - r0).length(),
        }
    };
    match method {
        Method::Euler => {
            let x1 = x + sigma * h;
            let n1 = nh(x1, evals)?;
            let arg = b / n1;
            if arg > 1.0 {
                return Err(turning(x1, arg));
            }
            let phi = arg.asin();
            let r = st.r + up * (sigma * h) + e * (h * phi.tan());
            Ok(Seg::To(out(r, dir(arg, sigma), n1)))
        }
        Method::PaperRk4 => {
            // f(x, y) = tan Φ(x): the angle of refraction at height x. y is unused.
            let f = |x: f64, _y: f64, evals: &mut u64| -> Result<f64, String> {
                let arg = b / nh(x, evals)?;
                if arg > 1.0 {
                    return Err(turning(x, arg));
                }
                Ok(arg.asin().tan())
            };
            let hs = sigma * h;
            let y = 0.0;
            let k1 = h * f(x, y, evals)?;
            let k2 = h * f(x + hs / 2.0, y + k1 / 2.0, evals)?;
            let k3 = h * f(x + hs / 2.0, x + k2 / 2.0, evals)?; // sic: x_n for y_n
            let k4 = h * f(x + hs, x + k3, evals)?; // sic
            let dy = k1 / 6.0 + k2 / 6.0 + k3 / 6.0 + k4 / 6.0; // sic: 1/6 four times
            let n1 = nh(x + hs, evals)?;
            let arg = b / n1;
            if arg > 1.0 {
                return Err(turning(x + hs, arg));
            }
            let r = st.r + up * hs + e * dy;
            Ok(Seg::To(out(r, dir(arg, sigma), n1)))
        }
        Method::Length => {
            let r = st.r + st.t * h;
            let n1 = nh(x + tv * h, evals)?;
            let arg = b / n1;
            let t = if arg > 1.0 { th - up * tv } else { dir(arg, sigma) };
            Ok(Seg::To(out(r, t, n1)))
        }
        Method::Slab => {
            let mut sigma = sigma;
            let mut t = st.t;
            let mut n_cur = st.n;
            for _ in 0..2 {
                let q = snap(x / h);
                let k = if sigma > 0.0 { q.floor() } else { q.ceil() - 1.0 };
                let n_l = nh((k + 1.0) * h, evals)?;
                // Snell where the ray crosses a boundary; a ray launched inside a layer
                // simply takes the layer's index.
                let on_boundary = q == q.round();
                let arg = if on_boundary {
                    n_cur * sin_phi / n_l
                } else {
                    sin_phi
                };
                if arg > 1.0 {
                    // Total internal reflection at this boundary: stay in the layer
                    // we are in, go back.
                    sigma = -sigma;
                    t = e * sin_phi + up * (sigma * t.dot(up).abs());
                    continue;
                }
                t = dir(arg, sigma);
                n_cur = n_l;
                let xb = if sigma > 0.0 { (k + 1.0) * h } else { k * h };
                let dist = (xb - x) / t.dot(up);
                if !(dist.is_finite()) || t.dot(up) == 0.0 {
                    return Ok(Seg::Forever);
                }
                let r = st.r + t * dist.max(0.0);
                return Ok(Seg::To(out(r, t, n_cur)));
            }
            Err(format!("slab: total internal reflection both ways at height {x}"))
        }
        _ => Err(format!("{method} is not one of the paper's methods")),
    }
}
