//! snell's errors as Python exceptions. A scene that cannot be loaded raises
//! [`SceneError`] (a `ValueError`) whose message is the CLI's
//! (`file:line:column: key: message`) and whose attributes name the parts.
use pyo3::exceptions::{PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;

pyo3::create_exception!(
    snell,
    SceneError,
    PyValueError,
    "A scene (file, string, dict or override) that cannot be loaded.\n\n\
     The message is the command line's: ``file:line:column: key: message``\n\
     (``<dict>: key: message`` for a dict). Attributes: ``file`` (the file name,\n\
     ``<string>``, ``<dict>`` or ``--set 'KEY=VALUE'``), ``key`` (the key path,\n\
     e.g. ``objects[1].material.ior``), ``line`` and ``column`` (1-based, ``None``\n\
     for a dict), ``message`` (what was expected and what was found)."
);

/// Where a scene's text came from: a dict's text is generated, so its line
/// and column mean nothing to the user and are left out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TextKind {
    /// A file or a string the user wrote.
    Written,
    /// TOML generated from a dict.
    FromDict,
}

/// The label a dict scene's errors carry in place of a file name.
pub const DICT_LABEL: &str = "<dict>";

/// A [`SceneError`] with its attributes.
pub fn scene_error(
    py: Python<'_>,
    file: &str,
    key: &str,
    place: Option<(usize, usize)>,
    message: &str,
) -> PyErr {
    let text = match place {
        Some((line, column)) => format!("{file}:{line}:{column}: {key}: {message}"),
        None => format!("{file}: {key}: {message}"),
    };
    let err = SceneError::new_err(text);
    let value = err.value(py);
    let (line, column) = place.unzip();
    // Setting attributes on a fresh exception instance cannot fail short of
    // memory exhaustion; the message above carries the same facts regardless.
    let _ = value.setattr("file", file);
    let _ = value.setattr("key", key);
    let _ = value.setattr("line", line);
    let _ = value.setattr("column", column);
    let _ = value.setattr("message", message);
    err
}

/// A library error as a Python exception: [`SceneError`] for input errors,
/// `OSError` for files, `RuntimeError` for Embree, `ValueError` otherwise.
pub fn to_py(py: Python<'_>, e: snell::Error, kind: TextKind) -> PyErr {
    match e {
        snell::Error::Input {
            file,
            key,
            line,
            column,
            message,
        } => {
            let place = (kind == TextKind::Written || file != DICT_LABEL).then_some((line, column));
            scene_error(py, &file, &key, place, &message)
        }
        snell::Error::Io { path, message } => PyOSError::new_err(format!("{}: {message}", path.display())),
        e @ snell::Error::Embree(_) => PyRuntimeError::new_err(e.to_string()),
        snell::Error::Invalid(m) => PyValueError::new_err(m),
    }
}

/// `to_py` for errors that are never about a dict's text.
pub fn lib_err(py: Python<'_>, e: snell::Error) -> PyErr {
    to_py(py, e, TextKind::Written)
}
