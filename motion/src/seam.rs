//! The seed's end (issue 17): a model's first forecast need not start where the seed stops. A
//! tiny model trained with input noise lands its first generated frame on a pose of the dance
//! proper (the seed is a sequence's slower first half second), and the dance jumps by a few
//! centimetres in one frame: 2.5–5.7 m/s mean joint speed for that frame, in every dance.
//!
//! Inertialization (Bollo, "Inertialization: high-performance animation transitions", GDC 2016)
//! removes such a jump: the gap between where the seed was going and the first generated frame is
//! measured once, added to that frame in full and to the next ones with a weight that falls
//! smoothly to zero over `frames` frames. The gap is a root translation and one rotation per joint
//! (applied on the left, R′ = exp(w·log Δ)·R); the seed's continuation is its last frame moved on
//! by its last frame-to-frame step. The sampler feeds the eased frames back, so the model
//! continues from what is exported.

use crate::motion::Layout;
use crate::rotation::{
    axis_angle_to_matrix, matmul, matrix_to_axis_angle, project_to_so3, transpose, Mat3,
};

/// The gap at the seam: root translation and per-joint axis-angle offsets.
#[derive(Debug, Clone, PartialEq)]
pub struct Seam {
    trans: [f64; 3],
    rot: Vec<[f64; 3]>,
}

fn block(frame: &[f32], at: usize) -> Mat3 {
    std::array::from_fn(|k| frame[at + k] as f64)
}

/// Weight of the gap on generated frame `k` (0-based) when it fades over `frames` frames:
/// 1 − smoothstep(k / frames), so 1 on the first frame and 0 from frame `frames` on.
pub fn weight(k: usize, frames: usize) -> f64 {
    if k >= frames {
        return 0.0;
    }
    let x = k as f64 / frames as f64;
    1.0 - x * x * (3.0 - 2.0 * x)
}

impl Seam {
    /// The gap between the continuation of the seed (`prev`, `last`: its last two frames) and the
    /// first generated frame `first`, in the model's layout.
    pub fn measure(prev: &[f32], last: &[f32], first: &[f32], layout: Layout) -> Seam {
        let off = layout.trans_offset();
        let trans = std::array::from_fn(|a| {
            let (p, l) = (prev[off + a] as f64, last[off + a] as f64);
            2.0 * l - p - first[off + a] as f64
        });
        let rot = (0..24)
            .map(|j| {
                let b = off + 3 + 9 * j;
                let (p, l) = (
                    project_to_so3(&block(prev, b)),
                    project_to_so3(&block(last, b)),
                );
                // Constant angular velocity: last · (prevᵀ · last).
                let next = matmul(&l, &matmul(&transpose(&p), &l));
                let g = project_to_so3(&block(first, b));
                matrix_to_axis_angle(&matmul(&next, &transpose(&g)))
            })
            .collect();
        Seam { trans, rot }
    }

    /// Adds `w` × the gap to a generated frame.
    pub fn apply(&self, frame: &mut [f32], w: f64, layout: Layout) {
        if w == 0.0 {
            return;
        }
        let off = layout.trans_offset();
        for a in 0..3 {
            frame[off + a] = (frame[off + a] as f64 + w * self.trans[a]) as f32;
        }
        for (j, r) in self.rot.iter().enumerate() {
            let b = off + 3 + 9 * j;
            let d = axis_angle_to_matrix([w * r[0], w * r[1], w * r[2]]);
            let m = matmul(&d, &block(frame, b));
            for (x, v) in frame[b..b + 9].iter_mut().zip(m) {
                *x = v as f32;
            }
        }
    }
}

