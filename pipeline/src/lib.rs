//! qean-pipeline: the application layer that glues a trained checkpoint to what a user gets. [`generate`]
//! turns a checkpoint and songs into dances and their exports; [`evaluate`] is checkpoint mode of the
//! metrics (sample the test + val split, score it with `qean-eval`, write `R/eval/step-N/report.{json,md}`);
//! [`curves`] evaluates the checkpoints a curve still lacks; [`demo`] is `qean demo` (every stage, its tables
//! and verdicts; it trains through child `qean train` processes). Every entry point takes a typed request.
//! It reads runs through qean-checkpoint and never depends on the trainer (`qean bench`, which times the
//! trainer's update, is the qean-bench crate).

pub mod check_data;
pub mod curves;
pub mod demo;
pub mod edit;
pub mod error;
pub mod evaluate;
pub mod generate;
pub mod genre_clf;
pub mod genre_control;
pub mod gpt;
pub mod inbetween;
pub mod inbetween_benchmark;
pub mod keyframe_control;
pub mod keyframe_fidelity;
pub mod keyframe_settings;
pub mod keyframes;
pub mod text_quality;
pub mod tsmt;
pub mod view;
pub mod vqvae;

pub use error::{Error, Result};
