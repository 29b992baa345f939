//! One TOML file describes a training run: `[data]`, `[model]` (qean-models' schema), `[optim]`,
//! `[schedule]` and `[train]`. Presets share defaults through `extends = "parent.toml"`, and
//! `--set key.path=value` overrides any field from the command line.
//!
//! Every table is checked per file, so an unknown key or a wrong type is reported with the file
//! and line it is on; an override is reported with the `--set` that carries it.

use std::path::{Path, PathBuf};

use crate::model::{load_merged_table_checked, Arch, ConfigError, ModelConfig};
use crate::spec::ModelSpec;
use qean_aistpp::dataset::Split;
use qean_aistpp::windows::WindowSpec;
use qean_motion::motion::Layout;
use serde::{Deserialize, Serialize};

use crate::genre::GenreConfig;
use crate::genre_clf::GenreClfConfig;
use crate::gpt::GptConfig;
use crate::inbetween::InbetweenConfig;
use crate::keyframe::KeyframeConfig;
use crate::recipe::RecipeConfig;
use crate::schedule::ScheduleConfig;
use crate::tsmt::TsmtConfig;
use crate::vqvae::VqConfig;

/// `[data]`: where the dataset is (AIST++, FineDance or a folder of dances) and which splits to use.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DataConfig {
    /// Dataset directory (its layout is detected; `qean synth` makes one). Relative paths are relative to the
    /// working directory; the resolved config stores it absolute.
    pub dir: Option<PathBuf>,
    /// Split the windows are drawn from.
    pub train_split: Split,
    /// Split for the teacher-forced validation loss (`""` turns validation off).
    #[serde(with = "split_or_none")]
    pub val_split: Option<Split>,
}

/// `val_split` in TOML: a split name, or `""` for none (TOML has no null).
mod split_or_none {
    use qean_aistpp::dataset::Split;
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(v: &Option<Split>, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(v.map_or("", Split::name))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<Split>, D::Error> {
        let text = String::deserialize(d)?;
        if text.is_empty() {
            return Ok(None);
        }
        text.parse().map(Some).map_err(serde::de::Error::custom)
    }
}

impl Default for DataConfig {
    fn default() -> Self {
        DataConfig {
            dir: None,
            train_split: Split::Train,
            val_split: Some(Split::Val),
        }
    }
}

/// `[optim]`: Adam (Burn's update: ε added to the bias-corrected √v̂, PyTorch's form; SPEC §4.8).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OptimConfig {
    pub beta1: f64,
    pub beta2: f64,
    /// Set explicitly: Burn's own default is 1e-5 (PyTorch 1e-8, Keras 1e-7).
    pub epsilon: f64,
    /// L2 penalty added to the gradient (0 = none, as both papers).
    pub weight_decay: f64,
    /// Clip the global gradient norm to this value (0 = no clipping, as both papers).
    pub grad_clip_norm: f64,
}

impl Default for OptimConfig {
    fn default() -> Self {
        OptimConfig {
            beta1: 0.9,
            beta2: 0.999,
            epsilon: 1e-8,
            weight_decay: 0.0,
            grad_clip_norm: 0.0,
        }
    }
}

/// `[train]`: run length, batch, seed, intervals.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TrainConfig {
    /// Number of updates.
    pub steps: u64,
    pub batch_size: usize,
    /// Seeds the initialisation, the window stream and dropout.
    pub seed: u64,
    /// Write a checkpoint every this many updates (and at the end).
    pub checkpoint_every: u64,
    /// Log a metrics.csv row every this many updates.
    pub log_every: u64,
    /// Validation loss every this many updates (0 = only at checkpoints).
    pub val_every: u64,
    /// Checkpoints kept: the last `keep_last`, plus the best by validation loss.
    pub keep_last: usize,
    /// Decay of an exponential moving average of the weights (0 = none): with one, every checkpoint also
    /// holds `ema.bpk`, and validation, sampling and evaluation use it; training itself is unchanged.
    pub ema_decay: f64,
    /// Backend the run trains on: flex (CPU, default), ndarray (CPU; needs the `ndarray` build) or wgpu (GPU;
    /// needs the `wgpu` build).
    pub backend: crate::Backend,
}