/// The same easing on joint positions (`frames × 24` points), for decoders that give positions, not
/// rotations (the VQ-VAE, SPEC §13.8): the gap between the seed's last frame (`seed_last`, 24 points)
/// and the decoder's version of that frame (`joints` at `last`) is added to every later frame with the
/// weight of [`weight`], so the first generated frame moves on from the seed by the decoder's own step
/// and the gap is gone after `frames` frames. Frames up to `last` are left alone.
pub fn ease_joints(joints: &mut [[f64; 3]], last: usize, seed_last: &[[f64; 3]], frames: usize) {
    let gap: Vec<[f64; 3]> = (0..24)
        .map(|j| std::array::from_fn(|a| seed_last[j][a] - joints[last * 24 + j][a]))
        .collect();
    for (k, frame) in joints[(last + 1) * 24..].chunks_mut(24).enumerate() {
        let w = weight(k, frames);
        if w == 0.0 {
            break;
        }
        for (p, g) in frame.iter_mut().zip(&gap) {
            for a in 0..3 {
                p[a] += w * g[a];
            }
        }
    }
}

/// Motion warping to a keyframe pose (Witkin & Popović 1995, a displacement map): the gap between the
/// pose's root-relative joints and the dance's at frame `at` is added to the frames `at ± radius` with a
/// raised-cosine weight (1 at `at`, 0 at the span's ends), so the dance passes through the pose at `at`
/// and moves as before elsewhere. The root's path is left alone (a keyframe does not place the root).
pub fn warp_to_pose(joints: &mut [[f64; 3]], at: usize, pose: &[[f64; 3]], radius: usize) {
    let frames = joints.len() / 24;
    if at >= frames || pose.len() != 24 {
        return;
    }
    let frame = &joints[at * 24..(at + 1) * 24];
    let gap: Vec<[f64; 3]> = (0..24)
        .map(|j| std::array::from_fn(|a| (pose[j][a] - pose[0][a]) - (frame[j][a] - frame[0][a])))
        .collect();
    let lo = at.saturating_sub(radius);
    let hi = (at + radius).min(frames - 1);
    for t in lo..=hi {
        let u = t.abs_diff(at) as f64 / (radius + 1) as f64;
        let w = 0.5 * (1.0 + (std::f64::consts::PI * u).cos());
        for (p, g) in joints[t * 24..(t + 1) * 24].iter_mut().zip(&gap) {
            for a in 0..3 {
                p[a] += w * g[a];
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rotation::IDENTITY;

    fn frame(layout: Layout, trans: [f64; 3], rot: &[[f64; 3]; 24]) -> Vec<f32> {
        let off = layout.trans_offset();
        let mut f = vec![0.0f32; layout.dim()];
        for a in 0..3 {
            f[off + a] = trans[a] as f32;
        }
        for (j, r) in rot.iter().enumerate() {
            let m = axis_angle_to_matrix(*r);
            for k in 0..9 {
                f[off + 3 + 9 * j + k] = m[k] as f32;
            }
        }
        f
    }

    #[test]
    fn weight_falls_smoothly_from_one_to_zero() {
        assert_eq!(weight(0, 10), 1.0);
        assert_eq!(weight(5, 10), 0.5);
        assert_eq!(weight(10, 10), 0.0);
        assert_eq!(weight(11, 10), 0.0);
        assert_eq!(weight(0, 0), 0.0);
        let w: Vec<f64> = (0..=10).map(|k| weight(k, 10)).collect();
        assert!(w.windows(2).all(|p| p[1] <= p[0]));
    }

    /// With the full gap the first generated frame becomes the seed's continuation; without it
    /// the frame is unchanged.
    #[test]
    fn full_weight_continues_the_seed() {
        for layout in [Layout::L225, Layout::L219] {
            let mut rot = [[0.0; 3]; 24];
            let prev = frame(layout, [0.0, 1.0, 0.0], &rot);
            rot[3] = [0.0, 0.0, 0.1];
            rot[18] = [0.2, -0.1, 0.0];
            let last = frame(layout, [0.01, 1.0, 0.0], &rot);
            let first = frame(layout, [-0.03, 0.95, 0.04], &[[0.3, 0.2, -0.4]; 24]);
            let seam = Seam::measure(&prev, &last, &first, layout);
            let mut eased = first.clone();
            seam.apply(&mut eased, 1.0, layout);
            let off = layout.trans_offset();
            // Translation moves on by the last step: 0.02, 1.0, 0.0.
            for (a, want) in [0.02, 1.0, 0.0].iter().enumerate() {
                assert!((eased[off + a] as f64 - want).abs() < 1e-6);
            }
            // Rotations move on by the last step too: joint 3 to 0.2 rad about z, joint 0 stays.
            let r3 = matrix_to_axis_angle(&block(&eased, off + 3 + 9 * 3));
            assert!((r3[2] - 0.2).abs() < 1e-5 && r3[0].abs() < 1e-5, "{r3:?}");
            let r0 = block(&eased, off + 3);
            assert!(r0.iter().zip(IDENTITY).all(|(a, b)| (a - b).abs() < 1e-5));
            let mut same = first.clone();
            seam.apply(&mut same, 0.0, layout);
            assert_eq!(same, first);
        }
    }

    /// Joint positions: a decoder 5 cm off the seed's last frame, moving 1 cm per frame. Eased over 4
    /// frames, the first generated frame is the seed plus the decoder's own step, the gap is gone from
    /// frame 4 on, and the frames up to the seam are untouched.
    #[test]
    fn eased_joints_continue_the_seed() {
        let decoded: Vec<[f64; 3]> = (0..10)
            .flat_map(|t| (0..24).map(move |j| [0.05 + 0.01 * t as f64, j as f64 * 0.1, 0.0]))
            .collect();
        let seed_last: Vec<[f64; 3]> = (0..24).map(|j| [0.02, j as f64 * 0.1, 0.0]).collect();
        let mut eased = decoded.clone();
        ease_joints(&mut eased, 2, &seed_last, 4);
        assert_eq!(eased[..3 * 24], decoded[..3 * 24]);
        for j in 0..24 {
            assert!(
                (eased[3 * 24 + j][0] - 0.03).abs() < 1e-12,
                "{:?}",
                eased[3 * 24 + j]
            );
            for t in 7..10 {
                assert_eq!(eased[t * 24 + j], decoded[t * 24 + j]);
            }
        }
        let x: Vec<f64> = (3..8).map(|t| eased[t * 24][0]).collect();
        assert!(x.windows(2).all(|p| p[1] > p[0]), "{x:?}");
        let mut off = decoded.clone();
        ease_joints(&mut off, 2, &seed_last, 0);
        assert_eq!(off, decoded);
    }

    /// The warped dance passes through the pose (root-relative) at the keyframe, keeps its root, and is
    /// unchanged outside the span; the weight rises smoothly.
    #[test]
    fn warping_reaches_the_pose_at_the_keyframe_only() {
        let frames = 60;
        let mut joints: Vec<[f64; 3]> = (0..frames * 24)
            .map(|i| {
                let (t, j) = ((i / 24) as f64, (i % 24) as f64);
                [0.01 * t + 0.05 * j, 0.9 + 0.02 * (0.3 * t).sin() * j, 0.0]
            })
            .collect();
        let before = joints.clone();
        let pose: Vec<[f64; 3]> = (0..24)
            .map(|j| [2.0 + 0.04 * j as f64, 0.5, 0.1 * j as f64])
            .collect();
        warp_to_pose(&mut joints, 30, &pose, 10);
        for j in 0..24 {
            for a in 0..3 {
                let got = joints[30 * 24 + j][a] - joints[30 * 24][a];
                let want = pose[j][a] - pose[0][a];
                assert!((got - want).abs() < 1e-12, "joint {j} axis {a}");
            }
        }
        for t in (0..20).chain(41..frames) {
            assert_eq!(
                joints[t * 24..(t + 1) * 24],
                before[t * 24..(t + 1) * 24],
                "frame {t}"
            );
        }
        // The root keeps its path (its gap is 0 by construction).
        assert_eq!(joints[30 * 24], before[30 * 24]);
        let step = |t: usize| (joints[t * 24 + 5][2] - before[t * 24 + 5][2]).abs();
        assert!(step(21) < step(25) && step(25) < step(29), "smooth rise");
    }
}
