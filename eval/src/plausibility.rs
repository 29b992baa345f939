//! Authenticity and Coherence without a physics engine (SPEC §11.11; the TSMT paper counts what a
//! Bullet humanoid could not execute, with limits it does not give). Rotations come from the inverse
//! kinematics of SPEC §11.3 for generated and ground-truth dances alike.
//!
//! - Authenticity: the fraction of frames in which every checked joint is within its range (`hinge`
//!   IK; knee and elbow bends from positions; hip Euler boxes after SCOPE; swing cones after SKEL),
//!   each limit widened by a slack (10°).
//! - Coherence: the fraction of transitions t → t + 1 in which no non-leaf joint turns faster than
//!   ω_max (1500°/s; `swing` IK; the root's global orientation).

use std::f64::consts::PI;

use qean_motion::ik::{inverse_kinematics, IkMode};
use qean_motion::rotation::{mat_vec, matmul, transpose, Mat3};
use qean_motion::skeleton::{OFFSETS, PARENTS};
use qean_motion::vec3::{cross, dot, norm, sub};

use crate::motion_beats::{rotation_angle, NON_LEAF};
use crate::positions::{Frame, N_JOINTS};

/// The limits and their slack.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlausibilityLimits {
    /// Degrees added to every joint limit (10).
    pub slack_deg: f64,
    /// Fastest allowed local angular speed, degrees per second (1500).
    pub omega_max_deg_s: f64,
}

impl Default for PlausibilityLimits {
    fn default() -> Self {
        PlausibilityLimits {
            slack_deg: 10.0,
            omega_max_deg_s: 1500.0,
        }
    }
}

/// Bend limits from positions: (joint, child, degrees). Knees after Bullet's humanoid (160°),
/// elbows after SKEL's elbow flexion (3π/4).
const BENDS: [(usize, usize, f64); 4] = [
    (4, 7, 160.0),
    (5, 8, 160.0),
    (18, 20, 135.0),
    (19, 21, 135.0),
];

/// Swing cones: (joint, child whose rest direction is swung, degrees). Spine, chest, neck, collars
/// and ankles 45° (SKEL ±π/4, scapula rounded up), wrists 90° (SKEL ±π/2).
const SWINGS: [(usize, usize, f64); 10] = [
    (3, 6, 45.0),
    (6, 9, 45.0),
    (9, 12, 45.0),
    (12, 15, 45.0),
    (13, 16, 45.0),
    (14, 17, 45.0),
    (7, 10, 45.0),
    (8, 11, 45.0),
    (20, 22, 90.0),
    (21, 23, 90.0),
];

/// Hip boxes on R = R_x(a)·R_y(b)·R_z(c), in units of π (SCOPE's SMPL `EulerAngleConstInfo`): joint,
/// then [lo, hi] of a, b and c.
const HIPS: [(usize, [[f64; 2]; 3]); 2] = [
    (1, [[-0.67, 0.50], [-0.25, 0.48], [-0.17, 0.25]]),
    (2, [[-0.67, 0.50], [-0.48, 0.25], [-0.25, 0.17]]),
];

/// XYZ Euler angles (a, b, c) with R = R_x(a)·R_y(b)·R_z(c).
pub fn euler_xyz(r: &Mat3) -> [f64; 3] {
    let b = r[2].clamp(-1.0, 1.0).asin();
    [(-r[5]).atan2(r[8]), b, (-r[1]).atan2(r[0])]
}

/// The angle between two vectors, degrees.
fn angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm(cross(a, b)).atan2(dot(a, b)).to_degrees()
}

/// Whether one frame (positions and its `hinge` local rotations) is within every limit.
pub fn frame_within_limits(p: &[[f64; 3]], r: &[Mat3], limits: &PlausibilityLimits) -> bool {
    let slack = limits.slack_deg;
    let bends_ok = BENDS.iter().all(|&(j, c, max)| {
        let parent = PARENTS[j] as usize;
        angle_deg(sub(p[j], p[parent]), sub(p[c], p[j])) <= max + slack
    });
    let swings_ok = SWINGS.iter().all(|&(j, c, max)| {
        let o = OFFSETS[c];
        angle_deg(o, mat_vec(&r[j], o)) <= max + slack
    });
    let hips_ok = HIPS.iter().all(|&(j, box_pi)| {
        let e = euler_xyz(&r[j]);
        let s = slack.to_radians();
        (0..3).all(|k| e[k] >= box_pi[k][0] * PI - s && e[k] <= box_pi[k][1] * PI + s)
    });
    bends_ok && swings_ok && hips_ok
}

fn flat(joints: &[Frame]) -> Vec<[f64; 3]> {
    joints.iter().flat_map(|f| f.iter().copied()).collect()
}

