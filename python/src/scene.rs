//! `snell.load_file`, `snell.load_string`, `snell.load_dict` and the
//! `Scene` they return. A scene keeps its TOML text and overrides, so that
//! `Scene.set` applies one more `--set` to the same text and loads it again,
//! exactly as `snell render --set` does.
use crate::convert::{override_text, scene_toml, BadValue};
use crate::errors::{scene_error, to_py, TextKind, DICT_LABEL};
use pyo3::prelude::*;
use snell::scene::source::Source;
use snell::scene::{build_scene_text, BuildOptions, ImportOptions, RenderScene, SceneText};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A loaded scene: the geometry built in Embree, the camera, lights and
/// media, and the film (size, samples per pixel, seed) the file declares.
///
/// Made by :func:`load_file`, :func:`load_string` or :func:`load_dict`;
/// immutable (:meth:`set` returns a new scene). Render it with
/// :func:`snell.render`, trace single rays with :func:`snell.trace_path`.
#[pyclass(frozen, module = "snell")]
pub struct Scene {
    /// The file as given, `<string>` or `<dict>`.
    label: String,
    /// The TOML as given (before overrides), named as errors name it; for a
    /// glTF or Mitsuba file, the imported scene written as TOML, with the
    /// import (its warnings, and where each key came from in the file).
    text: Arc<SceneText>,
    /// Where relative file names (meshes, maps) are resolved.
    base_dir: PathBuf,
    kind: TextKind,
    /// `KEY=VALUE` overrides, in the order they were set.
    sets: Vec<String>,
    /// The text after overrides.
    resolved: String,
    pub(crate) scene: RenderScene,
}

impl Scene {
    fn load(
        py: Python<'_>,
        label: String,
        text: Arc<SceneText>,
        base_dir: PathBuf,
        kind: TextKind,
        sets: Vec<String>,
    ) -> PyResult<Scene> {
        let build = || -> snell::Result<(String, RenderScene)> {
            let src =
                snell::overrides::apply(Source::new(&text.source.file, text.source.text.clone()), &sets)?;
            let scene = build_scene_text(&text, &src, &base_dir, &BuildOptions::default())?;
            Ok((src.text, scene))
        };
        let (resolved, scene) = py.detach(build).map_err(|e| to_py(py, e, kind))?;
        Ok(Scene {
            label,
            text,
            base_dir,
            kind,
            sets,
            resolved,
            scene,
        })
    }
}

/// TOML text named `file` in errors (not imported).
fn written(file: &str, toml: String) -> Arc<SceneText> {
    Arc::new(SceneText {
        source: Source::new(file, toml),
        imported: None,
    })
}

fn bad_value(py: Python<'_>, file: &str, b: BadValue) -> PyErr {
    scene_error(py, file, &b.key, None, &b.message)
}

/// Load a scene file, as ``snell render`` reads it: snell TOML, glTF 2.0
/// (``.gltf``, ``.glb``) or Mitsuba 3 XML (``.xml``), the last two through
/// their importers (their warnings are in :attr:`Scene.warnings`,
/// :meth:`Scene.to_toml` is the imported scene).
///
/// Relative file names in it (meshes, textures, environment maps) are
/// resolved against the file's directory.
///
/// Raises:
///     SceneError: the file is not a valid scene; the message and the
///         attributes name the file, the key path (a JSON pointer in a glTF
///         file), the line and the column.
///     OSError: the file cannot be read.
#[pyfunction]
pub fn load_file(py: Python<'_>, path: PathBuf) -> PyResult<Scene> {
    let text = py
        .detach(|| SceneText::read(&path, &ImportOptions::default()))
        .map_err(|e| to_py(py, e, TextKind::Written))?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    Scene::load(
        py,
        path.display().to_string(),
        Arc::new(text),
        dir,
        TextKind::Written,
        Vec::new(),
    )
}

/// Load a scene from TOML text.
///
/// Args:
///     toml: the scene, in the format of a scene file.
///     base_dir: where relative file names are resolved (default: the
///         current directory).
///     name: the name errors give the text (default ``<string>``).
///
/// Raises:
///     SceneError: the text is not a valid scene (with line and column).
#[pyfunction]
#[pyo3(signature = (toml, base_dir=None, name="<string>"))]
pub fn load_string(py: Python<'_>, toml: String, base_dir: Option<PathBuf>, name: &str) -> PyResult<Scene> {
    Scene::load(
        py,
        name.to_string(),
        written(name, toml),
        base_dir.unwrap_or_else(|| PathBuf::from(".")),
        TextKind::Written,
        Vec::new(),
    )
}