impl Default for TrainConfig {
    fn default() -> Self {
        TrainConfig {
            steps: 500_000,
            batch_size: 16,
            seed: 0,
            checkpoint_every: 1000,
            log_every: 10,
            val_every: 1000,
            keep_last: 3,
            ema_decay: 0.0,
            backend: crate::Backend::Flex,
        }
    }
}

impl TrainConfig {
    /// Every count at least 1 and the average's decay in [0, 1).
    pub fn validate(&self) -> Result<(), String> {
        for (key, value) in [
            ("steps", self.steps),
            ("batch_size", self.batch_size as u64),
            ("checkpoint_every", self.checkpoint_every),
            ("log_every", self.log_every),
            ("keep_last", self.keep_last as u64),
        ] {
            if value == 0 {
                return Err(format!("train.{key} must be at least 1"));
            }
        }
        if !(0.0..1.0).contains(&self.ema_decay) {
            return Err(format!(
                "train.ema_decay must be in [0, 1), got {}",
                self.ema_decay
            ));
        }
        Ok(())
    }
}

/// A whole run config.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct RunConfig {
    pub data: DataConfig,
    pub model: ModelConfig,
    pub optim: OptimConfig,
    pub schedule: ScheduleConfig,
    pub train: TrainConfig,
    /// Remedies against freezing and jitter (default: mint's plain recipe).
    pub recipe: RecipeConfig,
    /// Li et al.'s two-stream motion transformer (`model.arch = "tsmt"` only; written only then).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tsmt: Option<TsmtConfig>,
    /// Lin's transformer in-betweeners (`model.arch = "inbetween"` only; written only then).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub inbetween: Option<InbetweenConfig>,
    /// The motion VQ-VAE (`model.arch = "vqvae"` only; written only then).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub vq: Option<VqConfig>,
    /// The music-to-dance GPT (`model.arch = "gpt"` only; written only then).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub gpt: Option<GptConfig>,
    /// The genre classifier (`model.arch = "genre_clf"` only; written only then).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub genre_clf: Option<GenreClfConfig>,
    /// The genre-control stage (`model.arch = "gpt_genre"` only; written only then).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub genre: Option<GenreConfig>,
    /// The keyframe-control stage (`model.arch = "gpt_keyframe"` only; written only then).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub keyframe: Option<KeyframeConfig>,
}

/// What one file of an `extends` chain may hold (every table optional and partial).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(dead_code)]
struct RunFile {
    extends: Option<toml::Value>,
    data: Option<DataConfig>,
    model: Option<ModelConfig>,
    optim: Option<OptimConfig>,
    schedule: Option<ScheduleConfig>,
    train: Option<TrainConfig>,
    recipe: Option<RecipeConfig>,
    tsmt: Option<TsmtConfig>,
    inbetween: Option<InbetweenConfig>,
    vq: Option<VqConfig>,
    gpt: Option<GptConfig>,
    genre_clf: Option<GenreClfConfig>,
    genre: Option<GenreConfig>,
    keyframe: Option<KeyframeConfig>,
}

fn check_file(path: &Path, text: &str) -> Result<(), ConfigError> {
    toml::from_str::<RunFile>(text)
        .map(|_| ())
        .map_err(|e| ConfigError::from_toml(path, text, &e))
}

/// A `--set` override giving `key` a string value, quoted as TOML (so paths with spaces or quotes survive).
pub fn string_override(key: &str, value: &str) -> String {
    format!("{key}={}", toml::Value::String(value.to_string()))
}

