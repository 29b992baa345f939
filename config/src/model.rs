//! The `[model]` table of a run config (TOML), and the `extends` chain that keeps presets short.
//!
//! Every field has a default, and the defaults are mint's FACT (SPEC §4.1–4.2,
//! `configs/fact_v5_deeper_t10_cm12.config`), so an empty `[model]` table is mint's model.
//! Every [DECISION] of SPEC §4 and §10 is a field here; field names follow the option names
//! SPEC uses (`attn_scale`, `rope_pairing`, `qra_layers`, ...); SPE's rotary settings sit in
//! `[model.rope]` and QRA's in `[model.qra]`, without the prefix (`[model.qra] layers`).
//!
//! A config file may name a parent with a top-level `extends = "relative/path.toml"`. The parent
//! is loaded first (recursively, relative to the file that names it) and the child's tables are
//! merged over it key by key. Other top-level tables (`[train]`, ...) are merged the same way
//! but belong to the trainer; this module only reads `[model]`.

use std::collections::BTreeSet;
use std::fmt;
use std::path::{Path, PathBuf};

use qean_motion::motion::Layout;
use serde::{Deserialize, Serialize};

/// Which model family to build: mint's FACT, QEAN (FACT plus the switches below), or Li et al.'s
/// two-stream motion transformer (configured by the run's `[tsmt]` table, not by `[model]`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Arch {
    /// mint's FACT exactly (SPEC §4.2); the QEAN switches must stay at their FACT values.
    Fact,
    /// QEAN: FACT plus SPE / QRA / dropout / input fusion (SPEC §4.3–4.7).
    Qean,
    /// TSMT (SPEC §11): its sizes and options are the `[tsmt]` table; the rest of `[model]` is unused.
    Tsmt,
    /// Lin's transformer in-betweeners (SPEC §12.4c): the `[inbetween]` table; the rest of `[model]` is
    /// unused.
    Inbetween,
    /// The motion VQ-VAE of the multi-modal control system (SPEC §13.2): the `[vq]` table.
    Vqvae,
    /// The music-to-dance GPT over a frozen VQ-VAE's tokens (SPEC §13.3): the `[gpt]` table.
    Gpt,
    /// The genre-control stage over a frozen GPT (SPEC §13.5): the `[gpt]` and `[genre]` tables.
    GptGenre,
    /// The genre classifier of the control evaluation (SPEC §13.10): the `[genre_clf]` table.
    GenreClf,
    /// Keyframe control over a frozen GPT (SPEC §13.6): the `[gpt]` and `[keyframe]` tables.
    GptKeyframe,
}

/// Attention score scale `s` (SPEC §4.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AttnScale {
    /// `1/sqrt(hidden)`: mint's quirk (it scales by the model width, not the head width).
    Hidden,
    /// `1/sqrt(d_head)`: the textbook scale.
    Head,
}

/// How token positions enter the model (QEAN's `spe` flag, SPEC §4.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PositionKind {
    /// Learned absolute embeddings added after the input dense layers (FACT).
    Learned,
    /// SPE: rotary q/k in every attention layer; absolute embeddings removed unless `rope.keep_abs_pos`.
    Rotary,
}

/// Which self-attention the cross-modal layers use (QEAN's `qra` flag).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AttentionKind {
    /// Scaled dot-product softmax attention (FACT).
    Softmax,
    /// Quaternion rotary attention (SPEC §4.5).
    Qra,
}

/// Rotary pair convention (SPEC §4.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RopePairing {
    /// Adjacent pairs `(x_{2t}, x_{2t+1})` (RoFormer, QEAN eq. 12–24, Burn's `RotaryEncoding`).
    Interleaved,
    /// Pairs `(x_t, x_{t+d/2})` (GPT-NeoX style).
    HalfSplit,
}

/// Rotary positions of the cross-modal tokens (SPEC §4.4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CrossPositions {
    /// Motion token i at position i, audio token j at position j: s − t is a time offset.
    PerModality,
    /// Positions 0..360 over the concatenated sequence.
    Concatenated,
}

