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
    // Training them is not built yet: one clear line, nothing written.
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("run");
    let mut c = qean();
    c.args(["train", "--config"])
        .arg(configs().join("inbetween/tiny_motion.toml"))
        .arg("--data")
        .arg(dir.path())
        .arg("--run-dir")
        .arg(&run);
    assert_clean_failure(&mut c, "not built yet");
    assert!(!run.exists());
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
