//! Pickles and .npy files written by numpy 1.x and 2.x themselves (tools/make_pickle_fixtures.py): every
//! protocol 2–5, f32/f64, (N,72) and (N,24,3), Fortran order, big-endian, a list-valued scaling.

use std::path::PathBuf;

use qean_io::npy;
use qean_motion::Motion;

fn dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/pickle")
}

fn expected() -> (Vec<f64>, Vec<f64>, usize) {
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir().join("expected.json")).unwrap())
            .unwrap();
    let f = |k: &str| {
        v[k].as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect::<Vec<_>>()
    };
    (
        f("poses"),
        f("trans"),
        v["frames"].as_u64().unwrap() as usize,
    )
}

#[test]
fn numpy_pickles_of_every_protocol() {
    let (poses, trans, n) = expected();
    let mut seen = 0;
    for entry in std::fs::read_dir(dir()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("pkl") {
            continue;
        }
        seen += 1;
        let m = Motion::read_pkl(&path).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(m.frames, n, "{path:?}");
        assert_eq!(m.scaling, 2.0, "{path:?}");
        let name = path.file_name().unwrap().to_str().unwrap();
        let tol = if name.contains("f32") { 1e-6 } else { 0.0 };
        for (a, b) in m.poses.iter().zip(&poses) {
            assert!(
                (a - b).abs() <= tol * b.abs().max(1.0),
                "{name}: {a} vs {b}"
            );
        }
        for (a, b) in m.trans.iter().zip(&trans) {
            assert!(
                (a - b).abs() <= tol * b.abs().max(1.0),
                "{name}: {a} vs {b}"
            );
        }
    }
    assert_eq!(seen, 14, "7 cases × numpy 1 and 2");
}

#[test]
fn numpy_npy_files() {
    let (poses, _, n) = expected();
    let mut seen = 0;
    for entry in std::fs::read_dir(dir()).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().and_then(|e| e.to_str()) != Some("npy") {
            continue;
        }
        seen += 1;
        let a = npy::read(&path).unwrap();
        assert_eq!(a.shape, vec![n, 72]);
        let tol = if path.to_str().unwrap().contains("f32") {
            1e-6
        } else {
            0.0
        };
        for (x, y) in a.data.iter().zip(&poses) {
            assert!((x - y).abs() <= tol * y.abs().max(1.0), "{path:?}");
        }
    }
    assert_eq!(seen, 6);
}
