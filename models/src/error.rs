//! The models crate's error: one line naming the weights file or the backend and the problem.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A weights file that cannot be written or read (missing, or from another model or config).
    #[error("{}: {message}", path.display())]
    Weights { path: PathBuf, message: String },
    /// A backend that is unknown, not in this build, or cannot start.
    #[error("{0}")]
    Backend(String),
    /// A config of another family than the model asked for (e.g. a TSMT run where FACT or QEAN is built).
    #[error("{0}")]
    Family(String),
}
