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

type Mat3 = [[f64; 3]; 3];

fn matmul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut c = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    c
}

/// Rodrigues (SPEC §3.1): R = I + sin θ K + (1 − cos θ) K².
fn rodrigues(r: [f64; 3]) -> Mat3 {
    let th = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    let (k, s, c) = if th < 1e-8 {
        (r, 1.0, 0.5) // I + [r]x + ½[r]x²
    } else {
        ([r[0] / th, r[1] / th, r[2] / th], th.sin(), 1.0 - th.cos())
    };
    let kx = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
    let kx2 = matmul(&kx, &kx);
    let mut m = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            m[i][j] = if i == j { 1.0 } else { 0.0 } + s * kx[i][j] + c * kx2[i][j];
        }
    }
    m
}

/// Joints of the real AIST++ excerpt (softcat477_sample.json) by SPEC §3.3 FK with the `smpl` root.
pub fn softcat_joints() -> Vec<Frame> {
    let read = |rel: &str| -> serde_json::Value {
        let p = shared_dir().join(rel);
        serde_json::from_str(
            &std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display())),
        )
        .unwrap()
    };
    let sample = read("data/aistpp/motions/softcat477_sample.json");
    let skel = read("data/skeleton/smpl_skeleton_edge.json");
    let poses: Vec<Vec<f64>> = serde_json::from_value(sample["smpl_poses"].clone()).unwrap();
    let trans: Vec<[f64; 3]> = serde_json::from_value(sample["smpl_trans"].clone()).unwrap();
    let scaling: Vec<f64> = serde_json::from_value(sample["smpl_scaling"].clone()).unwrap();
    let parents: Vec<i64> = serde_json::from_value(skel["parents"].clone()).unwrap();
    let offsets: Vec<[f64; 3]> = serde_json::from_value(skel["offsets"].clone()).unwrap();
    poses
        .iter()
        .zip(&trans)
        .map(|(pose, tr)| {
            let mut g = [[[0.0; 3]; 3]; N_JOINTS];
            let mut p = [[0.0; 3]; N_JOINTS];
            for i in 0..N_JOINTS {
                let r = rodrigues([pose[3 * i], pose[3 * i + 1], pose[3 * i + 2]]);
                if parents[i] < 0 {
                    g[i] = r;
                    for a in 0..3 {
                        p[i][a] = tr[a] / scaling[0] + J0[a];
                    }
                } else {
                    let q = parents[i] as usize;
                    g[i] = matmul(&g[q], &r);
                    for a in 0..3 {
                        p[i][a] = p[q][a] + (0..3).map(|b| g[q][a][b] * offsets[i][b]).sum::<f64>();
                    }
                }
            }
            p
        })
        .collect()
}
