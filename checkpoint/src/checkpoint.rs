//! `R/checkpoints/step-N/`: everything a run needs to continue exactly.
//!
//! - `model.bpk`: the weights (Burn burnpack);
//! - `optimizer.bpk`: Adam's moments and step counts;
//! - `state.json`: updates applied, the window stream's position, seeds, losses, the best
//!   checkpoint so far, the weights' hash;
//! - `config.toml`: the resolved run config.
//!
//! The RNGs: the window stream is a pure function of (seed, epoch, position), stored here;
//! dropout draws from the device RNG, which the trainer reseeds from (seed, step) before every
//! update; the initialisation is seeded once at step 0. So these files fix every random draw
//! of the rest of the run.
//!
//! A checkpoint is written into a hidden temporary directory and renamed into place: a kill at
//! any moment leaves complete checkpoints only.

use std::path::{Path, PathBuf};

use qean_aistpp::windows::SamplerState;
use qean_io::error::{Error, Result};
use serde::{Deserialize, Serialize};

use crate::run_dir;
use qean_config::run::RunConfig;
use qean_config::ModelSpec;

pub const MODEL_FILE: &str = "model.bpk";
pub const OPTIMIZER_FILE: &str = "optimizer.bpk";
/// The moving average of the weights (runs with `train.ema_decay` > 0): what samplers load.
pub const EMA_FILE: &str = "ema.bpk";
pub const STATE_FILE: &str = "state.json";
pub const CONFIG_FILE: &str = "config.toml";
/// Version of the checkpoint layout.
pub const FORMAT: u32 = 1;

/// The best checkpoint by validation loss.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Best {
    pub step: u64,
    pub val_loss: f64,
}

/// `state.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TrainerState {
    pub format: u32,
    /// Updates applied.
    pub step: u64,
    /// The run length the schedule was computed for.
    pub total_steps: u64,
    /// `train.seed`: initialisation, window stream and per-update dropout seeds derive from it.
    pub seed: u64,
    /// Position of the window stream.
    pub sampler: SamplerState,
    /// Learning rate of the next update.
    pub next_lr: f64,
    /// Training loss of the last update.
    pub last_loss: Option<f64>,
    /// Validation loss at this step, when computed.
    pub val_loss: Option<f64>,
    /// Best validation loss so far.
    pub best: Option<Best>,
    /// Training wall-clock seconds so far (all sessions).
    pub elapsed_seconds: f64,
    /// [`qean_models::params::params_hash`] of the saved weights.
    pub params_hash: String,
    /// The same of the weights' moving average (`ema.bpk`), for runs that keep one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ema_params_hash: Option<String>,
    /// Backend that produced it.
    pub backend: String,
}

/// A checkpoint on disk, read.
#[derive(Debug, Clone)]
pub struct Checkpoint {
    pub dir: PathBuf,
    pub config: RunConfig,
    pub state: TrainerState,
}

impl Checkpoint {
    /// The hash of the weights samplers load: the moving average's where the run recorded one, else
    /// the trained weights' (what a frozen stage and a reused dance must match).
    pub fn sampled_hash(&self) -> &str {
        self.state
            .ema_params_hash
            .as_deref()
            .unwrap_or(&self.state.params_hash)
    }

    /// Reads `state.json` and `config.toml` of a checkpoint directory.
    pub fn read(dir: &Path) -> Result<Checkpoint> {
        if !dir.is_dir() {
            return Err(Error::at(dir, "no such checkpoint directory"));
        }
        let state_path = dir.join(STATE_FILE);
        let text = std::fs::read_to_string(&state_path).map_err(|e| Error::io(&state_path, e))?;
        let state: TrainerState = serde_json::from_str(&text)
            .map_err(|e| Error::at(&state_path, format!("malformed trainer state: {e}")))?;
        if state.format != FORMAT {
            return Err(Error::at(
                &state_path,
                format!(
                    "checkpoint format {} (this build reads {FORMAT})",
                    state.format
                ),
            ));
        }
        let config_path = dir.join(CONFIG_FILE);
        let config = RunConfig::load(&config_path, &[]).map_err(|e| Error::msg(e.to_string()))?;
        let ema = (config.train.ema_decay > 0.0).then_some(EMA_FILE);
        for f in [MODEL_FILE, OPTIMIZER_FILE].into_iter().chain(ema) {
            if !dir.join(f).is_file() {
                return Err(Error::at(dir.join(f), "missing from the checkpoint"));
            }
        }
        Ok(Checkpoint {
            dir: dir.to_path_buf(),
            config,
            state,
        })
    }

