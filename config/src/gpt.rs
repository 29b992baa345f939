//! `[gpt]`: the music-to-dance GPT of the multi-modal control system (SPEC §13.3–13.4, §13.8). It predicts the
//! tokens of a frozen motion VQ-VAE (`vqvae_run`); every [DECISION] of §13.3 is a key here. Defaults are the
//! paper preset (Bailando's GPT size).

use serde::{Deserialize, Serialize};

/// How M-Base lays out music and motion.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MLayout {
    /// [music tokens | motion tokens], block-causal over the two streams (Bailando).
    #[default]
    TwoStream,
    /// One stream: x_j = E(c_{s+j−1}) + MLP(a_{s+j}) + P_j.
    Sum,
}

/// How the music weight w falls inside a text interval (SPEC §13.7 `text.schedule` [DECISION]: the
/// paper's Fig. 3 is unreadable).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TextSchedule {
    /// w = 1 − t.
    #[default]
    Linear,
    /// w = (1 + cos πt) / 2.
    Cosine,
    /// w = 0 over the whole interval.
    Step,
}

/// The `[gpt]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GptConfig {
    /// The frozen VQ-VAE run (its newest checkpoint); `--set gpt.vqvae_run=DIR` overrides it.
    pub vqvae_run: Option<std::path::PathBuf>,
    /// Codebook size K of that VQ-VAE (checked against it; the head has K + 1 outputs).
    pub codes: usize,
    /// Frames per token of that VQ-VAE (8: a music token is 8 × 35 feature values).
    pub rate: usize,
    /// Width D.
    pub hidden: usize,
    pub heads: usize,
    /// Blocks of each base (L_b) and of the shared head (L_h).
    pub base_layers: usize,
    pub head_layers: usize,
    /// Tokens per window n.
    pub window: usize,
    pub dropout: f64,
    pub m_layout: MLayout,
    /// Stream m holds a_{s+j+δ}.
    pub music_lookahead: usize,
    /// CLIP embedding width of the text base.
    pub text_dim: usize,
    /// Probability of keeping each input token in music steps (1: no corruption).
    pub m_pkeep: f64,
    /// The same for text steps (T2M-GPT 0.5).
    pub pkeep: f64,
    /// One text step every `text_every` steps when text data exists (2: even music, odd text).
    pub text_every: u64,
    /// Text data: a directory of `NAME.npy` text embeddings (`text_dim` values each, e.g. CLIP) for training
    /// sequences; sequences without one take no text steps.
    pub text_dir: Option<std::path::PathBuf>,
    /// Text data: a text–motion set in the HumanML3D layout (SPEC §13.1: `new_joints/`, `texts/`,
    /// `text_emb/`, `<split>.txt`); each (motion, caption) pair of its `text_split` is one text item, its
    /// motion made 24 joints at 60 fps and tokenised by the frozen VQ-VAE.
    pub text_set: Option<std::path::PathBuf>,
    /// The split file of `text_set` read for training (`train` → `train.txt`).
    pub text_split: String,
    /// Frame rate of `text_set`'s joints (HumanML3D: 20); resampled to 60 fps by linear interpolation.
    pub text_fps: f64,
    /// Scale every text embedding (training and sampling) to unit length (SPEC `text.l2_normalise`; off:
    /// T2M-GPT feeds CLIP raw).
    pub text_l2_normalise: bool,
    /// Synthetic text data: every training sequence gets a pseudo-embedding of its genre (a seeded random
    /// unit vector per AIST++ genre code). It exercises the T-Base and the shared-head alternation; it is
    /// not language.
    pub synthetic_text: bool,
    /// Seed tokens of sampling (15 = the first 120 ground-truth frames).
    pub seed_tokens: usize,
    /// Sampling: top-k (1 = greedy, Bailando; 0 = the full distribution) and temperature.
    pub top_k: usize,
    pub temperature: f64,
    /// Sampling, ours: the logits of codes among the last `repetition_window` tokens are divided by this
    /// (multiplied when negative) before picking, so the dance does not lock onto one still code
    /// (1 = off, the paper's picking; CTRL's repetition penalty).
    pub repetition_penalty: f64,
    pub repetition_window: usize,
    /// Decoding, ours: the decoded dance's lowest point pinned to the seed's floor over windows of this many
    /// frames (0 = off, the paper's decoding): the root integrated from decoded velocities otherwise sinks
    /// through the floor (`qean_motion::floor`; docs/control.md, "Feet on the floor").
    pub floor_window: usize,
    /// Decoding, ours: the slow glide of the planted feet (the same bias, sideways) taken away over windows
    /// of this many frames (0 = off, the paper's decoding; `qean_motion::floor::stop_sliding`).
    pub slide_window: usize,
    /// Decoding, ours: σ (frames) of a Gaussian over time on the decoded joints after the seed (0 = off,
    /// the paper's decoding): the decoder's frame-to-frame roughness taken away (`qean_motion::smooth`).
    pub smooth_sigma: f64,
    /// SPEC §13.2.6 option: the training split is also tokenised from frame offsets 1..rate−1 (the music
    /// shifted alike), so the GPT sees `rate` different token sequences of each dance instead of one.
    pub token_shift_aug: bool,
    /// Text control (SPEC §13.7): the music weight's schedule inside a text interval, and its ramp in tokens
    /// on each side (4 = 0.53 s; 0 = `step`).
    pub text_schedule: TextSchedule,
    pub text_ramp: usize,
}