/// Which cross-modal layers use QRA (SPEC §4.5 "Plug-in").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QraLayers {
    /// Every cross-modal layer.
    All,
    /// The first `layers_k` layers.
    FirstK,
    /// The last `layers_k` layers.
    LastK,
}

/// Where QRA sits (SPEC §4.5 "Plug-in").
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QraTopology {
    /// QRA replaces the self-attention of the chosen cross-modal layers.
    #[serde(rename = "self")]
    SelfAttention,
    /// One extra QRA block: motion tokens query audio tokens, added before the cross stack.
    CrossPrefix,
}

/// What the ω/θ convolutions read (SPEC §4.5 step 1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QraConvInput {
    /// The normalised layer input (the Quatformer reference).
    Normed,
    /// The projected q (for ω_Q, θ_Q) and k (for ω_K, θ_K), before RoPE (QEAN eq. 25).
    Projected,
}

/// q/k width per head when it is not a multiple of 4 (SPEC §4.5 step 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QraDk {
    /// d_h = hidden/heads; the `d_h mod 4` remainder dims enter the score unrotated.
    Floor,
    /// q/k projected to heads × round_up(d_h, 4); v stays at hidden.
    RoundUp,
}

/// How q and k are projected inside QRA (SPEC §4.6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QraQkProj {
    /// The bias-free fused q/k/v dense layer of FACT.
    Dense,
    /// q and k from quaternion linear layers (implies `dk = round_up`); v from a dense layer.
    Quaternion,
}

/// QRA's normalised positions (SPEC §4.5 step 4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QraPositions {
    /// n/N over the concatenated index (the reference).
    Concatenated,
    /// frame/240: motion token i and audio token i share a position.
    TimeAligned,
}

/// How the four ω/θ convs of QRA start (issue 17: with the default initialisation the first QRA
/// layer's scores correlate weakly with dot-product scores, so QRA starts near random attention).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QraInit {
    /// U(±1/sqrt(C_in·kernel)) for weights and biases (the Quatformer reference).
    Default,
    /// The same bound × 0.1: small rotations, QRA close to attention at step 0.
    Small,
    /// Weights and biases zero: QRA equals attention at step 0 (QRA-1). ω = ReLU(0) then gets
    /// no gradient, so only the phases θ learn.
    Zero,
}

/// How the audio branch embeds its input (SPEC §4.7).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum InputFusion {
    /// Dense(35 → hidden) on the audio features (FACT).
    Dense,
    /// QEAN §3.2 read literally: per frame [audio 35 | motion 219 or 0], first 252 dims as 63
    /// quaternions, QuaternionLinear(63 → hidden/4).
    Quaternion254,
}

/// Where dropout applies when `dropout > 0` (SPEC §4.7).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DropoutSite {
    /// The attention probabilities.
    Attention,
    /// The attention and MLP branch outputs, before the residual add.
    Residual,
    /// After embedding + position.
    Embedding,
}

/// `[model.rope]`: SPE's rotary position settings (SPEC §4.3–4.4).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RopeOptions {
    /// Rotary pair convention (`rope_pairing` in SPEC).
    pub pairing: RopePairing,
    /// Rotary base, 10000 (`rope_base`).
    pub base: f64,
    /// Rotary positions of the cross-modal tokens.
    pub cross_positions: CrossPositions,
    /// Keep the learned absolute embeddings with `position = rotary`.
    pub keep_abs_pos: bool,
}

impl Default for RopeOptions {
    fn default() -> Self {
        Self {
            pairing: RopePairing::Interleaved,
            base: 10000.0,
            cross_positions: CrossPositions::PerModality,
            keep_abs_pos: false,
        }
    }
}

