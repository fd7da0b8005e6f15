//! glTF 2.0 scenes (placeholder until the importer lands).
use super::{ImportOptions, Imported};
use crate::error::{Error, Result};
use crate::scene::shapes::Mesh;
use std::path::Path;

/// Import a glTF scene.
pub fn import(path: &Path, _opts: &ImportOptions) -> Result<Imported> {
    Err(Error::Invalid(format!(
        "{}: glTF import is not available",
        path.display()
    )))
}

/// One primitive of a glTF mesh.
pub fn load_primitive(
    _path: &Path,
    _mesh: u64,
    _prim: u64,
    _smooth: bool,
) -> Result<Mesh, (&'static str, String)> {
    Err(("file", "glTF meshes are not available".into()))
}
