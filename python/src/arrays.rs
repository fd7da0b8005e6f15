//! (N, 3) NumPy arrays in and out of the solvers.
use glam::DVec3;
use numpy::ndarray::{Array1, Array2};
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArray2, PyArrayLikeDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// The rows of an (N, 3) array as points (any real dtype, any layout).
///
/// # Errors
/// `ValueError` naming `name` when the shape is not (N, 3).
pub fn points(name: &str, a: &PyArrayLikeDyn<'_, f64, AllowTypeChange>) -> PyResult<Vec<DVec3>> {
    let shape = a.shape();
    if shape.len() != 2 || shape[1] != 3 {
        return Err(PyValueError::new_err(format!(
            "{name}: expected an array of shape (N, 3), got {shape:?}"
        )));
    }
    let v = a.as_array();
    Ok(match v.as_slice() {
        Some(flat) => flat
            .chunks_exact(3)
            .map(|c| DVec3::new(c[0], c[1], c[2]))
            .collect(),
        None => v
            .outer_iter()
            .map(|r| DVec3::new(r[[0]], r[[1]], r[[2]]))
            .collect(),
    })
}

/// Points as a C-contiguous float64 array of shape (N, 3).
pub fn points_array<'py>(py: Python<'py>, p: &[DVec3]) -> Bound<'py, PyArray2<f64>> {
    let flat: Vec<f64> = p.iter().flat_map(|v| v.to_array()).collect();
    // The length is 3·N by construction.
    let a = Array2::from_shape_vec((p.len(), 3), flat).unwrap_or_else(|_| Array2::zeros((0, 3)));
    a.into_pyarray(py)
}

/// Flat x, y, z triples as a C-contiguous float64 array of shape (N, 3).
pub fn rows3(py: Python<'_>, flat: Vec<f64>) -> Bound<'_, PyArray2<f64>> {
    let n = flat.len() / 3;
    // The length is 3·N by construction.
    let a = Array2::from_shape_vec((n, 3), flat).unwrap_or_else(|_| Array2::zeros((0, 3)));
    a.into_pyarray(py)
}

/// A vector as a 1-D array.
pub fn array1<T: numpy::Element>(py: Python<'_>, v: Vec<T>) -> Bound<'_, PyArray1<T>> {
    Array1::from_vec(v).into_pyarray(py)
}
