//! FineDance's 6-D rotations and its 30 → 60 fps step against numpy and scipy (tools/make_finedance_fixtures.py).

use std::path::PathBuf;

use qean_motion::finedance::{rot6d_to_matrix, to_motion};
use qean_motion::rotation::axis_angle_to_matrix;

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/finedance")
}

fn rows(v: &serde_json::Value) -> Vec<Vec<f64>> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|r| {
            r.as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap())
                .collect()
        })
        .collect()
}

fn expected() -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir().join("expected.json")).unwrap()).unwrap()
}

#[test]
fn rot6d_equals_pytorch3d_in_numpy() {
    let v = expected();
    for (d, m) in rows(&v["d6"]).iter().zip(rows(&v["matrices"])) {
        let got = rot6d_to_matrix(&std::array::from_fn(|k| d[k])).unwrap();
        for (a, b) in got.iter().zip(&m) {
            assert!((a - b).abs() < 1e-12, "{got:?} vs {m:?}");
        }
    }
}

#[test]
fn sixty_fps_equals_scipy_slerp() {
    let v = expected();
    let a = qean_io::npy::read(&dir().join("motion.npy")).unwrap();
    let frames = v["frames"].as_u64().unwrap() as usize;
    let m = to_motion(&a.data, frames).unwrap();
    let poses = rows(&v["poses"]);
    let trans = rows(&v["trans"]);
    assert_eq!(m.frames, poses.len());
    for f in 0..m.frames {
        for j in 0..24 {
            let ours = axis_angle_to_matrix(std::array::from_fn(|k| m.poses[f * 72 + j * 3 + k]));
            let theirs = axis_angle_to_matrix(std::array::from_fn(|k| poses[f][j * 3 + k]));
            for (x, y) in ours.iter().zip(&theirs) {
                assert!((x - y).abs() < 1e-9, "frame {f} joint {j}");
            }
        }
        for (k, t) in trans[f].iter().enumerate() {
            assert!((m.trans[f * 3 + k] - t).abs() < 1e-12);
        }
    }
}
