//! Named evaluation protocols (issue 39; the facts and their sources in docs/protocols.md). Bailando,
//! EDGE and Lodge score dances at different frame rates, on different clips, joints and reference sets;
//! a number is only comparable with a published one under the same protocol. A preset fixes those
//! settings in an [`EvalConfig`], and every report names the preset and lists each setting it fixed,
//! with where the setting comes from: the group's code, an inference where their code is silent, or
//! where we cannot follow them.
//!
//! The cut ([`cut`]) turns dances and reference motions into the clips a protocol scores: the seed
//! dropped, every `frame_stride`-th frame kept (60 → 30 fps), then the first clip or overlapping slices.
//! Music beats (60-fps frames) are mapped to the clip's rate by rounding.

use clap::ValueEnum;
use serde::{Deserialize, Serialize};

use crate::config::{BaSegment, EvalConfig, PositionMode};
use crate::error::{Error, Result};
use crate::pfc::PfcVariant;
use crate::positions::{Frame, Sequence};
use crate::report::Exclusion;

/// A named protocol of the field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, ValueEnum)]
#[serde(rename_all = "snake_case")]
#[value(rename_all = "snake_case")]
pub enum ProtocolPreset {
    /// Bailando (CVPR 2022) `utils/metrics_new.py`: 60 fps, the first 1,200 frames, SMPL 24 joints,
    /// zero-started positions, every AIST++ motion as the reference: our defaults.
    Bailando,
    /// EDGE (CVPR 2023): 30 fps, 5-s clips every 2.5 s, no seed, PFC; the test split only.
    Edge,
    /// Lodge (CVPR 2024) `metric/metrics_finedance.py` (FineDance's protocol): 30 fps, the first 1,024
    /// frames, 22 body joints made root-relative, kinetic features at frame_time 1/60 as their code has it.
    Lodge,
}

/// Overlapping clips of `length` frames every `stride` frames (at the metrics' frame rate).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Slices {
    pub length: usize,
    pub stride: usize,
}

/// Which frames of each reference motion the metrics see (after the frame-rate cut).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ReferenceCut {
    /// The whole motion (Bailando).
    #[default]
    Whole,
    /// Its first `max_frames` frames, as the generated clip (Lodge).
    First,
    /// The same slices as the generated dances (EDGE, inferred: its FID code is not public).
    Slices,
}

/// The joints the kinetic and geometric features see.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum JointSet {
    /// SMPL's 24 joints (72-D kinetic features).
    #[default]
    Smpl24,
    /// SMPL-X's 22 body joints: the two hands (22, 23) left out (66-D kinetic features, Lodge).
    Body22,
}

/// Which sequences checkpoint mode generates and scores against (directory mode takes the directories
/// it is given).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Splits {
    /// Dances for the test + val sequences, every non-ignored motion as the reference (Bailando).
    #[default]
    TestValAgainstAll,
    /// Dances for the test sequences, the test motions as the reference (EDGE's test split).
    TestAgainstTest,
}

/// Where a fixed setting comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// Read in the group's public code (docs/protocols.md gives file and line).
    Code,
    /// Their code is silent; our reading of their paper or issues.
    Inferred,
    /// Ours, where we cannot do what they do (said why).
    Deviation,
}

/// One setting a preset fixes, for the report.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Setting {
    pub name: String,
    pub value: String,
    pub source: Source,
}

fn setting(name: &str, value: &str, source: Source) -> Setting {
    Setting {
        name: name.into(),
        value: value.into(),
        source,
    }
}

impl std::str::FromStr for ProtocolPreset {
    type Err = String;

    /// The name `--protocol-preset` takes.
    fn from_str(name: &str) -> std::result::Result<Self, String> {
        <Self as ValueEnum>::from_str(name, false).map_err(|_| {
            format!("unknown protocol preset `{name}`; expected bailando, edge or lodge")
        })
    }
}

