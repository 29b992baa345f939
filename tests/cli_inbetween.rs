//! `qean eval --task inbetween` (SPEC §12.5–12.6) on a small synthetic dataset: every default row at two key
//! counts, Lin's table beside ours, the ordering checks logged, and bad requests refused.

use std::process::Command;

mod common;
use common::*;

#[test]
fn benchmark_table_on_a_synthetic_dataset() {
    let dir = tempfile::tempdir().unwrap();
    let data = dataset(dir.path());
    let out = dir.path().join("ib");
    let mut c = qean();
    c.args([
        "eval",
        "--task",
        "inbetween",
        "--keys",
        "3,9",
        "--set",
        "keyframes.stem_source=hpss",
        "--data",
    ])
    .arg(&data)
    .arg("--out")
    .arg(&out);
    let printed = run_ok(&mut c);
    assert!(printed.contains("Lin's published numbers"), "{printed}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let rows = report["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 14, "7 rows × 2 key counts");
    for r in rows {
        for k in ["mse", "fid_k", "fid_g", "dist_k", "dist_g"] {
            assert!(r[k].as_f64().unwrap().is_finite(), "{r}");
        }
        assert!(r["mse"].as_f64().unwrap() >= 0.0);
    }
    let get = |s: &str, m: &str, n: u64, k: &str| {
        rows.iter()
            .find(|r| r["strategy"] == s && r["method"] == m && r["n"] == n)
            .unwrap()[k]
            .as_f64()
            .unwrap()
    };
    // More keys, closer to the dance (Lin's metric check, here for MSE with even keys).
    assert!(get("even", "linear", 9, "mse") < get("even", "linear", 3, "mse"));
    // Fitting each dance's own curves never loses to the straight line on the same keys, in MSE per span…
    // and the DP keys are chosen for straight lines: DP + linear beats even + linear at 3 keys.
    assert!(get("dp", "linear", 3, "mse") < get("even", "linear", 3, "mse"));
    let checks = report["checks"].as_array().unwrap();
    assert!(checks
        .iter()
        .any(|c| c.as_str().unwrap().starts_with("(i) even")));
    assert!(checks
        .iter()
        .any(|c| c.as_str().unwrap().starts_with("(ii)")));
    let md = std::fs::read_to_string(out.join("report.md")).unwrap();
    assert!(md.contains("| even / linear+SLERP |") && md.contains("Runtime:"));
    bezier_training_means_drive_edits(dir.path(), &out);
}

/// The benchmark's Bézier training means (one file per N) are what `qean edit --method bezier --theta`
/// draws with (SPEC §12.7 "bezier uses the trained mean θ").
fn bezier_training_means_drive_edits(dir: &std::path::Path, bench: &std::path::Path) {
    for n in [3, 9] {
        let f: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(bench.join(format!("bezier_even_N{n}.json"))).unwrap(),
        )
        .unwrap();
        assert_eq!(f["format"], "qean-bezier-theta");
        assert_eq!(f["n"], n);
        assert_eq!(f["theta"].as_array().unwrap().len(), 75);
        assert!(f["sequences"].as_u64().unwrap() > 0);
    }
    let theta = bench.join("bezier_even_N3.json");
    let excerpt = shared().join("aistpp/motions/softcat477_sample_with_scaling.pkl");
    let edits = dir.join("edits.json");
    std::fs::write(&edits, r#"{"regenerate": [[10, 110]], "keep": "grid:3"}"#).unwrap();
    let edit = |out: &str, extra: &[&str]| {
        let mut c = qean();
        c.arg("edit")
            .arg("--motion")
            .arg(&excerpt)
            .arg("--edits")
            .arg(&edits)
            .args(["--bpm", "120", "--out"])
            .arg(dir.join(out))
            .args(extra);
        c
    };
    let t = theta.to_str().unwrap();
    let own = dir.join("own.pkl");
    run_ok(&mut edit("own.pkl", &["--method", "bezier"]));
    run_ok(&mut edit("mean.pkl", &["--method", "bezier", "--theta", t]));
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("mean.report.json")).unwrap())
            .unwrap();
    let source = report["theta_source"].as_str().unwrap();
    assert!(
        source.starts_with("training mean of") && source.contains("N = 3"),
        "{source}"
    );
    let (a, b) = (
        qean_motion::Motion::read_pkl(&own).unwrap(),
        qean_motion::Motion::read_pkl(&dir.join("mean.pkl")).unwrap(),
    );
    let input = qean_motion::Motion::read_pkl(&excerpt).unwrap();
    assert_ne!(
        a.poses[50 * 72..51 * 72],
        b.poses[50 * 72..51 * 72],
        "another θ, another curve"
    );
    assert_eq!(b.poses[..10 * 72], input.poses[..10 * 72]);
    assert_eq!(b.poses[111 * 72..], input.poses[111 * 72..]);
    // A mean fitted under other settings, or with another method: one line, nothing written.
    assert_clean_failure(
        &mut edit(
            "chord.pkl",
            &[
                "--method",
                "bezier",
                "--theta",
                t,
                "--set",
                "inbetween.bezier_param=chord",
            ],
        ),
        "bezier_param = handles",
    );
    assert_clean_failure(
        &mut edit("slerp.pkl", &["--method", "slerp", "--theta", t]),
        "--method bezier",
    );
    let broken = dir.join("broken.json");
    std::fs::write(&broken, r#"{"format": "qean-bezier-theta"}"#).unwrap();
    assert_clean_failure(
        &mut edit(
            "broken.pkl",
            &["--method", "bezier", "--theta", broken.to_str().unwrap()],
        ),
        "broken.json",
    );
    for gone in ["chord.pkl", "slerp.pkl", "broken.pkl"] {
        assert!(!dir.join(gone).exists(), "{gone}");
    }
}

