//! The pipeline's error: what the layers below reported (each already names its file or sequence), or a
//! problem with the request itself. Printed as one line.

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
    /// A sampler request the loop cannot use.
    #[error(transparent)]
    Sample(#[from] qean_models::autoregress::SampleError<std::convert::Infallible>),
    /// A request the pipeline cannot serve (a bad tag, too few sequences, ...).
    #[error("{0}")]
    Invalid(String),
}

pub type Result<T> = std::result::Result<T, Error>;