impl ProtocolPreset {
    /// A short title for reports.
    pub fn title(self) -> &'static str {
        match self {
            ProtocolPreset::Bailando => "Bailando (CVPR 2022, utils/metrics_new.py)",
            ProtocolPreset::Edge => "EDGE (CVPR 2023, 5-s clips; eval/eval_pfc.py)",
            ProtocolPreset::Lodge => "Lodge (CVPR 2024, metric/metrics_finedance.py)",
        }
    }

    /// Generated frames checkpoint mode samples per dance (at 60 fps) under this preset: Bailando
    /// scores 20 s, EDGE slices 30-s dances (its `--out_length`), Lodge the first 1,024 frames at 30 fps.
    pub fn sample_frames(self) -> usize {
        match self {
            ProtocolPreset::Bailando => 1200,
            ProtocolPreset::Edge => 1800,
            ProtocolPreset::Lodge => 2048,
        }
    }

    /// The columns of the group's main table, in our report's names.
    pub fn columns(self) -> &'static [&'static str] {
        match self {
            ProtocolPreset::Bailando | ProtocolPreset::Lodge => {
                &["FID_k", "FID_g", "Dist_k", "Dist_g", "BeatAlign"]
            }
            ProtocolPreset::Edge => &["PFC", "BeatAlign", "Dist_k", "Dist_g"],
        }
    }

    /// `base` with every setting this preset fixes (the metrics mode and the variants it leaves alone
    /// stay as given; `seed_frames` and `music_offset` describe the input, not the protocol).
    pub fn apply(self, base: EvalConfig) -> EvalConfig {
        let common = EvalConfig {
            preset: Some(self),
            ba_segment: BaSegment::Generated,
            ..base
        };
        match self {
            ProtocolPreset::Bailando => EvalConfig {
                frame_stride: 1,
                max_frames: 1200,
                slices: None,
                reference_cut: ReferenceCut::Whole,
                joints: JointSet::Smpl24,
                positions: PositionMode::ZeroStart,
                kinetic_fps: 60.0,
                pfc: PfcVariant::Ours,
                splits: Splits::TestValAgainstAll,
                ..common
            },
            ProtocolPreset::Edge => EvalConfig {
                frame_stride: 2,
                max_frames: 150,
                slices: Some(Slices {
                    length: 150,
                    stride: 75,
                }),
                reference_cut: ReferenceCut::Slices,
                joints: JointSet::Smpl24,
                positions: PositionMode::ZeroStart,
                kinetic_fps: 30.0,
                pfc: PfcVariant::Edge,
                splits: Splits::TestAgainstTest,
                ..common
            },
            ProtocolPreset::Lodge => EvalConfig {
                frame_stride: 2,
                max_frames: 1024,
                slices: None,
                reference_cut: ReferenceCut::First,
                joints: JointSet::Body22,
                positions: PositionMode::RootRelative,
                kinetic_fps: 60.0,
                pfc: PfcVariant::Ours,
                splits: Splits::TestValAgainstAll,
                ..common
            },
        }
    }

    /// Every setting the preset fixes, with its source (docs/protocols.md has the evidence).
    pub fn settings(self) -> Vec<Setting> {
        use Source::*;
        match self {
            ProtocolPreset::Bailando => vec![
                setting("frame rate", "60 fps (AIST++'s own)", Code),
                setting("evaluated clip", "the first 1,200 frames (20 s) of each dance", Code),
                setting("seed", "left out (Bailando keeps its one 8-frame VQ code in the clip; ours is 120 ground-truth frames, which would flatter the dance)", Deviation),
                setting("positions", "frame-0 root subtracted (zero start)", Code),
                setting("joints", "SMPL 24 (72-D kinetic features)", Code),
                setting("kinetic frame time", "1/60 s", Code),
                setting("reference set", "every non-ignored motion, whole length", Code),
                setting("generated set", "test + val sequences", Code),
                setting("BeatAlign", "σ = 3 frames at 60 fps, averaged over music beats, on the 1,200 scored frames (Bailando's runs on the whole generated dance, its seed included)", Deviation),
                setting("main table", "FID_k, FID_g, Dist_k, Dist_g, BeatAlign", Code),
            ],
            ProtocolPreset::Edge => vec![
                setting("frame rate", "30 fps: every second frame of 60-fps AIST++ (data_stride 2)", Code),
                setting("evaluated clips", "5 s (150 frames) every 2.5 s (75 frames) of each dance", Inferred),
                setting("seed", "left out (EDGE generates from noise, no seed)", Code),
                setting("positions", "frame-0 root of each clip subtracted (EDGE's FID/Dist code is not public)", Inferred),
                setting("up axis", "y (EDGE rotates AIST++ to z up; every metric here reads the data's vertical axis, so the rotation should not change a number: our reading, not EDGE's code)", Inferred),
                setting("joints", "SMPL 24", Code),
                setting("kinetic frame time", "1/30 s (not public; the clip's own rate)", Inferred),
                setting("reference set", "the test motions, cut into the same 5-s clips every 2.5 s (EDGE's reference set is not public; its training slices step 0.5 s)", Inferred),
                setting("generated set", "test sequences (crossmodal_test, 20 on AIST++)", Code),
                setting("PFC", "EDGE's formula at 30 fps, ×10⁴, on each 5-s clip with the root's acceleration normalised by the clip's maximum (EDGE's script scores whole stitched dances; its paper, 5-s clips)", Inferred),
                setting("BeatAlign", "σ = 3 frames at 30 fps; music beats at 60 fps mapped to 30 fps (EDGE's beat code is not public)", Inferred),
                setting("main table", "PFC, BeatAlign, Dist_k, Dist_g (FID shown, not in EDGE's table)", Code),
            ],
            ProtocolPreset::Lodge => vec![
                setting("frame rate", "30 fps, FineDance's own; AIST++ motion: every second frame (our transfer of the FineDance protocol: Lodge's published AIST++ numbers follow Bailando's, compare those under `bailando`)", Inferred),
                setting("evaluated clip", "the first 1,024 frames (34 s at 30 fps) of each dance", Code),
                setting("seed", "left out (no seed motion found in Lodge's inference)", Inferred),
                setting("positions", "frame-0 root subtracted, then joints 1… relative to the root of each frame", Code),
                setting("joints", "22 body joints for FID and Dist (66-D kinetic features); BeatAlign on all 24", Code),
                setting("kinetic frame time", "1/60 s on 30-fps motion (as Lodge's code has it)", Code),
                setting("reference set", "every non-ignored motion, its first 1,024 frames at 30 fps", Code),
                setting("generated set", "test + val sequences (Lodge's AIST++ runs follow Bailando)", Inferred),
                setting("BeatAlign", "σ = 3 frames at 30 fps on the 1,024-frame clip (Lodge's runs on the whole dance); our music beats (HPSS-percussive, 60 fps) mapped to 30 fps, where Lodge tracks beats on the raw onset envelope at 30 fps with tightness 100", Deviation),
                setting("main table", "FID_k, FID_g, Dist_k, Dist_g, BeatAlign (Lodge's foot-skating ratio is not computed here)", Deviation),
            ],
        }
    }
}

