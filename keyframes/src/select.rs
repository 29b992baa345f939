//! From a strategy name to keyframes: cut the motion into measures (§12.2) and pick N keys in each (§12.3).

use crate::dp::{error_table, select, selection_cost, DpSpace};
use crate::euler::motion_to_euler;
use crate::even::even_keys;
use crate::measure::segments;
use crate::onset_keys::{onset_keys, peaks};
use crate::options::KeyframeOptions;
use qean_motion::{FkRoot, Layout, Motion};
use serde::{Deserialize, Serialize};

/// A keyframe strategy (Lin's KF_* labels).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Strategy {
    /// KF_even: evenly spaced.
    Even,
    /// KF_onset: peaks of the music's onset envelope.
    Onset,
    /// KF_stems: peaks of the stem-weighted onset curve.
    Stems,
    /// KF_nmfd: peaks of the NMFD drum activations.
    Nmfd,
    /// KF_dp: Roberts's salient poses from the motion itself.
    Dp,
}

impl Strategy {
    pub const NAMES: &'static str = "even, onset, stems, nmfd, dp";

    pub fn parse(s: &str) -> Result<Strategy, String> {
        match s {
            "even" => Ok(Strategy::Even),
            "onset" => Ok(Strategy::Onset),
            "stems" => Ok(Strategy::Stems),
            "nmfd" => Ok(Strategy::Nmfd),
            "dp" => Ok(Strategy::Dp),
            other => Err(format!(
                "unknown keyframe strategy {other:?} (expected one of {})",
                Strategy::NAMES
            )),
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Strategy::Even => "even",
            Strategy::Onset => "onset",
            Strategy::Stems => "stems",
            Strategy::Nmfd => "nmfd",
            Strategy::Dp => "dp",
        }
    }

    /// Whether the strategy reads a music curve.
    pub fn needs_curve(self) -> bool {
        matches!(self, Strategy::Onset | Strategy::Stems | Strategy::Nmfd)
    }
}

/// The keys of one motion.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Selection {
    /// Inclusive measure segments [a, b].
    pub segments: Vec<(usize, usize)>,
    /// Sorted, unique frames (segment ends included).
    pub keyframes: Vec<usize>,
    pub strategy: Strategy,
    /// Keys per segment.
    pub n: usize,
    pub bpm: f64,
    /// Per segment: the DP's cost of these keys (`dp_error`/`dp_combine`), for every strategy.
    pub segment_costs: Vec<f64>,
}

/// Per-frame vectors in the DP's space, frames × dim.
pub fn dp_points(motion: &Motion, opts: &KeyframeOptions) -> (Vec<f64>, usize) {
    match opts.dp_space {
        DpSpace::Euler75 => (
            motion_to_euler(motion, opts.euler_order, opts.euler_unwrap),
            75,
        ),
        DpSpace::Rotmat225 => (
            motion
                .to_layout(Layout::L225)
                .iter()
                .map(|&v| v as f64)
                .collect(),
            225,
        ),
        DpSpace::Joints72 => (
            motion
                .joints(FkRoot::Smpl)
                .iter()
                .flatten()
                .copied()
                .collect(),
            72,
        ),
    }
}

/// Pick `n` keys per measure. `curve` (the onset, stem or NMFD curve, one value per frame) is needed by
/// the music strategies; `offset` is the resolved measure offset in frames.
pub fn select_keys(
    motion: &Motion,
    curve: Option<&[f64]>,
    strategy: Strategy,
    n: usize,
    bpm: f64,
    offset: usize,
    opts: &KeyframeOptions,
) -> Result<Selection, String> {
    if n < 2 {
        return Err(format!(
            "--n must be at least 2 (both segment ends are keys), got {n}"
        ));
    }
    if !(bpm.is_finite() && bpm > 0.0) {
        return Err(format!(
            "the tempo must be a positive number of beats per minute, got {bpm}"
        ));
    }
    if offset >= motion.frames {
        return Err(format!(
            "the measure offset ({offset} frames) is past the motion's end ({} frames)",
            motion.frames
        ));
    }
    let segs = segments(
        motion.frames,
        bpm,
        opts.measure_rounding,
        opts.segment_boundary,
        offset,
    );
    let curve_peaks = match (strategy.needs_curve(), curve) {
        (true, Some(c)) => Some((c, peaks(c, opts.peak_picker))),
        (true, None) => return Err(format!("strategy {} needs music", strategy.name())),
        (false, _) => None,
    };
    let (points, dim) = dp_points(motion, opts);
    let mut keyframes = Vec::new();
    let mut segment_costs = Vec::with_capacity(segs.len());
    for &(a, b) in &segs {
        let len = b - a + 1;
        let e = error_table(&points[a * dim..(b + 1) * dim], dim, opts.dp_error);
        let keys: Vec<usize> = match strategy {
            Strategy::Even => even_keys(a, b, n),
            Strategy::Dp => select(&e, len, n, opts.dp_combine)
                .0
                .iter()
                .map(|k| a + k)
                .collect(),
            _ => {
                let (c, p) = curve_peaks.as_ref().expect("checked above");
                onset_keys(c, p, (a, b), n, opts.kf_edge_guard, opts.fallback)
            }
        };
        let rel: Vec<usize> = keys.iter().map(|k| k - a).collect();
        segment_costs.push(selection_cost(&e, len, &rel, opts.dp_combine));
        keyframes.extend(keys);
    }
    keyframes.sort_unstable();
    keyframes.dedup();
    Ok(Selection {
        segments: segs,
        keyframes,
        strategy,
        n,
        bpm,
        segment_costs,
    })
}
