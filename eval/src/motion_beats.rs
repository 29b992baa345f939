//! Motion beats after Kim, Park and Shin (2003) and beat precision/recall/F1 against the paired ground
//! truth's motion beats (SPEC §11.9, the TSMT paper's beat metric).
//!
//! Beats are the moments the summed joint angular speed stops falling: the −→+ zero crossings of its
//! first difference (local minima, "moments of stop"), after Gaussian smoothing with scipy's
//! `gaussian_filter1d` semantics. Matching is one-to-one within a tolerance.

use qean_motion::rotation::{matmul, transpose, Mat3};
use qean_motion::skeleton::PARENTS;

use crate::beat_align::gaussian_filter1d;
use crate::positions::{Frame, N_JOINTS};

/// Frames per second of the speeds.
const FPS: f64 = 60.0;

/// Summed angular speed of the 23 bones (rad/s), T − 1 samples: the angle each bone direction
/// turns between frames t and t + 1, times 60 (`kim_input = bones`).
pub fn bone_angular_speed(joints: &[Frame]) -> Vec<f64> {
    let dir = |f: &Frame, j: usize| {
        let p = PARENTS[j] as usize;
        let d = [f[j][0] - f[p][0], f[j][1] - f[p][1], f[j][2] - f[p][2]];
        let n = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt().max(1e-12);
        [d[0] / n, d[1] / n, d[2] / n]
    };
    joints
        .windows(2)
        .map(|w| {
            (1..N_JOINTS)
                .map(|j| {
                    let (a, b) = (dir(&w[0], j), dir(&w[1], j));
                    let c = [
                        a[1] * b[2] - a[2] * b[1],
                        a[2] * b[0] - a[0] * b[2],
                        a[0] * b[1] - a[1] * b[0],
                    ];
                    let s = (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt();
                    s.atan2(a[0] * b[0] + a[1] * b[1] + a[2] * b[2]) * FPS
                })
                .sum()
        })
        .collect()
}

/// Geodesic angle of a rotation (radians).
pub fn rotation_angle(r: &Mat3) -> f64 {
    ((r[0] + r[4] + r[8] - 1.0) / 2.0).clamp(-1.0, 1.0).acos()
}

/// Summed local angular speed (rad/s) of the given joints' rotations (frames × 24 local matrices),
/// T − 1 samples (`kim_input = local_rot` takes [`NON_LEAF`]).
pub fn rotation_angular_speed(rotations: &[Mat3], joints: &[usize]) -> Vec<f64> {
    let frames = rotations.len() / N_JOINTS;
    (0..frames.saturating_sub(1))
        .map(|t| {
            joints
                .iter()
                .map(|&j| {
                    let (a, b) = (
                        &rotations[t * N_JOINTS + j],
                        &rotations[(t + 1) * N_JOINTS + j],
                    );
                    rotation_angle(&matmul(&transpose(a), b)) * FPS
                })
                .sum()
        })
        .collect()
}

/// The 19 joints with children (the leaves 10, 11, 15, 22, 23 move nothing).
pub const NON_LEAF: [usize; 19] = [
    0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21,
];

/// Beats of a summed angular speed S (sample t spans frames t..t+1): after smoothing with σ
/// (0 = none), the t with A[t] < 0 ≤ A[t+1] where A[t] = S[t] − S[t−1].
pub fn beats_of_speed(speed: &[f64], sigma: f64) -> Vec<usize> {
    let s = if sigma > 0.0 {
        gaussian_filter1d(speed, sigma)
    } else {
        speed.to_vec()
    };
    let a: Vec<f64> = s.windows(2).map(|w| w[1] - w[0]).collect();
    // a[i] = A[i + 1].
    (1..s.len().saturating_sub(1))
        .filter(|&t| a[t - 1] < 0.0 && a[t] >= 0.0)
        .collect()
}

/// Kim-style motion beats of joint positions (`bones` input) with smoothing σ.
pub fn motion_beats(joints: &[Frame], sigma: f64) -> Vec<usize> {
    beats_of_speed(&bone_angular_speed(joints), sigma)
}

/// One-to-one matches between sorted beat lists within `tol` frames: a greedy two-pointer pass that
/// matches and advances both when within tolerance, else advances the smaller (a maximum matching
/// for interval tolerances).
pub fn match_beats(generated: &[usize], reference: &[usize], tol: usize) -> usize {
    let (mut i, mut j, mut m) = (0, 0, 0);
    while i < generated.len() && j < reference.len() {
        let (g, r) = (generated[i], reference[j]);
        if g.abs_diff(r) <= tol {
            m += 1;
            i += 1;
            j += 1;
        } else if g < r {
            i += 1;
        } else {
            j += 1;
        }
    }
    m
}

/// Beat precision, recall and F1 of one sequence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeatPrf {
    pub precision: f64,
    pub recall: f64,
    pub f1: f64,
}