#[test]
fn bad_benchmark_requests_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let ib = |args: &[&str]| {
        let mut c: Command = qean();
        c.args(["eval", "--task", "inbetween"]).args(args);
        c
    };
    let out = dir.path().join("out");
    let out_s = out.to_str().unwrap();
    assert_clean_failure(&mut ib(&["--out", out_s]), "--data");
    let missing = dir.path().join("nodata");
    assert_clean_failure(
        &mut ib(&["--out", out_s, "--data", missing.to_str().unwrap()]),
        "nodata",
    );
    assert_clean_failure(
        &mut ib(&[
            "--out",
            out_s,
            "--data",
            missing.to_str().unwrap(),
            "--strategies",
            "spiral",
        ]),
        "spiral",
    );
    assert_clean_failure(
        &mut ib(&[
            "--out",
            out_s,
            "--data",
            missing.to_str().unwrap(),
            "--methods",
            "cubic",
        ]),
        "cubic",
    );
    assert_clean_failure(
        &mut ib(&[
            "--out",
            out_s,
            "--data",
            missing.to_str().unwrap(),
            "--set",
            "inbetween.mse_space=quats",
        ]),
        "mse_space",
    );
    assert_clean_failure(
        &mut ib(&[
            "--out",
            out_s,
            "--data",
            missing.to_str().unwrap(),
            "--set",
            "inbetween.fid_reference=nowhere",
        ]),
        "fid_reference",
    );
    assert!(!out.exists());
}

