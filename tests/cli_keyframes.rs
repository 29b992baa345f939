//! `qean keyframes` (SPEC §12.2–12.3) on the shared AIST++ excerpt at 120 BPM, and its bad inputs.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::*;

fn excerpt() -> PathBuf {
    shared().join("aistpp/motions/softcat477_sample_with_scaling.pkl")
}

fn keyframes(json: &Path, args: &[&str]) -> Command {
    let mut c = qean();
    c.arg("keyframes")
        .arg("--motion")
        .arg(excerpt())
        .arg("--json")
        .arg(json)
        .args(args);
    c
}

fn read(json: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap()
}

fn frames(v: &serde_json::Value) -> Vec<u64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect()
}

#[test]
fn even_and_dp_keys_on_the_excerpt() {
    let dir = tempfile::tempdir().unwrap();
    let even3 = dir.path().join("even3.json");
    run_ok(&mut keyframes(
        &even3,
        &["--bpm", "120", "--strategy", "even", "--n", "3"],
    ));
    let v = read(&even3);
    assert_eq!(v["strategy"], "even");
    assert_eq!(v["n"], 3);
    assert_eq!(v["segments"], serde_json::json!([[0, 120], [120, 126]]));
    assert_eq!(&frames(&v["keyframes"])[..3], &[0, 60, 120]);
    assert_eq!(*frames(&v["keyframes"]).last().unwrap(), 126);

    let even5 = dir.path().join("even5.json");
    run_ok(&mut keyframes(
        &even5,
        &["--bpm", "120", "--strategy", "even", "--n", "5"],
    ));
    let dp5 = dir.path().join("dp5.json");
    let out = run_ok(&mut keyframes(
        &dp5,
        &["--bpm", "120", "--strategy", "dp", "--n", "5"],
    ));
    assert!(out.contains("at 120 BPM (--bpm)"), "{out}");
    let (e, d) = (read(&even5), read(&dp5));
    assert_eq!(&frames(&d["keyframes"])[..5], &[0, 48, 72, 93, 120]);
    // Minimax cost of the first measure: the DP's keys never lose to even keys.
    let cost = |v: &serde_json::Value| v["segment_costs"][0].as_f64().unwrap();
    assert!(cost(&d) <= cost(&e), "dp {} > even {}", cost(&d), cost(&e));
    assert!((cost(&d) - 2.026).abs() < 1e-3 && (cost(&e) - 3.015).abs() < 1e-3);

    // Options travel through --set and land in the JSON.
    let sum = dir.path().join("sum.json");
    run_ok(&mut keyframes(
        &sum,
        &[
            "--bpm",
            "120",
            "--strategy",
            "dp",
            "--n",
            "5",
            "--set",
            "keyframes.dp_combine=sum",
        ],
    ));
    assert_eq!(read(&sum)["options"]["dp_combine"], "sum");
}

#[test]
fn onset_keys_from_music() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("onset.json");
    let music = shared().join("music/Kevin_MacLeod_-_Vibe_Ace.ogg");
    let mut c = keyframes(&json, &["--bpm", "120", "--strategy", "onset", "--n", "5"]);
    run_ok(c.arg("--music").arg(&music));
    let v = read(&json);
    let keys = frames(&v["keyframes"]);
    assert_eq!(&keys[..1], &[0]);
    assert!(keys.contains(&120) && keys.contains(&126));
    assert!(keys.windows(2).all(|w| w[0] < w[1]));
}

#[test]
fn bad_inputs_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("k.json");
    assert_clean_failure(
        &mut keyframes(&json, &["--bpm", "120", "--strategy", "zigzag"]),
        "zigzag",
    );
    assert_clean_failure(
        &mut keyframes(&json, &["--bpm=0"]),
        "--bpm must be a positive",
    );
    assert_clean_failure(
        &mut keyframes(&json, &["--bpm=-80"]),
        "--bpm must be a positive",
    );
    assert_clean_failure(&mut keyframes(&json, &["--strategy", "even"]), "no tempo");
    assert_clean_failure(
        &mut keyframes(&json, &["--bpm", "120", "--strategy", "onset"]),
        "needs the music",
    );
    assert_clean_failure(
        &mut keyframes(&json, &["--bpm", "120", "--n", "1"]),
        "at least 2",
    );
    assert_clean_failure(
        &mut keyframes(
            &json,
            &["--bpm", "120", "--set", "keyframes.dp_space=quaternions"],
        ),
        "dp_space",
    );
    assert_clean_failure(
        &mut keyframes(&json, &["--bpm", "120", "--set", "train.steps=3"]),
        "only keyframes.*",
    );
    assert!(!json.exists());
    let missing_dir = dir.path().join("nope/k.json");
    assert_clean_failure(
        &mut keyframes(&missing_dir, &["--bpm", "120"]),
        "does not exist",
    );
    let mut c = qean();
    c.args(["keyframes", "--bpm", "120", "--json"])
        .arg(&json)
        .arg("--motion")
        .arg(dir.path().join("gone.pkl"));
    assert_clean_failure(&mut c, "gone.pkl");
    assert!(listing(dir.path()).is_empty());
}
