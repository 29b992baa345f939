//! End-to-end tests of the data commands through the real binary.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::*;

#[test]
fn inspect_softcat_reports_127_frames() {
    let out = qean()
        .arg("inspect")
        .arg(shared().join("aistpp/motions/softcat477_SMPL-to-FBX_sample.pkl"))
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("frames: 127"), "{text}");
    assert!(text.contains("smpl_poses: f8 [127, 72]"), "{text}");
}

#[test]
fn synth_then_inspect_and_joints() {
    let tmp = tempfile::tempdir().unwrap();
    let ds = tmp.path().join("ds");
    let st = qean()
        .args([
            "synth",
            "--sequences",
            "9",
            "--seconds",
            "4",
            "--seed",
            "3",
            "--sample-rate",
            "8000",
            "--out",
        ])
        .arg(&ds)
        .status()
        .unwrap();
    assert!(st.success());
    let out = qean().arg("inspect").arg(&ds).output().unwrap();
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("motion files (not ignored): 9"), "{text}");
    assert!(text.contains("test : 1 sequences"), "{text}");

    let first = std::fs::read_dir(ds.join("motions"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let j = tmp.path().join("j.npy");
    let st = qean()
        .arg("joints")
        .arg(&first)
        .arg("--out")
        .arg(&j)
        .status()
        .unwrap();
    assert!(st.success());
    let arr = qean_io::npy::read(&j).unwrap();
    assert_eq!(arr.shape[1..], [24, 3]);
    assert!(arr.shape[0] >= 200);

    // A second synth into the same place is refused and changes nothing.
    let before = listing(tmp.path());
    assert_clean_failure(qean().args(["synth", "--out"]).arg(&ds), "not empty");
    assert_eq!(before, listing(tmp.path()));
}

/// Python's pickle.load + numpy reads our files (needs python3 with numpy; CI sets QEAN_REQUIRE_PYTHON=1).
#[test]
fn synth_pickles_load_in_python() {
    if !python_has("numpy") {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let ds = tmp.path().join("ds");
    assert!(qean()
        .args([
            "synth",
            "--sequences",
            "3",
            "--seconds",
            "2",
            "--sample-rate",
            "8000",
            "--out"
        ])
        .arg(&ds)
        .status()
        .unwrap()
        .success());
    let script = r#"
import pickle, sys, glob, numpy as np
files = sorted(glob.glob(sys.argv[1] + "/motions/*.pkl"))
assert len(files) == 3, files
for f in files:
    d = pickle.load(open(f, "rb"))
    p, t, s = d["smpl_poses"], d["smpl_trans"], d["smpl_scaling"]
    assert isinstance(p, np.ndarray) and p.ndim == 2 and p.shape[1] == 72, p.shape
    assert t.shape == (p.shape[0], 3), t.shape
    assert s.shape == (1,), s.shape
    assert np.isfinite(p).all() and np.isfinite(t).all()
print("ok", len(files))
"#;
    let out = Command::new("python3")
        .args(["-c", script])
        .arg(&ds)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "python failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(String::from_utf8_lossy(&out.stdout).trim(), "ok 3");
}

#[test]
fn bad_inputs_fail_cleanly() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let good =
        std::fs::read(shared().join("aistpp/motions/softcat477_sample_with_scaling.pkl")).unwrap();

    let truncated = dir.join("truncated.pkl");
    std::fs::write(&truncated, &good[..good.len() / 2]).unwrap();
    let empty = dir.join("empty.pkl");
    std::fs::write(&empty, b"").unwrap();
    let garbage = dir.join("garbage.pkl");
    std::fs::write(&garbage, b"this is not a pickle at all").unwrap();

    let motion = qean_motion::Motion::read_pkl(
        &shared().join("aistpp/motions/softcat477_sample_with_scaling.pkl"),
    )
    .unwrap();
    let n = motion.frames;
    let write = |name: &str, items: &[(&str, &[usize], qean_io::pickle::ArrayRef)]| {
        let p = dir.join(name);
        std::fs::write(&p, qean_io::pickle::dumps_dict(items, &[])).unwrap();
        p
    };
    use qean_io::pickle::ArrayRef::F64;
    let missing = write(
        "missing.pkl",
        &[("smpl_poses", &[n, 72], F64(&motion.poses))],
    );
    let wrong_shape = write(
        "shape.pkl",
        &[
            ("smpl_poses", &[n * 2, 36], F64(&motion.poses)),
            ("smpl_trans", &[n, 3], F64(&motion.trans)),
        ],
    );
    let mut nan_poses = motion.poses.clone();
    nan_poses[100] = f64::NAN;
    let nan = write(
        "nan.pkl",
        &[
            ("smpl_poses", &[n, 72], F64(&nan_poses)),
            ("smpl_trans", &[n, 3], F64(&motion.trans)),
        ],
    );

    let out_npy = dir.join("out.npy");
    let cases: Vec<(PathBuf, &str)> = vec![
        (truncated, "truncated"),
        (empty, "empty file"),
        (garbage, "not a readable pickle"),
        (missing, "missing key 'smpl_trans'"),
        (wrong_shape, "expected (N, 72)"),
        (nan, "non-finite"),
        (dir.join("nope.pkl"), "no such file"),
    ];
    for (path, needle) in &cases {
        let before = listing(dir);
        let err = assert_clean_failure(
            qean().arg("joints").arg(path).arg("--out").arg(&out_npy),
            needle,
        );
        assert!(
            err.contains(path.file_name().unwrap().to_str().unwrap()),
            "{err}"
        );
        assert_eq!(before, listing(dir), "files changed for {path:?}");
        assert_clean_failure(qean().arg("inspect").arg(path), needle);
    }

    // Dataset directories.
    assert_clean_failure(
        qean().arg("inspect").arg(dir.join("nodir/")),
        "no such file",
    );
    let ds = dir.join("ds");
    std::fs::create_dir_all(ds.join("motions")).unwrap();
    std::fs::create_dir_all(ds.join("splits")).unwrap();
    std::fs::write(ds.join("splits/crossmodal_val.txt"), "").unwrap();
    assert_clean_failure(
        qean().arg("inspect").arg(&ds),
        "crossmodal_val.txt: split file is empty",
    );

    // An output directory that does not exist.
    let good_path = shared().join("aistpp/motions/softcat477_sample_with_scaling.pkl");
    assert_clean_failure(
        qean()
            .arg("joints")
            .arg(&good_path)
            .arg("--out")
            .arg(dir.join("no/such/dir/j.npy")),
        "does not exist",
    );
}

/// An independent BVH reader (the `bvh` package from PyPI) parses our export with the right joints and frames.
#[test]
fn bvh_export_parses_in_python() {
    if !python_has("bvh") {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("m.bvh");
    let st = qean()
        .arg("convert")
        .arg(shared().join("aistpp/motions/softcat477_SMPL-to-FBX_sample.pkl"))
        .arg("--out")
        .arg(&out)
        .status()
        .unwrap();
    assert!(st.success());
    let script = r#"
import sys
from bvh import Bvh
m = Bvh(open(sys.argv[1]).read())
names = m.get_joints_names()
assert len(names) == 24, names
assert names[0] == "pelvis" and "left_wrist" in names, names
assert m.nframes == 127, m.nframes
assert abs(m.frame_time - 1/60) < 1e-6, m.frame_time
assert m.joint_channels("pelvis")[:3] == ["Xposition", "Yposition", "Zposition"]
v = m.frame_joint_channel(126, "left_elbow", "Yrotation")
print("ok", len(names), m.nframes)
"#;
    let o = Command::new("python3")
        .args(["-c", script])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "python failed: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert_eq!(String::from_utf8_lossy(&o.stdout).trim(), "ok 24 127");
}

/// `qean eval` reads AIST++ pickles (forward kinematics) and prints the table.
#[test]
fn eval_on_synthetic_pickles() {
    let tmp = tempfile::tempdir().unwrap();
    let ds = tmp.path().join("ds");
    assert!(qean()
        .args([
            "synth",
            "--sequences",
            "12",
            "--seconds",
            "5",
            "--sample-rate",
            "8000",
            "--out"
        ])
        .arg(&ds)
        .status()
        .unwrap()
        .success());
    let gen = tmp.path().join("gen");
    std::fs::create_dir(&gen).unwrap();
    for e in std::fs::read_dir(ds.join("motions")).unwrap().take(4) {
        let p = e.unwrap().path();
        std::fs::copy(&p, gen.join(p.file_name().unwrap())).unwrap();
    }
    let json = tmp.path().join("report.json");
    let out = qean()
        .args(["eval", "--seed-frames", "0", "--generated"])
        .arg(&gen)
        .arg("--reference")
        .arg(ds.join("motions"))
        .arg("--json")
        .arg(&json)
        .arg("--music")
        .arg(ds.join("wav"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(table.contains("FID_k"), "{table}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let r = &v["reports"][0];
    assert_eq!(r["n_generated"], 4);
    assert_eq!(r["n_reference"], 12);
    assert!(r["fid_k"].as_f64().unwrap().is_finite());
    // Beats tracked from the synthetic music; the synthetic dances are beat-locked.
    let ba = r["beat_align"]
        .as_f64()
        .unwrap_or_else(|| panic!("no BeatAlign: {}", r["excluded"]));
    assert!(ba > 0.0 && ba <= 1.0, "{ba}");
}

/// `qean features --dataset` caches every music ID once; the synthetic music's tracked beats follow its tempo.
#[test]
fn features_of_a_synthetic_dataset() {
    let tmp = tempfile::tempdir().unwrap();
    let ds = tmp.path().join("ds");
    assert!(qean()
        .args([
            "synth",
            "--sequences",
            "6",
            "--seconds",
            "8",
            "--seed",
            "4",
            "--out"
        ])
        .arg(&ds)
        .status()
        .unwrap()
        .success());
    let run = || {
        let o = qean()
            .args(["features", "--dataset"])
            .arg(&ds)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).to_string()
    };
    assert!(run().contains("0 already cached"));
    assert!(run().contains(" 0 computed"));
    let d = qean_aistpp::dataset::Dataset::open(&ds).unwrap();
    let mut checked = 0;
    for id in ["mBR0", "mHO5"] {
        if d.music_ids(&d.all_sequences().unwrap())
            .contains(&id.to_string())
        {
            let (f, frames) = qean_aistpp::feature_cache::load(&d, id).unwrap();
            let beats: Vec<usize> = (0..frames).filter(|&t| f[t * 35 + 34] > 0.5).collect();
            let bpm = qean_aistpp::names::tempo_prior(id).unwrap();
            let period = 3600.0 / bpm;
            let gaps: Vec<f64> = beats.windows(2).map(|w| (w[1] - w[0]) as f64).collect();
            let mean = gaps.iter().sum::<f64>() / gaps.len() as f64;
            // The tracker's tempo grid is 3600/k frames; allow one frame.
            assert!(
                (mean - period).abs() <= 1.5,
                "{id}: mean beat gap {mean}, expected {period}"
            );
            checked += 1;
        }
    }
    assert!(checked > 0);
}

/// `qean inspect configs/fact.toml`: mint's FACT has exactly 120,406,977 parameters.
#[test]
fn inspect_fact_config_counts_parameters() {
    let cfg = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/fact.toml");
    let out = qean().arg("inspect").arg(&cfg).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("parameter count: 120,406,977"), "{text}");
    // SPEC §11.6: the TSMT presets.
    for (preset, want) in [("paper", "1,419,388"), ("tiny", "37,524")] {
        let cfg = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("configs/tsmt/{preset}.toml"));
        let out = qean().arg("inspect").arg(&cfg).output().unwrap();
        let text = String::from_utf8_lossy(&out.stdout);
        assert!(
            text.contains(&format!("parameter count: {want}\n")),
            "{text}"
        );
    }
    // An unknown key is an error naming the file and the key.
    let tmp = tempfile::tempdir().unwrap();
    let bad = tmp.path().join("bad.toml");
    std::fs::write(&bad, "[model]\narch = \"fact\"\nhidden_sise = 64\n").unwrap();
    assert_clean_failure(qean().arg("inspect").arg(&bad), "hidden_sise");
}