/// `[model.qra]`: quaternion rotary attention's settings (SPEC §4.5–4.6). SPEC spells each as
/// `qra_<name>`; the old flat `[model]` keys `qra_<name>` are still read (see [`upgrade_legacy_keys`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct QraOptions {
    /// Period count P (2).
    pub periods: usize,
    /// Conv kernel of the ω/θ convs (1 or 3, zero "same" padding).
    pub kernel: usize,
    /// Which cross-modal layers use QRA.
    pub layers: QraLayers,
    /// k for `layers = first_k | last_k`.
    pub layers_k: usize,
    /// QRA placement.
    pub topology: QraTopology,
    /// What the ω/θ convs read.
    pub conv_input: QraConvInput,
    /// q/k width per head.
    pub dk: QraDk,
    /// q/k projection inside QRA.
    pub qk_proj: QraQkProj,
    /// QRA's normalised positions.
    pub positions: QraPositions,
    /// Multiply ω by 2π (QEAN eq. 26); the Quatformer code omits it.
    pub two_pi: bool,
    /// Initialisation of the ω/θ convs.
    pub init: QraInit,
    /// Weight of Quatformer's ω smoothness penalty mean((ω_{n+1} − ω_n)²).
    pub lambda_omega: f64,
    /// Weight of Quatformer's phase penalty mean(θ²).
    pub lambda_theta: f64,
}

impl Default for QraOptions {
    fn default() -> Self {
        Self {
            periods: 2,
            kernel: 1,
            layers: QraLayers::All,
            layers_k: 0,
            topology: QraTopology::SelfAttention,
            conv_input: QraConvInput::Normed,
            dk: QraDk::Floor,
            qk_proj: QraQkProj::Dense,
            positions: QraPositions::Concatenated,
            two_pi: true,
            init: QraInit::Default,
            lambda_omega: 0.0,
            lambda_theta: 0.0,
        }
    }
}

/// The flat `[model]` keys of configs written before `[model.rope]` and `[model.qra]` existed,
/// and where each lives now: (old key, table, new key).
const LEGACY_KEYS: [(&str, &str, &str); 17] = [
    ("rope_pairing", "rope", "pairing"),
    ("rope_base", "rope", "base"),
    ("cross_positions", "rope", "cross_positions"),
    ("keep_abs_pos", "rope", "keep_abs_pos"),
    ("qra_periods", "qra", "periods"),
    ("qra_kernel", "qra", "kernel"),
    ("qra_layers", "qra", "layers"),
    ("qra_layers_k", "qra", "layers_k"),
    ("qra_topology", "qra", "topology"),
    ("qra_conv_input", "qra", "conv_input"),
    ("qra_dk", "qra", "dk"),
    ("qra_qk_proj", "qra", "qk_proj"),
    ("qra_positions", "qra", "positions"),
    ("qra_two_pi", "qra", "two_pi"),
    ("qra_init", "qra", "init"),
    ("qra_lambda_omega", "qra", "lambda_omega"),
    ("qra_lambda_theta", "qra", "lambda_theta"),
];

/// Where an old flat `[model]` key lives now, e.g. `qra_layers` → `("qra", "layers")`.
pub fn legacy_key(key: &str) -> Option<(&'static str, &'static str)> {
    LEGACY_KEYS
        .iter()
        .find(|(old, _, _)| *old == key)
        .map(|&(_, table, new)| (table, new))
}

/// Moves old flat keys of a whole config table's `[model]` (`qra_layers = ...`) into their
/// nested tables (`[model.qra] layers = ...`), so run directories and configs written before
/// the nesting keep working. Returns the keys moved; a key given both ways is an error naming
/// the new spelling.
pub fn upgrade_legacy_keys(table: &mut toml::Table) -> Result<Vec<&'static str>, String> {
    let Some(toml::Value::Table(model)) = table.get_mut("model") else {
        return Ok(Vec::new());
    };
    let mut moved = Vec::new();
    for (old, sub, new) in LEGACY_KEYS {
        let Some(value) = model.remove(old) else {
            continue;
        };
        let entry = model
            .entry(sub)
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        let toml::Value::Table(nested) = entry else {
            return Err(format!("[model]: `{sub}` must be a table"));
        };
        if nested.contains_key(new) {
            return Err(format!(
                "[model]: `{old}` and `{sub}.{new}` are both set; `{old}` is the old spelling of `[model.{sub}] {new}`, keep one"
            ));
        }
        nested.insert(new.to_string(), value);
        moved.push(old);
    }
    Ok(moved)
}

