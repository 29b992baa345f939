//! The variant switches of the evaluation (SPEC §7, §10) and their labels. Every number in a report is
//! tagged with the configuration that produced it.

use clap::ValueEnum;
use serde::{Deserialize, Serialize};

use crate::pfc::PfcVariant;
use crate::preset::{JointSet, ProtocolPreset, ReferenceCut, Slices, Splits};

/// SPEC §7.6. `Reference` keeps the reference code's bugs (acceleration precedence, τ = 1/120);
/// `Corrected` fixes both and changes nothing else.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, ValueEnum)]
#[serde(rename_all = "snake_case")]
#[value(rename_all = "snake_case")]
pub enum MetricsMode {
    #[default]
    Reference,
    Corrected,
}

/// SPEC §7.1: Bailando subtracts the frame-0 root of the evaluated segment; mint uses absolute positions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, ValueEnum)]
#[serde(rename_all = "snake_case")]
#[value(rename_all = "snake_case")]
pub enum PositionMode {
    #[default]
    ZeroStart,
    MintAbsolute,
    /// Lodge: zero start, then every joint but the root relative to the root of its frame.
    RootRelative,
}

/// SPEC §7.3: which geometric ("manual") extractor.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, ValueEnum)]
#[serde(rename_all = "snake_case")]
#[value(rename_all = "snake_case")]
pub enum GeometricVariant {
    /// Bailando `utils/features/manual_new.py` = aist-api `features/manual.py` after 091f00b.
    #[default]
    ManualNew,
    /// aist-api `features/manual.py` before 091f00b: mis-ordered joint names and their constants.
    LegacyFairmotion,
}

/// SPEC §7.5: which BeatAlign formula.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, ValueEnum)]
#[serde(rename_all = "snake_case")]
#[value(rename_all = "snake_case")]
pub enum BaVariant {
    /// Bailando `utils/beat_align_score.py`: averaged over music beats.
    #[default]
    Bailando,
    /// mint PR-41 `tools/calculate_beat_scores.py`: averaged over motion beats.
    Mint,
}

/// SPEC §7.5: where the music beats came from (a label: the caller supplies the beats).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, ValueEnum)]
#[serde(rename_all = "snake_case")]
#[value(rename_all = "snake_case")]
pub enum MusicBeatSource {
    /// HPSS-percussive median onset envelope, start_bpm 120 (Bailando's music features).
    #[default]
    Bailando,
    /// Column 34 of the 35-D FACT feature.
    Feature35,
}

/// SPEC §7.5: which frames BeatAlign scores for generated motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, ValueEnum)]
#[serde(rename_all = "snake_case")]
#[value(rename_all = "snake_case")]
pub enum BaSegment {
    /// The generated frames only, against music [seed, seed + L).
    #[default]
    Generated,
    /// Seed and generated frames, against music [0, seed + L).
    Full,
}

/// Everything that decides the numbers of one evaluation.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvalConfig {
    pub metrics_mode: MetricsMode,
    pub positions: PositionMode,
    pub geometric: GeometricVariant,
    pub ba_variant: BaVariant,
    pub ba_music_beats: MusicBeatSource,
    pub ba_segment: BaSegment,
    /// Leading frames of each generated sequence that are the seed, not generated (SPEC §1.6: 120 for
    /// our sampler's seed ++ generated output; 0 for files holding generated frames only).
    pub seed_frames: usize,
    /// At most this many generated frames are evaluated (SPEC §1.6: 1200).
    pub max_frames: usize,
    /// Music frame of each generated sequence's frame 0 (0 when the seed is the first GT frames).
    pub music_offset: usize,
    /// Beat P/R/F1 (SPEC §11.9): motion beats match within this many frames (5; the seed's ±2 at
    /// 24 fps is 2 here as a literal frame count).
    #[serde(default = "default_beat_tol")]
    pub beat_tol: usize,
    /// σ of the Gaussian smoothing of the Kim-style motion beats (5; 0 = none).
    #[serde(default = "default_kim_sigma")]
    pub kim_sigma: f64,
    /// I-seq-D's chunk length in frames (240).
    #[serde(default = "default_chunk")]
    pub chunk: usize,
    /// Degrees added to every Authenticity joint limit (10).
    #[serde(default = "default_slack")]
    pub limit_slack_deg: f64,
    /// Coherence's fastest joint turn, degrees per second (1500).
    #[serde(default = "default_omega_max")]
    pub omega_max_deg_s: f64,
    /// PFC's frame rate: ours (60 fps) or EDGE's (30 fps).
    #[serde(default)]
    pub pfc: PfcVariant,
    /// The named protocol these settings follow (`None`: set one by one).
    #[serde(default)]
    pub preset: Option<ProtocolPreset>,
    /// The metrics see every `frame_stride`-th frame (2: 60 → 30 fps, EDGE and Lodge).
    #[serde(default = "one")]
    pub frame_stride: usize,
    /// Frame rate of the sequences handed in (60 for AIST++; the protocol cut sets its clips' rate).
    #[serde(default = "sixty")]
    pub fps: f64,
    /// Generated dances scored as overlapping clips (EDGE) instead of their first `max_frames`.
    #[serde(default)]
    pub slices: Option<Slices>,
    /// Which frames of the reference motions are scored.
    #[serde(default)]
    pub reference_cut: ReferenceCut,
    /// The joints of the kinetic and geometric features.
    #[serde(default)]
    pub joints: JointSet,
    /// The kinetic features' frame time is 1/kinetic_fps (Bailando and Lodge: 1/60 whatever the data's rate).
    #[serde(default = "sixty")]
    pub kinetic_fps: f64,
    /// Checkpoint mode's generated and reference sequences.
    #[serde(default)]
    pub splits: Splits,
    /// The reference set's name in the tables' ground-truth row (the dataset's: AIST++, FineDance, …).
    #[serde(default = "aistpp_name")]
    pub reference_name: String,
}

