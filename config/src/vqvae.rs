//! `[vq]`: the motion VQ-VAE of the multi-modal control system (SPEC §13.2). Every [DECISION] of §13.2 is a
//! key here (`--set vq.quantizer=st`). Defaults are the paper preset (T2M-GPT's sizes at Bailando's 60-fps
//! downsampling of 8).

use qean_motion::pos72::RootChannels;
use serde::{Deserialize, Serialize};

/// Order of the dilations in a residual stack.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Dilations {
    /// 3^(depth−1), …, 3, 1 (T2M-GPT's `Resnet1D` reversed, in encoder and decoder).
    #[default]
    Decreasing,
    /// 1, 3, …, 3^(depth−1) in the encoder (Bailando).
    Increasing,
}

/// How the decoder doubles the length.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VqDecoder {
    /// Nearest upsampling ×2 then Conv1d(k3) (T2M-GPT).
    #[default]
    Upsample,
    /// ConvTranspose1d(W, W, 4, 2, 1), and no conv before the output layer (Bailando).
    Bailando,
}

/// The quantiser.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Quantizer {
    /// EMA codebook (μ) with dead-code reset from the batch (T2M-GPT `QuantizeEMAReset`).
    #[default]
    EmaReset,
    /// A learned codebook with the straight-through loss (TM2T).
    St,
}

/// Where a reset code's replacement comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ResetSource {
    /// Candidate row k of the (tiled) batch (T2M-GPT).
    #[default]
    Batch,
    /// The candidates shuffled first (Bailando/Jukebox).
    Randperm,
}

/// The reconstruction loss.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VqLoss {
    /// L1 on positions, velocities and accelerations (Bailando).
    #[default]
    Bailando,
    /// Smooth-L1 reconstruction + 0.5·smooth-L1 on the joint block (T2M-GPT).
    T2m,
}

/// How AIST++ and a text set share the VQ-VAE's epochs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TextBalance {
    /// 1:1: the smaller source's sequences repeat within an epoch.
    #[default]
    Equal,
    /// Each sequence once per epoch.
    Proportional,
}

/// Feature normalisation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum VqNormalise {
    /// Raw pos72 (Bailando).
    #[default]
    None,
    /// Training-split mean and SD per channel (ddof 0), fitted once into `mean`/`std`.
    Zscore,
}

/// The `[vq]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VqConfig {
    /// What the first three pos72 channels hold (`velocity`; `floor` puts the root height in channel 1).
    pub root: RootChannels,
    pub root_vel_scale: f64,
    pub normalise: VqNormalise,
    /// Conv width W.
    pub width: usize,
    /// Code dimension C.
    pub code_dim: usize,
    /// Codebook size K.
    pub codes: usize,
    /// Residual blocks per stack.
    pub depth: usize,
    /// Downsamplings (the rate is 2^down_t).
    pub down_t: usize,
    /// Training window (frames; a multiple of 2^down_t).
    pub window: usize,
    pub enc_dilations: Dilations,
    pub decoder: VqDecoder,
    pub quantizer: Quantizer,
    /// EMA decay μ.
    pub mu: f64,
    /// A reset code's statistics become (candidate, 1) instead of keeping their decayed values.
    pub reset_stats: bool,
    pub reset_source: ResetSource,
    /// β_st of the straight-through quantiser.
    pub beta_st: f64,
    pub loss: VqLoss,
    pub lambda_vel: f64,
    pub lambda_acc: f64,
    /// β on the commitment loss.
    pub commit: f64,
    /// A random rotation about y per window (unset: on when `text_set` is used, SPEC §13.2.1 [DECISION]:
    /// HumanML3D faces +Z at frame 0, AIST++ does not).
    pub yaw_augment: Option<bool>,
    /// A text–motion set in the HumanML3D layout (SPEC §13.1) whose `text_split` motions join the AIST++
    /// training split (SPEC §13.2.5), as 24 joints at 60 fps: the codebook the GPT's T-Base predicts must
    /// cover text motions too.
    pub text_set: Option<std::path::PathBuf>,
    pub text_split: String,
    /// Frame rate of `text_set`'s joints (HumanML3D: 20).
    pub text_fps: f64,
    /// How the two sources are drawn: `equal` (SPEC [DECISION] "balance": each epoch visits the smaller
    /// side's sequences as often as it takes to match the larger's count) or `proportional` (each
    /// sequence once).
    pub text_balance: TextBalance,
    /// Per-channel statistics of `normalise = "zscore"` (filled by the trainer from the training split).
    pub mean: Vec<f64>,
    pub std: Vec<f64>,
}