/// The `[model]` table. Defaults are mint's FACT.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ModelConfig {
    /// Model family.
    pub arch: Arch,
    /// Width of every transformer (800).
    pub hidden: usize,
    /// Attention heads in every transformer (mint 10, QEAN 16).
    pub heads: usize,
    /// MLP inner width (3072, the proto default).
    pub ffn: usize,
    /// Layers of the motion encoder (2).
    pub motion_layers: usize,
    /// Layers of the audio encoder (2).
    pub audio_layers: usize,
    /// Layers of the cross-modal transformer (12).
    pub cross_layers: usize,
    /// Motion feature layout, 225 (mint, zero-padded) or 219 (SPEC §1.4).
    pub motion_layout: Layout,
    /// Audio feature width (35, SPEC §2).
    pub audio_dim: usize,
    /// Motion input frames (120).
    pub motion_len: usize,
    /// Audio input frames (240).
    pub audio_len: usize,
    /// Supervised output tokens (20): the loss reads tokens 0..target_len.
    pub target_len: usize,
    /// Attention score scale.
    pub attn_scale: AttnScale,
    /// Dropout rate (FACT 0, QEAN 0.1).
    pub dropout: f64,
    /// Where dropout applies.
    pub dropout_sites: BTreeSet<DropoutSite>,
    /// Learned absolute or rotary positions (the SPE switch).
    pub position: PositionKind,
    /// Rotary settings, `[model.rope]` (used with `position = rotary`).
    pub rope: RopeOptions,
    /// Softmax or QRA in the cross-modal stack (the QRA switch).
    pub attention: AttentionKind,
    /// QRA settings, `[model.qra]` (used with `attention = qra`).
    pub qra: QraOptions,
    /// Audio-branch input embedding.
    pub input_fusion: InputFusion,
}

impl Default for ModelConfig {
    fn default() -> Self {
        Self {
            arch: Arch::Fact,
            hidden: 800,
            heads: 10,
            ffn: 3072,
            motion_layers: 2,
            audio_layers: 2,
            cross_layers: 12,
            motion_layout: Layout::L225,
            audio_dim: 35,
            motion_len: 120,
            audio_len: 240,
            target_len: 20,
            attn_scale: AttnScale::Hidden,
            dropout: 0.0,
            dropout_sites: [
                DropoutSite::Attention,
                DropoutSite::Residual,
                DropoutSite::Embedding,
            ]
            .into_iter()
            .collect(),
            position: PositionKind::Learned,
            rope: RopeOptions::default(),
            attention: AttentionKind::Softmax,
            qra: QraOptions::default(),
            input_fusion: InputFusion::Dense,
        }
    }
}

impl ModelConfig {
    /// Motion feature width: the layout (225 or 219).
    pub fn motion_dim(&self) -> usize {
        self.motion_layout.dim()
    }

    /// Width of one head.
    pub fn head_dim(&self) -> usize {
        self.hidden / self.heads
    }

    /// q/k width per head inside QRA (d_h, or d_h rounded up to a multiple of 4).
    pub fn qra_qk_head_dim(&self) -> usize {
        let d = self.head_dim();
        match (self.qra.dk, self.qra.qk_proj) {
            (QraDk::Floor, QraQkProj::Dense) => d,
            _ => d.div_ceil(4) * 4,
        }
    }

    /// Whether learned absolute position embeddings are present.
    pub fn learned_positions(&self) -> bool {
        self.position == PositionKind::Learned || self.rope.keep_abs_pos
    }

    /// Whether cross-modal layer `layer` (0-based) uses QRA as its self-attention.
    pub fn layer_uses_qra(&self, layer: usize) -> bool {
        if self.attention != AttentionKind::Qra || self.qra.topology != QraTopology::SelfAttention {
            return false;
        }
        match self.qra.layers {
            QraLayers::All => true,
            QraLayers::FirstK => layer < self.qra.layers_k,
            QraLayers::LastK => layer + self.qra.layers_k >= self.cross_layers,
        }
    }