    /// The architecture tables as TOML: the family's own (`[model]` for FACT and QEAN).
    pub fn architecture_toml(&self) -> String {
        let part = |t: std::result::Result<String, toml::ser::Error>| t.expect("configs serialise");
        match self.config.spec() {
            ModelSpec::GptGenre(g, c) => format!(
                "[gpt]\n{}\n[genre]\n{}",
                part(toml::to_string(g)),
                part(toml::to_string(c))
            ),
            ModelSpec::GptKeyframe(g, k) => format!(
                "[gpt]\n{}\n[keyframe]\n{}",
                part(toml::to_string(g)),
                part(toml::to_string(k))
            ),
            ModelSpec::FactQean(m) => part(toml::to_string(m)),
            ModelSpec::Tsmt(t) => part(toml::to_string(t)),
            ModelSpec::Inbetween(i) => part(toml::to_string(i)),
            ModelSpec::Vqvae(v) => part(toml::to_string(v)),
            ModelSpec::Gpt(g) => part(toml::to_string(g)),
            ModelSpec::GenreClf(g) => part(toml::to_string(g)),
        }
    }

    /// Refuses to continue these weights as another model: the error names the checkpoint and the
    /// first differing `[model]` line.
    pub fn check_model(&self, model: &qean_config::ModelConfig) -> Result<()> {
        if self.config.model == *model {
            return Ok(());
        }
        self.check_different(model)
    }

    /// [`Checkpoint::check_model`] for a whole run config: TSMT runs compare their `[tsmt]` sizes
    /// (bins and sampling settings may differ).
    pub fn check_config(&self, config: &qean_config::RunConfig) -> Result<()> {
        self.check_model(&config.model)?;
        if let (Some(a), Some(b)) = (&self.config.inbetween, &config.inbetween) {
            let shape = |c: &qean_config::inbetween::InbetweenConfig| {
                (
                    c.variant,
                    c.hidden,
                    c.heads,
                    c.ffn,
                    c.layers,
                    c.audio_layers,
                    c.max_len,
                    c.decoder,
                    c.merge_axis,
                    c.include_jb && c.variant == qean_config::inbetween::Variant::Genre,
                )
            };
            self.same_shape(
                "in-betweener",
                shape(a),
                shape(b),
                "variant, hidden, heads, ffn, layers, audio_layers, max_len, decoder, merge_axis, include_jb (genre)",
            )?;
        }
        if let (Some(a), Some(b)) = (&self.config.genre_clf, &config.genre_clf) {
            self.same_shape(
                "genre classifier",
                (a.width, a.genres),
                (b.width, b.genres),
                "width, genres",
            )?;
        }
        self.check_control_shapes(config)?;
        let shape = |c: &qean_config::RunConfig| {
            c.tsmt.clone().map(|t| qean_config::tsmt::TsmtConfig {
                bins_lo: Vec::new(),
                bins_hi: Vec::new(),
                temperature: 1.0,
                top_k: 0,
                slide_stride: 1,
                seed_frames: 1,
                lr_start_factor: 1.0,
                ik: Default::default(),
                dropout: 0.0,
                windows: Default::default(),
                // Training recipe and sampling keys: the same weights either way.
                target_sigma: 0.0,
                input_noise: 0.0,
                decode: Default::default(),
                subbin_radius: 0,
                coherent_seconds: 0.0,
                upsample: Default::default(),
                smooth_sigma: 0.0,
                ..t
            })
        };
        let (a, b) = (shape(&self.config), shape(config));
        if a == b {
            return Ok(());
        }
        let text = |t: &Option<qean_config::tsmt::TsmtConfig>| {
            t.as_ref()
                .map(|t| toml::to_string(t).unwrap_or_default())
                .unwrap_or_default()
        };
        let (ta, tb) = (text(&a), text(&b));
        let line = ta
            .lines()
            .zip(tb.lines())
            .find(|(x, y)| x != y)
            .map(|(x, y)| format!("{x} (checkpoint) vs {y}"))
            .unwrap_or_else(|| "[tsmt] differs".into());
        Err(Error::at(
            &self.dir,
            format!("the checkpoint is another TSMT model: {line}"),
        ))
    }

    /// The multi-modal control families' sizes: `[gpt]`, `[genre]`, `[vq]`.
    fn check_control_shapes(&self, config: &qean_config::RunConfig) -> Result<()> {
        if let (Some(a), Some(b)) = (&self.config.gpt, &config.gpt) {
            self.same_shape(
                "GPT",
                a.shape(),
                b.shape(),
                qean_config::gpt::GptConfig::SHAPE_FIELDS,
            )?;
        }
        if let (Some(a), Some(b)) = (&self.config.keyframe, &config.keyframe) {
            self.same_shape("keyframe module", a.weights, b.weights, "weights")?;
        }
        if let (Some(a), Some(b)) = (&self.config.genre, &config.genre) {
            let shape = |c: &qean_config::genre::GenreConfig| {
                (
                    c.code_dim,
                    c.z_dim,
                    c.tokens,
                    c.xattn_on,
                    c.disc_width,
                    c.disc_layers,
                    c.disc_ff,
                    c.disc_heads,
                    c.genres,
                )
            };
            self.same_shape(
                "genre module",
                shape(a),
                shape(b),
                "code_dim, z_dim, tokens, xattn_on, disc_width, disc_layers, disc_ff, disc_heads, genres",
            )?;
        }
        if let (Some(a), Some(b)) = (&self.config.vq, &config.vq) {
            let shape = |c: &qean_config::vqvae::VqConfig| {
                (
                    c.width,
                    c.code_dim,
                    c.codes,
                    c.depth,
                    c.down_t,
                    c.enc_dilations,
                    c.decoder,
                    c.quantizer,
                )
            };
            self.same_shape(
                "VQ-VAE",
                shape(a),
                shape(b),
                "width, code_dim, codes, depth, down_t, enc_dilations, decoder, quantizer",
            )?;
        }
        Ok(())
    }