/// Whether `cfg` scores other clips than the whole-rate first `max_frames` after the seed.
pub fn needs_cut(cfg: &EvalConfig) -> bool {
    cfg.frame_stride > 1 || cfg.slices.is_some() || cfg.reference_cut != ReferenceCut::Whole
}

/// The clips a protocol scores, with the configuration that scores them as they are (no seed, the
/// clip's frame rate and length), the frame stride that maps 60-fps music beats onto them, and the
/// motions too short for any clip.
pub struct Cut {
    pub generated: Vec<Sequence>,
    pub reference: Vec<Sequence>,
    pub cfg: EvalConfig,
    pub stride: usize,
    pub dropped: Vec<Exclusion>,
}

/// Our settings for what no protocol defines (motion energy, the TSMT paper's metrics): every frame
/// after the seed at the data's rate, 24 joints, zero start, no preset.
pub fn whole_dances(cfg: &EvalConfig) -> EvalConfig {
    EvalConfig {
        preset: None,
        frame_stride: 1,
        slices: None,
        reference_cut: ReferenceCut::Whole,
        joints: JointSet::Smpl24,
        positions: PositionMode::ZeroStart,
        kinetic_fps: 60.0,
        pfc: PfcVariant::Ours,
        max_frames: usize::MAX,
        ..cfg.clone()
    }
}

/// A motion that gave no clip, for the report's exclusions.
fn dropped(set: &str, s: &Sequence, frames: usize, cfg: &EvalConfig) -> Exclusion {
    let reason = match cfg.slices {
        Some(sl) => format!(
            "{frames} frame(s) at the protocol's rate: shorter than one {}-frame clip",
            sl.length
        ),
        None => format!("{frames} frame(s) at the protocol's rate: no clip"),
    };
    tracing::warn!(sequence = %s.name, "no clip under the protocol: {reason}");
    Exclusion {
        set: set.into(),
        name: s.name.clone(),
        from: "all".into(),
        reason,
    }
}

/// Every `stride`-th frame of `frames`.
fn decimate(frames: &[Frame], stride: usize) -> Vec<Frame> {
    frames.iter().step_by(stride.max(1)).copied().collect()
}

/// The clips of one motion at the metrics' rate: (first frame, frames). `length` ≤ what is there.
fn clips(frames: &[Frame], slices: Option<Slices>, first: usize) -> Vec<(usize, Vec<Frame>)> {
    match slices {
        None => vec![(0, frames[..first.min(frames.len())].to_vec())],
        Some(Slices { length, stride }) => {
            let mut out = Vec::new();
            let mut start = 0;
            while start + length <= frames.len() {
                out.push((start, frames[start..start + length].to_vec()));
                start += stride.max(1);
            }
            out
        }
    }
}

