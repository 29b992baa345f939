//! The pipeline's error: what the layers below reported (each already names its file or sequence), or a
//! problem with the request itself. Printed as one line.

use std::fmt::Display;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// Files, datasets, checkpoints (qean-io's error, which names the file).
    #[error(transparent)]
    Io(#[from] qean_io::Error),
    /// The metrics.
    #[error(transparent)]
    Eval(#[from] qean_eval::Error),
    /// Building or running a model.
    #[error(transparent)]
    Models(#[from] qean_models::Error),
    /// A run configuration (names the file and the key).
    #[error(transparent)]
    Config(#[from] qean_config::ConfigError),
    /// A sampler request the loop cannot use.
    #[error(transparent)]
    Sample(#[from] qean_models::autoregress::SampleError<std::convert::Infallible>),
    /// A request the pipeline cannot serve (a bad tag, too few sequences, a child process that failed, ...).
    #[error("{0}")]
    Invalid(String),
}

pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// An error of the pipeline's own, in words.
    pub fn invalid(message: impl Into<String>) -> Self {
        Error::Invalid(message.into())
    }
}

/// What was being done, put before an error that comes from outside the workspace (a child process, JSON,
/// the file system) or before a missing value: one line, "what: why".
pub trait Context<T> {
    fn context(self, what: impl Display) -> Result<T>;
    fn with_context<S: Display>(self, what: impl FnOnce() -> S) -> Result<T>;
}

impl<T, E: Display> Context<T> for std::result::Result<T, E> {
    fn context(self, what: impl Display) -> Result<T> {
        self.map_err(|e| Error::Invalid(format!("{what}: {e}")))
    }
    fn with_context<S: Display>(self, what: impl FnOnce() -> S) -> Result<T> {
        self.map_err(|e| Error::Invalid(format!("{}: {e}", what())))
    }
}

impl<T> Context<T> for Option<T> {
    fn context(self, what: impl Display) -> Result<T> {
        self.ok_or_else(|| Error::Invalid(what.to_string()))
    }
    fn with_context<S: Display>(self, what: impl FnOnce() -> S) -> Result<T> {
        self.ok_or_else(|| Error::Invalid(what().to_string()))
    }
}

/// Returns early with [`Error::Invalid`] built like `format!` (also for the crates above: qean-bench).
#[macro_export]
macro_rules! bail {
    ($($arg:tt)*) => {
        return Err($crate::Error::Invalid(format!($($arg)*)))
    };
}

/// [`bail!`] unless the condition holds.
#[macro_export]
macro_rules! ensure {
    ($cond:expr, $($arg:tt)*) => {
        if !$cond {
            $crate::bail!($($arg)*);
        }
    };
}
pub use crate::{bail, ensure};
