//! Joint positions from any motion file we understand: an AIST++ pickle (forward kinematics), a `.npy` of joint
//! positions (frames, 24, 3), of model vectors (frames, 225 | 219) or of FineDance rows (frames, 315, read at
//! 60 fps), or a BVH of the SMPL skeleton.

use std::path::Path;

use crate::fk::FkRoot;
use crate::ik::IkMode;
use crate::motion::{Layout, Motion};
use crate::skeleton::NUM_JOINTS;
use qean_io::error::{Error, Result};

/// A motion from any motion file: rotations as they are (`crate::motion::read_motion`), joint positions (a
/// (frames, 24, 3) `.npy` or a BVH) solved by inverse kinematics, with the mean distance (metres) between the
/// given joints and those of the solved motion (bones at SMPL's lengths).
pub fn read_any(path: &Path, ik: IkMode, root: FkRoot) -> Result<(Motion, Option<f64>)> {
    let positions = match qean_io::fsutil::extension_lower(path).as_str() {
        "bvh" => true,
        "npy" => qean_io::npy::read(path)?.shape.len() == 3,
        _ => false,
    };
    if !positions {
        return Ok((crate::motion::read_motion(path)?, None));
    }
    let joints = load_joints(path, root)?;
    let motion = crate::ik::motion_from_joints(&joints, ik, root);
    let back = motion.joints(root);
    let mean = joints
        .iter()
        .zip(&back)
        .map(|(p, q)| (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt())
        .sum::<f64>()
        / joints.len().max(1) as f64;
    Ok((motion, Some(mean)))
}

/// Load joint positions (frames × 24, metres, +Y up) from `path`, choosing the reader by extension.
pub fn load_joints(path: &Path, root: FkRoot) -> Result<Vec<[f64; 3]>> {
    let ext = qean_io::fsutil::extension_lower(path);
    let joints = match ext.as_str() {
        "pkl" | "pickle" => Motion::read_pkl(path)?.joints(root),
        "npy" => {
            let a = qean_io::npy::read(path)?;
            match a.shape.as_slice() {
                [_, j, 3] if *j == NUM_JOINTS => a.data.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
                [_, d] if Layout::from_dim(*d).is_some() => {
                    let v: Vec<f32> = a.data.iter().map(|&x| x as f32).collect();
                    Motion::from_layout(&v, Layout::from_dim(*d).unwrap())
                        .map_err(|m| Error::at(path, m))?
                        .joints(root)
                }
                [frames, crate::finedance::WIDTH] => crate::finedance::to_motion(&a.data, *frames)
                    .map_err(|m| Error::at(path, m))?
                    .joints(root),
                other => {
                    return Err(Error::at(
                        path,
                        format!(
                            "array of shape {other:?} is not a motion (expected (frames, 24, 3) joints, (frames, 225|219) vectors or (frames, 315) FineDance rows)"
                        ),
                    ))
                }
            }
        }
        "bvh" => crate::bvh::read(path)?
            .smpl_positions()
            .ok_or_else(|| Error::at(path, "BVH skeleton is not the 24-joint SMPL skeleton"))?,
        _ => {
            return Err(Error::at(
                path,
                "unknown motion format (expected .pkl, .npy or .bvh)",
            ))
        }
    };
    check_joints(path, &joints)?;
    Ok(joints)
}

/// Joint positions read from `path` a motion can be made of: at least one frame, every value finite.
pub fn check_joints(path: &Path, joints: &[[f64; 3]]) -> Result<()> {
    if joints.is_empty() {
        return Err(Error::at(path, "the motion has no frames"));
    }
    if let Some(i) = joints.iter().position(|p| !p.iter().all(|x| x.is_finite())) {
        return Err(Error::at(
            path,
            format!("joint positions are not finite at frame {}", i / NUM_JOINTS),
        ));
    }
    Ok(())
}

/// Joint positions (frames × 24) as a flat float32 array, the layout of `.joints.npy` files.
pub fn joints_to_f32(joints: &[[f64; 3]]) -> Vec<f32> {
    joints.iter().flat_map(|p| p.map(|x| x as f32)).collect()
}

/// Write joint positions (frames × 24) as a (frames, 24, 3) float32 `.npy`, atomically.
pub fn write_joints(path: &Path, joints: &[[f64; 3]]) -> Result<()> {
    let j = NUM_JOINTS;
    qean_io::npy::write_f32(path, &[joints.len() / j, j, 3], &joints_to_f32(joints))
}
