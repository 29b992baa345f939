//! qean-config: what a run is, as data. The `[model]` schema with every [DECISION] of SPEC §4,
//! the LR schedule, the whole run config (`[data]`, `[model]`, `[optim]`, `[schedule]`,
//! `[train]`) with `extends` chains and `--set` overrides, and the sweep planner.
//!
//! Plain Rust (no Burn), so configs can be read, checked and fuzzed without building a backend;
//! qean-models and qean-train re-export these modules under their old paths.

pub mod model;
pub mod recipe;
pub mod run;
pub mod schedule;
pub mod sweep;

pub use model::{ConfigError, ModelConfig};
pub use recipe::{AudioNorm, Predict, RecipeBase, RecipeConfig, RolloutMode};
pub use run::RunConfig;

/// Backend names a run config and `--backend` accept (qean-models builds the device).
pub const BACKENDS: [&str; 3] = ["flex", "ndarray", "wgpu"];

/// The default backend.
pub const DEFAULT_BACKEND: &str = "flex";
