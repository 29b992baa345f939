//! Joint positions → SMPL rotations (SPEC §11.3): a deterministic inverse kinematics over the §3.3
//! skeleton, used for TSMT's exports and metrics and by `qean convert` for any joint-position file.
//!
//! In joint order (parents first): the root and the chest (three children each) take the Kabsch
//! rotation of their rest offsets onto the observed ones; a joint with one child takes the minimal
//! rotation of its rest bone onto the observed bone (`swing`: no twist relative to the parent), or,
//! in `hinge` mode, knees rotate about local x and elbows about local y only, with the hip's
//! (shoulder's) twist solved to allow it; leaves get the identity. FK of the result puts every joint
//! back where it was whenever the bones have the skeleton's lengths.

use serde::{Deserialize, Serialize};

use crate::fk::FkRoot;
use crate::motion::Motion;
use crate::rotation::{
    axis_angle_to_matrix, mat_vec, matmul, matrix_to_axis_angle, project_to_so3, transpose, Mat3,
    IDENTITY,
};
use crate::skeleton::{NUM_JOINTS, OFFSETS, PARENTS, SMPL_MALE_PELVIS};
use crate::vec3::{cross, dot, norm, scale, sub, unit};

/// How rotations are chosen for single-child joints.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum IkMode {
    /// The minimal rotation onto each bone (zero twist relative to the parent).
    #[default]
    Swing,
    /// Knees about local x, elbows about local y; the parent's twist solved to match.
    Hinge,
}

/// Joints whose rotation is a Kabsch fit to their children: the root and the chest.
const KABSCH: [(usize, [usize; 3]); 2] = [(0, [1, 2, 3]), (9, [12, 13, 14])];

/// Hinge joints: (joint, its child, hinge axis, flexion sign). Knees flex by +θ_x, the left elbow by
/// −θ_y and the right by +θ_y (the signs of the ground truth's ranges).
const HINGES: [(usize, usize, usize, f64); 4] = [
    (4, 7, 0, 1.0),
    (5, 8, 0, 1.0),
    (18, 20, 1, -1.0),
    (19, 21, 1, 1.0),
];

/// The single child of each joint with one (None for the root, the chest and the leaves).
fn only_child(j: usize) -> Option<usize> {
    let mut kids = (1..NUM_JOINTS).filter(|&c| PARENTS[c] as usize == j);
    match (kids.next(), kids.next()) {
        (Some(c), None) => Some(c),
        _ => None,
    }
}

/// The minimal rotation taking unit `a` onto unit `b` (π about a perpendicular axis when opposite).
pub fn swing_between(a: [f64; 3], b: [f64; 3]) -> Mat3 {
    let c = cross(a, b);
    let s = norm(c);
    let angle = s.atan2(dot(a, b));
    match unit(c) {
        Some(axis) if s > 1e-12 => axis_angle_to_matrix(scale(axis, angle)),
        _ if dot(a, b) > 0.0 => IDENTITY,
        _ => {
            // Opposite: any axis perpendicular to a.
            let helper = if a[0].abs() < 0.9 {
                [1.0, 0.0, 0.0]
            } else {
                [0.0, 1.0, 0.0]
            };
            let axis = unit(cross(a, helper)).expect("a non-parallel helper");
            axis_angle_to_matrix(scale(axis, std::f64::consts::PI))
        }
    }
}

/// The Kabsch rotation taking the rest offsets of `children` onto their observed offsets from `p`.
fn kabsch(p: &[[f64; 3]], j: usize, children: [usize; 3]) -> Mat3 {
    // M = Σ d_c o_cᵀ; its closest rotation is V·diag(1, 1, det)·Uᵀ of H = Mᵀ = U S Vᵀ.
    let mut m = [0.0; 9];
    for c in children {
        let d = sub(p[c], p[j]);
        let o = OFFSETS[c];
        for r in 0..3 {
            for k in 0..3 {
                m[3 * r + k] += d[r] * o[k];
            }
        }
    }
    project_to_so3(&m)
}

/// The rotation of a single-child joint under `swing`: rest bone onto the observed bone, expressed
/// in the parent's frame `parent_global`.
fn swing_rotation(p: &[[f64; 3]], j: usize, c: usize, parent_global: &Mat3) -> Mat3 {
    let rest = unit(OFFSETS[c]).expect("non-zero bone");
    match unit(mat_vec(&transpose(parent_global), sub(p[c], p[j]))) {
        Some(u) => swing_between(rest, u),
        None => IDENTITY,
    }
}

