//! Joint positions of a text–motion set in the HumanML3D layout, made into ours (SPEC §13.1 "Conversion of
//! text motions"): 22 or 24 SMPL joints at `fps` (HumanML3D: 20) become 24 joints at 60 fps, and back
//! (for writing such a set).

use nalgebra::Vector3;

use crate::motion::FPS;
use crate::skeleton::{NUM_JOINTS, OFFSETS};

/// Joints of a HumanML3D motion: SMPL joints 0..21 (no hands).
pub const HUMANML_JOINTS: usize = 22;

const L_ELBOW: usize = 18;
const R_ELBOW: usize = 19;
const L_WRIST: usize = 20;
const R_WRIST: usize = 21;
const L_HAND: usize = 22;
const R_HAND: usize = 23;

/// ρ = |o_hand| / |o_wrist| of each side (left, right), from the skeleton's rest offsets: the hand continues
/// the forearm by this fraction of its length (SPEC: ρ_L = 0.333397, ρ_R = 0.333302).
pub fn hand_ratios() -> [f64; 2] {
    let len = |j: usize| Vector3::from(OFFSETS[j]).norm();
    [len(L_HAND) / len(L_WRIST), len(R_HAND) / len(R_WRIST)]
}

/// 22-joint frames (frames × 22, flat) with hands added: J22 = J20 + ρ_L(J20 − J18), J23 = J21 + ρ_R(J21 − J19).
pub fn add_hands(joints22: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let [rl, rr] = hand_ratios();
    let mut out = Vec::with_capacity(joints22.len() / HUMANML_JOINTS * NUM_JOINTS);
    for frame in joints22.chunks_exact(HUMANML_JOINTS) {
        let p = |j: usize| Vector3::from(frame[j]);
        let hand = |wrist: usize, elbow: usize, r: f64| {
            let h = p(wrist) + (p(wrist) - p(elbow)) * r;
            [h.x, h.y, h.z]
        };
        out.extend_from_slice(frame);
        out.push(hand(L_WRIST, L_ELBOW, rl));
        out.push(hand(R_WRIST, R_ELBOW, rr));
    }
    out
}

/// Frames of `joints` per frame at `fps`, resampled to 60 fps by linear interpolation of positions: output
/// frame t is the source at time t·fps/60 (in source frames), for every t whose time lies inside the motion.
pub fn resample_to_60(frames: &[[f64; 3]], joints: usize, fps: f64) -> Vec<[f64; 3]> {
    let n = frames.len() / joints;
    if n == 0 || (fps - FPS).abs() < 1e-12 {
        return frames.to_vec();
    }
    let step = fps / FPS;
    let out_frames = ((n - 1) as f64 / step + 1e-9).floor() as usize + 1;
    let mut out = Vec::with_capacity(out_frames * joints);
    for t in 0..out_frames {
        let s = t as f64 * step;
        let i = (s.floor() as usize).min(n - 1);
        let a = s - i as f64;
        let j = (i + 1).min(n - 1);
        for k in 0..joints {
            let (p, q) = (frames[i * joints + k], frames[j * joints + k]);
            out.push([0, 1, 2].map(|c| p[c] + a * (q[c] - p[c])));
        }
    }
    out
}

/// A HumanML3D-layout motion (frames × `joints`, 22 or 24, at `fps`) as ours: 24 joints at 60 fps.
pub fn to_ours(frames: &[[f64; 3]], joints: usize, fps: f64) -> Vec<[f64; 3]> {
    let full = if joints == HUMANML_JOINTS {
        add_hands(frames)
    } else {
        frames.to_vec()
    };
    resample_to_60(&full, NUM_JOINTS, fps)
}

/// Ours (24 joints at 60 fps) as a HumanML3D-layout motion: every `60 / fps`-th frame (an integer ratio),
/// joints 0..21.
pub fn to_humanml(joints24: &[[f64; 3]], fps: f64) -> Vec<[f64; 3]> {
    let every = (FPS / fps).round().max(1.0) as usize;
    joints24
        .chunks_exact(NUM_JOINTS)
        .step_by(every)
        .flat_map(|f| f[..HUMANML_JOINTS].iter().copied())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::skeleton::rest_joints;

    #[test]
    fn hand_ratios_match_the_spec() {
        let [l, r] = hand_ratios();
        assert!((l - 0.333397).abs() < 1e-6, "{l}");
        assert!((r - 0.333302).abs() < 1e-6, "{r}");
    }

    #[test]
    fn hands_continue_the_forearm() {
        let rest = rest_joints([0.1, 0.9, -0.2]);
        let got = add_hands(&rest[..HUMANML_JOINTS]);
        assert_eq!(got.len(), NUM_JOINTS);
        assert_eq!(&got[..HUMANML_JOINTS], &rest[..HUMANML_JOINTS]);
        // In the rest pose the hand offsets are nearly parallel to the forearms: within 2.5 cm of the template.
        for j in [L_HAND, R_HAND] {
            let d = (Vector3::from(got[j]) - Vector3::from(rest[j])).norm();
            assert!(d < 0.025, "joint {j}: {d} m from the template");
        }
        // On the forearm's line, at ρ of its length beyond the wrist.
        let fore = Vector3::from(got[L_WRIST]) - Vector3::from(got[L_ELBOW]);
        let hand = Vector3::from(got[L_HAND]) - Vector3::from(got[L_WRIST]);
        assert!((hand - fore * hand_ratios()[0]).norm() < 1e-12);
    }

    #[test]
    fn resampling_interpolates_and_keeps_the_ends() {
        // One joint moving 1 m per source frame at 20 fps: 1/3 m per 60-fps frame.
        let src: Vec<[f64; 3]> = (0..5).map(|i| [i as f64, 0.0, 0.0]).collect();
        let out = resample_to_60(&src, 1, 20.0);
        assert_eq!(out.len(), 13);
        for (t, p) in out.iter().enumerate() {
            assert!((p[0] - t as f64 / 3.0).abs() < 1e-12, "frame {t}: {}", p[0]);
        }
        assert_eq!(resample_to_60(&src, 1, 60.0), src);
    }

    #[test]
    fn humanml_round_trip() {
        let rest = rest_joints([0.0, 0.9, 0.0]);
        let ours: Vec<[f64; 3]> = (0..7)
            .flat_map(|t| {
                rest.iter()
                    .map(move |p| [p[0] + t as f64 * 0.01, p[1], p[2]])
            })
            .collect();
        let h = to_humanml(&ours, 20.0);
        assert_eq!(h.len(), 3 * HUMANML_JOINTS);
        let back = to_ours(&h, HUMANML_JOINTS, 20.0);
        assert_eq!(back.len(), 7 * NUM_JOINTS);
        for (a, b) in ours.iter().zip(&back) {
            assert!((Vector3::from(*a) - Vector3::from(*b)).norm() < 0.02);
        }
    }
}
