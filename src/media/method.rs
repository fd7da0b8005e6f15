//! How a curved ray is integrated ([`Method`]), and which methods fit which
//! field.
use super::field::IndexField;
use super::{exact, invariant_cast, stratified, MediumError};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// How a curved ray is integrated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// Dormand–Prince 5(4), error-controlled by `tolerance` (metres per step).
    Rk45,
    /// Classical RK4 with a fixed arc-length step `step`.
    Rk4,
    /// The paper's horizontal layers of thickness `step`.
    Slab,
    /// The paper's fixed-length pieces of `step`.
    Length,
    /// The paper's Euler method (height steps of `step`).
    Euler,
    /// The paper's Runge–Kutta as printed (height steps of `step`), typos included.
    PaperRk4,
    /// Closed form (catenary) for linear and constant fields.
    Exact,
    /// Stratified fields traced by their invariant n·cos θ (closed forms or a
    /// 1-D quadrature, `stratified/`), chords only where geometry may be met,
    /// their deviation a fraction of the pixel footprint.
    Invariant,
}

impl Method {
    /// What a scene's `method = "auto"` (the default) means for `field`:
    /// `invariant` where n depends on height alone along a coordinate axis
    /// and the path has a closed form (linear and exponential profiles),
    /// rk45 otherwise: 3-D fields, oblique strata, and the fields that need
    /// the quadrature (inversion, profile), which costs more than rk45 today
    /// (mirage_sea 240×120×4: 24.7 s against 3.9 s, the same image).
    pub fn auto_for(field: &IndexField) -> Method {
        if stratified::has_closed_form(field) && check_method(field, Method::Invariant, "").is_ok() {
            Method::Invariant
        } else {
            Method::Rk45
        }
    }
}

impl Method {
    /// Every method, in the order of [`Method::name`]'s listing.
    pub const ALL: [Method; 8] = [
        Method::Rk45,
        Method::Rk4,
        Method::Slab,
        Method::Length,
        Method::Euler,
        Method::PaperRk4,
        Method::Exact,
        Method::Invariant,
    ];

    /// The name in scene files and JSON queries (`rk45`, `paper_rk4`, …);
    /// [`FromStr`] parses it back.
    pub fn name(self) -> &'static str {
        match self {
            Method::Rk45 => "rk45",
            Method::Rk4 => "rk4",
            Method::Slab => "slab",
            Method::Length => "length",
            Method::Euler => "euler",
            Method::PaperRk4 => "paper_rk4",
            Method::Exact => "exact",
            Method::Invariant => "invariant",
        }
    }

    /// One of the paper's piecewise-straight methods.
    pub fn is_paper(self) -> bool {
        matches!(
            self,
            Method::Slab | Method::Length | Method::Euler | Method::PaperRk4
        )
    }
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Method {
    type Err = MediumError;
    fn from_str(s: &str) -> Result<Method, MediumError> {
        Method::ALL.into_iter().find(|m| m.name() == s).ok_or_else(|| {
            MediumError::invalid(
                "medium.method",
                format!(
                    "expected one of rk45, rk4, slab, length, euler, paper_rk4, exact, invariant; got {s:?}"
                ),
            )
        })
    }
}

/// Checks that `method` can trace `field` (exact: linear/constant; paper: stratified).
///
/// # Errors
///
/// [`MediumError::Invalid`] at `key` when the field's kind does not fit the method.
pub fn check_method(field: &IndexField, method: Method, key: &str) -> Result<(), MediumError> {
    if method == Method::Exact && exact::linear_params(field).is_none() {
        return Err(MediumError::invalid(
            key,
            format!(
                "method exact has a closed form for linear and constant fields only, not {}",
                field.kind()
            ),
        ));
    }
    if method == Method::Invariant
        && field
            .strata()
            .and_then(|s| invariant_cast::up_axis(s.up))
            .is_none()
    {
        return Err(MediumError::invalid(
            key,
            format!(
                "method invariant needs a stratified field whose `up` lies along a coordinate axis, not {}",
                field.kind()
            ),
        ));
    }
    if method.is_paper() && field.strata().is_none() {
        return Err(MediumError::invalid(
            key,
            format!(
                "method {method} (from the paper) needs n to depend on height only, not a {}",
                field.kind()
            ),
        ));
    }
    Ok(())
}
