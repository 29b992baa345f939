//! One error type for the data crate: every error names the file it concerns (when there is one)
//! and says what is wrong, so the CLI can print it as a single line.

use std::fmt;
use std::path::{Path, PathBuf};

#[derive(Debug)]
pub struct Error {
    /// The file or directory the problem is about, if any.
    pub path: Option<PathBuf>,
    pub message: String,
}

pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// An error about `path`.
    pub fn at(path: impl AsRef<Path>, message: impl Into<String>) -> Self {
        Error {
            path: Some(path.as_ref().to_path_buf()),
            message: message.into(),
        }
    }

    /// An error not tied to a file (e.g. an invalid argument).
    pub fn msg(message: impl Into<String>) -> Self {
        Error {
            path: None,
            message: message.into(),
        }
    }

    /// An I/O error on `path`, worded for people ("no such file" rather than "os error 2").
    pub fn io(path: impl AsRef<Path>, err: std::io::Error) -> Self {
        use std::io::ErrorKind::*;
        let message = match err.kind() {
            NotFound => "no such file or directory".to_string(),
            PermissionDenied => "permission denied".to_string(),
            UnexpectedEof => "file is truncated".to_string(),
            _ => err.to_string(),
        };
        Error::at(path, message)
    }

    /// Attach a path to an error that has none yet.
    pub fn with_path(mut self, path: impl AsRef<Path>) -> Self {
        if self.path.is_none() {
            self.path = Some(path.as_ref().to_path_buf());
        }
        self
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.path {
            Some(p) => write!(f, "{}: {}", p.display(), self.message),
            None => write!(f, "{}", self.message),
        }
    }
}

impl std::error::Error for Error {}
