//! Errors of the std layer: core errors and IO errors, with the file they concern.

use std::fmt;
use std::path::{Path, PathBuf};

/// An error from `rnd-std`, carrying the file (when there is one) and what is wrong.
#[derive(Debug)]
pub struct Error {
    /// The file concerned, if any.
    pub path: Option<PathBuf>,
    /// What went wrong.
    pub msg: String,
    /// The underlying IO error, if any.
    pub source: Option<std::io::Error>,
}

impl Error {
    /// A message without a file.
    pub fn msg(msg: impl Into<String>) -> Self {
        Error {
            path: None,
            msg: msg.into(),
            source: None,
        }
    }
    /// A message about `path`.
    pub fn at(path: &Path, msg: impl Into<String>) -> Self {
        Error {
            path: Some(path.to_path_buf()),
            msg: msg.into(),
            source: None,
        }
    }
    /// An IO error while doing `what` with `path`.
    pub fn io(path: &Path, what: &str, e: std::io::Error) -> Self {
        Error {
            path: Some(path.to_path_buf()),
            msg: format!("{what}: {e}"),
            source: Some(e),
        }
    }
    /// Sets the path if none is set.
    pub fn with_path(mut self, path: &Path) -> Self {
        if self.path.is_none() {
            self.path = Some(path.to_path_buf());
        }
        self
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.path {
            Some(p) if p.as_os_str() == "-" => write!(f, "(stdin): {}", self.msg),
            Some(p) => write!(f, "{}: {}", p.display(), self.msg),
            None => f.write_str(&self.msg),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.source.as_ref().map(|e| e as _)
    }
}

impl From<rnd_core::Error> for Error {
    fn from(e: rnd_core::Error) -> Self {
        Error::msg(e.msg)
    }
}

/// Result alias.
pub type Result<T> = std::result::Result<T, Error>;