    /// The dropout rate at `site` (0 when the site is off).
    pub fn dropout_at(&self, site: DropoutSite) -> f64 {
        if self.dropout_sites.contains(&site) {
            self.dropout
        } else {
            0.0
        }
    }

    /// Checks the combinations the type system does not; the message names the offending key.
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("hidden", self.hidden),
            ("heads", self.heads),
            ("ffn", self.ffn),
            ("motion_len", self.motion_len),
            ("audio_len", self.audio_len),
            ("audio_dim", self.audio_dim),
            ("target_len", self.target_len),
            ("qra.periods", self.qra.periods),
        ];
        for (key, value) in positive {
            if value == 0 {
                return Err(format!("`{key}` must be positive"));
            }
        }
        if !self.hidden.is_multiple_of(self.heads) {
            return Err(format!(
                "`heads` = {} does not divide `hidden` = {}",
                self.heads, self.hidden
            ));
        }
        if self.target_len > self.motion_len + self.audio_len {
            return Err("`target_len` exceeds the number of output tokens".into());
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return Err(format!("`dropout` must be in [0, 1), got {}", self.dropout));
        }
        if self.position == PositionKind::Rotary && !self.head_dim().is_multiple_of(2) {
            return Err(format!(
                "`position = rotary` needs an even head width, got {}",
                self.head_dim()
            ));
        }
        if self.rope.base.is_nan() || self.rope.base <= 1.0 {
            return Err(format!("`rope.base` must be > 1, got {}", self.rope.base));
        }
        if self.qra.kernel != 1 && self.qra.kernel != 3 {
            return Err(format!(
                "`qra.kernel` must be 1 or 3, got {}",
                self.qra.kernel
            ));
        }
        if self.attention == AttentionKind::Qra && self.qra_qk_head_dim() < 4 {
            return Err("QRA needs at least 4 q/k dims per head".into());
        }
        if self.qra.layers != QraLayers::All && self.qra.layers_k > self.cross_layers {
            return Err(format!(
                "`qra.layers_k` = {} exceeds `cross_layers` = {}",
                self.qra.layers_k, self.cross_layers
            ));
        }
        if self.qra.lambda_omega < 0.0 || self.qra.lambda_theta < 0.0 {
            return Err("`qra.lambda_omega` and `qra.lambda_theta` must be >= 0".into());
        }
        if self.input_fusion == InputFusion::Quaternion254 {
            if !self.hidden.is_multiple_of(4) {
                return Err("`input_fusion = quaternion_254` needs `hidden` divisible by 4".into());
            }
            if self.audio_dim + 219 < 252 || self.motion_len > self.audio_len {
                return Err(
                    "`input_fusion = quaternion_254` needs audio_dim + 219 >= 252 and motion_len <= audio_len"
                        .into(),
                );
            }
        }
        if self.arch == Arch::Fact {
            let fact = Self {
                arch: Arch::Fact,
                hidden: self.hidden,
                heads: self.heads,
                ffn: self.ffn,
                motion_layers: self.motion_layers,
                audio_layers: self.audio_layers,
                cross_layers: self.cross_layers,
                motion_layout: self.motion_layout,
                audio_dim: self.audio_dim,
                motion_len: self.motion_len,
                audio_len: self.audio_len,
                target_len: self.target_len,
                attn_scale: self.attn_scale,
                ..Self::default()
            };
            if let Some(key) = self.first_difference(&fact) {
                return Err(format!(
                    "`{key}` is a QEAN option: with `arch = \"fact\"` it must keep its default (use `arch = \"qean\"`)"
                ));
            }
        }
        Ok(())
    }

    /// The first key whose value differs from `other`'s (as TOML), as a dotted path (`qra.layers`).
    fn first_difference(&self, other: &Self) -> Option<String> {
        let a = toml::Table::try_from(self).ok()?;
        let b = toml::Table::try_from(other).ok()?;
        first_difference(&a, &b)
    }
}

