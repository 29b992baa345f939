//! `[inbetween]`: the transformer in-betweeners of Lin's thesis (SPEC §12.4c). Every [DECISION] of §12.4c is
//! a key here (`--set inbetween.variant=genre`). Defaults are the `ib_paper` sizes of the `motion` variant.

use crate::model::AttnScale;
use serde::{Deserialize, Serialize};

/// Which in-betweener (Lin's D_* labels).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Variant {
    /// D_motion: the interpolated keyframes alone.
    #[default]
    Motion,
    /// D_genre: keyframes + a one-hot of the nine genres.
    Genre,
    /// D_cross_full: a decoder on the keyframes cross-attending to an encoder of the 22-D music feature.
    CrossFull,
    /// D_cross_drum: the same on the drums stem's feature.
    CrossDrum,
    /// D_merged_full: each frame's keyframe vector merged with its encoded music, then self-attention.
    MergedFull,
    /// D_merged_drum: the same on the drums stem.
    MergedDrum,
}

impl Variant {
    pub const ALL: [Variant; 6] = [
        Variant::Motion,
        Variant::Genre,
        Variant::CrossFull,
        Variant::CrossDrum,
        Variant::MergedFull,
        Variant::MergedDrum,
    ];

    /// Whether the variant reads music.
    pub fn has_audio(self) -> bool {
        !matches!(self, Variant::Motion | Variant::Genre)
    }

    /// Whether it is a decoder with cross-attention.
    pub fn is_cross(self) -> bool {
        matches!(self, Variant::CrossFull | Variant::CrossDrum)
    }

    /// Whether its music comes from the drums stem.
    pub fn drums(self) -> bool {
        matches!(self, Variant::CrossDrum | Variant::MergedDrum)
    }

    pub fn name(self) -> &'static str {
        match self {
            Variant::Motion => "motion",
            Variant::Genre => "genre",
            Variant::CrossFull => "cross_full",
            Variant::CrossDrum => "cross_drum",
            Variant::MergedFull => "merged_full",
            Variant::MergedDrum => "merged_drum",
        }
    }
}

/// The decoder layer of the cross variants.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Decoder {
    /// Self-attention, cross-attention, MLP.
    #[default]
    Standard,
    /// Cross-attention and MLP only (Lin §2.3.4's description).
    CrossOnly,
}

/// How the merged variants join motion and music (`merge_axis`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MergeAxis {
    /// Per frame: Dense([B_t | enc_t] (225 + d) → d) (SPEC §12.4c default).
    #[default]
    Features,
    /// Tokens [Dense(B); enc] concatenated along time as in FACT, the output read at the B tokens.
    Time,
}

/// The interpolated base B the network corrects.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Base {
    /// Linear root + SLERP joints (§12.4a), in the 225-D layout.
    #[default]
    Slerp,
    /// Element-wise lerp of the 225-D vectors.
    ElementwiseLerp,
}

/// How the learnt residual meets the keys ([OURS]: Lin adds f(·) everywhere and clamps the keys).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Taper {
    /// Ŷ = B + f(·), keys clamped afterwards (Lin): the dance can jump one frame from a key.
    #[default]
    None,
    /// Ŷ = B + w·f(·) with w = sin²(π(t − t1)/(t2 − t1)) between consecutive keys t1 < t2: zero value and
    /// slope at every key, so the residual fades in and out and clamping changes nothing.
    Sin2,
}

/// Where the drums variants' stem comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DrumSource {
    /// `<data>/stems/<music ID>/drums.wav` (e.g. OpenUnmix's output, as Lin).
    #[default]
    Files,
    /// librosa's HPSS percussive part of the full mix (no separation model needed).
    Hpss,
}

/// How the 22 music columns are scaled before the music encoder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MusicNorm {
    /// Per column (x − mean)/SD over the training split's music, fitted once ([DECISION]: raw MFCCs reach
    /// the hundreds, and the encoder output enters the motion stream without a LayerNorm).
    #[default]
    Standardize,
    /// Raw feature values.
    None,
}

/// The MLP's activation.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MlpAct {
    /// §4.1's tanh-GELU ([DECISION]: App. A's "softmax" read as the attention softmax).
    #[default]
    Gelu,
    Relu,
}

