//! SMPL forward kinematics from the skeleton offsets (SPEC §3.3).
//!
//! G_0 = R_0, p_0 = root; G_i = G_π(i)·R_i; p_i = p_π(i) + G_π(i)·o_i (the parent's rotation moves the offset).

use crate::rotation::{mat_vec, matmul, Mat3};
use crate::skeleton::{NUM_JOINTS, OFFSETS, PARENTS, SMPL_MALE_PELVIS};

/// Where the root joint sits relative to the (scaled) translation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FkRoot {
    /// p_0 = trans/scaling + J0 (SMPL male rest pelvis): reproduces smplx SMPL joints, as mint and
    /// Bailando compute them. The default.
    #[default]
    Smpl,
    /// p_0 = trans/scaling, as EDGE's `vis.py`.
    Edge,
}

/// Joint positions, frames × 24, from root positions (frames) and joint rotations (frames × 24).
pub fn forward_kinematics(roots: &[[f64; 3]], rotations: &[Mat3], root: FkRoot) -> Vec<[f64; 3]> {
    assert_eq!(
        rotations.len(),
        roots.len() * NUM_JOINTS,
        "rotations must be frames × 24"
    );
    let shift = match root {
        FkRoot::Smpl => SMPL_MALE_PELVIS,
        FkRoot::Edge => [0.0; 3],
    };
    let mut out = Vec::with_capacity(rotations.len());
    let mut global = [[0.0; 9]; NUM_JOINTS];
    let mut pos = [[0.0; 3]; NUM_JOINTS];
    for (t, r) in roots.iter().enumerate() {
        let rots = &rotations[t * NUM_JOINTS..(t + 1) * NUM_JOINTS];
        global[0] = rots[0];
        pos[0] = [r[0] + shift[0], r[1] + shift[1], r[2] + shift[2]];
        for j in 1..NUM_JOINTS {
            let p = PARENTS[j] as usize;
            let o = mat_vec(&global[p], OFFSETS[j]);
            pos[j] = [pos[p][0] + o[0], pos[p][1] + o[1], pos[p][2] + o[2]];
            global[j] = matmul(&global[p], &rots[j]);
        }
        out.extend_from_slice(&pos);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::Motion;
    use crate::rotation::axis_angle_to_matrix;
    use qean_io::testdata::shared_dir;
    use rand::{Rng, SeedableRng};

    fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
    }

    #[test]
    fn bone_lengths_equal_offsets() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let frames = 50;
        let roots: Vec<[f64; 3]> = (0..frames)
            .map(|_| std::array::from_fn(|_| rng.random_range(-1.0..1.0)))
            .collect();
        let rots: Vec<Mat3> = (0..frames * NUM_JOINTS)
            .map(|_| axis_angle_to_matrix(std::array::from_fn(|_| rng.random_range(-2.0..2.0))))
            .collect();
        let joints = forward_kinematics(&roots, &rots, FkRoot::Edge);
        for t in 0..frames {
            let p = &joints[t * NUM_JOINTS..(t + 1) * NUM_JOINTS];
            assert_eq!(p[0], roots[t]);
            for j in 1..NUM_JOINTS {
                let o = OFFSETS[j];
                let len = (o[0] * o[0] + o[1] * o[1] + o[2] * o[2]).sqrt();
                assert!((dist(p[j], p[PARENTS[j] as usize]) - len).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn rest_pose_matches_skeleton() {
        let rots = vec![crate::rotation::IDENTITY; NUM_JOINTS];
        let j = forward_kinematics(&[[0.0; 3]], &rots, FkRoot::Smpl);
        let want = crate::skeleton::rest_joints(SMPL_MALE_PELVIS);
        for k in 0..NUM_JOINTS {
            assert!(dist(j[k], want[k]) < 1e-15);
        }
        assert!(dist(j[16], [0.19911, 0.23681, -0.01807]) < 1e-5);
    }

    /// SPEC §1.7: the softcat sample with the `edge` root.
    #[test]
    fn softcat_sanity_values() {
        let m = Motion::read_pkl(
            &shared_dir().join("aistpp/motions/softcat477_SMPL-to-FBX_sample.pkl"),
        )
        .unwrap();
        let j = m.joints(FkRoot::Edge);
        let root0 = j[0];
        let want = [-0.2493, 1.8578, -0.1204];
        for a in 0..3 {
            assert!((root0[a] - want[a]).abs() < 5e-5, "{root0:?}");
        }
        let jr = &j;
        let ys = |joint: usize| (0..m.frames).map(move |t| jr[t * NUM_JOINTS + joint][1]);
        let (hmin, hmax) = ys(15).fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
        assert!(
            (hmin - 2.251).abs() < 5e-4 && (hmax - 2.558).abs() < 5e-4,
            "head {hmin} {hmax}"
        );
        let ankles = ys(7).chain(ys(8));
        let (amin, amax) = ankles.fold((f64::MAX, f64::MIN), |(a, b), y| (a.min(y), b.max(y)));
        assert!(
            (amin - 1.036).abs() < 5e-4 && (amax - 1.289).abs() < 5e-4,
            "ankles {amin} {amax}"
        );
        let toes_min = ys(10).chain(ys(11)).fold(f64::MAX, f64::min);
        assert!(toes_min >= 0.937 - 5e-4, "toes {toes_min}");
        // The smpl root differs by the constant pelvis offset.
        let js = m.joints(FkRoot::Smpl);
        for k in 0..3 {
            assert!((js[5][k] - j[5][k] - SMPL_MALE_PELVIS[k]).abs() < 1e-12);
        }
    }
}
