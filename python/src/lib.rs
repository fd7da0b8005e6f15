//! The `snell._snell` extension module: Python bindings of the snell
//! library. It binds the library and holds no renderer logic of its own;
//! the Python package `snell` (beside this crate) re-exports it.
use pyo3::prelude::*;

mod arrays;
mod control;
mod convert;
mod errors;
mod grin;
mod image;
mod path;
mod render;
mod scene;
mod warp;

/// snell: a ray tracer on Intel Embree 3 for nested dielectrics, gradient-index
/// media and analytic refraction warps (native module; import ``snell``).
#[pymodule]
fn _snell(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("SceneError", py.get_type::<errors::SceneError>())?;
    m.add_class::<scene::Scene>()?;
    m.add_function(wrap_pyfunction!(scene::load_file, m)?)?;
    m.add_function(wrap_pyfunction!(scene::load_string, m)?)?;
    m.add_function(wrap_pyfunction!(scene::load_dict, m)?)?;
    m.add_class::<render::RenderResult>()?;
    m.add_function(wrap_pyfunction!(render::render, m)?)?;
    m.add_function(wrap_pyfunction!(render::render_result, m)?)?;
    m.add_function(wrap_pyfunction!(image::read, m)?)?;
    m.add_function(wrap_pyfunction!(image::write, m)?)?;
    m.add_function(wrap_pyfunction!(path::trace_path, m)?)?;
    m.add_class::<grin::GrinTrace>()?;
    m.add_function(wrap_pyfunction!(grin::trace, m)?)?;
    m.add_class::<warp::WarpImages>()?;
    m.add_function(wrap_pyfunction!(warp::plate, m)?)?;
    m.add_function(wrap_pyfunction!(warp::plate_positions, m)?)?;
    m.add_function(wrap_pyfunction!(warp::hollow_cylinder, m)?)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