/// `hinge` for the parent `h` of hinge joint `k` (child `c`, axis `axis`, flexion sign): the
/// parent's rotation with its twist about the bone solved so that `k` is a pure rotation about
/// `axis`, and that rotation; None when no twist allows it (a nearly straight limb).
fn hinge_pair(
    p: &[[f64; 3]],
    h: usize,
    (k, c, axis, sign): (usize, usize, usize, f64),
    grand_global: &Mat3,
) -> Option<(Mat3, Mat3)> {
    let a = unit(OFFSETS[k])?;
    let bone = unit(mat_vec(&transpose(grand_global), sub(p[k], p[h])))?;
    let swing = swing_between(a, bone);
    let rest = unit(OFFSETS[c])?;
    // The lower bone in the swing frame: v = R_swingᵀ G_πᵀ (p_c − p_k).
    let v = unit(mat_vec(
        &transpose(&matmul(grand_global, &swing)),
        sub(p[c], p[k]),
    ))?;
    // Twist ψ about a: (R(ψ) e)·v = rest[axis], i.e. A cos ψ + B sin ψ = C.
    let mut e = [0.0; 3];
    e[axis] = 1.0;
    let (ae, av) = (dot(a, e), dot(a, v));
    let (big_a, big_b, big_c) = (
        dot(e, v) - ae * av,
        dot(cross(a, e), v),
        rest[axis] - ae * av,
    );
    let r = big_a.hypot(big_b);
    if r < 1e-12 || big_c.abs() > r {
        return None;
    }
    let phi = big_b.atan2(big_a);
    let spread = (big_c / r).clamp(-1.0, 1.0).acos();
    let (i1, i2) = ((axis + 1) % 3, (axis + 2) % 3);
    let solve = |psi: f64| {
        let parent = matmul(&swing, &axis_angle_to_matrix(scale(a, psi)));
        let w = unit(mat_vec(
            &transpose(&matmul(grand_global, &parent)),
            sub(p[c], p[k]),
        ))?;
        let theta =
            (rest[i1] * w[i2] - rest[i2] * w[i1]).atan2(rest[i1] * w[i1] + rest[i2] * w[i2]);
        let mut rv = [0.0; 3];
        rv[axis] = theta;
        Some((sign * theta, parent, axis_angle_to_matrix(rv)))
    };
    let first = solve(phi + spread)?;
    let second = solve(phi - spread)?;
    let best = if second.0 > first.0 { second } else { first };
    Some((best.1, best.2))
}

/// Rotations of one frame's 24 joint positions; returns the local rotations and how many hinge limbs
/// fell back to `swing`.
fn frame_rotations(p: &[[f64; 3]], mode: IkMode) -> ([Mat3; NUM_JOINTS], usize) {
    let mut local = [IDENTITY; NUM_JOINTS];
    let mut global = [IDENTITY; NUM_JOINTS];
    let mut fallbacks = 0;
    let mut hinge_done = [false; NUM_JOINTS];
    for j in 0..NUM_JOINTS {
        let parent_global = if j == 0 {
            IDENTITY
        } else {
            global[PARENTS[j] as usize]
        };
        if hinge_done[j] {
            global[j] = matmul(&parent_global, &local[j]);
            continue;
        }
        if let Some(&(_, kids)) = KABSCH.iter().find(|(k, _)| *k == j) {
            global[j] = kabsch(p, j, kids);
            local[j] = matmul(&transpose(&parent_global), &global[j]);
            continue;
        }
        let Some(c) = only_child(j) else {
            global[j] = parent_global;
            continue;
        };
        let hinge = HINGES.iter().find(|h| h.0 == c).copied();
        match (mode, hinge) {
            (IkMode::Hinge, Some(h)) => match hinge_pair(p, j, h, &parent_global) {
                Some((parent, knee)) => {
                    local[j] = parent;
                    local[c] = knee;
                    hinge_done[c] = true;
                }
                None => {
                    fallbacks += 1;
                    local[j] = swing_rotation(p, j, c, &parent_global);
                }
            },
            _ => local[j] = swing_rotation(p, j, c, &parent_global),
        }
        global[j] = matmul(&parent_global, &local[j]);
    }
    (local, fallbacks)
}

/// Local rotations (frames × 24) of joint positions (frames × 24), and the number of hinge limbs
/// that fell back to `swing` (0 in `swing` mode).
pub fn inverse_kinematics(joints: &[[f64; 3]], mode: IkMode) -> (Vec<Mat3>, usize) {
    assert!(
        joints.len().is_multiple_of(NUM_JOINTS),
        "joints must be frames × 24"
    );
    let mut out = Vec::with_capacity(joints.len());
    let mut fallbacks = 0;
    for p in joints.chunks_exact(NUM_JOINTS) {
        let (r, f) = frame_rotations(p, mode);
        out.extend_from_slice(&r);
        fallbacks += f;
    }
    (out, fallbacks)
}

