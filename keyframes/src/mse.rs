//! Reconstruction error (SPEC §12.5, Lin eq. 2.8): (1/(T·J))·Σ_t Σ_j |x_t^j − x̂_t^j|² per sequence.

use crate::euler::{motion_to_euler, EulerOrder};
use qean_motion::{FkRoot, Motion};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The space the squared error is measured in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum MseSpace {
    /// Squared Frobenius norm of R − R̂ per joint (0..8, dimensionless).
    #[default]
    Rotmat,
    /// FK joint positions, m².
    Joints,
    /// Unwrapped Euler triples (rad²), the reconstruction's branch aligned to the original's at frame 0.
    Euler,
}

/// MSE of a reconstruction against the original (same length).
pub fn mse(original: &Motion, rebuilt: &Motion, space: MseSpace) -> f64 {
    assert_eq!(original.frames, rebuilt.frames, "mse needs equal lengths");
    let frames = original.frames;
    let total: f64 = match space {
        MseSpace::Rotmat => original
            .rotations()
            .iter()
            .zip(rebuilt.rotations())
            .map(|(a, b)| {
                a.iter()
                    .zip(b.iter())
                    .map(|(x, y)| (x - y).powi(2))
                    .sum::<f64>()
            })
            .sum(),
        MseSpace::Joints => original
            .joints(FkRoot::Smpl)
            .iter()
            .zip(rebuilt.joints(FkRoot::Smpl))
            .map(|(a, b)| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>())
            .sum(),
        MseSpace::Euler => {
            let a = motion_to_euler(original, EulerOrder::XYZ, true);
            let b = motion_to_euler(rebuilt, EulerOrder::XYZ, true);
            let mut sum = 0.0;
            for c in 0..72 {
                // Whole turns that bring the rebuilt channel's frame 0 nearest the original's.
                let shift = 2.0 * PI * ((a[c] - b[c]) / (2.0 * PI)).round();
                sum += (0..frames)
                    .map(|t| (a[t * 75 + c] - b[t * 75 + c] - shift).powi(2))
                    .sum::<f64>();
            }
            sum
        }
    };
    total / (frames * 24) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    fn motion(angle: f64, x: f64) -> Motion {
        let frames = 4;
        let mut poses = vec![0.0; frames * 72];
        for t in 0..frames {
            poses[t * 72 + 3 * 5 + 2] = angle;
        }
        let trans = (0..frames).flat_map(|_| [x, 0.9, 0.0]).collect();
        Motion::new(poses, trans, 1.0).unwrap()
    }

    #[test]
    fn zero_on_identical_and_known_offsets() {
        let m = motion(0.3, 0.0);
        for space in [MseSpace::Rotmat, MseSpace::Joints, MseSpace::Euler] {
            assert_eq!(mse(&m, &m.clone(), space), 0.0);
        }
        // One joint turned by δ about z: ‖R − R̂‖²_F = 8·sin²(δ/2) = 4(1 − cos δ), over 24 joints.
        let d = 0.2;
        let r = motion(0.3 + d, 0.0);
        let want = 4.0 * (1.0 - d.cos()) / 24.0;
        assert!((mse(&m, &r, MseSpace::Rotmat) - want).abs() < 1e-15);
        // Euler: a pure z turn of joint 5 changes its c angle by δ.
        assert!((mse(&m, &r, MseSpace::Euler) - d * d / 24.0).abs() < 1e-14);
        // Joints: a root shift of 0.1 m moves all 24 joints by 0.1 m.
        let s = motion(0.3, 0.1);
        assert!((mse(&m, &s, MseSpace::Joints) - 0.01).abs() < 1e-14);
        // A whole-turn difference of branch at frame 0 is not an error.
        let w = motion(0.3 + 2.0 * PI, 0.0);
        assert!(mse(&m, &w, MseSpace::Euler) < 1e-20);
    }
}