impl Default for GptConfig {
    fn default() -> Self {
        Self::paper()
    }
}

impl GptConfig {
    /// `paper` (SPEC §13.9, Bailando's size): D 768, 12 heads, 6 + 6 blocks, n 32, K 1024.
    pub fn paper() -> Self {
        GptConfig {
            vqvae_run: None,
            codes: 1024,
            rate: 8,
            hidden: 768,
            heads: 12,
            base_layers: 6,
            head_layers: 6,
            window: 32,
            dropout: 0.1,
            m_layout: MLayout::TwoStream,
            music_lookahead: 0,
            text_dim: 512,
            m_pkeep: 1.0,
            pkeep: 0.5,
            text_every: 2,
            text_dir: None,
            text_set: None,
            text_split: "train".into(),
            text_fps: 20.0,
            text_l2_normalise: false,
            synthetic_text: false,
            seed_tokens: 15,
            top_k: 1,
            temperature: 1.0,
            repetition_penalty: 1.0,
            repetition_window: 8,
            floor_window: 0,
            slide_window: 0,
            smooth_sigma: 0.0,
            token_shift_aug: false,
            text_schedule: TextSchedule::Linear,
            text_ramp: 4,
        }
    }

    /// `tiny` (CPU): D 64, 4 heads, 2 + 2 blocks, n 16, K 128.
    pub fn tiny() -> Self {
        GptConfig {
            codes: 128,
            hidden: 64,
            heads: 4,
            base_layers: 2,
            head_layers: 2,
            window: 16,
            ..Self::paper()
        }
    }

    /// The sizes that fix a GPT's parameters, named by [`GptConfig::SHAPE_FIELDS`]: a checkpoint to resume
    /// or a frozen GPT to build on must have the same.
    pub fn shape(
        &self,
    ) -> (
        usize,
        usize,
        usize,
        usize,
        usize,
        usize,
        usize,
        MLayout,
        usize,
    ) {
        (
            self.codes,
            self.rate,
            self.hidden,
            self.heads,
            self.base_layers,
            self.head_layers,
            self.window,
            self.m_layout,
            self.text_dim,
        )
    }

    /// The names of [`GptConfig::shape`]'s values, in order.
    pub const SHAPE_FIELDS: &'static str =
        "codes, rate, hidden, heads, base_layers, head_layers, window, m_layout, text_dim";

    /// Values no GPT can use, as one message.
    /// How `text_set` is read: at `text_fps`, `text_dim`-wide embeddings, caption slices on this GPT's
    /// token grid.
    pub fn text_set_options(&self) -> qean_aistpp::text_set::TextSetOptions {
        qean_aistpp::text_set::TextSetOptions {
            fps: self.text_fps,
            dim: self.text_dim,
            l2_normalise: self.text_l2_normalise,
            rate: self.rate,
        }
    }

    /// Whether text steps are configured (any of `text_dir`, `text_set`, `synthetic_text`).
    pub fn has_text(&self) -> bool {
        self.text_dir.is_some() || self.text_set.is_some() || self.synthetic_text
    }

    pub fn validate(&self) -> Result<(), String> {
        if self.hidden == 0 || self.heads == 0 || !self.hidden.is_multiple_of(self.heads) {
            return Err(format!(
                "gpt.hidden = {} must be a positive multiple of gpt.heads = {}",
                self.hidden, self.heads
            ));
        }
        if self.codes < 2 || self.window < 2 || self.rate == 0 || self.base_layers == 0 {
            return Err("gpt.codes and gpt.window must be at least 2, gpt.rate and gpt.base_layers at least 1".into());
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return Err(format!(
                "gpt.dropout must be in [0, 1), got {}",
                self.dropout
            ));
        }
        for (name, p) in [("m_pkeep", self.m_pkeep), ("pkeep", self.pkeep)] {
            if !(p > 0.0 && p <= 1.0) {
                return Err(format!("gpt.{name} must be in (0, 1], got {p}"));
            }
        }
        if !(self.temperature.is_finite() && self.temperature > 0.0) {
            return Err(format!(
                "gpt.temperature must be positive, got {}",
                self.temperature
            ));
        }
        if !(self.repetition_penalty.is_finite() && self.repetition_penalty >= 1.0) {
            return Err(format!(
                "gpt.repetition_penalty must be ≥ 1 (1 = off), got {}",
                self.repetition_penalty
            ));
        }
        if self.text_every == 0 {
            return Err("gpt.text_every must be at least 1".into());
        }
        if !(self.smooth_sigma.is_finite() && (0.0..=10.0).contains(&self.smooth_sigma)) {
            return Err(format!(
                "gpt.smooth_sigma must be in [0, 10] frames (0 = off), got {}",
                self.smooth_sigma
            ));
        }
        if !(self.text_fps.is_finite() && self.text_fps > 0.0 && self.text_fps <= 60.0) {
            return Err(format!(
                "gpt.text_fps must be in (0, 60] (HumanML3D: 20), got {}",
                self.text_fps
            ));
        }
        Ok(())
    }
}
