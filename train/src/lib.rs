//! qean-train: training every model family (FACT, QEAN, TSMT, the in-betweener, the VQ-VAE, the GPT,
//! genre control, the genre classifier) from TOML run configs — run configs with `extends` and
//! `--set`, the training loop, LR schedules, metrics logs, atomic checkpoints with exact resume,
//! sweeps, and the safetensors export. What a run leaves (checkpoints, run directories, loading a
//! checkpoint's model) is read by qean-checkpoint, below this crate.

pub mod data;
pub mod ema;
pub mod export;
pub mod fact_qean;
pub mod family;
pub mod genre;
pub mod genre_clf;
pub mod gpt;
pub mod inbetween;
pub mod inspect;
pub mod keyframe;
pub mod logging;
pub mod metrics_log;
pub mod paper_table;
pub mod plot;
pub mod progress;
pub mod recipe;
pub mod registry;
pub mod resume;
pub mod sweep;
pub mod trainer;
pub mod tsmt;
pub mod vqvae;

pub use family::Family;
pub use registry::train;
pub use trainer::{train_family, Start, TrainOptions, TrainOutcome};
