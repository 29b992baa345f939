//! PFC, the physical foot-contact score of EDGE (Tseng et al., CVPR 2023, §5.1; its `eval/eval_pfc.py`):
//! a body whose root accelerates must be pushed by a foot on the ground, so at every frame the root's
//! acceleration (its upward part only: falling needs no push) is multiplied by the horizontal speed of
//! the stiller joint of each foot. A dance that slides or floats while it accelerates scores high; a
//! still figure scores 0. Lower is better.
//!
//! Per sequence of T frames at `fps` (Δt = 1/fps), joints p (metres):
//! - a[t] = ‖(p0[t+2] − 2 p0[t+1] + p0[t]) / Δt²‖ with its up component clamped at 0, then divided by its
//!   maximum over the sequence (t = 0 … T−3);
//! - v_j[t] = ‖horizontal(p_j[t+2] − p_j[t+1])‖ per frame (not per second), for the left ankle and foot
//!   (7, 10) and the right ankle and foot (8, 11);
//! - score = mean_t( min(v7, v10) · min(v8, v11) · a[t] ).
//!
//! PFC = 10⁴ × the mean over sequences. EDGE scores motion at 30 fps with z up; `PfcVariant::Edge`
//! takes every second frame of our 60-fps motion (the up axis is the data's vertical either way: y here,
//! z in EDGE's files). Where EDGE divides by a zero maximum (a root that never accelerates) and gets
//! NaN, the sequence scores 0 here. Plain f64, no Burn.

use clap::ValueEnum;
use serde::{Deserialize, Serialize};

use crate::positions::Frame;
use qean_motion::vec3::{norm, sub};

/// The score's scale (EDGE multiplies by 10⁴).
pub const SCALE: f64 = 1e4;
/// EDGE's joints of each foot: (ankle, foot) left, then right (SMPL order).
pub const FEET: [[usize; 2]; 2] = [[7, 10], [8, 11]];

/// At which frame rate PFC is scored.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize, ValueEnum)]
#[serde(rename_all = "snake_case")]
#[value(rename_all = "snake_case")]
pub enum PfcVariant {
    /// Our frame rate, 60 fps: every frame.
    #[default]
    Ours,
    /// EDGE's 30 fps: every second frame. Per-frame foot steps are twice as long at half the rate:
    /// the same dance scores 3–5× higher than under `ours` (3.4× on the real excerpt, 5.2× on the demo's data).
    Edge,
}

impl PfcVariant {
    /// Keep every `stride`-th frame of 60-fps motion; score at `fps`.
    pub fn stride_and_fps(self) -> (usize, f64) {
        self.stride_and_fps_from(60.0)
    }

    /// The same for motion at `data_fps` (a protocol's clips may be 30 fps already).
    pub fn stride_and_fps_from(self, data_fps: f64) -> (usize, f64) {
        match self {
            PfcVariant::Ours => (1, data_fps),
            PfcVariant::Edge => (((data_fps / 30.0).round() as usize).max(1), 30.0),
        }
    }
}

/// One sequence's score before the 10⁴ scale: `joints` sampled every `stride` frames, at `fps` after
/// sampling, `up` the vertical axis (1 = y, 2 = z). `None` for fewer than 3 frames after sampling.
pub fn sequence_score(joints: &[Frame], stride: usize, fps: f64, up: usize) -> Option<f64> {
    let frames: Vec<&Frame> = joints.iter().step_by(stride.max(1)).collect();
    if frames.len() < 3 {
        return None;
    }
    let dt2 = 1.0 / (fps * fps);
    let accel: Vec<f64> = frames
        .windows(3)
        .map(|w| {
            let mut a = [0.0; 3];
            for (k, v) in a.iter_mut().enumerate() {
                *v = (w[2][0][k] - 2.0 * w[1][0][k] + w[0][0][k]) / dt2;
            }
            a[up] = a[up].max(0.0);
            norm(a)
        })
        .collect();
    let peak = accel.iter().cloned().fold(0.0, f64::max);
    if peak <= 0.0 {
        return Some(0.0);
    }
    // The horizontal length of joint j's step into the window's last frame.
    let step = |w: &[&Frame], j: usize| {
        let mut d = sub(w[2][j], w[1][j]);
        d[up] = 0.0;
        norm(d)
    };
    let total: f64 = frames
        .windows(3)
        .zip(&accel)
        .map(|(w, a)| {
            let [left, right] = FEET.map(|[ankle, foot]| step(w, ankle).min(step(w, foot)));
            left * right * a / peak
        })
        .sum();
    Some(total / accel.len() as f64)
}