    /// An error naming the family and the differing sizes when a section's shape changed.
    fn same_shape<T: PartialEq + std::fmt::Debug>(
        &self,
        family: &str,
        checkpoint: T,
        config: T,
        fields: &str,
    ) -> Result<()> {
        if checkpoint == config {
            return Ok(());
        }
        Err(Error::at(
            &self.dir,
            format!(
                "the checkpoint is another {family}: {checkpoint:?} (checkpoint) vs {config:?} ({fields})"
            ),
        ))
    }

    fn check_different(&self, model: &qean_config::ModelConfig) -> Result<()> {
        let a = toml::to_string(&self.config.model).unwrap_or_default();
        let b = toml::to_string(model).unwrap_or_default();
        let diff = a
            .lines()
            .zip(b.lines())
            .find(|(x, y)| x != y)
            .map(|(x, y)| format!(" (checkpoint `{x}`, config `{y}`)"))
            .unwrap_or_default();
        Err(Error::at(
            &self.dir,
            format!("the checkpoint holds a different model than the config{diff}"),
        ))
    }

    /// The run directory holding this checkpoint (`R` of `R/checkpoints/step-N`).
    pub fn run_dir(&self) -> Option<PathBuf> {
        let parent = self.dir.parent()?;
        (parent.file_name()? == run_dir::CHECKPOINTS)
            .then(|| parent.parent().map(Path::to_path_buf))?
    }
}

/// Resolves what a user named: a checkpoint directory (`R/checkpoints/step-N`), or a run
/// directory `R` (its newest complete checkpoint). Errors name the path.
pub fn resolve(path: &Path) -> Result<Checkpoint> {
    if path.join(STATE_FILE).is_file() {
        return Checkpoint::read(path);
    }
    if !path.is_dir() {
        return Err(Error::at(path, "no such run or checkpoint directory"));
    }
    let list = run_dir::list_checkpoints(path)?;
    // Newest first; a directory that does not read (e.g. damaged by hand) is skipped with a warning.
    for (_, dir) in list.iter().rev() {
        match Checkpoint::read(dir) {
            Ok(c) => return Ok(c),
            Err(e) => tracing::warn!("skipping unreadable checkpoint: {e}"),
        }
    }
    Err(Error::at(
        path,
        "holds no checkpoint (expected a run directory with checkpoints/step-N/ or a step-N directory)",
    ))
}

/// Resolves a run that a run's config links to (`gpt.vqvae_run`, `genre.gpt_run`): as written (absolute,
/// or relative to the current directory), else, when the link is relative and `owner` (the run that
/// names it) is given, beside that run: `OWNER/../NAME`. So a demo's `runs/gpt` finds its `runs/vq`
/// wherever the demo directory is and whichever directory the command runs in.
pub fn resolve_linked(link: &Path, owner: Option<&Path>) -> Result<Checkpoint> {
    if link.is_absolute() || link.exists() {
        return resolve(link);
    }
    let beside = owner
        .and_then(Path::parent)
        .zip(link.file_name())
        .map(|(runs, name)| runs.join(name));
    match beside {
        Some(b) if b.exists() => resolve(&b),
        Some(b) => Err(Error::at(
            link,
            format!(
                "no such run or checkpoint directory here, nor beside the run that names it ({})",
                b.display()
            ),
        )),
        None => resolve(link),
    }
}

/// Resolves a run directory plus an optional checkpoint name (`step-N`, `N` or a path).
pub fn resolve_in_run(run: &Path, checkpoint: Option<&str>) -> Result<Checkpoint> {
    match checkpoint {
        None => resolve(run),
        Some(name) => {
            let as_path = Path::new(name);
            if as_path.join(STATE_FILE).is_file() {
                return Checkpoint::read(as_path);
            }
            let name = if name.chars().all(|c| c.is_ascii_digit()) {
                format!("step-{name}")
            } else {
                name.to_string()
            };
            Checkpoint::read(&run.join(run_dir::CHECKPOINTS).join(name))
        }
    }
}
