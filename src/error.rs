//! One error type with context: the file, the key path and the line:column.
use std::path::PathBuf;

/// Every error snell reports to a user.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene (or JSON query) file is malformed or has an invalid value.
    #[error("{file}:{line}:{column}: {key}: {message}")]
    Input {
        file: String,
        /// Key path such as `objects[2].material.ior` ("(document)" at top level).
        key: String,
        line: usize,
        column: usize,
        message: String,
    },
    /// Reading or writing a file failed.
    #[error("{}: {message}", path.display())]
    Io { path: PathBuf, message: String },
    /// Embree reported an error.
    #[error(transparent)]
    Embree(#[from] crate::embree::EmbreeError),
    /// Anything else a user asked for that cannot be done (with why).
    #[error("{0}")]
    Invalid(String),
}

impl Error {
    pub fn io(path: impl Into<PathBuf>, e: impl std::fmt::Display) -> Error {
        Error::Io {
            path: path.into(),
            message: e.to_string(),
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
