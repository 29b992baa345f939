//! Shared test helpers: the SMPL rest pose from the project's skeleton file and synthetic motions.
#![allow(dead_code)]

use std::path::PathBuf;

use qean_eval::{Frame, Sequence, N_JOINTS};

/// SMPL-male rest pelvis J0 (SPEC §3.3).
pub const J0: [f64; 3] = [-0.00217368, -0.24078917, 0.02858379];

/// `shared/` beside the repository root (CI clones with shared/ beside it; worktrees use /work/shared).
pub fn shared_dir() -> PathBuf {
    if let Ok(d) = std::env::var("QEAN_SHARED_DIR") {
        return PathBuf::from(d);
    }
    let beside = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared");
    if beside.exists() {
        beside
    } else {
        PathBuf::from("/work/shared")
    }
}

/// Rest joints: J0 plus the cumulative offsets of `skeleton/smpl_skeleton_edge.json` (identity
/// rotations, so p_i = p_parent + o_i).
pub fn rest_pose() -> Frame {
    let path = shared_dir().join("data/skeleton/smpl_skeleton_edge.json");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    let parents: Vec<i64> = serde_json::from_value(v["parents"].clone()).unwrap();
    let offsets: Vec<[f64; 3]> = serde_json::from_value(v["offsets"].clone()).unwrap();
    let mut f = [[0.0; 3]; N_JOINTS];
    for i in 0..N_JOINTS {
        let base = if parents[i] < 0 {
            J0
        } else {
            f[parents[i] as usize]
        };
        for a in 0..3 {
            f[i][a] = base[a] + offsets[i][a];
        }
    }
    f
}

/// A smooth pseudo-random dance: rest pose plus per-joint sinusoids and a root drift.
pub fn synthetic_motion(seed: u64, frames: usize) -> Vec<Frame> {
    let rest = rest_pose();
    let r = |k: u64| {
        ((seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(k.wrapping_mul(1442695040888963407)))
            >> 33) as f64
            / (1u64 << 31) as f64
    };
    (0..frames)
        .map(|t| {
            let t = t as f64 / 60.0;
            let mut f = rest;
            for (j, p) in f.iter_mut().enumerate() {
                for (a, x) in p.iter_mut().enumerate() {
                    let k = (j * 3 + a) as u64;
                    let amp = 0.02 + 0.15 * r(k);
                    let freq = 0.5 + 2.5 * r(k + 100);
                    let phase = std::f64::consts::TAU * r(k + 200);
                    *x += amp * (std::f64::consts::TAU * freq * t + phase).sin()
                        + 0.05 * t * r(300 + a as u64);
                }
            }
            f
        })
        .collect()
}

pub fn seq(name: &str, joints: Vec<Frame>) -> Sequence {
    Sequence::new(name, joints)
}

/// An AIST++-style name with music `m{genre}{k}`.
pub fn aist_name(genre: &str, k: usize, dancer: usize, ch: usize) -> String {
    format!("g{genre}_sBM_cAll_d{dancer:02}_m{genre}{k}_ch{ch:02}")
}
