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
