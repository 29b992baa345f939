//! Joint positions as the metrics see them (SPEC §7.1): T frames × 24 SMPL joints × xyz, y up, metres.

use crate::config::PositionMode;
use crate::error::{Error, Result};

pub const N_JOINTS: usize = 24;

/// One frame: 24 joints in SMPL order (SPEC §3.3).
pub type Frame = [[f64; 3]; N_JOINTS];

/// A named motion.
#[derive(Debug, Clone, PartialEq)]
pub struct Sequence {
    pub name: String,
    pub joints: Vec<Frame>,
    /// The music this motion dances to, when its name does not say (a pairing file or a `.music`
    /// sidecar): the key of its beats (a music ID or an audio file's stem). `None`: the AIST++ music ID
    /// in the name.
    pub music: Option<String>,
    /// The music frame of this motion's frame 0 (a seed taken from inside a ground-truth motion
    /// starts its dance that far into the music), added to the configuration's `music_offset`.
    pub music_offset: usize,
}

impl Sequence {
    pub fn new(name: impl Into<String>, joints: Vec<Frame>) -> Self {
        Sequence {
            name: name.into(),
            joints,
            music: None,
            music_offset: 0,
        }
    }
}

/// Error on the first non-finite coordinate, naming the frame and joint.
pub fn check_finite(name: &str, joints: &[Frame]) -> Result<()> {
    for (t, frame) in joints.iter().enumerate() {
        for (j, p) in frame.iter().enumerate() {
            if !p.iter().all(|x| x.is_finite()) {
                return Err(Error::NonFinite {
                    name: name.to_string(),
                    frame: t,
                    joint: j,
                    value: *p,
                });
            }
        }
    }
    Ok(())
}

/// The positions the features are computed on. Zero-start subtracts the segment's frame-0 root from
/// every joint (Bailando `extract_aist_features.py`, `metrics_new.py`); mint keeps absolute positions,
/// which matters because the reference acceleration bug sees absolute positions (SPEC §7.2).
pub fn prepare(joints: &[Frame], mode: PositionMode) -> Vec<Frame> {
    match mode {
        PositionMode::MintAbsolute => joints.to_vec(),
        PositionMode::RootRelative => prepare(joints, PositionMode::ZeroStart)
            .into_iter()
            .map(|mut frame| {
                let root = frame[0];
                for p in frame.iter_mut().skip(1) {
                    for a in 0..3 {
                        p[a] -= root[a];
                    }
                }
                frame
            })
            .collect(),
        PositionMode::ZeroStart => {
            let Some(first) = joints.first() else {
                return Vec::new();
            };
            let root = first[0];
            joints
                .iter()
                .map(|frame| {
                    let mut out = *frame;
                    for p in out.iter_mut() {
                        for a in 0..3 {
                            p[a] -= root[a];
                        }
                    }
                    out
                })
                .collect()
        }
    }
}