fn first_difference(a: &toml::Table, b: &toml::Table) -> Option<String> {
    a.iter().find_map(|(k, v)| match (v, b.get(k.as_str())) {
        (toml::Value::Table(x), Some(toml::Value::Table(y))) => {
            first_difference(x, y).map(|inner| format!("{k}.{inner}"))
        }
        (v, other) if other != Some(v) => Some(k.clone()),
        _ => None,
    })
}

/// A config-file error: the file, the line when known, and the problem, on one line.
#[derive(Debug, Clone, PartialEq)]
pub struct ConfigError {
    /// The file the problem is in.
    pub path: PathBuf,
    /// 1-based line, when known.
    pub line: Option<usize>,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{}: {}", self.path.display(), line, self.message),
            None => write!(f, "{}: {}", self.path.display(), self.message),
        }
    }
}

impl std::error::Error for ConfigError {}

impl ConfigError {
    /// An error in `path` (at `line` when known).
    pub fn new(path: &Path, line: Option<usize>, message: impl Into<String>) -> Self {
        Self {
            path: path.to_path_buf(),
            line,
            message: message.into(),
        }
    }

    /// A TOML parse or schema error, with the line its span points at.
    pub fn from_toml(path: &Path, text: &str, err: &toml::de::Error) -> Self {
        let line = err
            .span()
            .map(|span| text[..span.start.min(text.len())].matches('\n').count() + 1);
        Self::new(path, line, err.message().trim().to_string())
    }
}

/// The part of a config file this crate checks: `extends` and `[model]`. Other tables pass.
#[derive(Deserialize)]
struct FileView {
    #[allow(dead_code)]
    extends: Option<String>,
    #[allow(dead_code)]
    model: Option<ModelConfig>,
}

const MAX_EXTENDS_DEPTH: usize = 16;

/// Reads a config file and its `extends` chain into one merged table (the child wins, key by
/// key, recursing into tables). Each file's `[model]` table is checked on its own first, so an
/// unknown or mistyped key is reported with its own file and line.
pub fn load_merged_table(path: &Path) -> Result<toml::Table, ConfigError> {
    load_merged_table_checked(path, &|path, text| {
        toml::from_str::<FileView>(text)
            .map(|_| ())
            .map_err(|e| ConfigError::from_toml(path, text, &e))
    })
}

/// A per-file check: (file, its text) → Ok, or the error with the file's own line.
pub type FileCheck = dyn Fn(&Path, &str) -> Result<(), ConfigError>;

/// [`load_merged_table`] with the caller's per-file check (the trainer checks every table of a
/// run config, not only `[model]`).
pub fn load_merged_table_checked(
    path: &Path,
    check: &FileCheck,
) -> Result<toml::Table, ConfigError> {
    load_chain(path, 0, check)
}

fn load_chain(path: &Path, depth: usize, check: &FileCheck) -> Result<toml::Table, ConfigError> {
    if depth > MAX_EXTENDS_DEPTH {
        return Err(ConfigError::new(
            path,
            None,
            "`extends` chain is too deep (a cycle?)",
        ));
    }
    let text = std::fs::read_to_string(path)
        .map_err(|e| ConfigError::new(path, None, format!("cannot read: {e}")))?;
    let mut table: toml::Table =
        toml::from_str(&text).map_err(|e| ConfigError::from_toml(path, &text, &e))?;
    // Checked per file, so the error carries this file's line. A file with old flat keys is
    // checked in its upgraded form, whose lines are not the file's.
    let moved = upgrade_legacy_keys(&mut table).map_err(|m| ConfigError::new(path, None, m))?;
    if moved.is_empty() {
        check(path, &text)?;
    } else {
        let upgraded = toml::to_string(&table)
            .map_err(|e| ConfigError::new(path, None, format!("cannot re-read: {e}")))?;
        check(path, &upgraded).map_err(|e| ConfigError { line: None, ..e })?;
    }
    let parent = match table.remove("extends") {
        None => return Ok(table),
        Some(toml::Value::String(rel)) => {
            let base = path.parent().unwrap_or_else(|| Path::new("."));
            base.join(rel)
        }
        Some(_) => {
            let line = text
                .lines()
                .position(|l| l.trim_start().starts_with("extends"))
                .map(|i| i + 1);
            return Err(ConfigError::new(
                path,
                line,
                "`extends` must be a string (a path relative to this file)",
            ));
        }
    };
    if !parent.is_file() {
        return Err(ConfigError::new(
            path,
            None,
            format!("`extends` names {}, which does not exist", parent.display()),
        ));
    }
    let mut merged = load_chain(&parent, depth + 1, check)?;
    merge_into(&mut merged, table);
    Ok(merged)
}