/// The `[inbetween]` table.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct InbetweenConfig {
    pub variant: Variant,
    /// Model width d (800).
    pub hidden: usize,
    /// Heads (10).
    pub heads: usize,
    /// MLP inner width (3072).
    pub ffn: usize,
    /// Layers of the self-attention stack or decoder (4).
    pub layers: usize,
    /// Layers of the music encoder (4).
    pub audio_layers: usize,
    /// Dropout (0.1) on attention probabilities and branch outputs.
    pub dropout: f64,
    /// Rows of each learned position table (240 ≥ the longest measure, 181 frames at 80 BPM).
    pub max_len: usize,
    /// Score scale: 1/√d_head (default) or mint's 1/√d.
    pub scale: AttnScale,
    pub decoder: Decoder,
    /// How `merged_*` join motion and music.
    pub merge_axis: MergeAxis,
    pub base: Base,
    /// How the residual meets the keys (`none`: Lin's; `sin2`: faded to 0 at every key).
    pub taper: Taper,
    /// Weight of a velocity term in the training loss ([OURS]; 0 = Lin's plain MSE): the MSE of the
    /// frame-to-frame differences, (Ŷ_{t+1} − Ŷ_t) − (Y_{t+1} − Y_t), over consecutive valid frames.
    pub lambda_vel: f64,
    /// Keyframes per measure in training (even keys, §12.3a).
    pub train_keys: usize,
    /// Draw N from {3, 5, 9} per window instead of `train_keys` (for edits with other key counts).
    pub mixed_keys: bool,
    /// Interior keys drawn uniformly among the measure's frames (its ends stay keys) instead of even ones
    /// (SPEC §12.4c "or random keys": for edits that keep hand-picked frames).
    pub random_keys: bool,
    /// Train on Ballet Jazz too (SPEC §12.1 `include_jb`): Lin drops it (its drums stem is silent), leaving
    /// 866 training sequences and nine genres; with it the genre variant's one-hot has ten (JB last).
    pub include_jb: bool,
    /// The drums stem of `cross_drum` / `merged_drum`.
    pub drums: DrumSource,
    pub music_norm: MusicNorm,
    /// The MLP activation (`ib_mlp_act`).
    pub mlp_act: MlpAct,
    /// Per-column mean and SD of the 22 music columns (filled by the trainer from the training split when
    /// `music_norm = "standardize"`; kept by resume and used at inference).
    pub music_mean: Vec<f64>,
    pub music_std: Vec<f64>,
}

impl Default for InbetweenConfig {
    fn default() -> Self {
        Self::paper()
    }
}

impl InbetweenConfig {
    /// Scale one row of the 22 music columns as the model was trained (`music_norm`).
    pub fn normalise_music(&self, row: &mut [f32]) {
        if self.music_norm == MusicNorm::Standardize && self.music_mean.len() == row.len() {
            for (k, v) in row.iter_mut().enumerate() {
                *v = ((*v as f64 - self.music_mean[k]) / self.music_std[k]) as f32;
            }
        }
    }

    /// `ib_paper` (Lin App. A): d 800, 10 heads, FFN 3072, 4 layers (+4 in the music encoder), dropout 0.1.
    pub fn paper() -> Self {
        InbetweenConfig {
            variant: Variant::Motion,
            hidden: 800,
            heads: 10,
            ffn: 3072,
            layers: 4,
            audio_layers: 4,
            dropout: 0.1,
            max_len: 240,
            scale: AttnScale::Head,
            decoder: Decoder::Standard,
            merge_axis: MergeAxis::Features,
            base: Base::Slerp,
            taper: Taper::None,
            lambda_vel: 0.0,
            train_keys: 5,
            mixed_keys: false,
            random_keys: false,
            include_jb: false,
            drums: DrumSource::Files,
            music_norm: MusicNorm::Standardize,
            mlp_act: MlpAct::Gelu,
            music_mean: Vec::new(),
            music_std: Vec::new(),
        }
    }

    /// `ib_tiny` (CPU): d 64, 4 heads, FFN 128, 2 layers (+2).
    pub fn tiny() -> Self {
        InbetweenConfig {
            hidden: 64,
            heads: 4,
            ffn: 128,
            layers: 2,
            audio_layers: 2,
            ..Self::paper()
        }
    }

    /// Values the types allow but the model cannot use, as `inbetween.<key>` messages.
    pub fn validate(&self) -> Result<(), String> {
        let positive = [
            ("hidden", self.hidden),
            ("heads", self.heads),
            ("ffn", self.ffn),
            ("layers", self.layers),
            ("max_len", self.max_len),
        ];
        if let Some((k, _)) = positive.iter().find(|(_, v)| *v == 0) {
            return Err(format!("inbetween.{k} must be at least 1"));
        }
        if !self.hidden.is_multiple_of(self.heads) {
            return Err(format!(
                "inbetween.heads ({}) must divide inbetween.hidden ({})",
                self.heads, self.hidden
            ));
        }
        if self.variant.has_audio() && self.audio_layers == 0 {
            return Err(format!(
                "inbetween.audio_layers must be at least 1 for variant {}",
                self.variant.name()
            ));
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return Err(format!(
                "inbetween.dropout must be in [0, 1), got {}",
                self.dropout
            ));
        }
        let stats = [self.music_mean.len(), self.music_std.len()];
        if stats != [0, 0] && stats != [22, 22] {
            return Err(
                "inbetween.music_mean and music_std must hold 22 values each (or none)".into(),
            );
        }
        if self.music_std.iter().any(|s| !(s.is_finite() && *s > 0.0))
            || self.music_mean.iter().any(|m| !m.is_finite())
        {
            return Err("inbetween.music_mean/music_std must be finite, with every SD > 0".into());
        }
        if !(self.lambda_vel.is_finite() && self.lambda_vel >= 0.0) {
            return Err(format!(
                "inbetween.lambda_vel must be a finite value ≥ 0, got {}",
                self.lambda_vel
            ));
        }
        if self.train_keys < 2 {
            return Err("inbetween.train_keys must be at least 2".into());
        }
        Ok(())
    }
}