/// A clip named after its motion and its first frame, so a generated clip and the ground-truth clip
/// of the same sequence pair up, and the music ID in the name still reads.
fn clip_of(s: &Sequence, index: usize, sliced: bool, frames: Vec<Frame>, music: usize) -> Sequence {
    Sequence {
        name: if sliced {
            format!("{}@{index:03}", s.name)
        } else {
            s.name.clone()
        },
        joints: frames,
        music: s.music.clone(),
        music_offset: music,
    }
}

/// Cuts `generated` (seed ++ dance, per `cfg.seed_frames`) and `reference` into the clips of `cfg`.
pub fn cut(generated: &[Sequence], reference: &[Sequence], cfg: &EvalConfig) -> Result<Cut> {
    let stride = cfg.frame_stride.max(1);
    if let Some(s) = cfg.slices {
        if s.length == 0 || s.stride == 0 {
            return Err(Error::Invalid(format!(
                "protocol slices need a length and a stride above 0, got {s:?}"
            )));
        }
    }
    let sliced = cfg.slices.is_some();
    // A 60-fps music frame on the clip's grid: the nearest, as the beats ([`beats_at_stride`]).
    let on_grid = |f: usize| (f + stride / 2) / stride;
    let (mut gen, mut refs, mut gone) = (Vec::new(), Vec::new(), Vec::new());
    for s in generated {
        let from = cfg.seed_frames.min(s.joints.len());
        let dance = decimate(&s.joints[from..], stride);
        // The music frame (60 fps) of the dance's first frame.
        let music0 = cfg.music_offset + s.music_offset + from;
        let pieces = clips(&dance, cfg.slices, cfg.max_frames);
        if pieces.is_empty() {
            gone.push(dropped("generated", s, dance.len(), cfg));
        }
        for (i, (start, frames)) in pieces.into_iter().enumerate() {
            let music = on_grid(music0 + start * stride);
            gen.push(clip_of(s, i, sliced, frames, music));
        }
    }
    for s in reference {
        let whole = decimate(&s.joints, stride);
        let n = whole.len();
        let pieces = match cfg.reference_cut {
            ReferenceCut::Whole => vec![(0, whole)],
            ReferenceCut::First => clips(&whole, None, cfg.max_frames),
            ReferenceCut::Slices => clips(&whole, cfg.slices, cfg.max_frames),
        };
        if pieces.is_empty() {
            gone.push(dropped("reference", s, n, cfg));
        }
        let named = cfg.reference_cut == ReferenceCut::Slices;
        for (i, (start, frames)) in pieces.into_iter().enumerate() {
            let music = on_grid(s.music_offset + start * stride);
            refs.push(clip_of(s, i, named, frames, music));
        }
    }
    let max_frames = cfg.slices.map_or(cfg.max_frames, |s| s.length);
    Ok(Cut {
        generated: gen,
        reference: refs,
        cfg: EvalConfig {
            frame_stride: 1,
            fps: cfg.fps / stride as f64,
            slices: None,
            reference_cut: ReferenceCut::Whole,
            seed_frames: 0,
            music_offset: 0,
            max_frames,
            ba_segment: BaSegment::Generated,
            ..cfg.clone()
        },
        stride,
        dropped: gone,
    })
}

/// 60-fps music beat frames on a clip's grid of every `stride`-th frame (nearest frame).
pub fn beats_at_stride(beats: &[usize], stride: usize) -> Vec<usize> {
    let s = stride.max(1);
    let mut out: Vec<usize> = beats.iter().map(|&b| (b + s / 2) / s).collect();
    out.dedup();
    out
}

