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

/// How a sampled frame's bins become coordinates (docs/tsmt.md, "Decoding"). `bin` is the paper's
/// (SPEC §11.2 and §11.8); the others are ours, against the jitter of independent draws and of the
/// bins themselves.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TsmtDecode {
    /// Every coordinate draws its own bin and takes the bin's centre (the paper).
    #[default]
    Bin,
    /// Bins drawn as the paper draws them; each coordinate takes the mean of its distribution over the
    /// drawn bin and `subbin_radius` bins on each side (sub-bin resolution, the same tokens).
    Subbin,
    /// One uniform per frame shared by every coordinate, wandering smoothly in time (a reflected random
    /// walk over [0, 1) that crosses its range in about `coherent_seconds`), read through each
    /// coordinate's distribution as a continuous quantile (linear inside a bin); the token fed back is
    /// the bin it falls in.
    Coherent,
    /// The mean of each coordinate's distribution (deterministic); the token fed back is its bin.
    Mean,
}

impl TsmtDecode {
    /// Every decoding's name, as `--decode` and `tsmt.decode` spell it.
    pub const NAMES: [&'static str; 4] = ["bin", "subbin", "coherent", "mean"];

    pub fn name(self) -> &'static str {
        match self {
            TsmtDecode::Bin => "bin",
            TsmtDecode::Subbin => "subbin",
            TsmtDecode::Coherent => "coherent",
            TsmtDecode::Mean => "mean",
        }
    }
}

impl std::str::FromStr for TsmtDecode {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "bin" => Ok(TsmtDecode::Bin),
            "subbin" => Ok(TsmtDecode::Subbin),
            "coherent" => Ok(TsmtDecode::Coherent),
            "mean" => Ok(TsmtDecode::Mean),
            _ => Err(format!(
                "unknown TSMT decoding `{s}`: expected one of {}",
                Self::NAMES.join(", ")
            )),
        }
    }
}

/// How a coarse model's frames (`frame_step` > 1) are brought back to 60 fps.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TsmtUpsample {
    /// The uniform cubic B-spline with the sampled frames as control points: smooth acceleration, near
    /// the frames rather than through them.
    #[default]
    Bspline,
    /// Catmull–Rom interpolation through the sampled frames.
    CatmullRom,
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
    /// Training targets spread as a Gaussian of this SD (in bins) over neighbouring bins (0: one bin, the
    /// paper's cross-entropy).
    pub target_sigma: f64,
    /// Noise on the training inputs: each input token moved by a rounded N(0, σ²) number of bins (0: the
    /// paper's clean teacher forcing).
    pub input_noise: f64,
    /// How sampled bins become coordinates (`bin`: the paper's).
    pub decode: TsmtDecode,
    /// `subbin`: bins averaged on each side of the drawn one.
    pub subbin_radius: usize,
    /// `coherent`: seconds in which the shared quantile crosses its range.
    pub coherent_seconds: f64,
    /// The model steps every `frame_step` frames of the 60 fps data (1: every frame, as SPEC §11.1 maps the
    /// paper; 3: 20 fps, near the paper's own 24 fps); sampled frames are interpolated back to 60 fps.
    pub frame_step: usize,
    /// Ours: with `frame_step` > 1 the training split is also read on the grids from frames 1..frame_step−1
    /// (each its own sequence), not only from frame 0, so the coarse rate throws no data away.
    pub shift_aug: bool,
    /// How frames sampled at the coarse rate become 60 fps frames.
    pub upsample: TsmtUpsample,
    /// Ground-truth seed frames before generation.
    pub seed_frames: usize,
    /// The LR starts at this factor of `schedule.initial` (0.1: the tsmt-fork helper).
    pub lr_start_factor: f64,
    /// IK for exports and Coherence.
    pub ik: IkMode,
    /// Decoding, ours: σ (frames) of a Gaussian over time on the decoded joints (0 = off, the paper's
    /// decoding; `qean_motion::smooth`, as `gpt.smooth_sigma`).
    pub smooth_sigma: f64,
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
            target_sigma: 0.0,
            input_noise: 0.0,
            decode: TsmtDecode::Bin,
            subbin_radius: 3,
            coherent_seconds: 2.0,
            frame_step: 1,
            shift_aug: false,
            upsample: TsmtUpsample::Bspline,
            seed_frames: 120,
            lr_start_factor: 1.0,
            ik: IkMode::Swing,
            smooth_sigma: 0.0,
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
        if !(self.smooth_sigma.is_finite() && (0.0..=10.0).contains(&self.smooth_sigma)) {
            return Err(format!(
                "tsmt.smooth_sigma must be in [0, 10] frames (0 = off), got {}",
                self.smooth_sigma
            ));
        }
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
            ("frame_step", self.frame_step),
            ("seed_frames", self.seed_frames),
        ];
        for (key, value) in positive {
            if value == 0 {
                return Err(format!("tsmt.{key} must be positive"));
            }
        }
        if self.frame_step > 10 {
            return Err(format!(
                "tsmt.frame_step must be at most 10 (6 fps), got {}",
                self.frame_step
            ));
        }
        if self.frame_step > 1 && self.root_mode == RootMode::Delta {
            return Err(
                "tsmt.frame_step > 1 needs tsmt.root_mode = \"drop\" (the root deltas are per 60 fps frame)"
                    .into(),
            );
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
        if !(self.target_sigma.is_finite() && (0.0..=50.0).contains(&self.target_sigma)) {
            return Err(format!(
                "tsmt.target_sigma must be in [0, 50] bins, got {}",
                self.target_sigma
            ));
        }
        if !(self.input_noise.is_finite() && (0.0..=50.0).contains(&self.input_noise)) {
            return Err(format!(
                "tsmt.input_noise must be in [0, 50] bins, got {}",
                self.input_noise
            ));
        }
        if !(self.coherent_seconds.is_finite() && self.coherent_seconds > 0.0) {
            return Err(format!(
                "tsmt.coherent_seconds must be positive, got {}",
                self.coherent_seconds
            ));
        }
        if !(self.lr_start_factor.is_finite() && self.lr_start_factor > 0.0) {
            return Err(format!(
                "tsmt.lr_start_factor must be positive, got {}",
                self.lr_start_factor
            ));
        }
        self.validate_bins()
    }

    /// The explicit bin ranges (`bins_lo`, `bins_hi`): one finite lo < hi per coordinate, or none.
    fn validate_bins(&self) -> Result<(), String> {
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
        // Decodings by name, in the config and on the command line.
        for name in TsmtDecode::NAMES {
            let d: TsmtDecode = name.parse().unwrap();
            assert_eq!(d.name(), name);
            let c: TsmtConfig = toml::from_str(&format!("decode = \"{name}\"")).unwrap();
            assert_eq!(c.decode, d);
        }
        let e = "smooth".parse::<TsmtDecode>().unwrap_err();
        assert!(
            e.contains("`smooth`") && e.contains("bin, subbin, coherent, mean"),
            "{e}"
        );
        assert!(toml::from_str::<TsmtConfig>("decode = \"smooth\"").is_err());
    }
}
