//! A labelled temporal filter for decoded joints (ours, `gpt.smooth_sigma`): a GPT's dances move with
//! more frame-to-frame roughness than the data (acceleration 1.4–1.8× the ground truth's at its speed), and
//! a Gaussian over about a frame takes much of it away while leaving the moves: σ = 1 frame keeps 98.5 % of
//! the ground truth's speed and 96 % of its acceleration, and removes 18–20 % of a GPT dance's
//! acceleration at 1–2 % of its speed (docs/freezing.md, "A temporal filter on the decoded joints").

use crate::skeleton::NUM_JOINTS;

/// Every joint of the frames from `from` on (frames × 24, flat) replaced by its Gaussian average over time
/// (σ in frames, taps to ±⌈3σ⌉, the ends clamped); frames before `from` are read but kept. σ ≤ 0: unchanged.
pub fn gaussian_smooth(joints: &mut [[f64; 3]], from: usize, sigma: f64) {
    let n = joints.len() / NUM_JOINTS;
    if sigma <= 0.0 || from >= n {
        return;
    }
    let r = (3.0 * sigma).ceil() as i64;
    let taps: Vec<f64> = (-r..=r)
        .map(|k| (-0.5 * (k as f64 / sigma).powi(2)).exp())
        .collect();
    let total: f64 = taps.iter().sum();
    let source = joints.to_vec();
    for t in from..n {
        for j in 0..NUM_JOINTS {
            let mut acc = [0.0; 3];
            for (i, w) in taps.iter().enumerate() {
                let s = (t as i64 + i as i64 - r).clamp(0, n as i64 - 1) as usize;
                let p = source[s * NUM_JOINTS + j];
                for c in 0..3 {
                    acc[c] += w * p[c];
                }
            }
            joints[t * NUM_JOINTS + j] = acc.map(|v| v / total);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(frames: usize, f: impl Fn(usize) -> f64) -> Vec<[f64; 3]> {
        (0..frames)
            .flat_map(|t| std::iter::repeat_n([f(t), 0.0, 0.0], NUM_JOINTS))
            .collect()
    }

    #[test]
    fn straight_motion_stays_and_zigzag_calms() {
        // A constant velocity is kept away from the ends (the taps are symmetric).
        let mut ramp = line(40, |t| 0.01 * t as f64);
        let before = ramp.clone();
        gaussian_smooth(&mut ramp, 5, 1.0);
        for t in 5..36 {
            assert!((ramp[t * NUM_JOINTS][0] - before[t * NUM_JOINTS][0]).abs() < 1e-12);
        }
        // Frames before `from` are kept.
        assert_eq!(ramp[..5 * NUM_JOINTS], before[..5 * NUM_JOINTS]);
        // A frame-to-frame zigzag loses most of its amplitude.
        let mut zig = line(40, |t| if t % 2 == 0 { 0.01 } else { -0.01 });
        gaussian_smooth(&mut zig, 0, 1.0);
        assert!(
            zig[20 * NUM_JOINTS][0].abs() < 0.002,
            "{}",
            zig[20 * NUM_JOINTS][0]
        );
        // σ 0 is off.
        let mut same = before.clone();
        gaussian_smooth(&mut same, 0, 0.0);
        assert_eq!(same, before);
    }
}
