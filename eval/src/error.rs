//! One error type for the metrics: each variant names the sequence or file it concerns and says what is
//! wrong, so the CLI prints it as one line.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error("sequence '{name}' has {frames} frame(s); the metrics need at least {min}")]
    TooShort {
        name: String,
        frames: usize,
        min: usize,
    },
    #[error("{set} set: {got} usable sequence(s), but {what} needs at least {needed}")]
    TooFewSequences {
        set: &'static str,
        what: &'static str,
        needed: usize,
        got: usize,
    },
    #[error("sequence '{name}': joint {joint} of frame {frame} is not finite ({value:?})")]
    NonFinite {
        name: String,
        frame: usize,
        joint: usize,
        value: [f64; 3],
    },
    #[error("sequence '{name}': {message}")]
    Sequence { name: String, message: String },
    #[error("{}: {message}", path.display())]
    File { path: PathBuf, message: String },
    #[error("{0}")]
    Invalid(String),
    /// What was being done when `inner` happened (e.g. "loading generated motions").
    #[error("{context}: {inner}")]
    Context { context: String, inner: Box<Error> },
}

pub type Result<T> = std::result::Result<T, Error>;

impl From<qean_io::Error> for Error {
    /// A file-format or I/O error of the layers below (they name the file when they know it).
    fn from(e: qean_io::Error) -> Self {
        match e.path {
            Some(p) => Error::file(p, e.message),
            None => Error::Invalid(e.message),
        }
    }
}

impl Error {
    /// This error, prefixed with what was being done.
    pub fn context(self, context: impl Into<String>) -> Self {
        Error::Context {
            context: context.into(),
            inner: Box::new(self),
        }
    }

    pub fn file(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Error::File {
            path: path.into(),
            message: message.into(),
        }
    }
}