fn merge_into(base: &mut toml::Table, over: toml::Table) {
    for (key, value) in over {
        match (base.get_mut(&key), value) {
            (Some(toml::Value::Table(b)), toml::Value::Table(o)) => merge_into(b, o),
            (_, value) => {
                base.insert(key, value);
            }
        }
    }
}

/// Extracts and validates `[model]` from a merged table (defaults fill what is absent).
pub fn model_from_table(table: &toml::Table, path: &Path) -> Result<ModelConfig, ConfigError> {
    let model = match table.get("model") {
        None => ModelConfig::default(),
        Some(toml::Value::Table(t)) => t
            .clone()
            .try_into::<ModelConfig>()
            .map_err(|e| ConfigError::new(path, None, format!("[model]: {}", e.message())))?,
        Some(_) => return Err(ConfigError::new(path, None, "`model` must be a table")),
    };
    model
        .validate()
        .map_err(|m| ConfigError::new(path, None, format!("[model]: {m}")))?;
    Ok(model)
}

/// Loads the `[model]` table of a config file, following `extends`.
pub fn load_model_config(path: &Path) -> Result<ModelConfig, ConfigError> {
    let table = load_merged_table(path)?;
    model_from_table(&table, path)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent).unwrap();
        }
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn empty_model_table_is_mint_fact() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "a.toml", "[model]\n");
        let c = load_model_config(&p).unwrap();
        assert_eq!(c, ModelConfig::default());
        assert_eq!((c.hidden, c.heads, c.ffn), (800, 10, 3072));
    }

    #[test]
    fn unknown_key_names_key_file_and_line() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            dir.path(),
            "bad.toml",
            "[model]\nheads = 16\nhiden = 64\n\n[train]\nsteps = 3\n",
        );
        let e = load_model_config(&p).unwrap_err();
        assert_eq!(e.path, p);
        assert_eq!(e.line, Some(3), "{e}");
        assert!(e.message.contains("hiden"), "{e}");
        assert!(!e.to_string().contains('\n'), "one line: {e}");
    }

    #[test]
    fn unknown_key_in_parent_reports_the_parent() {
        let dir = tempfile::tempdir().unwrap();
        let parent = write(dir.path(), "base/p.toml", "[model]\n\nqra_period = 3\n");
        let child = write(
            dir.path(),
            "c.toml",
            "extends = \"base/p.toml\"\n[model]\nheads = 16\n",
        );
        let e = load_model_config(&child).unwrap_err();
        assert_eq!(e.path, parent);
        assert_eq!(e.line, Some(3));
    }

    #[test]
    fn extends_merges_child_over_parent() {
        let dir = tempfile::tempdir().unwrap();
        write(
            dir.path(),
            "p.toml",
            "[model]\narch = \"qean\"\nheads = 16\ndropout = 0.1\n[train]\nsteps = 5\n",
        );
        let child = write(
            dir.path(),
            "sub/c.toml",
            "extends = \"../p.toml\"\n[model]\nposition = \"rotary\"\n",
        );
        let table = load_merged_table(&child).unwrap();
        assert_eq!(table["train"]["steps"].as_integer(), Some(5));
        let c = model_from_table(&table, &child).unwrap();
        assert_eq!(c.heads, 16);
        assert_eq!(c.dropout, 0.1);
        assert_eq!(c.position, PositionKind::Rotary);
        assert_eq!(c.arch, Arch::Qean);
    }

    #[test]
    fn wrong_type_and_bad_values_are_reported() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(dir.path(), "t.toml", "[model]\nheads = \"ten\"\n");
        let e = load_model_config(&p).unwrap_err();
        assert_eq!(e.line, Some(2), "{e}");
        let p = write(dir.path(), "h.toml", "[model]\nheads = 7\n");
        let e = load_model_config(&p).unwrap_err();
        assert!(e.message.contains("heads"), "{e}");
        let p = write(dir.path(), "q.toml", "[model]\nattention = \"qra\"\n");
        let e = load_model_config(&p).unwrap_err();
        assert!(e.message.contains("attention"), "{e}");
        let p = write(dir.path(), "m.toml", "extends = \"missing.toml\"\n");
        let e = load_model_config(&p).unwrap_err();
        assert!(e.message.contains("missing.toml"), "{e}");
    }

    #[test]
    fn extends_cycle_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let a = write(dir.path(), "a.toml", "extends = \"b.toml\"\n");
        write(dir.path(), "b.toml", "extends = \"a.toml\"\n");
        let e = load_model_config(&a).unwrap_err();
        assert!(e.message.contains("too deep"), "{e}");
    }

    #[test]
    fn nested_qra_and_rope_tables_and_their_old_flat_keys() {
        let dir = tempfile::tempdir().unwrap();
        let nested = write(
            dir.path(),
            "n.toml",
            "[model]\narch = \"qean\"\nattention = \"qra\"\n[model.qra]\nlayers = \"last_k\"\nlayers_k = 2\ninit = \"zero\"\n[model.rope]\nbase = 500.0\n",
        );
        let want = load_model_config(&nested).unwrap();
        assert_eq!(
            (
                want.qra.layers,
                want.qra.layers_k,
                want.qra.init,
                want.rope.base
            ),
            (QraLayers::LastK, 2, QraInit::Zero, 500.0)
        );
        // A config (or a run directory's config.toml) written with the flat keys reads the same.
        let flat = write(
            dir.path(),
            "f.toml",
            "[model]\narch = \"qean\"\nattention = \"qra\"\nqra_layers = \"last_k\"\nqra_layers_k = 2\nqra_init = \"zero\"\nrope_base = 500.0\n",
        );
        assert_eq!(load_model_config(&flat).unwrap(), want);
        // Given both ways: one line naming the new spelling.
        let both = write(
            dir.path(),
            "b.toml",
            "[model]\nqra_init = \"zero\"\n[model.qra]\ninit = \"small\"\n",
        );
        let e = load_model_config(&both).unwrap_err().to_string();
        assert!(
            e.contains("qra_init") && e.contains("[model.qra] init"),
            "{e}"
        );
        assert!(!e.contains('\n'), "{e}");
        // An unknown key inside a nested table still names its file and line.
        let bad = write(dir.path(), "u.toml", "[model]\n[model.qra]\nperiod = 3\n");
        let e = load_model_config(&bad).unwrap_err();
        assert_eq!(e.line, Some(3), "{e}");
        assert!(e.message.contains("period"), "{e}");
        // A FACT config with a QRA setting names the nested key.
        let fact = write(dir.path(), "x.toml", "[model]\n[model.qra]\nkernel = 3\n");
        let e = load_model_config(&fact).unwrap_err().to_string();
        assert!(e.contains("`qra.kernel` is a QEAN option"), "{e}");
    }

    #[test]
    fn qra_layer_selection() {
        let c = ModelConfig {
            arch: Arch::Qean,
            attention: AttentionKind::Qra,
            cross_layers: 5,
            qra: QraOptions {
                layers: QraLayers::LastK,
                layers_k: 2,
                ..QraOptions::default()
            },
            ..ModelConfig::default()
        };
        let used: Vec<bool> = (0..5).map(|l| c.layer_uses_qra(l)).collect();
        assert_eq!(used, [false, false, false, true, true]);
        let mut c = c;
        c.qra.layers = QraLayers::FirstK;
        let used: Vec<bool> = (0..5).map(|l| c.layer_uses_qra(l)).collect();
        assert_eq!(used, [true, true, false, false, false]);
    }
}
