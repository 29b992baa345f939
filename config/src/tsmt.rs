//! `[tsmt]`: Li et al.'s two-stream motion transformer (SPEC §11). Every [DECISION] of §11 is a key
//! here, spelled as SPEC spells it without the `tsmt.` prefix (`--set tsmt.window=480`). Defaults are
//! the `tsmt_paper` preset (the sizes of the authors' training script, SPEC §11.6).

use serde::{Deserialize, Serialize};

/// How the coordinate bins are fitted (SPEC §11.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum BinsMode {
    /// One [lo, hi] per coordinate: its min and max over the training split.
    #[default]
    PerDim,
    /// One [lo, hi] for every coordinate (the reference code's single class table).
    Shared,
}

/// What happens to the root (SPEC §11.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RootMode {
    /// The root is not predicted (the reference); n = 69 root-relative coordinates.
    #[default]
    Drop,
    /// Three more coordinates (Δx, y, Δz): the ground-plane displacement from the previous frame
    /// and the absolute height; n = 72.
    Delta,
}

impl RootMode {
    /// Coordinates per frame: 69 (23 root-relative joints), or 72 with the root deltas.
    pub fn coords(self) -> usize {
        match self {
            RootMode::Drop => 69,
            RootMode::Delta => 72,
        }
    }
}

/// How training windows are drawn (SPEC §11.7).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum WindowMode {
    /// A random start per visit (the §5 window stream).
    #[default]
    Random,
    /// Fixed blocks with 50 % overlap (the paper's 20-s segments with 10-s overlap).
    Segments,
}

/// The audio stream's layout (SPEC §11.5 step 3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AudioStreams {
    /// MFCC and beat embeddings concatenated into one stream (the paper's single 1-D conv).
    #[default]
    Single,
    /// A beat stream and an MFCC stream, concatenated at the fusion (the reference's `multi_stream`).
    Split,
}

/// Inverse kinematics from positions to SMPL rotations (SPEC §11.3).
pub use qean_motion::ik::IkMode;

/// The `[tsmt]` table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct TsmtConfig {
    /// Number of bins per coordinate, C (300).
    pub n_bins: usize,
    /// How the bins are fitted.
    pub bins_mode: BinsMode,
    /// Lower bin edge per coordinate (filled from the training split when training starts,
    /// stored as f64, never recomputed; one value per coordinate in both modes).
    pub bins_lo: Vec<f64>,
    /// Upper bin edge per coordinate (as `bins_lo`).
    pub bins_hi: Vec<f64>,
    /// Root handling.
    pub root_mode: RootMode,
    /// Context length W in frames (480 = 8 s at 60 fps).
    pub window: usize,
    /// How training windows are drawn.
    pub windows: WindowMode,
    /// Pose embedding width per coordinate, D_E.
    pub embed: usize,
    /// Pose stream width D.
    pub hidden: usize,
    /// Pose stream heads H.
    pub heads: usize,
    /// Per-head q/k/v width of the pose stream, d_k = d_v (not D/H).
    pub head_dim: usize,
    /// Pose stream blocks L.
    pub layers: usize,
    /// Audio stream width D_a.
    pub audio_hidden: usize,
    /// Audio stream heads H_a.
    pub audio_heads: usize,
    /// Per-head width of the audio stream, d_ka.
    pub audio_head_dim: usize,
    /// Audio stream blocks L_a.
    pub audio_layers: usize,
    /// Audio stream layout.
    pub audio_streams: AudioStreams,
    /// Width of each coordinate's feature before the shared classifier, d_out.
    pub d_out: usize,
    /// Dropout rate (0.1).
    pub dropout: f64,
    /// Sampling temperature τ (0 = argmax).
    pub temperature: f64,
    /// Keep only the k most likely bins when sampling (0 = all).
    pub top_k: usize,
    /// Frames dropped at once when the context is full (1 = the reference).
    pub slide_stride: usize,
    /// Ground-truth seed frames before generation.
    pub seed_frames: usize,
    /// The LR starts at this factor of `schedule.initial` (0.1: the tsmt-fork helper).
    pub lr_start_factor: f64,
    /// IK for exports and Coherence.
    pub ik: IkMode,
}

impl Default for TsmtConfig {
    fn default() -> Self {
        Self::paper()
    }
}

