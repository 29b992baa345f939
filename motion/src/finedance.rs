//! FineDance motions (Li et al., ICCV 2023): per frame the root translation (metres) followed by 52 SMPL-H/X
//! joints in the 6-D rotation representation of Zhou et al. (CVPR 2019), at 30 fps. Here: the 6-D → matrix
//! map (PyTorch3D's `rotation_6d_to_matrix`: the six values are the matrix's first two rows), the reduction
//! to the 24 SMPL body joints and the step to 60 fps.
//!
//! Choices (issue 42): joints 0–21 are SMPL's body joints in SMPL's order; SMPL's hand joints 22 and 23
//! have no FineDance counterpart (52 = 22 body + 2 × 15 finger joints) and get the identity, which moves no
//! joint position of the 24. 30 → 60 fps: every source frame is kept and one frame is put between each pair
//! (the rotations' geodesic midpoint, the translations' mean), so T frames give 2T − 1.

use crate::motion::Motion;
use crate::rotation::{axis_angle_to_matrix, matmul, matrix_to_axis_angle, transpose, Mat3};
use crate::vec3::{cross, dot, scale, sub, unit};

/// FineDance's frame rate.
pub const FPS: f64 = 30.0;
/// Joints per FineDance frame (SMPL-H/X body and fingers).
pub const JOINTS: usize = 52;
/// Values per FineDance frame: translation + 52 × 6.
pub const WIDTH: usize = 3 + JOINTS * 6;
/// SMPL body joints FineDance carries (SMPL's 0–21).
const BODY: usize = 22;

/// The rotation of a 6-D vector: its two halves, Gram–Schmidt orthonormalised, are the first two rows and
/// their cross product the third (Zhou et al., section 4; PyTorch3D's `rotation_6d_to_matrix`). `None` when
/// the halves are (nearly) zero or parallel.
pub fn rot6d_to_matrix(d: &[f64; 6]) -> Option<Mat3> {
    let a1 = [d[0], d[1], d[2]];
    let a2 = [d[3], d[4], d[5]];
    let b1 = unit(a1)?;
    let b2 = unit(sub(a2, scale(b1, dot(b1, a2))))?;
    let b3 = cross(b1, b2);
    Some([
        b1[0], b1[1], b1[2], b2[0], b2[1], b2[2], b3[0], b3[1], b3[2],
    ])
}

/// The geodesic midpoint of two rotations (slerp at ½): R1 · exp(½ log(R1ᵀ R2)).
fn midpoint(r1: &Mat3, r2: &Mat3) -> Mat3 {
    let rel = matrix_to_axis_angle(&matmul(&transpose(r1), r2));
    matmul(r1, &axis_angle_to_matrix(scale(rel, 0.5)))
}

/// FineDance rows (`frames` × [`WIDTH`] values) → a 60-fps [`Motion`] of the 24 SMPL joints (translation in
/// metres, scaling 1), or a message naming the first frame that cannot be one.
pub fn to_motion(values: &[f64], frames: usize) -> Result<Motion, String> {
    if frames == 0 || values.len() != frames * WIDTH {
        return Err(format!(
            "expected frames × {WIDTH} values (3 translation + {JOINTS} joints × 6-D rotation), got {} for {frames} frames",
            values.len()
        ));
    }
    let mut rotations: Vec<Vec<Mat3>> = Vec::with_capacity(frames);
    for (f, row) in values.chunks_exact(WIDTH).enumerate() {
        if let Some(i) = row.iter().position(|v| !v.is_finite()) {
            return Err(format!("frame {f}: value {i} is not a finite number"));
        }
        let mut joints = Vec::with_capacity(24);
        for j in 0..BODY {
            let d: [f64; 6] = std::array::from_fn(|k| row[3 + 6 * j + k]);
            joints.push(rot6d_to_matrix(&d).ok_or_else(|| {
                format!("frame {f}, joint {j}: the 6-D rotation's two halves are zero or parallel")
            })?);
        }
        joints.extend([axis_angle_to_matrix([0.0; 3]); 2]);
        rotations.push(joints);
    }
    let trans = |f: usize| -> [f64; 3] { std::array::from_fn(|k| values[f * WIDTH + k]) };
    let mut poses = Vec::with_capacity((2 * frames - 1) * 72);
    let mut out_trans = Vec::with_capacity((2 * frames - 1) * 3);
    for f in 0..frames {
        if f > 0 {
            for (a, b) in rotations[f - 1].iter().zip(&rotations[f]) {
                poses.extend(matrix_to_axis_angle(&midpoint(a, b)));
            }
            let (a, b) = (trans(f - 1), trans(f));
            out_trans.extend((0..3).map(|k| 0.5 * (a[k] + b[k])));
        }
        for r in &rotations[f] {
            poses.extend(matrix_to_axis_angle(r));
        }
        out_trans.extend(trans(f));
    }
    Motion::new(poses, out_trans, 1.0)
}

