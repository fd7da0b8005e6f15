//! `snell.read` and `snell.write`: images through the library's own readers
//! and writers (EXR linear float32, PNG sRGB 8-bit, written atomically).
use numpy::ndarray::Array3;
use numpy::AllowTypeChange;
use numpy::{IntoPyArray, PyArray3, PyArrayLikeDyn, PyUntypedArrayMethods};
use pyo3::exceptions::{PyOSError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// Read an image as linear RGB.
///
/// EXR files (``snell render -o x.exr``) are read exactly (float32, linear);
/// PNG and other 8-bit files are decoded from sRGB to linear, as the scene
/// loader reads textures; Radiance HDR as is.
///
/// Returns:
///     A C-contiguous float32 array of shape (height, width, 3), row 0 at the top.
///
/// Raises:
///     OSError: the file cannot be read or decoded.
#[pyfunction]
pub fn read(py: Python<'_>, path: PathBuf) -> PyResult<Bound<'_, PyArray3<f32>>> {
    let img = py
        .detach(|| snell::scene::texture::load_image(&path))
        .map_err(|e| PyOSError::new_err(format!("{}: {e}", path.display())))?;
    let flat: Vec<f32> = img.pixels.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
    let a = Array3::from_shape_vec((img.height, img.width, 3), flat)
        .map_err(|e| PyOSError::new_err(format!("{}: {e}", path.display())))?;
    Ok(a.into_pyarray(py))
}

/// Write an image, atomically (a temporary file renamed), as the CLI does.
///
/// Args:
///     path: ``.exr`` (linear float32, lossless; with ``aovs`` as extra
///         channels) or ``.png`` (sRGB 8-bit, clamped to [0, 1], no tone mapping).
///     image: linear RGB, shape (height, width, 3), any real dtype (stored as float32).
///     aovs: extra EXR channels, ``{name: array (height, width)}``.
///
/// Raises:
///     ValueError: the image or a layer has the wrong shape.
///     OSError: the extension is not .exr or .png, or the file cannot be written.
#[pyfunction]
#[pyo3(signature = (path, image, aovs=None))]
pub fn write(
    py: Python<'_>,
    path: PathBuf,
    image: PyArrayLikeDyn<'_, f32, AllowTypeChange>,
    aovs: Option<&Bound<'_, PyDict>>,
) -> PyResult<()> {
    let shape = image.shape().to_vec();
    if shape.len() != 3 || shape[2] != 3 || shape[0] == 0 || shape[1] == 0 {
        return Err(PyValueError::new_err(format!(
            "image: expected shape (height, width, 3), got {shape:?}"
        )));
    }
    let (h, w) = (shape[0], shape[1]);
    let view = image.as_array();
    let px: Vec<glam::Vec3A> = view
        .outer_iter()
        .flat_map(|row| {
            row.outer_iter()
                .map(|p| glam::Vec3A::new(p[[0]], p[[1]], p[[2]]))
                .collect::<Vec<_>>()
        })
        .collect();
    let mut layers: Vec<(String, Vec<f32>)> = Vec::new();
    if let Some(d) = aovs {
        for (k, v) in d.iter() {
            let name: String = k.extract()?;
            let a: PyArrayLikeDyn<'_, f32, AllowTypeChange> = v.extract().map_err(|e| {
                PyValueError::new_err(format!("aovs[{name:?}]: expected an array of numbers: {e}"))
            })?;
            if a.shape() != [h, w] {
                return Err(PyValueError::new_err(format!(
                    "aovs[{name:?}]: expected shape ({h}, {w}), got {:?}",
                    a.shape()
                )));
            }
            layers.push((name, a.as_array().iter().copied().collect()));
        }
    }
    let refs: Vec<(&str, &[f32])> = layers.iter().map(|(n, v)| (n.as_str(), v.as_slice())).collect();
    let (w32, h32) = (
        u32::try_from(w).map_err(|_| PyValueError::new_err("image: too wide"))?,
        u32::try_from(h).map_err(|_| PyValueError::new_err("image: too tall"))?,
    );
    py.detach(|| snell::image_io::save(&path, w32, h32, &px, &refs, &[]))
        .map_err(|e| crate::errors::lib_err(py, e))
}
