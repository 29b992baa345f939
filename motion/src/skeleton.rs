//! The SMPL kinematic tree and rest-pose bone offsets (SPEC §3.3), enough for forward kinematics without the
//! licensed SMPL model file.
//!
//! Source: the `smpl_offsets`/`smpl_parents` tables of the EDGE repository's `vis.py` (MIT, Stanford-TML/EDGE),
//! which are the SMPL male template with betas = 0. Metres, +Y up, +Z forward, +X the subject's left.

/// Number of SMPL body joints.
pub const NUM_JOINTS: usize = 24;

/// SMPL joint names in index order.
pub const JOINT_NAMES: [&str; NUM_JOINTS] = [
    "pelvis",
    "left_hip",
    "right_hip",
    "spine1",
    "left_knee",
    "right_knee",
    "spine2",
    "left_ankle",
    "right_ankle",
    "spine3",
    "left_foot",
    "right_foot",
    "neck",
    "left_collar",
    "right_collar",
    "head",
    "left_shoulder",
    "right_shoulder",
    "left_elbow",
    "right_elbow",
    "left_wrist",
    "right_wrist",
    "left_hand",
    "right_hand",
];

/// Parent of each joint (−1 for the root).
pub const PARENTS: [i32; NUM_JOINTS] = [
    -1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21,
];

/// Rest offset of each joint from its parent (metres).
pub const OFFSETS: [[f64; 3]; NUM_JOINTS] = [
    [0.0, 0.0, 0.0],
    [0.05858135, -0.08228004, -0.01766408],
    [-0.06030973, -0.09051332, -0.01354254],
    [0.00443945, 0.12440352, -0.03838522],
    [0.04345142, -0.38646945, 0.008037],
    [-0.04325663, -0.38368791, -0.00484304],
    [0.00448844, 0.1379564, 0.02682033],
    [-0.01479032, -0.42687458, -0.037428],
    [0.01905555, -0.4200455, -0.03456167],
    [-0.00226458, 0.05603239, 0.00285505],
    [0.04105436, -0.06028581, 0.12204243],
    [-0.03483987, -0.06210566, 0.13032329],
    [-0.0133902, 0.21163553, -0.03346758],
    [0.07170245, 0.11399969, -0.01889817],
    [-0.08295366, 0.11247234, -0.02370739],
    [0.01011321, 0.08893734, 0.05040987],
    [0.12292141, 0.04520509, -0.019046],
    [-0.11322832, 0.04685326, -0.00847207],
    [0.2553319, -0.01564902, -0.02294649],
    [-0.26012748, -0.01436928, -0.03126873],
    [0.26570925, 0.01269811, -0.00737473],
    [-0.26910836, 0.00679372, -0.00602676],
    [0.08669055, -0.01063603, -0.01559429],
    [-0.0887537, -0.00865157, -0.01010708],
];

/// Rest-pose pelvis of the SMPL male template (SPEC §3.3): added to the translation by the `smpl` root
/// convention, which reproduces smplx `SMPL(gender=MALE)` joints.
pub const SMPL_MALE_PELVIS: [f64; 3] = [-0.00217368, -0.24078917, 0.02858379];

/// Rest-pose joint positions with the pelvis at `root`.
pub fn rest_joints(root: [f64; 3]) -> [[f64; 3]; NUM_JOINTS] {
    let mut p = [[0.0; 3]; NUM_JOINTS];
    p[0] = root;
    for j in 1..NUM_JOINTS {
        let par = PARENTS[j] as usize;
        for a in 0..3 {
            p[j][a] = p[par][a] + OFFSETS[j][a];
        }
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parents_precede_children() {
        for (j, &p) in PARENTS.iter().enumerate().skip(1) {
            assert!((p as usize) < j);
        }
    }

    #[test]
    fn offsets_match_shared_json() {
        let path = qean_io::testdata::shared_dir().join("skeleton/smpl_skeleton_edge.json");
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
        let offs = v["offsets"].as_array().unwrap();
        for j in 0..NUM_JOINTS {
            for a in 0..3 {
                assert_eq!(offs[j][a].as_f64().unwrap(), OFFSETS[j][a]);
            }
            assert_eq!(v["parents"][j].as_i64().unwrap(), PARENTS[j] as i64);
        }
    }

    #[test]
    fn identity_pose_left_shoulder() {
        let p = rest_joints(SMPL_MALE_PELVIS);
        let want = [0.19911, 0.23681, -0.01807];
        for a in 0..3 {
            assert!((p[16][a] - want[a]).abs() < 1e-5, "{:?}", p[16]);
        }
    }
}