/// P = m/|G|, R = m/|R|, F = 2PR/(P + R); all 0 when either list is empty (mir_eval's convention).
pub fn beat_prf(generated: &[usize], reference: &[usize], tol: usize) -> BeatPrf {
    if generated.is_empty() || reference.is_empty() {
        return BeatPrf {
            precision: 0.0,
            recall: 0.0,
            f1: 0.0,
        };
    }
    let m = match_beats(generated, reference, tol) as f64;
    let (p, r) = (m / generated.len() as f64, m / reference.len() as f64);
    let f1 = if p + r > 0.0 {
        2.0 * p * r / (p + r)
    } else {
        0.0
    };
    BeatPrf {
        precision: p,
        recall: r,
        f1,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use qean_motion::fk::{forward_kinematics, FkRoot};
    use qean_motion::rotation::{axis_angle_to_matrix, IDENTITY};

    /// A standing skeleton whose right elbow (19) bends as `angle(t)` about local y.
    fn elbow(frames: usize, angle: impl Fn(usize) -> f64) -> (Vec<Frame>, Vec<Mat3>) {
        let mut rots = vec![IDENTITY; frames * N_JOINTS];
        for t in 0..frames {
            rots[t * N_JOINTS + 19] = axis_angle_to_matrix([0.0, angle(t), 0.0]);
        }
        let joints = forward_kinematics(&vec![[0.0; 3]; frames], &rots, FkRoot::Edge);
        let frames: Vec<Frame> = joints
            .chunks_exact(N_JOINTS)
            .map(|c| std::array::from_fn(|j| c[j]))
            .collect();
        (frames, rots)
    }

    /// SPEC §11.13.9: a sinusoidal elbow of period 40 stops every 20 frames; `bones` equals
    /// `local_rot` for a single hinge.
    #[test]
    fn a_sinusoidal_elbow_beats_every_twenty_frames() {
        let (joints, rots) = elbow(200, |t| {
            0.8 * (2.0 * std::f64::consts::PI * t as f64 / 40.0).sin()
        });
        let beats = motion_beats(&joints, 5.0);
        assert!(beats.len() >= 8, "{beats:?}");
        for w in beats.windows(2) {
            assert!((w[1] - w[0]).abs_diff(20) <= 1, "{beats:?}");
        }
        // Stops at the turning points t = 10 + 20k.
        for b in &beats {
            let phase = (b + 10) % 20;
            assert!(phase <= 1 || phase >= 19, "{beats:?}");
        }
        // The same stops from the local rotations (ties at the exact turning point may fall on
        // either of two equal frames).
        let local = beats_of_speed(&rotation_angular_speed(&rots, &NON_LEAF), 5.0);
        assert_eq!(local.len(), beats.len(), "{local:?} vs {beats:?}");
        assert!(local.iter().zip(&beats).all(|(a, b)| a.abs_diff(*b) <= 1));
    }

    /// SPEC §11.13.9: [10, 20, 30] vs [12, 26, 31, 50] with tolerance 2 → 2/3, 1/2, 4/7.
    #[test]
    fn precision_recall_f1_hand_case() {
        let s = beat_prf(&[10, 20, 30], &[12, 26, 31, 50], 2);
        assert!((s.precision - 2.0 / 3.0).abs() < 1e-15);
        assert!((s.recall - 0.5).abs() < 1e-15);
        assert!((s.f1 - 4.0 / 7.0).abs() < 1e-15);
        assert_eq!(beat_prf(&[], &[1], 2).f1, 0.0);
    }

    /// The greedy pass finds a maximum matching (brute force over small random lists).
    #[test]
    fn greedy_matching_is_maximum() {
        use rand::{Rng, SeedableRng};
        fn best(g: &[usize], r: &[usize], used: &mut Vec<bool>, tol: usize) -> usize {
            let Some((&first, rest)) = g.split_first() else {
                return 0;
            };
            let mut m = best(rest, r, used, tol);
            for k in 0..r.len() {
                if !used[k] && first.abs_diff(r[k]) <= tol {
                    used[k] = true;
                    m = m.max(1 + best(rest, r, used, tol));
                    used[k] = false;
                }
            }
            m
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(4);
        for _ in 0..300 {
            let mut list = |n: usize| {
                let mut v: Vec<usize> = (0..n).map(|_| rng.random_range(0..30)).collect();
                v.sort();
                v.dedup();
                v
            };
            let (g, r) = (list(6), list(6));
            let tol = 2;
            assert_eq!(
                match_beats(&g, &r, tol),
                best(&g, &r, &mut vec![false; r.len()], tol),
                "{g:?} {r:?}"
            );
        }
    }
}
