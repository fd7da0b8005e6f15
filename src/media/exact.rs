//! The closed-form ray in a linear field n = n0 + m·h (h = p·up − base).
//!
//! With the optical parameter τ (dτ = ds/n) the ray equation becomes
//! d²r/dτ² = n∇n = ∇(n²/2), and for ∇n = m·up it separates:
//! the component of v = n·t across `up` is constant, and n(τ) obeys n'' = m²n, so
//!
//! ```text
//! n(τ)      = n_s cosh(mτ) + w_s sinh(mτ)                 (w = v·up, the vertical part)
//! w(τ)      = n_s sinh(mτ) + w_s cosh(mτ)
//! h(τ) − h_s = w_s τ S(mτ) + n_s m τ²/2 · S(mτ/2)²          S(z) = sinh(z)/z
//! r⊥(τ)     = r⊥_s + v⊥ τ
//! s(τ)      = n_s τ S(mτ) + w_s m τ²/2 · S(mτ/2)²
//! ```
//!
//! a catenary in the plane of the ray and the gradient. Written with S(z) (a series
//! near 0) there is no cosh(mτ) − 1 cancellation, so m = 1e-6 /m is as accurate as
//! m = 1, and m = 0 is the straight line exactly.
use glam::DVec3;

use super::field::IndexField;
use super::state::{check_n, State};

/// sinh(z)/z without cancellation.
pub fn sinhc(z: f64) -> f64 {
    if z.abs() < 1e-3 {
        let z2 = z * z;
        1.0 + z2 / 6.0 * (1.0 + z2 / 20.0)
    } else {
        z.sinh() / z
    }
}

/// (m, up) of a linear (or constant) field.
pub fn linear_params(field: &IndexField) -> Option<(f64, DVec3)> {
    match *field {
        IndexField::Linear { m, up, .. } => Some((m, up)),
        IndexField::Constant { .. } => Some((0.0, DVec3::Y)),
        _ => None,
    }
}

/// Position, v and arc length at optical parameter τ from `st`.
pub fn at_tau(m: f64, up: DVec3, st: &State, tau: f64) -> (DVec3, DVec3, f64) {
    let ns = st.n;
    let ws = st.v.dot(up);
    let vperp = st.v - up * ws;
    let z = m * tau;
    let s1 = sinhc(z);
    let s2 = sinhc(z / 2.0);
    let half = 0.5 * m * tau * tau * s2 * s2;
    let dh = ws * tau * s1 + ns * half;
    let w = ns * m * tau * s1 + ws * z.cosh();
    let s = ns * tau * s1 + ws * half;
    (st.r + vperp * tau + up * dh, vperp + up * w, s)
}

/// τ at which the arc length from `st` equals `ell` (Newton on s(τ), ds/dτ = n > 0,
/// safeguarded by bisection).
pub fn tau_for_length(m: f64, up: DVec3, st: &State, ell: f64) -> f64 {
    if ell == 0.0 {
        return 0.0;
    }
    let ws = st.v.dot(up);
    let n_at = |tau: f64| st.n * (m * tau).cosh() + ws * (m * tau).sinh();
    let mut tau = ell / st.n;
    // Bracket [lo, hi]: s is increasing.
    let (mut lo, mut hi) = (0.0f64, f64::INFINITY);
    for _ in 0..100 {
        let (_, _, s) = at_tau(m, up, st, tau);
        let f = s - ell;
        if f > 0.0 {
            hi = hi.min(tau);
        } else {
            lo = lo.max(tau);
        }
        if f.abs() <= 1e-15 * ell.abs() {
            break;
        }
        let n = n_at(tau);
        let mut next = tau - f / n;
        if !(next > lo && next < hi && next.is_finite()) {
            next = if hi.is_finite() {
                0.5 * (lo + hi)
            } else {
                2.0 * tau.max(lo)
            };
        }
        if next == tau {
            break;
        }
        tau = next;
    }
    tau
}

/// The state after `ell` metres of arc from `st` in a linear field.
///
/// # Errors
///
/// A message when `field` is not linear or constant, or when n at the end point
/// is not finite or not > 0.
pub fn advance(field: &IndexField, st: &State, ell: f64) -> Result<State, String> {
    let (m, up) = linear_params(field).ok_or_else(|| {
        format!(
            "method exact needs a linear or constant field, not {}",
            field.kind()
        )
    })?;
    let tau = tau_for_length(m, up, st, ell);
    let (r, v, _) = at_tau(m, up, st, tau);
    let (n, g) = field.eval(r);
    check_n(n, r)?;
    Ok(State {
        r,
        t: v.normalize(),
        v,
        n,
        g,
        s: st.s + ell,
    })
}

/// Optical parameters τ > 0 where the vertical part of the direction vanishes
/// (a turning point: tanh(mτ) = −w_s/n_s).
pub fn turning_tau(m: f64, up: DVec3, st: &State) -> Option<f64> {
    let ws = st.v.dot(up);
    if m == 0.0 || ws == 0.0 {
        return None;
    }
    let x = -ws / st.n;
    if x.abs() >= 1.0 {
        return None;
    }
    let tau = x.atanh() / m;
    (tau > 0.0).then_some(tau)
}
