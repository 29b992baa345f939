//! qean-config: what a run is, as data. The `[model]` schema with every [DECISION] of SPEC §4,
//! the LR schedule, the whole run config (`[data]`, `[model]`, `[optim]`, `[schedule]`,
//! `[train]`) with `extends` chains and `--set` overrides, and the sweep planner.
//!
//! Plain Rust (no Burn), so configs can be read, checked and fuzzed without building a backend;
//! qean-models and qean-train re-export these modules under their old paths.

pub mod genre;
pub mod genre_clf;
pub mod gpt;
pub mod inbetween;
pub mod keyframe;
pub mod model;
pub mod recipe;
pub mod run;
pub mod schedule;
pub mod spec;
pub mod sweep;
pub mod tsmt;
pub mod vqvae;

pub use model::{ConfigError, ModelConfig};
pub use recipe::{AudioNorm, Predict, RecipeBase, RecipeConfig, RolloutMode};
pub use run::RunConfig;
pub use spec::ModelSpec;

/// Backend names a run config and `--backend` accept (qean-models builds the device).
pub const BACKENDS: [&str; 3] = ["flex", "ndarray", "wgpu"];

/// The default backend.
pub const DEFAULT_BACKEND: &str = "flex";

/// The backend a run trains or samples on (`train.backend`, `--backend`); qean-models builds its device.
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Default,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum Backend {
    /// Burn's pure-Rust CPU backend (the default).
    #[default]
    Flex,
    /// The ndarray CPU backend, kept to cross-check flex.
    Ndarray,
    /// GPU through wgpu (Vulkan, Metal, DX12, GL); needs a build with `--features wgpu`.
    Wgpu,
}

impl Backend {
    pub fn name(self) -> &'static str {
        match self {
            Backend::Flex => "flex",
            Backend::Ndarray => "ndarray",
            Backend::Wgpu => "wgpu",
        }
    }
}

impl std::fmt::Display for Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Backend {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "flex" => Ok(Backend::Flex),
            "ndarray" => Ok(Backend::Ndarray),
            "wgpu" => Ok(Backend::Wgpu),
            other => Err(format!(
                "unknown backend `{other}`: expected one of {}",
                BACKENDS.join(", ")
            )),
        }
    }
}