impl TsmtConfig {
    /// `tsmt_paper` (SPEC §11.6): the sizes of the authors' training script.
    pub fn paper() -> Self {
        Self {
            n_bins: 300,
            bins_mode: BinsMode::PerDim,
            bins_lo: Vec::new(),
            bins_hi: Vec::new(),
            root_mode: RootMode::Drop,
            window: 480,
            windows: WindowMode::Random,
            embed: 10,
            hidden: 128,
            heads: 4,
            head_dim: 128,
            layers: 4,
            audio_hidden: 32,
            audio_heads: 2,
            audio_head_dim: 32,
            audio_layers: 2,
            audio_streams: AudioStreams::Single,
            d_out: 10,
            dropout: 0.1,
            temperature: 1.0,
            top_k: 0,
            slide_stride: 1,
            seed_frames: 120,
            lr_start_factor: 1.0,
            ik: IkMode::Swing,
        }
    }

    /// `tsmt_tiny` (SPEC §11.6): CPU tests and the demo.
    pub fn tiny() -> Self {
        Self {
            embed: 4,
            hidden: 32,
            heads: 2,
            head_dim: 16,
            layers: 2,
            audio_hidden: 8,
            audio_heads: 1,
            audio_head_dim: 4,
            audio_layers: 1,
            d_out: 4,
            window: 64,
            ..Self::paper()
        }
    }

    /// Number of coordinates n: 69 (23 root-relative joints), or 72 with the root deltas.
    pub fn coords(&self) -> usize {
        self.root_mode.coords()
    }

    /// Checks what the types do not; the message names the key.
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("n_bins", self.n_bins),
            ("window", self.window),
            ("embed", self.embed),
            ("hidden", self.hidden),
            ("heads", self.heads),
            ("head_dim", self.head_dim),
            ("layers", self.layers),
            ("audio_hidden", self.audio_hidden),
            ("audio_heads", self.audio_heads),
            ("audio_head_dim", self.audio_head_dim),
            ("audio_layers", self.audio_layers),
            ("d_out", self.d_out),
            ("slide_stride", self.slide_stride),
            ("seed_frames", self.seed_frames),
        ];
        for (key, value) in positive {
            if value == 0 {
                return Err(format!("tsmt.{key} must be positive"));
            }
        }
        if self.n_bins > u16::MAX as usize {
            return Err(format!("tsmt.n_bins must be at most {}", u16::MAX));
        }
        if self.slide_stride > self.window {
            return Err(format!(
                "tsmt.slide_stride = {} exceeds tsmt.window = {}",
                self.slide_stride, self.window
            ));
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return Err(format!(
                "tsmt.dropout must be in [0, 1), got {}",
                self.dropout
            ));
        }
        if !(self.temperature.is_finite() && self.temperature >= 0.0) {
            return Err(format!(
                "tsmt.temperature must be ≥ 0, got {}",
                self.temperature
            ));
        }
        if !(self.lr_start_factor.is_finite() && self.lr_start_factor > 0.0) {
            return Err(format!(
                "tsmt.lr_start_factor must be positive, got {}",
                self.lr_start_factor
            ));
        }
        if self.bins_lo.len() != self.bins_hi.len() {
            return Err("tsmt.bins_lo and tsmt.bins_hi must have the same length".into());
        }
        if !self.bins_lo.is_empty() && self.bins_lo.len() != self.coords() {
            return Err(format!(
                "tsmt.bins_lo holds {} values; root_mode {:?} has {} coordinates",
                self.bins_lo.len(),
                self.root_mode,
                self.coords()
            ));
        }
        if let Some(d) = (0..self.bins_lo.len()).find(|&d| {
            let (lo, hi) = (self.bins_lo[d], self.bins_hi[d]);
            !(lo.is_finite() && hi.is_finite() && hi > lo)
        }) {
            return Err(format!(
                "tsmt bins of coordinate {d}: need finite lo < hi, got [{}, {}]",
                self.bins_lo[d], self.bins_hi[d]
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_validate_and_name_their_keys() {
        TsmtConfig::paper().validate().unwrap();
        TsmtConfig::tiny().validate().unwrap();
        let bad = TsmtConfig {
            heads: 0,
            ..TsmtConfig::tiny()
        };
        assert!(bad.validate().unwrap_err().contains("tsmt.heads"));
        let bad = TsmtConfig {
            bins_lo: vec![0.0; 69],
            bins_hi: vec![0.0; 69],
            ..TsmtConfig::tiny()
        };
        assert!(bad.validate().unwrap_err().contains("coordinate 0"));
        let text = toml::to_string(&TsmtConfig::tiny()).unwrap();
        assert_eq!(
            toml::from_str::<TsmtConfig>(&text).unwrap(),
            TsmtConfig::tiny()
        );
        assert!(toml::from_str::<TsmtConfig>("windw = 3").is_err());
    }
}