/// Parses `key.path=value`: the value as TOML (number, bool, string, array), else as a bare string.
pub fn parse_override(spec: &str) -> Result<(Vec<String>, toml::Value), String> {
    let (key, value) = spec
        .split_once('=')
        .ok_or_else(|| format!("--set {spec}: expected key.path=value"))?;
    let key = key.trim();
    let mut parts: Vec<String> = key.split('.').map(|s| s.trim().to_string()).collect();
    // An old flat key (`model.qra_init`) means its nested place (`model.qra.init`).
    if let [table, field] = parts.as_slice() {
        if let ("model", Some((sub, new))) = (table.as_str(), crate::model::legacy_key(field)) {
            parts = vec!["model".into(), sub.into(), new.into()];
        }
    }
    if parts.len() < 2 || parts.iter().any(|p| p.is_empty()) {
        return Err(format!(
            "--set {spec}: the key must name a table and a field, e.g. train.steps"
        ));
    }
    let value = value.trim();
    let parsed = toml::from_str::<toml::Table>(&format!("v = {value}"))
        .ok()
        .and_then(|mut t| t.remove("v"))
        .unwrap_or_else(|| toml::Value::String(value.to_string()));
    Ok((parts, parsed))
}

fn nest(parts: &[String], value: toml::Value) -> toml::Table {
    let mut table = toml::Table::new();
    if parts.len() == 1 {
        table.insert(parts[0].clone(), value);
    } else {
        table.insert(
            parts[0].clone(),
            toml::Value::Table(nest(&parts[1..], value)),
        );
    }
    table
}

/// Sets `parts` in `table` (creating tables on the way), checking the key and the value's type.
pub fn apply_override(table: &mut toml::Table, spec: &str, path: &Path) -> Result<(), ConfigError> {
    let (parts, value) = parse_override(spec).map_err(|m| ConfigError::new(path, None, m))?;
    // Check the override on its own, so the error names it rather than a line of the file.
    let alone = nest(&parts, value.clone());
    toml::Value::Table(alone.clone())
        .try_into::<RunFile>()
        .map_err(|e| ConfigError::new(path, None, format!("--set {spec}: {}", e.message())))?;
    let mut cursor = table;
    for p in &parts[..parts.len() - 1] {
        let entry = cursor
            .entry(p.clone())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        cursor = match entry {
            toml::Value::Table(t) => t,
            _ => {
                return Err(ConfigError::new(
                    path,
                    None,
                    format!("--set {spec}: `{p}` is not a table"),
                ))
            }
        };
    }
    cursor.insert(parts[parts.len() - 1].clone(), value);
    Ok(())
}

/// A family's table must be there for its architecture and only then: `[name]` for `model.arch = arch`.
fn check_section<T>(
    table: Option<&T>,
    wanted: bool,
    name: &str,
    arch: &str,
    actual: Arch,
    validate: impl Fn(&T) -> Result<(), String>,
) -> Result<(), String> {
    let article = if name.starts_with('i') { "an" } else { "a" };
    match (table, wanted) {
        (Some(t), true) => validate(t),
        (None, true) => Err(format!(
            "model.arch = \"{arch}\" needs {article} [{name}] table"
        )),
        (Some(_), false) => Err(format!(
            "{article} [{name}] table is for model.arch = \"{arch}\", not {actual:?}"
        )
        .to_lowercase()),
        (None, false) => Ok(()),
    }
}

impl RunConfig {
    /// Loads a run config (following `extends`), applies `--set` overrides, checks every value.
    pub fn load(path: &Path, overrides: &[String]) -> Result<RunConfig, ConfigError> {
        let mut table = load_merged_table_checked(path, &check_file)?;
        for spec in overrides {
            apply_override(&mut table, spec, path)?;
        }
        Self::from_table(table, path)
    }