/// Two hands (SMPL 22, 23) set to their wrists (20, 21): the geometric features' lowest point is then
/// the 22 body joints' (no predicate reads a hand).
pub fn body22(frames: &[Frame]) -> Vec<Frame> {
    frames
        .iter()
        .map(|f| {
            let mut f = *f;
            f[22] = f[20];
            f[23] = f[21];
            f
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::positions::N_JOINTS;

    fn seq(name: &str, t: usize) -> Sequence {
        let joints = (0..t)
            .map(|i| {
                let mut f = [[0.0; 3]; N_JOINTS];
                f[0][0] = i as f64;
                f
            })
            .collect();
        Sequence::new(name, joints)
    }

    #[test]
    fn edge_cuts_thirty_fps_slices_after_the_seed() {
        let cfg = ProtocolPreset::Edge.apply(EvalConfig::default());
        // 120 seed + 1,800 dance frames at 60 fps = 900 at 30 fps: 11 slices of 150 every 75.
        let g = seq("gBR_sBM_cAll_d04_mBR0_ch01", 1920);
        let c = cut(std::slice::from_ref(&g), &[seq("r_mBR0", 600)], &cfg).unwrap();
        assert_eq!(c.generated.len(), 11);
        assert!(c.generated.iter().all(|s| s.joints.len() == 150));
        // Slice 1 starts at dance frame 75 at 30 fps = frame 120 + 150 of the original.
        assert_eq!(c.generated[1].joints[0][0][0], 270.0);
        assert_eq!(c.generated[1].joints[1][0][0], 272.0);
        assert_eq!(c.generated[1].music_offset, (120 + 150) / 2);
        assert_eq!(c.generated[1].name, "gBR_sBM_cAll_d04_mBR0_ch01@001");
        // The reference: 300 frames at 30 fps → slices at 0, 75, 150.
        assert_eq!(c.reference.len(), 3);
        assert_eq!(c.cfg.seed_frames, 0);
        assert_eq!(c.cfg.max_frames, 150);
        assert_eq!(c.cfg.fps, 30.0);
        assert_eq!(c.stride, 2);
        assert!(!needs_cut(&c.cfg));
    }

    #[test]
    fn lodge_takes_the_first_1024_thirty_fps_frames_of_both_sets() {
        let cfg = ProtocolPreset::Lodge.apply(EvalConfig::default());
        let c = cut(
            &[seq("g", 120 + 3000)],
            &[seq("r", 5000), seq("s", 100)],
            &cfg,
        )
        .unwrap();
        assert_eq!(c.generated[0].joints.len(), 1024);
        assert_eq!(c.generated[0].joints[0][0][0], 120.0);
        assert_eq!(c.reference[0].joints.len(), 1024);
        assert_eq!(c.reference[1].joints.len(), 50);
        assert_eq!(c.generated[0].name, "g");
        assert_eq!(cfg.joints, JointSet::Body22);
        assert_eq!(cfg.positions, PositionMode::RootRelative);
        assert_eq!(cfg.kinetic_fps, 60.0);
    }

    #[test]
    fn bailando_is_our_default_and_needs_no_cut() {
        let base = EvalConfig::default();
        let b = ProtocolPreset::Bailando.apply(base.clone());
        assert_eq!(
            EvalConfig {
                preset: None,
                ..b.clone()
            },
            base
        );
        assert!(!needs_cut(&b));
        assert_eq!(b.preset, Some(ProtocolPreset::Bailando));
    }

    #[test]
    fn every_preset_lists_its_settings_and_columns() {
        for p in [
            ProtocolPreset::Bailando,
            ProtocolPreset::Edge,
            ProtocolPreset::Lodge,
        ] {
            let s = p.settings();
            for name in ["frame rate", "seed", "positions", "joints", "reference set"] {
                assert!(s.iter().any(|x| x.name == name), "{p:?} lacks {name}");
            }
            assert!(p.columns().contains(&"BeatAlign"));
        }
        assert!(ProtocolPreset::Edge.columns().contains(&"PFC"));
    }

    /// A dance whose music starts on an odd 60-fps frame: its clip's offset is rounded as the beats are,
    /// so a beat 4 frames into the dance lands 2 frames into the clip.
    #[test]
    fn odd_music_starts_keep_the_beats_on_their_frames() {
        let cfg = ProtocolPreset::Edge.apply(EvalConfig {
            seed_frames: 0,
            music_offset: 121,
            ..EvalConfig::default()
        });
        let c = cut(&[seq("g", 500)], &[seq("r", 400)], &cfg).unwrap();
        let beat = beats_at_stride(&[125], 2)[0];
        assert_eq!(beat - c.generated[0].music_offset, 2);
        let beat = beats_at_stride(&[121 + 150 + 6], 2)[0];
        assert_eq!(beat - c.generated[1].music_offset, 3);
    }

    #[test]
    fn beats_map_to_the_nearest_thirty_fps_frame() {
        assert_eq!(
            beats_at_stride(&[0, 1, 3, 30, 31], 2),
            vec![0, 1, 2, 15, 16]
        );
        assert_eq!(beats_at_stride(&[5, 9], 1), vec![5, 9]);
    }
}