#[test]
fn inspect_prints_the_in_betweeners_parameter_counts() {
    let want = [
        ("motion", "30,485,313", "111,009"),
        ("genre", "30,492,513", "111,585"),
        ("cross_full", "70,877,601", "227,553"),
        ("cross_drum", "70,877,601", "227,553"),
        ("merged_full", "61,268,001", "198,497"),
        ("merged_drum", "61,268,001", "198,497"),
    ];
    for (variant, paper, tiny) in want {
        for (size, count) in [("paper", paper), ("tiny", tiny)] {
            let path = configs().join(format!("inbetween/{size}_{variant}.toml"));
            let out = run_ok(qean().arg("inspect").arg(&path));
            assert!(
                out.contains(&format!("parameter count: {count}\n")),
                "{size} {variant}: {out}"
            );
            assert!(
                out.contains(&format!("closed form (§12.4c): {count}")),
                "{out}"
            );
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    // The [inbetween] table is checked like any other.
    let bad = dir.path().join("bad.toml");
    std::fs::write(
        &bad,
        "[model]\narch = \"inbetween\"\n[inbetween]\nheads = 7\nhidden = 64\n",
    )
    .unwrap();
    assert_clean_failure(qean().arg("inspect").arg(&bad), "must divide");
    std::fs::write(&bad, "[inbetween]\nvariant = \"genre\"\n").unwrap();
    let mut c = qean();
    c.args(["train", "--config"])
        .arg(&bad)
        .arg("--data")
        .arg(dir.path())
        .arg("--run-dir")
        .arg(&run);
    assert_clean_failure(&mut c, "[inbetween] table is for");
    std::fs::write(
        &bad,
        "[model]\narch = \"inbetween\"\n[inbetween]\nvariant = \"tango\"\n",
    )
    .unwrap();
    assert_clean_failure(qean().arg("inspect").arg(&bad), "tango");
}

/// Tiny motion in-betweener on a synthetic dataset: a few steps, exact resume, and a genre run.
#[test]
fn tiny_in_betweeners_train_and_resume_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let data = dataset(dir.path());
    let train = |variant: &str, run: &std::path::Path, steps: u64, resume: bool| {
        let mut c = qean();
        c.arg("train").arg("--plain");
        if resume {
            c.arg("--resume").arg(run);
        } else {
            c.arg("--config")
                .arg(configs().join(format!("inbetween/tiny_{variant}.toml")))
                .arg("--data")
                .arg(&data)
                .arg("--run-dir")
                .arg(run);
        }
        for s in [
            format!("train.steps={steps}"),
            "train.batch_size=4".into(),
            "train.checkpoint_every=3".into(),
            "train.val_every=3".into(),
            "inbetween.hidden=16".into(),
            "inbetween.heads=2".into(),
            "inbetween.ffn=32".into(),
            "inbetween.layers=1".into(),
            "inbetween.audio_layers=1".into(),
        ] {
            c.arg("--set").arg(s);
        }
        run_ok(&mut c)
    };
    let straight = dir.path().join("straight");
    train("motion", &straight, 6, false);
    let split = dir.path().join("split");
    train("motion", &split, 3, false);
    train("motion", &split, 6, true);
    let last = |r: &std::path::Path| checkpoints(r).last().unwrap().clone();
    assert_eq!(params_hash(&last(&straight)), params_hash(&last(&split)));
    let losses = losses(&straight);
    assert!(!losses.is_empty());
    for variant in ["genre", "cross_full", "merged_full"] {
        let run = dir.path().join(variant);
        train(variant, &run, 2, false);
        assert!(!checkpoints(&run).is_empty(), "{variant}");
        // Music variants standardise the 22 music columns with statistics fitted once on the training split.
        let config =
            std::fs::read_to_string(checkpoints(&run).last().unwrap().join("config.toml")).unwrap();
        assert_eq!(
            !config.contains("music_mean = []"),
            variant != "genre",
            "{variant}"
        );
    }
    // The trained model at work: an edit (frames outside the range untouched) and a benchmark row.
    let motion_path = std::fs::read_dir(data.join("motions"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let input = qean_motion::Motion::read_pkl(&motion_path).unwrap();
    let edits = dir.path().join("edits.json");
    std::fs::write(&edits, r#"{"regenerate": [[20, 150]], "keep": "grid:5"}"#).unwrap();
    let out = dir.path().join("edited.pkl");
    let mut c = qean();
    c.args(["edit", "--method", "transformer", "--motion"])
        .arg(&motion_path)
        .arg("--edits")
        .arg(&edits)
        .arg("--run")
        .arg(&straight)
        .arg("--out")
        .arg(&out);
    run_ok(&mut c);
    let edited = qean_motion::Motion::read_pkl(&out).unwrap();
    for t in (0..20).chain(151..input.frames) {
        assert_eq!(
            edited.poses[t * 72..(t + 1) * 72],
            input.poses[t * 72..(t + 1) * 72],
            "frame {t}"
        );
    }
    assert_ne!(
        edited.poses[60 * 72 + 3..60 * 72 + 9],
        input.poses[60 * 72 + 3..60 * 72 + 9]
    );
    let report = std::fs::read_to_string(out.with_extension("report.json")).unwrap();
    assert!(report.contains("params_hash"), "{report}");
    let ib = dir.path().join("ib");
    let mut c = qean();
    c.args([
        "eval",
        "--task",
        "inbetween",
        "--keys",
        "5",
        "--strategies",
        "even",
        "--methods",
        "linear",
        "--data",
    ])
    .arg(&data)
    .arg("--inbetweeners")
    .arg(&straight)
    .arg("--out")
    .arg(&ib);
    let md = run_ok(&mut c);
    assert!(md.contains("| even / motion ("), "{md}");
    // The drums variants read the drums stem: a stems file per music ID (default), or HPSS.
    let mut c = qean();
    c.args(["train", "--config"])
        .arg(configs().join("inbetween/tiny_cross_drum.toml"))
        .arg("--data")
        .arg(&data)
        .arg("--run-dir")
        .arg(dir.path().join("drum"));
    assert_clean_failure(&mut c, "drums.wav: drums stem missing");
    assert!(!dir.path().join("drum").exists());
    let mut c = qean();
    c.args(["train", "--plain", "--config"])
        .arg(configs().join("inbetween/tiny_merged_drum.toml"))
        .arg("--data")
        .arg(&data)
        .arg("--run-dir")
        .arg(dir.path().join("drum_hpss"));
    for s in [
        "train.steps=2",
        "train.batch_size=4",
        "inbetween.drums=hpss",
        "inbetween.hidden=16",
        "inbetween.heads=2",
        "inbetween.ffn=32",
        "inbetween.layers=1",
        "inbetween.audio_layers=1",
    ] {
        c.arg("--set").arg(s);
    }
    run_ok(&mut c);
    assert!(!checkpoints(&dir.path().join("drum_hpss")).is_empty());
}