    /// A run config from a merged table (`path` names it in errors).
    pub fn from_table(table: toml::Table, path: &Path) -> Result<RunConfig, ConfigError> {
        let mut config: RunConfig = toml::Value::Table(table)
            .try_into()
            .map_err(|e: toml::de::Error| ConfigError::new(path, None, e.message().trim()))?;
        // The family's table, with its defaults where the file has none.
        match config.model.arch {
            Arch::Fact | Arch::Qean => {}
            Arch::Tsmt => drop(config.tsmt.get_or_insert_with(Default::default)),
            Arch::Inbetween => drop(config.inbetween.get_or_insert_with(Default::default)),
            Arch::Vqvae => drop(config.vq.get_or_insert_with(Default::default)),
            Arch::GenreClf => drop(config.genre_clf.get_or_insert_with(Default::default)),
            Arch::Gpt => drop(config.gpt.get_or_insert_with(Default::default)),
            Arch::GptGenre => {
                config.gpt.get_or_insert_with(Default::default);
                config.genre.get_or_insert_with(Default::default);
            }
            Arch::GptKeyframe => {
                config.gpt.get_or_insert_with(Default::default);
                config.keyframe.get_or_insert_with(Default::default);
            }
        }
        config
            .validate()
            .map_err(|m| ConfigError::new(path, None, m))?;
        Ok(config)
    }

    /// Checks values that the types alone do not.
    pub fn validate(&self) -> Result<(), String> {
        self.model.validate().map_err(|m| format!("[model]: {m}"))?;
        let arch = self.model.arch;
        let wants = |a: &[Arch]| a.contains(&arch);
        check_section(
            self.tsmt.as_ref(),
            wants(&[Arch::Tsmt]),
            "tsmt",
            "tsmt",
            arch,
            |t| t.validate(),
        )?;
        check_section(
            self.inbetween.as_ref(),
            wants(&[Arch::Inbetween]),
            "inbetween",
            "inbetween",
            arch,
            |t| t.validate(),
        )?;
        check_section(
            self.genre_clf.as_ref(),
            wants(&[Arch::GenreClf]),
            "genre_clf",
            "genre_clf",
            arch,
            |t| t.validate(),
        )?;
        check_section(
            self.gpt.as_ref(),
            wants(&[Arch::Gpt, Arch::GptGenre, Arch::GptKeyframe]),
            "gpt",
            "gpt",
            arch,
            |t| t.validate(),
        )?;
        check_section(
            self.genre.as_ref(),
            wants(&[Arch::GptGenre]),
            "genre",
            "gpt_genre",
            arch,
            |t| t.validate(),
        )?;
        check_section(
            self.keyframe.as_ref(),
            wants(&[Arch::GptKeyframe]),
            "keyframe",
            "gpt_keyframe",
            arch,
            |k| {
                k.validate()?;
                k.validate_window(self.gpt_table().window)
            },
        )?;
        check_section(
            self.vq.as_ref(),
            wants(&[Arch::Vqvae]),
            "vq",
            "vqvae",
            arch,
            |t| t.validate(),
        )?;
        self.train.validate()?;
        let o = &self.optim;
        let unit = |x: f64| (0.0..1.0).contains(&x);
        if !unit(o.beta1) || !unit(o.beta2) {
            return Err(format!(
                "optim.beta1 and optim.beta2 must be in [0, 1), got {} and {}",
                o.beta1, o.beta2
            ));
        }
        if !(o.epsilon.is_finite() && o.epsilon > 0.0) {
            return Err(format!("optim.epsilon must be positive, got {}", o.epsilon));
        }
        if !(o.weight_decay.is_finite() && o.weight_decay >= 0.0) {
            return Err(format!(
                "optim.weight_decay must be ≥ 0, got {}",
                o.weight_decay
            ));
        }
        if !(o.grad_clip_norm.is_finite() && o.grad_clip_norm >= 0.0) {
            return Err(format!(
                "optim.grad_clip_norm must be ≥ 0, got {}",
                o.grad_clip_norm
            ));
        }
        self.schedule.validate(self.train.steps)?;
        self.recipe
            .validate(self.model.motion_len, self.model.target_len)?;
        Ok(())
    }