fn one() -> usize {
    1
}

fn sixty() -> f64 {
    60.0
}

fn default_beat_tol() -> usize {
    5
}

fn default_kim_sigma() -> f64 {
    5.0
}

fn default_chunk() -> usize {
    240
}

fn default_slack() -> f64 {
    10.0
}

fn default_omega_max() -> f64 {
    1500.0
}

impl Default for EvalConfig {
    fn default() -> Self {
        EvalConfig {
            metrics_mode: MetricsMode::Reference,
            positions: PositionMode::ZeroStart,
            geometric: GeometricVariant::ManualNew,
            ba_variant: BaVariant::Bailando,
            ba_music_beats: MusicBeatSource::Bailando,
            ba_segment: BaSegment::Generated,
            seed_frames: 120,
            max_frames: 1200,
            music_offset: 0,
            beat_tol: default_beat_tol(),
            kim_sigma: default_kim_sigma(),
            chunk: default_chunk(),
            limit_slack_deg: default_slack(),
            omega_max_deg_s: default_omega_max(),
            pfc: PfcVariant::Ours,
            preset: None,
            frame_stride: 1,
            fps: sixty(),
            slices: None,
            reference_cut: ReferenceCut::Whole,
            joints: JointSet::Smpl24,
            kinetic_fps: sixty(),
            splits: Splits::TestValAgainstAll,
            reference_name: aistpp_name(),
        }
    }
}

fn aistpp_name() -> String {
    "AIST++".into()
}

impl EvalConfig {
    /// A one-line label naming every variant, printed under tables.
    pub fn label(&self) -> String {
        let protocol = match self.preset {
            Some(p) => format!("protocol preset {}: ", value_name(p)),
            None => String::new(),
        };
        let rate = self.fps / self.frame_stride.max(1) as f64;
        let cut = match (self.frame_stride, self.slices) {
            (1, None) => String::new(),
            (_, None) => format!(", at {rate} fps"),
            (_, Some(s)) => format!(
                ", at {rate} fps, clips of {} frames every {}",
                s.length, s.stride
            ),
        };
        let joints = match self.joints {
            JointSet::Smpl24 => "",
            JointSet::Body22 => ", 22 body joints",
        };
        let kinetic = if self.kinetic_fps == 60.0 {
            String::new()
        } else {
            format!(", kinetic frame time 1/{}", self.kinetic_fps)
        };
        format!(
            "{protocol}metrics_mode={}, positions={}, geometric={}, BeatAlign={} (music beats: {}, segment: {}), seed_frames={}, max_frames={}, music_offset={}, PFC={}",
            value_name(self.metrics_mode),
            value_name(self.positions),
            value_name(self.geometric),
            value_name(self.ba_variant),
            value_name(self.ba_music_beats),
            value_name(self.ba_segment),
            self.seed_frames,
            self.max_frames,
            self.music_offset,
            value_name(self.pfc)
        ) + &cut
            + joints
            + &kinetic
    }
}

/// The CLI/JSON spelling of a variant.
pub fn value_name<T: ValueEnum>(v: T) -> String {
    v.to_possible_value()
        .map(|p| p.get_name().to_string())
        .unwrap_or_default()
}
