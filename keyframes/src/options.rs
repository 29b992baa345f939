//! The `[keyframes]` settings (SPEC §12.7): every [DECISION] of §12.2–12.3 as an option, defaults as the SPEC.

use crate::dp::{DpCombine, DpError, DpSpace};
use crate::euler::EulerOrder;
use crate::measure::{Boundary, Rounding};
use crate::nmfd::NmfdSize;
use crate::onset_keys::{Fallback, PeakPicker};
use crate::stems::StemSource;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// How NMFD's templates start (`nmfd_init`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NmfdInit {
    /// libnmfd's seed-42 random templates (Lin's setting).
    #[default]
    Random,
    /// Templates learnt from drum samples: `nmfd_templates` holds kick/, snare/ and hihat/ folders of
    /// WAVs (libnmfd's `data/` folders, from its repository).
    Drums,
}

/// The drum classes of `nmfd_init = "drums"`, one NMFD component each, in libnmfd's order.
pub const DRUM_CLASSES: [&str; 3] = ["kick", "snare", "hihat"];

/// Where the measure grid starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeasureOffset {
    /// A fixed number of frames (default 0: Lin does not align to a downbeat).
    Frames(usize),
    /// The first beat of the music's beat column (34).
    FirstBeat,
}

impl Default for MeasureOffset {
    fn default() -> Self {
        MeasureOffset::Frames(0)
    }
}

impl MeasureOffset {
    /// The offset in frames, given the music's first beat when there is music.
    pub fn resolve(self, first_beat: Option<usize>) -> Result<usize, String> {
        match self {
            MeasureOffset::Frames(f) => Ok(f),
            MeasureOffset::FirstBeat => first_beat.ok_or_else(|| {
                "measure_offset = \"first_beat\" needs music with at least one beat".into()
            }),
        }
    }
}

impl Serialize for MeasureOffset {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            MeasureOffset::Frames(f) => s.serialize_u64(*f as u64),
            MeasureOffset::FirstBeat => s.serialize_str("first_beat"),
        }
    }
}

impl<'de> Deserialize<'de> for MeasureOffset {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(untagged)]
        enum Raw {
            Frames(u64),
            Name(String),
        }
        match Raw::deserialize(d)? {
            Raw::Frames(f) => Ok(MeasureOffset::Frames(f as usize)),
            Raw::Name(n) if n == "first_beat" => Ok(MeasureOffset::FirstBeat),
            Raw::Name(n) => Err(serde::de::Error::custom(format!(
                "measure_offset must be a frame count or \"first_beat\", got {n:?}"
            ))),
        }
    }
}

/// Keyframe selection settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct KeyframeOptions {
    pub measure_rounding: Rounding,
    pub segment_boundary: Boundary,
    pub measure_offset: MeasureOffset,
    /// Peaks closer than this many frames to a segment end are ignored (G, 5 frames = 83 ms).
    pub kf_edge_guard: usize,
    pub peak_picker: PeakPicker,
    pub fallback: Fallback,
    /// Stems for `stems` and `nmfd`: user WAVs (`files`, default) or the HPSS stand-in (`hpss`).
    pub stem_source: StemSource,
    /// Weights of the drums, bass, vocals and other onset envelopes (Lin eq. 3.3).
    pub stem_weights: [f64; 4],
    /// NMFD components R (libnmfd's drum demo: 3).
    pub nmfd_components: usize,
    /// NMFD iterations L (30).
    pub nmfd_iterations: usize,
    /// NMFD template frames T (8).
    pub nmfd_template_frames: usize,
    /// Weights of the NMFD activations in the curve (one per component; default all 1).
    pub nmfd_weights: Vec<f64>,
    pub nmfd_init: NmfdInit,
    /// The folder of drum samples for `nmfd_init = "drums"`.
    pub nmfd_templates: Option<std::path::PathBuf>,
    pub dp_error: DpError,
    pub dp_combine: DpCombine,
    pub dp_space: DpSpace,
    pub euler_order: EulerOrder,
    pub euler_unwrap: bool,
}

impl Default for KeyframeOptions {
    fn default() -> Self {
        KeyframeOptions {
            measure_rounding: Rounding::Cumulative,
            segment_boundary: Boundary::Shared,
            measure_offset: MeasureOffset::Frames(0),
            kf_edge_guard: 5,
            peak_picker: PeakPicker::OnsetDetect,
            fallback: Fallback::MaxPairSum,
            stem_source: StemSource::Files,
            stem_weights: [1.0; 4],
            nmfd_components: 3,
            nmfd_iterations: 30,
            nmfd_template_frames: 8,
            nmfd_weights: vec![1.0; 3],
            nmfd_init: NmfdInit::Random,
            nmfd_templates: None,
            dp_error: DpError::Chord,
            dp_combine: DpCombine::Max,
            dp_space: DpSpace::Euler75,
            euler_order: EulerOrder::XYZ,
            euler_unwrap: true,
        }
    }
}

impl KeyframeOptions {
    /// The NMFD sizes.
    pub fn nmfd_size(&self) -> NmfdSize {
        NmfdSize {
            components: self.nmfd_components,
            iterations: self.nmfd_iterations,
            template_frames: self.nmfd_template_frames,
        }
    }

    /// Values no strategy can use, as one message.
    pub fn validate(&self) -> Result<(), String> {
        if self.nmfd_components == 0 || self.nmfd_iterations == 0 || self.nmfd_template_frames == 0
        {
            return Err(
                "nmfd_components, nmfd_iterations and nmfd_template_frames must be at least 1"
                    .into(),
            );
        }
        if self.nmfd_weights.len() != self.nmfd_components {
            return Err(format!(
                "nmfd_weights has {} values for {} NMFD components",
                self.nmfd_weights.len(),
                self.nmfd_components
            ));
        }
        if self
            .stem_weights
            .iter()
            .chain(&self.nmfd_weights)
            .any(|w| !w.is_finite())
        {
            return Err("stem_weights and nmfd_weights must be finite".into());
        }
        if self.nmfd_init == NmfdInit::Drums {
            if self.nmfd_templates.is_none() {
                return Err(
                    "nmfd_init = \"drums\" needs nmfd_templates = \"DIR\" (kick/, snare/ and hihat/ folders of WAVs)"
                        .into(),
                );
            }
            if self.nmfd_components != DRUM_CLASSES.len() {
                return Err(format!(
                    "nmfd_init = \"drums\" learns one component per drum class ({}): nmfd_components must be {}",
                    DRUM_CLASSES.join(", "),
                    DRUM_CLASSES.len()
                ));
            }
        }
        Ok(())
    }
}