/// Load a scene from a dict with the keys of the scene format.
///
/// Tables are dicts, ``[[objects]]`` and ``[[lights]]`` are lists of dicts,
/// vectors are lists, tuples or NumPy arrays; numbers may be Python or NumPy
/// scalars. Keys that should take their defaults are left out (``None`` is
/// refused).
///
/// Args:
///     scene: the scene dict.
///     base_dir: where relative file names are resolved (default: the
///         current directory).
///
/// Raises:
///     SceneError: an unknown key, a value of the wrong type or out of range,
///         a missing mesh file: ``file`` is ``<dict>``, ``key`` the key path
///         (e.g. ``objects[0].material.ior``), ``line`` and ``column`` None.
#[pyfunction]
#[pyo3(signature = (scene, base_dir=None))]
pub fn load_dict(py: Python<'_>, scene: &Bound<'_, PyAny>, base_dir: Option<PathBuf>) -> PyResult<Scene> {
    let text = scene_toml(scene).map_err(|b| bad_value(py, DICT_LABEL, b))?;
    Scene::load(
        py,
        DICT_LABEL.to_string(),
        written(DICT_LABEL, text),
        base_dir.unwrap_or_else(|| PathBuf::from(".")),
        TextKind::FromDict,
        Vec::new(),
    )
}

#[pymethods]
impl Scene {
    /// A new scene with one key overridden, as ``snell render --set KEY=VALUE``.
    ///
    /// ``key`` is a dotted path; entries of ``objects`` and ``lights`` are
    /// chosen by name (``objects.water.material.ior``) or index
    /// (``objects[2].shape.radius``); missing tables on the way are created.
    /// ``value`` is a bool, number, string, list or dict.
    ///
    /// Raises:
    ///     SceneError: the key does not fit the scene, or the value is
    ///         invalid there (located in the override, as the CLI does).
    fn set(&self, py: Python<'_>, key: &str, value: &Bound<'_, PyAny>) -> PyResult<Scene> {
        let label = format!("--set '{key}=…'");
        let text = override_text(value, key).map_err(|b| bad_value(py, &label, b))?;
        let mut sets = self.sets.clone();
        sets.push(format!("{key}={text}"));
        Scene::load(
            py,
            self.label.clone(),
            self.text.clone(),
            self.base_dir.clone(),
            self.kind,
            sets,
        )
    }

    /// Film width the scene declares, pixels.
    #[getter]
    fn width(&self) -> u32 {
        self.scene.width
    }

    /// Film height the scene declares, pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.scene.height
    }

    /// Samples per pixel the scene declares.
    #[getter]
    fn spp(&self) -> u32 {
        self.scene.spp
    }

    /// Seed of the sample generators the scene declares.
    #[getter]
    fn seed(&self) -> u64 {
        self.scene.seed
    }

    /// Names of the dielectric solids, in rank order of the nested rule's input.
    #[getter]
    fn solids(&self) -> Vec<String> {
        self.scene.solids.iter().map(|s| s.name.clone()).collect()
    }

    /// Warnings of the loader (the CLI prints them as ``warning: ...``).
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.scene.warnings.clone()
    }

    /// The overrides applied so far, as ``KEY=VALUE`` (``--set`` arguments).
    #[getter]
    fn overrides(&self) -> Vec<String> {
        self.sets.clone()
    }

    /// The scene as TOML text, overrides applied (what ``snell render``
    /// would read for the same scene).
    fn to_toml(&self) -> String {
        self.resolved.clone()
    }

    fn __repr__(&self) -> String {
        format!(
            "<snell.Scene {} {}x{} {} spp, {} solids{}>",
            self.label,
            self.scene.width,
            self.scene.height,
            self.scene.spp,
            self.scene.solids.len(),
            if self.sets.is_empty() {
                String::new()
            } else {
                format!(", overrides {:?}", self.sets)
            }
        )
    }
}