impl Default for VqConfig {
    fn default() -> Self {
        Self::paper()
    }
}

impl VqConfig {
    /// `paper` (SPEC §13.9): W 512, C 512, K 1024, depth 3, down_t 3, window 128.
    pub fn paper() -> Self {
        VqConfig {
            root: RootChannels::Velocity,
            root_vel_scale: 1.0,
            normalise: VqNormalise::None,
            width: 512,
            code_dim: 512,
            codes: 1024,
            depth: 3,
            down_t: 3,
            window: 128,
            enc_dilations: Dilations::Decreasing,
            decoder: VqDecoder::Upsample,
            quantizer: Quantizer::EmaReset,
            mu: 0.99,
            reset_stats: false,
            reset_source: ResetSource::Batch,
            beta_st: 1.0,
            loss: VqLoss::Bailando,
            lambda_vel: 1.0,
            lambda_acc: 1.0,
            commit: 0.02,
            yaw_augment: None,
            text_set: None,
            text_split: "train".into(),
            text_fps: 20.0,
            text_balance: TextBalance::Equal,
            mean: Vec::new(),
            std: Vec::new(),
        }
    }

    /// `tiny` (CPU): W 64, C 64, K 128, depth 2, down_t 3, window 64.
    pub fn tiny() -> Self {
        VqConfig {
            width: 64,
            code_dim: 64,
            codes: 128,
            depth: 2,
            window: 64,
            ..Self::paper()
        }
    }

    /// Frames per token, 2^down_t.
    pub fn rate(&self) -> usize {
        1 << self.down_t
    }

    /// Whether windows are rotated about y (`yaw_augment`, or by default whether a text set is used).
    pub fn yaw(&self) -> bool {
        self.yaw_augment.unwrap_or(self.text_set.is_some())
    }

    /// Values no VQ-VAE can use, as one message.
    pub fn validate(&self) -> Result<(), String> {
        if !(self.text_fps.is_finite() && self.text_fps > 0.0 && self.text_fps <= 60.0) {
            return Err(format!(
                "vq.text_fps must be in (0, 60] (HumanML3D: 20), got {}",
                self.text_fps
            ));
        }
        if self.width == 0 || self.code_dim == 0 || self.codes < 2 || self.depth == 0 {
            return Err(
                "vq.width, vq.code_dim and vq.depth must be at least 1, vq.codes at least 2".into(),
            );
        }
        if self.down_t == 0 || self.down_t > 6 {
            return Err(format!("vq.down_t must be 1..=6, got {}", self.down_t));
        }
        if self.window == 0 || !self.window.is_multiple_of(self.rate()) {
            return Err(format!(
                "vq.window = {} must be a positive multiple of 2^down_t = {}",
                self.window,
                self.rate()
            ));
        }
        if !(self.mu > 0.0 && self.mu < 1.0) {
            return Err(format!("vq.mu must be in (0, 1), got {}", self.mu));
        }
        let finite = [
            self.root_vel_scale,
            self.beta_st,
            self.lambda_vel,
            self.lambda_acc,
            self.commit,
        ];
        if finite.iter().any(|v| !v.is_finite() || *v < 0.0) || self.root_vel_scale == 0.0 {
            return Err(
                "vq.root_vel_scale must be positive; beta_st, lambda_vel, lambda_acc and commit finite and ≥ 0"
                    .into(),
            );
        }
        Ok(())
    }
}