    /// The `[inbetween]` table of an in-betweener run (the paper preset for any other run).
    pub fn inbetween(&self) -> InbetweenConfig {
        self.inbetween_table().clone()
    }

    /// The `[tsmt]` table of a TSMT run (the paper preset for any other: callers match on `spec()`).
    pub fn tsmt(&self) -> TsmtConfig {
        self.tsmt_table().clone()
    }

    /// Ground-truth frames a generated dance starts with: the model's motion window (FACT, QEAN) or
    /// `tsmt.seed_frames`.
    pub fn seed_frames(&self) -> usize {
        match self.spec() {
            ModelSpec::Gpt(g) | ModelSpec::GptGenre(g, _) | ModelSpec::GptKeyframe(g, _) => {
                g.seed_tokens * g.rate
            }
            ModelSpec::Tsmt(t) => t.seed_frames,
            _ => self.model.motion_len,
        }
    }

    /// The shortest music the sampler can dance to: the music window (FACT, QEAN), or the seed
    /// and one frame to hear (TSMT, one token for the GPT).
    pub fn min_music_frames(&self) -> usize {
        match self.spec() {
            ModelSpec::Gpt(g) | ModelSpec::GptGenre(g, _) | ModelSpec::GptKeyframe(g, _) => {
                (g.seed_tokens + 1) * g.rate
            }
            ModelSpec::Tsmt(t) => t.seed_frames + 1,
            _ => self.model.audio_len,
        }
    }

    /// The window lengths the model sees (SPEC §1.5: the target follows the motion input; TSMT,
    /// §11.7: W input frames, the W frames after each, and the music rows s..s+W, of which the
    /// model takes s+1..s+W).
    pub fn window_spec(&self) -> WindowSpec {
        let same = |w: usize| WindowSpec {
            motion_len: w,
            target_len: w,
            target_shift: 0,
            audio_len: w,
        };
        match self.spec() {
            ModelSpec::GenreClf(g) => same(g.drawn_window()),
            ModelSpec::Vqvae(v) => same(v.window),
            ModelSpec::Gpt(g) | ModelSpec::GptGenre(g, _) | ModelSpec::GptKeyframe(g, _) => {
                WindowSpec {
                    motion_len: g.window,
                    target_len: g.window,
                    target_shift: 1,
                    audio_len: g.window + 1 + g.music_lookahead,
                }
            }
            ModelSpec::Tsmt(t) => WindowSpec {
                motion_len: t.window,
                target_len: t.window,
                target_shift: 1,
                audio_len: t.window + 1,
            },
            ModelSpec::FactQean(_) | ModelSpec::Inbetween(_) => WindowSpec {
                motion_len: self.model.motion_len,
                target_len: self.model.target_len,
                target_shift: self.model.motion_len,
                audio_len: self.model.audio_len,
            },
        }
    }

    /// The motion layout of the model.
    pub fn layout(&self) -> Layout {
        self.model.motion_layout
    }

    /// The config as TOML (what R/config.toml holds). Fails only on paths TOML cannot hold (not UTF-8).
    pub fn to_toml(&self) -> Result<String, String> {
        toml::to_string(self).map_err(|e| {
            let dir = self.data.dir.as_deref().filter(|d| d.to_str().is_none());
            match dir {
                Some(d) => format!(
                    "data.dir {}: the path is not valid UTF-8, which a run's config.toml cannot store",
                    d.display()
                ),
                None => format!("the run config cannot be written as TOML: {e}"),
            }
        })
    }

