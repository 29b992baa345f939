//! Keyframe fidelity (SPEC §13.10): how close an edited dance comes to its keyframe poses, and whether the
//! edit left a seam. KF-MPJPE compares root-relative joints, since a keyframe does not control where the
//! root is: |(Ĵ_j − Ĵ_0)(f) − (J^kf_j − J^kf_0)| averaged over the joints (and the keyframes).

use std::ops::Range;

use crate::positions::Frame;

/// The root-relative joint error of one frame against a keyframe pose, in metres (mean over joints).
pub fn pose_error(frame: &Frame, key: &Frame) -> f64 {
    let n = frame.len();
    let mut sum = 0.0;
    for j in 0..n {
        let d: f64 = (0..3)
            .map(|a| {
                let x = (frame[j][a] - frame[0][a]) - (key[j][a] - key[0][a]);
                x * x
            })
            .sum();
        sum += d.sqrt();
    }
    sum / n as f64
}

/// KF-MPJPE at frame `f` and its minimum over the frames f − half ..= f + half within the dance (SPEC:
/// "the minimum over f ± d/2"), both in metres.
pub fn keyframe_errors(dance: &[Frame], f: usize, key: &Frame, half: usize) -> (f64, f64) {
    let at = pose_error(&dance[f], key);
    let lo = f.saturating_sub(half);
    let hi = (f + half + 1).min(dance.len());
    let best = (lo..hi)
        .map(|t| pose_error(&dance[t], key))
        .fold(f64::INFINITY, f64::min);
    (at, best)
}

/// Mean joint acceleration magnitude (per frame², over joints) of frames t with both neighbours in `frames`
/// and keep(t).
fn mean_accel(frames: &[Frame], keep: impl Fn(usize) -> bool) -> Option<f64> {
    let (mut sum, mut count) = (0.0, 0usize);
    for t in 1..frames.len().saturating_sub(1) {
        if !keep(t) {
            continue;
        }
        let (next, now, prev) = (&frames[t + 1], &frames[t], &frames[t - 1]);
        for ((n, c), p) in next.iter().zip(now).zip(prev) {
            let a: f64 = (0..3)
                .map(|k| {
                    let x = n[k] - 2.0 * c[k] + p[k];
                    x * x
                })
                .sum();
            sum += a.sqrt();
            count += 1;
        }
    }
    (count > 0).then(|| sum / count as f64)
}

/// The seam check: mean |acceleration| over the frames of the edited spans relative to the rest of the
/// dance's frames (1 where the edit is as smooth as the rest; None when either side has no frame).
pub fn seam_accel_ratio(frames: &[Frame], spans: &[Range<usize>]) -> Option<f64> {
    let inside = |t: usize| spans.iter().any(|s| s.contains(&t));
    let edited = mean_accel(frames, inside)?;
    let rest = mean_accel(frames, |t| !inside(t))?;
    (rest > 0.0).then(|| edited / rest)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(shift: [f64; 3], bend: f64) -> Frame {
        let mut f = [[0.0; 3]; 24];
        for (j, p) in f.iter_mut().enumerate() {
            *p = [
                shift[0] + 0.1 * j as f64,
                shift[1] + bend * (j % 2) as f64,
                shift[2],
            ];
        }
        f
    }

    /// The root's position does not count; a bend of 3 cm on every second joint is 1.5 cm on average.
    #[test]
    fn errors_are_root_relative_means_over_joints() {
        let key = pose([0.0, 0.9, 0.0], 0.0);
        assert!(pose_error(&pose([5.0, 2.0, -1.0], 0.0), &key) < 1e-12);
        let e = pose_error(&pose([5.0, 2.0, -1.0], 0.03), &key);
        assert!((e - 0.015).abs() < 1e-12, "{e}");
        // Frames 0..10 bent by |t − 6| cm: at 4, 2 cm (mean 1 cm); the best within ±4 is frame 6 (0).
        let dance: Vec<Frame> = (0..10)
            .map(|t| pose([0.0; 3], 0.01 * (t as f64 - 6.0).abs()))
            .collect();
        let (at, best) = keyframe_errors(&dance, 4, &key, 4);
        assert!((at - 0.01).abs() < 1e-12 && best < 1e-12, "{at} {best}");
        // Near the end the window is clipped.
        let (_, best) = keyframe_errors(&dance, 9, &key, 1);
        assert!((best - 0.01).abs() < 1e-12, "{best}");
    }

    /// A jump inside the edited span makes its frames sharper than the rest; a still dance has no ratio.
    #[test]
    fn the_seam_ratio_compares_the_edited_frames_with_the_rest() {
        let span = 10..20;
        let still: Vec<Frame> = (0..40).map(|_| pose([0.3, 0.9, 0.0], 0.0)).collect();
        assert_eq!(
            seam_accel_ratio(&still, std::slice::from_ref(&span)),
            None,
            "no acceleration"
        );
        let wave: Vec<Frame> = (0..40)
            .map(|t| pose([0.01 * (t as f64).sin(), 0.0, 0.0], 0.0))
            .collect();
        let r = seam_accel_ratio(&wave, std::slice::from_ref(&span)).unwrap();
        assert!((0.5..2.0).contains(&r), "{r}");
        let mut jump = wave.clone();
        for f in jump.iter_mut().skip(15) {
            for p in f.iter_mut() {
                p[1] += 0.2;
            }
        }
        let r = seam_accel_ratio(&jump, std::slice::from_ref(&span)).unwrap();
        assert!(r > 3.0, "{r}");
    }
}
