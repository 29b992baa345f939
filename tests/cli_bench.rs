//! `qean bench` end to end: a measure runs in its own process and lands in the JSON and the table;
//! a peer that cannot run is reported, not fatal; a bad measure name is one clear error.

mod common;

use common::{qean, run_ok};

#[test]
fn features_measure_with_a_failing_peer() {
    let d = tempfile::tempdir().unwrap();
    let json = d.path().join("bench.json");
    let out = qean()
        .args(["bench", "--only", "features", "--peers", "--librosa-python"])
        .arg(d.path().join("no-such-python"))
        .arg("--json")
        .arg(&json)
        .arg("--work-dir")
        .arg(d.path().join("work"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(stdout.contains("| features | - |"), "{stdout}");
    assert!(
        stderr.contains("peer of features: cannot start"),
        "{stderr}"
    );
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let entries = report["entries"].as_array().unwrap();
    assert_eq!(entries.len(), 1);
    let e = &entries[0];
    assert_eq!(e["id"], "Features");
    // A 60 s track takes well over a millisecond and well under a minute even in a debug build.
    let seconds = e["value"].as_f64().unwrap();
    assert!(seconds > 1e-3 && seconds < 60.0, "{seconds}");
    assert!(e["peak_rss_mb"].as_f64().unwrap() > 1.0);
    assert!(e["peer"].is_null());
    assert!(e["peer_error"].as_str().unwrap().contains("no-such-python"));
    assert_eq!(report["sizes"]["track_seconds"], 60.0);
}

#[test]
fn unknown_measure_is_one_error_line() {
    let out = qean()
        .args(["bench", "--only", "features,warp"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(
        stderr.lines().filter(|l| l.starts_with("error:")).count(),
        1,
        "{stderr}"
    );
    assert!(stderr.contains("unknown measure `warp`"), "{stderr}");
}

#[test]
fn features_dataset_measure_fills_a_feature_cache() {
    let d = tempfile::tempdir().unwrap();
    let json = d.path().join("bench.json");
    let work = d.path().join("work");
    let stdout = run_ok(
        qean()
            .args(["bench", "--quick", "--only", "features-dataset", "--json"])
            .arg(&json)
            .arg("--work-dir")
            .arg(&work),
    );
    assert!(stdout.contains("| features-dataset | - |"), "{stdout}");
    let report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let e = &report["entries"][0];
    assert_eq!(e["id"], "FeaturesDataset");
    assert!(e["detail"].as_str().unwrap().contains("tracks/s"), "{e}");
    // Each track computed side by side equals the track computed alone (the tracks are named after
    // AIST++ music whose tempo prior is 120 BPM, as `qean features` without --start-bpm).
    let cache = work.join("feature-dataset-4/features");
    let alone = d.path().join("alone");
    std::fs::create_dir_all(&alone).unwrap();
    run_ok(
        qean()
            .arg("features")
            .arg(work.join("track-60s-44100hz.wav"))
            .arg("--out")
            .arg(&alone),
    );
    let a = qean_io::npy::read(&alone.join("track-60s-44100hz.npy")).unwrap();
    for id in ["mBR4", "mPO4", "mLO4", "mMH4"] {
        let b = qean_io::npy::read(&cache.join(format!("{id}.npy"))).unwrap();
        assert_eq!((&a.shape, &a.data), (&b.shape, &b.data), "{id}");
    }
}