    /// One line: architecture, size and run length.
    pub fn summary(&self) -> String {
        let run = format!(
            "batch {} steps {} seed {}",
            self.train.batch_size, self.train.steps, self.train.seed
        );
        match self.spec() {
            ModelSpec::GenreClf(g) => {
                format!("genre classifier width {} window {}; {run}", g.width, g.window)
            }
            ModelSpec::GptGenre(g, c) => format!(
                "genre control z {} tokens {} disc {}×{} ff {} {:?} {:?} over gpt hidden {} window {}; {run}",
                c.z_dim, c.tokens, c.disc_width, c.disc_layers, c.disc_ff, c.gan_loss, c.relax,
                g.hidden, g.window
            )
            .to_lowercase(),
            ModelSpec::GptKeyframe(g, k) => format!(
                "keyframe control radius {} centres ≤ {} {:?} static {} {:?} over gpt hidden {} window {}; {run}",
                k.radius, k.max_centres, k.train_mask, k.static_prob, k.decode, g.hidden, g.window
            )
            .to_lowercase(),
            ModelSpec::Gpt(g) => format!(
                "gpt hidden {} heads {} layers {} + {} window {} codes {} {:?}; {run}",
                g.hidden, g.heads, g.base_layers, g.head_layers, g.window, g.codes, g.m_layout
            )
            .to_lowercase(),
            ModelSpec::Vqvae(v) => format!(
                "vq-vae width {} codes {}×{} depth {} down_t {} window {} {:?} mu {} commit {}; {run}",
                v.width, v.codes, v.code_dim, v.depth, v.down_t, v.window, v.quantizer, v.mu, v.commit
            )
            .to_lowercase(),
            ModelSpec::Inbetween(i) => format!(
                "in-betweener {} hidden {} heads {} ffn {} layers {} (+{} music) dropout {} base {:?} keys {}{}{}; {run}",
                i.variant.name(), i.hidden, i.heads, i.ffn, i.layers,
                if i.variant.has_audio() { i.audio_layers } else { 0 },
                i.dropout, i.base, i.train_keys, if i.mixed_keys { " (mixed 3/5/9)" } else { "" },
                if i.random_keys { " at random frames" } else { "" }
            )
            .to_lowercase(),
            ModelSpec::Tsmt(t) => format!(
                "tsmt bins {} ({:?}) root {:?} window {} embed {} hidden {} heads {}×{} layers {}; audio {:?} hidden {} heads {}×{} layers {}; d_out {} dropout {}; {run}",
                t.n_bins, t.bins_mode, t.root_mode, t.window, t.embed, t.hidden, t.heads, t.head_dim,
                t.layers, t.audio_streams, t.audio_hidden, t.audio_heads, t.audio_head_dim,
                t.audio_layers, t.d_out, t.dropout
            )
            .to_lowercase(),
            ModelSpec::FactQean(m) => format!(
                "{:?} hidden {} heads {} ffn {} layers {}-{}-{} position {:?} attention {:?} dropout {}; {run}; {}",
                m.arch,
                m.hidden,
                m.heads,
                m.ffn,
                m.motion_layers,
                m.audio_layers,
                m.cross_layers,
                m.position,
                m.attention,
                m.dropout,
                self.recipe.describe()
            )
            .to_lowercase(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn defaults_overrides_and_round_trip() {
        let d = tempfile::tempdir().unwrap();
        let p = write(
            d.path(),
            "r.toml",
            "[model]\nhidden = 80\nheads = 8\nffn = 320\n[train]\nsteps = 7\n",
        );
        let c = RunConfig::load(
            &p,
            &[
                "train.batch_size=3".into(),
                "data.dir=/tmp/x y".into(),
                "schedule.boundaries=[2, 4]".into(),
                "schedule.values=[1e-5, 1e-6]".into(),
                "optim.epsilon = 1e-7".into(),
            ],
        )
        .unwrap();
        assert_eq!(c.train.steps, 7);
        assert_eq!(c.train.batch_size, 3);
        assert_eq!(c.data.dir.as_deref(), Some(Path::new("/tmp/x y")));
        assert_eq!(c.schedule.boundaries, vec![2, 4]);
        assert_eq!(c.optim.epsilon, 1e-7);
        assert_eq!(c.model.hidden, 80);
        // The resolved TOML reads back to the same config.
        let back = write(d.path(), "back.toml", &c.to_toml().unwrap());
        assert_eq!(RunConfig::load(&back, &[]).unwrap(), c);
    }

    #[test]
    fn old_flat_qra_keys_in_overrides_and_run_directories() {
        let d = tempfile::tempdir().unwrap();
        let p = write(
            d.path(),
            "q.toml",
            "[model]\narch = \"qean\"\nhidden = 64\nheads = 4\nffn = 96\nattention = \"qra\"\n[train]\nsteps = 2\n",
        );
        let old = RunConfig::load(&p, &["model.qra_init=zero".into()]).unwrap();
        let new = RunConfig::load(&p, &["model.qra.init=zero".into()]).unwrap();
        assert_eq!(old, new);
        assert_eq!(new.model.qra.init, crate::model::QraInit::Zero);
        // A run directory's config.toml written before the nesting (flat keys) reads the same.
        let mut table = toml::Table::try_from(&new).unwrap();
        let toml::Value::Table(model) = table.get_mut("model").unwrap() else {
            panic!("model is a table")
        };
        let toml::Value::Table(qra) = model.remove("qra").unwrap() else {
            panic!("qra is a table")
        };
        for (k, v) in qra {
            model.insert(format!("qra_{k}"), v);
        }
        let flat = toml::to_string(&table).unwrap();
        assert!(flat.contains("qra_init = \"zero\""), "{flat}");
        let back = write(d.path(), "old/config.toml", &flat);
        assert_eq!(RunConfig::load(&back, &[]).unwrap(), new);
    }

    #[test]
    fn errors_name_key_file_and_line() {
        let d = tempfile::tempdir().unwrap();
        let p = write(d.path(), "a.toml", "[train]\nsteps = 5\nstepz = 3\n");
        let e = RunConfig::load(&p, &[]).unwrap_err();
        assert_eq!((e.path.clone(), e.line), (p.clone(), Some(3)), "{e}");
        assert!(e.message.contains("stepz"), "{e}");
        let p = write(d.path(), "b.toml", "[optim]\n\nbeta1 = \"high\"\n");
        let e = RunConfig::load(&p, &[]).unwrap_err();
        assert_eq!(e.line, Some(3), "{e}");
        let p = write(d.path(), "c.toml", "[trian]\nsteps = 5\n");
        let e = RunConfig::load(&p, &[]).unwrap_err();
        assert!(e.message.contains("trian") && e.line == Some(1), "{e}");
        // In a parent file: the parent is named.
        let parent = write(d.path(), "base/p.toml", "[schedule]\ninitail = 1e-4\n");
        let child = write(d.path(), "ch.toml", "extends = \"base/p.toml\"\n");
        let e = RunConfig::load(&child, &[]).unwrap_err();
        assert_eq!((e.path.clone(), e.line), (parent, Some(2)), "{e}");
        // Overrides.
        let ok = write(d.path(), "ok.toml", "");
        for (spec, want) in [
            ("train.stepz=4", "stepz"),
            ("train.steps=many", "--set train.steps=many"),
            ("steps=4", "table and a field"),
            ("train.steps", "key.path=value"),
            ("train.steps=0", "train.steps"),
            ("train.ema_decay=1", "train.ema_decay must be in [0, 1)"),
            ("train.backend=cuda", "cuda"),
            ("data.train_split=dev", "dev"),
            ("schedule.values=[1e-5]", "boundaries"),
        ] {
            let e = RunConfig::load(&ok, &[spec.into()]).unwrap_err();
            let s = e.to_string();
            assert!(s.contains(want) && !s.contains('\n'), "{spec}: {s}");
        }
    }

    #[test]
    fn shipped_presets_load() {
        let configs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs");
        // Every run preset of every family (configs/sweeps/ holds sweep plans, not run configs).
        fn presets(dir: &Path, out: &mut Vec<PathBuf>) {
            for entry in std::fs::read_dir(dir).unwrap() {
                let path = entry.unwrap().path();
                if path.is_dir() && !path.ends_with("sweeps") {
                    presets(&path, out);
                } else if path.extension().is_some_and(|e| e == "toml") {
                    out.push(path);
                }
            }
        }
        let mut all = Vec::new();
        presets(&configs, &mut all);
        assert!(all.len() >= 35, "{} presets", all.len());
        let mut families = std::collections::BTreeSet::new();
        for path in &all {
            let c =
                RunConfig::load(path, &[]).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            assert!(c.train.steps > 0, "{}", path.display());
            families.insert(c.spec().family());
        }
        assert_eq!(families.len(), 8, "{families:?}");
        let fact = RunConfig::load(&configs.join("fact.toml"), &[]).unwrap();
        assert_eq!(fact.train.batch_size, 32);
        assert_eq!(fact.schedule.boundaries, vec![100_000, 150_000]);
        assert_eq!(fact.optim.epsilon, 1e-7);
        let full = RunConfig::load(&configs.join("qean/full.toml"), &[]).unwrap();
        assert_eq!(full.train.batch_size, 16);
        assert_eq!(full.schedule.boundaries, vec![90_000, 150_000]);
        assert_eq!(full.optim.epsilon, 1e-8);
    }

    #[cfg(unix)]
    #[test]
    fn a_non_utf8_data_dir_is_an_error_not_a_panic() {
        use std::os::unix::ffi::OsStrExt;
        let mut c = RunConfig::default();
        c.data.dir = Some(PathBuf::from(std::ffi::OsStr::from_bytes(b"/tmp/data\xff")));
        let e = c.to_toml().unwrap_err();
        assert!(e.starts_with("data.dir /tmp/data"), "{e}");
        assert!(e.contains("not valid UTF-8"), "{e}");
    }

    /// `model.arch = "tsmt"` reads the `[tsmt]` table (paper defaults when absent, --set works, an
    /// unknown key names file and line); a `[tsmt]` table on a FACT run is an error.
    #[test]
    fn tsmt_runs_and_their_table() {
        let d = tempfile::tempdir().unwrap();
        let p = write(d.path(), "t.toml", "[model]\narch = \"tsmt\"\n");
        let c = RunConfig::load(&p, &["tsmt.window=32".into()]).unwrap();
        assert!(matches!(c.spec(), ModelSpec::Tsmt(_)));
        assert_eq!(c.tsmt().window, 32);
        assert_eq!(c.tsmt().hidden, 128);
        let spec = c.window_spec();
        assert_eq!(
            (
                spec.motion_len,
                spec.target_shift,
                spec.target_len,
                spec.audio_len
            ),
            (32, 1, 32, 33)
        );
        assert!(c.summary().starts_with("tsmt bins 300"), "{}", c.summary());
        // The resolved config round-trips, bins and all.
        let mut fitted = c.clone();
        let t = fitted.tsmt.as_mut().unwrap();
        t.bins_lo = (0..69).map(|i| -0.1 - i as f64 * 1e-17).collect();
        t.bins_hi = (0..69).map(|i| 0.3 + i as f64 / 7.0).collect();
        let text = fitted.to_toml().unwrap();
        let q = write(d.path(), "resolved.toml", &text);
        assert_eq!(RunConfig::load(&q, &[]).unwrap(), fitted);
        let bad = write(
            d.path(),
            "bad.toml",
            "[model]\narch = \"tsmt\"\n[tsmt]\nwindw = 3\n",
        );
        let e = RunConfig::load(&bad, &[]).unwrap_err().to_string();
        assert!(
            e.contains("bad.toml") && e.contains("windw") && e.contains("bad.toml:4"),
            "{e}"
        );
        let fact = write(d.path(), "fact.toml", "[tsmt]\nwindow = 3\n");
        let e = RunConfig::load(&fact, &[]).unwrap_err().to_string();
        assert!(e.contains("model.arch = \"tsmt\""), "{e}");
        // A FACT run's config.toml has no [tsmt] table.
        assert!(!RunConfig::default().to_toml().unwrap().contains("[tsmt]"));
    }
}