/// Authenticity of joint positions: the fraction of frames within every limit (`hinge` IK).
pub fn authenticity(joints: &[Frame], limits: &PlausibilityLimits) -> f64 {
    let p = flat(joints);
    let (r, _) = inverse_kinematics(&p, IkMode::Hinge);
    authenticity_of(&p, &r, limits)
}

/// Authenticity from positions and given local rotations (frames × 24 each; `plaus_input = smpl`
/// passes the dataset's own rotations).
pub fn authenticity_of(p: &[[f64; 3]], r: &[Mat3], limits: &PlausibilityLimits) -> f64 {
    let frames = p.len() / N_JOINTS;
    if frames == 0 {
        return 1.0;
    }
    let ok = (0..frames)
        .filter(|&t| {
            frame_within_limits(
                &p[t * N_JOINTS..(t + 1) * N_JOINTS],
                &r[t * N_JOINTS..(t + 1) * N_JOINTS],
                limits,
            )
        })
        .count();
    ok as f64 / frames as f64
}

/// Coherence of joint positions: the fraction of transitions with no non-leaf joint faster than
/// ω_max (`swing` IK).
pub fn coherence(joints: &[Frame], limits: &PlausibilityLimits) -> f64 {
    let (r, _) = inverse_kinematics(&flat(joints), IkMode::Swing);
    coherence_of(&r, limits)
}

/// Coherence from local rotations (frames × 24).
pub fn coherence_of(r: &[Mat3], limits: &PlausibilityLimits) -> f64 {
    let frames = r.len() / N_JOINTS;
    if frames < 2 {
        return 1.0;
    }
    let max = limits.omega_max_deg_s.to_radians() / 60.0;
    let ok = (0..frames - 1)
        .filter(|&t| {
            NON_LEAF.iter().all(|&j| {
                let (a, b) = (&r[t * N_JOINTS + j], &r[(t + 1) * N_JOINTS + j]);
                rotation_angle(&matmul(&transpose(a), b)) <= max
            })
        })
        .count();
    ok as f64 / (frames - 1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use qean_io::testdata::shared_dir;
    use qean_motion::fk::FkRoot;
    use qean_motion::motion::Motion;
    use qean_motion::rotation::{axis_angle_to_matrix, matrix_to_axis_angle};

    fn sample() -> Motion {
        Motion::read_pkl(&shared_dir().join("aistpp/motions/softcat477_SMPL-to-FBX_sample.pkl"))
            .unwrap()
    }

    fn frames(m: &Motion) -> Vec<Frame> {
        m.joints(FkRoot::Smpl)
            .chunks_exact(N_JOINTS)
            .map(|c| std::array::from_fn(|j| c[j]))
            .collect()
    }

    /// SPEC §11.13.11: the ground-truth sample is authentic and coherent (IK and raw rotations).
    #[test]
    fn the_ground_truth_sample_is_plausible() {
        let m = sample();
        let l = PlausibilityLimits::default();
        assert_eq!(authenticity(&frames(&m), &l), 1.0);
        assert_eq!(coherence(&frames(&m), &l), 1.0);
        assert_eq!(coherence_of(&m.rotations(), &l), 1.0);
    }

    /// SPEC §11.11: a knee folded to 175° on frames 5–6 and hyperextended by 57° on frame 9 give
    /// Authenticity 1 − 3/T and Coherence 1 − 4/(T − 1).
    #[test]
    fn synthetic_violations_give_the_exact_fractions() {
        let mut m = sample();
        let set = |m: &mut Motion, t: usize, deg: f64| {
            let r = axis_angle_to_matrix([deg.to_radians(), 0.0, 0.0]);
            let aa = matrix_to_axis_angle(&r);
            m.poses[t * 72 + 3 * 4..t * 72 + 3 * 4 + 3].copy_from_slice(&aa);
        };
        set(&mut m, 5, 175.0);
        set(&mut m, 6, 175.0);
        set(&mut m, 9, -57.0);
        let t = m.frames as f64;
        let l = PlausibilityLimits::default();
        let j = frames(&m);
        let a = authenticity(&j, &l);
        let c = coherence(&j, &l);
        assert!(
            (a - (1.0 - 3.0 / t)).abs() < 1e-12,
            "authenticity {a}, want {}",
            1.0 - 3.0 / t
        );
        assert!((c - (1.0 - 4.0 / (t - 1.0))).abs() < 1e-12, "coherence {c}");
    }

    #[test]
    fn euler_xyz_inverts_the_product() {
        let (a, b, c) = (0.3, -0.7, 1.1);
        let r = matmul(
            &matmul(
                &axis_angle_to_matrix([a, 0.0, 0.0]),
                &axis_angle_to_matrix([0.0, b, 0.0]),
            ),
            &axis_angle_to_matrix([0.0, 0.0, c]),
        );
        let e = euler_xyz(&r);
        assert!((e[0] - a).abs() < 1e-12 && (e[1] - b).abs() < 1e-12 && (e[2] - c).abs() < 1e-12);
    }
}
