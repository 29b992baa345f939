//! qean-checkpoint: a run as the trainer leaves it, read by everything after the trainer. Run directories
//! and their checkpoints ([`checkpoint`], [`run_dir`]), weights and family state ([`weights`]), every
//! family's model loaded from a checkpoint through one `match` ([`registry`]), the conversions those
//! models' inputs and outputs need (the VQ-VAE's normalised pos72 rows, the GPT's frozen tokeniser and
//! music tokens, the in-betweener's drums and base), the dataset's music features computed on first use
//! ([`features`]) and the progress bars every long job shows. The trainer (qean-train) writes what this
//! crate reads; the sampler and the evaluation (qean-pipeline) read it without depending on the trainer.

pub mod checkpoint;
pub mod features;
pub mod genre_clf;
pub mod gpt;
pub mod inbetween;
pub mod progress;
pub mod registry;
pub mod run_dir;
pub mod tsmt;
pub mod vqvae;
pub mod weights;

pub use checkpoint::{resolve, resolve_in_run, Checkpoint};
pub use progress::ProgressMode;
pub use registry::FamilyModel;
