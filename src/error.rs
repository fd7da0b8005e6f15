//! One error type with context: the file, the key path and the line:column.
use std::path::PathBuf;

/// Every error snell reports to a user.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A scene (or JSON query) file is malformed or has an invalid value.
    #[error("{file}:{line}:{column}: {key}: {message}")]
    Input {
        /// The file name as given, or `--set 'KEY=VALUE'` for an override.
        file: String,
        /// Key path such as `objects[2].material.ior` ("(document)" at top level).
        key: String,
        /// 1-based line of the key or value in `file`.
        line: usize,
        /// 1-based column (in bytes) of the key or value on that line.
        column: usize,
        /// What was expected and what was found.
        message: String,
    },
    /// Reading or writing a file failed.
    #[error("{}: {message}", path.display())]
    Io {
        /// The file (or directory) that could not be read or written.
        path: PathBuf,
        /// Why, usually the operating system's error.
        message: String,
    },
    /// Embree reported an error.
    #[error(transparent)]
    Embree(#[from] crate::embree::EmbreeError),
    /// Anything else a user asked for that cannot be done (with why).
    #[error("{0}")]
    Invalid(String),
}

impl Error {
    /// An [`Error::Io`] at `path` with `e` as the message.
    pub fn io(path: impl Into<PathBuf>, e: impl std::fmt::Display) -> Error {
        Error::Io {
            path: path.into(),
            message: e.to_string(),
        }
    }
}

/// `Result` with snell's [`Error`] as the default error type.
pub type Result<T, E = Error> = std::result::Result<T, E>;
