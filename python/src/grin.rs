//! `snell.grin.trace`: rays in an unbounded gradient-index field, many at
//! once (rayon), each traced as one `snell grin-trace` query.
use crate::arrays::{array1, points, points_array};
use crate::convert::plain;
use glam::DVec3;
use numpy::{AllowTypeChange, PyArray1, PyArray2, PyArrayLikeDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;
use snell::media::grin_trace::{trace as trace_query, Query, Stop};
use snell::media::{check_method, IndexField, Method};

/// The end of every ray of :func:`snell.grin.trace`.
#[pyclass(frozen, module = "snell.grin")]
pub struct GrinTrace {
    /// End points, float64 (N, 3), metres (NaN where the ray failed).
    #[pyo3(get)]
    end: Py<PyArray2<f64>>,
    /// Unit tangents at the end points, float64 (N, 3) (NaN where the ray failed).
    #[pyo3(get)]
    direction: Py<PyArray2<f64>>,
    /// Arc length from the start to the end, float64 (N,), metres (NaN where failed).
    #[pyo3(get)]
    length: Py<PyArray1<f64>>,
    /// Field evaluations per ray, uint64 (N,) (n and ∇n at one point count once).
    #[pyo3(get)]
    evaluations: Py<PyArray1<u64>>,
    /// Integration steps (or pieces) per ray, uint64 (N,).
    #[pyo3(get)]
    steps: Py<PyArray1<u64>>,
    /// True where the ray reached its stop, bool (N,).
    #[pyo3(get)]
    ok: Py<PyArray1<bool>>,
    /// Per ray ``"ok"`` or why it failed (``key: message``, as ``snell
    /// grin-trace`` reports it without the ``queries[i].`` prefix).
    #[pyo3(get)]
    status: Vec<String>,
}

#[pymethods]
impl GrinTrace {
    fn __len__(&self) -> usize {
        self.status.len()
    }

    fn __repr__(&self) -> String {
        let ok = self.status.iter().filter(|s| *s == "ok").count();
        format!("<snell.grin.GrinTrace {} rays, {ok} ok>", self.status.len())
    }
}

/// Trace rays through a gradient-index field (no surfaces, no bounds).
///
/// Each ray is one ``snell grin-trace`` query, so the numbers are the same;
/// the rays are traced in parallel with the GIL released.
///
/// Args:
///     field: the index field, a dict as in a scene's ``[medium.field]``
///         (``{"kind": "linear", "n0": 1.0003, "m": -1e-5}``, ``"hot_ground"``,
///         ``"inversion"``, ``"exponential"``, ``"plume"``, ... see docs/grin.md).
///     origins: start points, (N, 3), metres.
///     directions: start directions, (N, 3) (need not be unit length).
///     method: ``"rk45"`` (default, error-controlled), ``"rk4"`` (fixed step),
///         ``"exact"`` (closed form, linear fields), or the paper's
///         ``"slab"``, ``"length"``, ``"euler"``, ``"paper_rk4"``.
///     length: stop after this arc length, metres. Exactly one of ``length``
///         and ``x`` is given.
///     x: stop where the ray crosses the plane x = X, metres.
///     tolerance: rk45's error tolerance, metres per step (default 1e-9).
///     step: the fixed-step methods' step, metres (default 0.01).
///     steps: a number of steps instead of ``step``.
///     max_length: give up after this arc length (default 1e6 m).
///
/// Returns:
///     A :class:`GrinTrace`: ``end``, ``direction``, ``length``,
///     ``evaluations``, ``steps``, ``ok`` arrays and a ``status`` list.
///
/// Raises:
///     ValueError: a malformed field, method or stop, or arrays of other
///         shapes than (N, 3). A ray that fails only sets its own status.
#[pyfunction]
#[pyo3(signature = (field, origins, directions, method="rk45", length=None, x=None, tolerance=None, step=None, steps=None, max_length=None))]
#[allow(clippy::too_many_arguments)]
pub fn trace(
    py: Python<'_>,
    field: &Bound<'_, PyAny>,
    origins: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    directions: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    method: &str,
    length: Option<f64>,
    x: Option<f64>,
    tolerance: Option<f64>,
    step: Option<f64>,
    steps: Option<u64>,
    max_length: Option<f64>,
) -> PyResult<GrinTrace> {
    let doc = plain(field, "field")
        .and_then(|p| p.to_json("field"))
        .map_err(|b| PyValueError::new_err(format!("{}: {}", b.key, b.message)))?;
    let field: IndexField =
        serde_json::from_value(doc).map_err(|e| PyValueError::new_err(format!("field: {e}")))?;
    let method: Method = serde_json::from_value(serde_json::Value::String(method.to_string()))
        .map_err(|e| PyValueError::new_err(format!("method: {e}")))?;
    let checked = field
        .validated("field")
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    check_method(&checked, method, "method").map_err(|e| PyValueError::new_err(e.to_string()))?;
    if length.is_some() == x.is_some() {
        return Err(PyValueError::new_err(
            "length, x: expected exactly one of them (the arc length or the plane x = X where rays stop)",
        ));
    }
    let starts = points("origins", &origins)?;
    let dirs = points("directions", &directions)?;
    if starts.len() != dirs.len() {
        return Err(PyValueError::new_err(format!(
            "origins and directions: expected as many rows, got {} and {}",
            starts.len(),
            dirs.len()
        )));
    }
    let answers: Vec<_> = py.detach(|| {
        starts
            .par_iter()
            .zip(&dirs)
            .map(|(&start, &direction)| {
                trace_query(&Query {
                    id: String::new(),
                    field: field.clone(),
                    start,
                    direction,
                    stop: Stop { x, s: length },
                    method,
                    tolerance,
                    step,
                    steps,
                    max_length,
                })
            })
            .collect()
    });
    let n = answers.len();
    let nan = DVec3::splat(f64::NAN);
    let (mut end, mut dir) = (Vec::with_capacity(n), Vec::with_capacity(n));
    let (mut len, mut evals, mut nsteps) = (
        Vec::with_capacity(n),
        Vec::with_capacity(n),
        Vec::with_capacity(n),
    );
    let (mut ok, mut status) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for a in answers {
        match a {
            Ok(a) => {
                end.push(a.end.unwrap_or(nan));
                dir.push(a.end_direction.unwrap_or(nan));
                len.push(a.arc_length.unwrap_or(f64::NAN));
                evals.push(a.evaluations);
                nsteps.push(a.steps);
                ok.push(true);
                status.push(a.status);
            }
            Err(e) => {
                end.push(nan);
                dir.push(nan);
                len.push(f64::NAN);
                evals.push(0);
                nsteps.push(0);
                ok.push(false);
                status.push(e);
            }
        }
    }
    Ok(GrinTrace {
        end: points_array(py, &end).unbind(),
        direction: points_array(py, &dir).unbind(),
        length: array1(py, len).unbind(),
        evaluations: array1(py, evals).unbind(),
        steps: array1(py, nsteps).unbind(),
        ok: array1(py, ok).unbind(),
        status,
    })
}