/// PFC of a set (10⁴ × the mean over its sequences of 3 or more sampled frames), y up; `None` when no
/// sequence is long enough.
pub fn pfc<'a>(
    sequences: impl IntoIterator<Item = &'a [Frame]>,
    variant: PfcVariant,
) -> Option<f64> {
    pfc_from(sequences, variant, 60.0)
}

/// [`pfc`] of motion at `data_fps`.
pub fn pfc_from<'a>(
    sequences: impl IntoIterator<Item = &'a [Frame]>,
    variant: PfcVariant,
    data_fps: f64,
) -> Option<f64> {
    let (stride, fps) = variant.stride_and_fps_from(data_fps);
    let scores: Vec<f64> = sequences
        .into_iter()
        .filter_map(|s| sequence_score(s, stride, fps, 1))
        .collect();
    (!scores.is_empty()).then(|| SCALE * scores.iter().sum::<f64>() / scores.len() as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::positions::N_JOINTS;

    fn pose(shift: [f64; 3]) -> Frame {
        let mut f = [[0.0; 3]; N_JOINTS];
        for (j, p) in f.iter_mut().enumerate() {
            *p = [
                0.1 * j as f64 + shift[0],
                0.05 * j as f64 + shift[1],
                shift[2],
            ];
        }
        f
    }

    #[test]
    fn a_still_figure_scores_zero() {
        let still = vec![pose([0.0; 3]); 50];
        assert_eq!(pfc([still.as_slice()], PfcVariant::Ours), Some(0.0));
        assert_eq!(pfc([still.as_slice()], PfcVariant::Edge), Some(0.0));
    }

    #[test]
    fn a_body_sliding_while_it_accelerates_scores_and_planted_feet_do_not() {
        // The whole body slides sideways with a growing speed: feet move, root accelerates.
        let slide: Vec<Frame> = (0..60)
            .map(|t| pose([0.0005 * (t * t) as f64, 0.0, 0.0]))
            .collect();
        let sliding = pfc([slide.as_slice()], PfcVariant::Ours).unwrap();
        assert!(sliding > 0.0, "{sliding}");
        // The same root motion with one foot held in place: zero.
        let planted: Vec<Frame> = slide
            .iter()
            .map(|f| {
                let mut f = *f;
                f[7] = [0.7, 0.35, 0.0];
                f
            })
            .collect();
        assert_eq!(pfc([planted.as_slice()], PfcVariant::Ours), Some(0.0));
        // Falling needs no push: a root accelerating downwards only scores 0 (sideways at a constant
        // 2⁻¹⁰ m per frame, exact in binary, so that its horizontal acceleration is exactly 0).
        let fall: Vec<Frame> = (0..60)
            .map(|t| pose([t as f64 / 1024.0, -0.0005 * (t * t) as f64, 0.0]))
            .collect();
        assert_eq!(pfc([fall.as_slice()], PfcVariant::Ours), Some(0.0));
    }

    #[test]
    fn too_short_sequences_are_left_out() {
        let two = vec![pose([0.0; 3]); 2];
        assert_eq!(pfc([two.as_slice()], PfcVariant::Ours), None);
        let four = vec![pose([0.0; 3]); 4];
        assert_eq!(pfc([four.as_slice()], PfcVariant::Edge), None);
    }
}