/// An AIST++ motion (axis-angle poses, translation, scaling 1) whose FK under `root` reproduces
/// `joints` (frames × 24) up to bone lengths.
pub fn motion_from_joints(joints: &[[f64; 3]], mode: IkMode, root: FkRoot) -> Motion {
    let (rotations, _) = inverse_kinematics(joints, mode);
    let shift = match root {
        FkRoot::Smpl => SMPL_MALE_PELVIS,
        FkRoot::Edge => [0.0; 3],
    };
    let poses = rotations.iter().flat_map(matrix_to_axis_angle).collect();
    let trans = joints
        .chunks_exact(NUM_JOINTS)
        .flat_map(|p| sub(p[0], shift))
        .collect();
    Motion::new(poses, trans, 1.0).expect("whole frames of finite values")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fk::forward_kinematics;
    use crate::rotation::determinant;
    use qean_io::testdata::shared_dir;

    fn sample() -> Motion {
        Motion::read_pkl(&shared_dir().join("aistpp/motions/softcat477_SMPL-to-FBX_sample.pkl"))
            .unwrap()
    }

    fn worst(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| norm(sub(*x, *y)))
            .fold(0.0, f64::max)
    }

    /// SPEC §11.3/§11.13.3: FK(IK(FK(θ))) = FK(θ) to 1e-9 m on the sample, both modes; every
    /// rotation orthonormal with det +1; hinge knees pure x and elbows pure y except on fallbacks.
    #[test]
    fn fk_of_ik_reproduces_the_sample_in_both_modes() {
        let m = sample();
        let joints = m.joints(FkRoot::Smpl);
        for mode in [IkMode::Swing, IkMode::Hinge] {
            let back = motion_from_joints(&joints, mode, FkRoot::Smpl);
            let err = worst(&back.joints(FkRoot::Smpl), &joints);
            let (rots, fallbacks) = inverse_kinematics(&joints, mode);
            println!("{mode:?}: worst joint error {err:.2e} m, {fallbacks} fallbacks");
            assert!(err <= 1e-9, "{mode:?}: {err}");
            let fk = forward_kinematics(&m.root_positions(), &rots, FkRoot::Smpl);
            assert!(worst(&fk, &joints) <= 1e-9);
            for r in &rots {
                let rrt = matmul(r, &transpose(r));
                for (i, x) in rrt.iter().enumerate() {
                    let want = if i % 4 == 0 { 1.0 } else { 0.0 };
                    assert!((x - want).abs() < 1e-9);
                }
                assert!((determinant(r) - 1.0).abs() < 1e-9);
            }
            if mode == IkMode::Hinge {
                assert!(fallbacks * 10 < m.frames * 4, "{fallbacks}");
                // Every hinge is a pure rotation about its axis, except on fallback limbs, which
                // are nearly straight (bend < 15°).
                let mut pure = 0;
                for (f, p) in rots
                    .chunks_exact(NUM_JOINTS)
                    .zip(joints.chunks_exact(NUM_JOINTS))
                {
                    for &(k, c, axis, _) in &HINGES {
                        let rv = matrix_to_axis_angle(&f[k]);
                        let off: f64 = (0..3).filter(|&i| i != axis).map(|i| rv[i].abs()).sum();
                        if off < 1e-9 {
                            pure += 1;
                            continue;
                        }
                        let upper = sub(p[k], p[PARENTS[k] as usize]);
                        let lower = sub(p[c], p[k]);
                        let bend = (dot(upper, lower)
                            / (dot(upper, upper) * dot(lower, lower)).sqrt())
                        .clamp(-1.0, 1.0)
                        .acos()
                        .to_degrees();
                        assert!(bend < 15.0, "fallback limb {k} bent {bend:.1}°");
                    }
                }
                assert_eq!(pure + fallbacks, m.frames * 4);
            }
        }
    }

    #[test]
    fn swing_between_handles_parallel_and_opposite() {
        let a = [0.0, 1.0, 0.0];
        assert_eq!(swing_between(a, a), IDENTITY);
        let r = swing_between(a, [0.0, -1.0, 0.0]);
        let v = mat_vec(&r, a);
        assert!((v[1] + 1.0).abs() < 1e-12);
        let b = unit([1.0, 1.0, 0.3]).unwrap();
        let v = mat_vec(&swing_between(a, b), a);
        assert!(worst(&[v], &[b]) < 1e-12);
    }
}