/// A 60-fps motion's rows in FineDance's layout at 30 fps (every second frame; the first two rows of each
/// rotation; SMPL's hand joints 22–23 dropped, the fingers at the identity): the inverse of [`to_motion`] on
/// its kept frames, for synthetic data and tests.
pub fn from_motion(m: &Motion) -> Vec<f64> {
    let mut out = Vec::new();
    for f in (0..m.frames).step_by(2) {
        out.extend((0..3).map(|k| m.trans[f * 3 + k] / m.scaling));
        for j in 0..JOINTS {
            let r = if j < BODY {
                let a = &m.poses[f * 72 + j * 3..f * 72 + j * 3 + 3];
                axis_angle_to_matrix([a[0], a[1], a[2]])
            } else {
                axis_angle_to_matrix([0.0; 3])
            };
            out.extend_from_slice(&r[..6]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn random_axis_angle(rng: &mut rand_chacha::ChaCha8Rng) -> [f64; 3] {
        std::array::from_fn(|_| rng.random_range(-1.5..1.5))
    }

    /// A rotation's first two rows give it back; scaled and skewed halves give the same rotation.
    #[test]
    fn rot6d_round_trips_and_orthonormalises() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for _ in 0..50 {
            let r = axis_angle_to_matrix(random_axis_angle(&mut rng));
            let d: [f64; 6] = std::array::from_fn(|k| r[k]);
            let back = rot6d_to_matrix(&d).unwrap();
            assert!(back.iter().zip(&r).all(|(a, b)| (a - b).abs() < 1e-12));
            let skewed: [f64; 6] = std::array::from_fn(|k| {
                if k < 3 {
                    2.5 * r[k]
                } else {
                    0.7 * r[k] + 0.4 * r[k - 3]
                }
            });
            let again = rot6d_to_matrix(&skewed).unwrap();
            assert!(again.iter().zip(&r).all(|(a, b)| (a - b).abs() < 1e-12));
        }
        assert!(rot6d_to_matrix(&[0.0; 6]).is_none());
        assert!(rot6d_to_matrix(&[1.0, 0.0, 0.0, 2.0, 0.0, 0.0]).is_none());
    }

    /// 30 → 60 fps keeps every source frame, puts the midpoint between, and reads back to the same rows.
    #[test]
    fn to_motion_doubles_the_rate_and_inverts_from_motion() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let frames = 4;
        let mut poses = Vec::new();
        for _ in 0..(2 * frames - 1) {
            for j in 0..24 {
                let a = if j < BODY {
                    random_axis_angle(&mut rng)
                } else {
                    [0.0; 3]
                };
                poses.extend(a);
            }
        }
        let trans: Vec<f64> = (0..(2 * frames - 1) * 3).map(|i| i as f64 * 0.01).collect();
        let m = Motion::new(poses, trans, 1.0).unwrap();
        let rows = from_motion(&m);
        assert_eq!(rows.len(), frames * WIDTH);
        let back = to_motion(&rows, frames).unwrap();
        assert_eq!(back.frames, 2 * frames - 1);
        for f in (0..back.frames).step_by(2) {
            for j in 0..24 {
                let a = axis_angle_to_matrix(std::array::from_fn(|k| m.poses[f * 72 + j * 3 + k]));
                let b =
                    axis_angle_to_matrix(std::array::from_fn(|k| back.poses[f * 72 + j * 3 + k]));
                assert!(
                    a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-9),
                    "{f} {j}"
                );
            }
        }
        // The inserted frame: half-way in angle from both neighbours, the translation their mean.
        let rot = |m: &Motion, f: usize, j: usize| {
            axis_angle_to_matrix(std::array::from_fn(|k| m.poses[f * 72 + j * 3 + k]))
        };
        for j in 0..BODY {
            let (a, mid, b) = (rot(&back, 0, j), rot(&back, 1, j), rot(&back, 2, j));
            let angle = |x: &Mat3, y: &Mat3| {
                let r = matrix_to_axis_angle(&matmul(&transpose(x), y));
                dot(r, r).sqrt()
            };
            assert!((angle(&a, &mid) - angle(&mid, &b)).abs() < 1e-9);
            assert!((2.0 * angle(&a, &mid) - angle(&a, &b)).abs() < 1e-9);
        }
        assert!((back.trans[3] - 0.5 * (m.trans[0] + m.trans[6])).abs() < 1e-12);
    }

    #[test]
    fn bad_rows_name_the_problem() {
        assert!(to_motion(&[0.0; 10], 1).unwrap_err().contains("315"));
        let mut row = vec![0.0; WIDTH];
        row[3 + 6 * 5] = f64::NAN;
        assert!(to_motion(&row, 1).unwrap_err().contains("frame 0"));
        let zero = vec![0.0; WIDTH];
        assert!(to_motion(&zero, 1).unwrap_err().contains("joint 0"));
    }
}
