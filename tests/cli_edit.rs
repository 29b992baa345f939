//! `qean edit` (SPEC §12.7) on the shared AIST++ excerpt: frames outside the ranges identical, edited
//! frames exact, keep = every frame gives the input back, and bad edits fail cleanly with nothing written.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::*;

fn excerpt() -> PathBuf {
    shared().join("aistpp/motions/softcat477_sample_with_scaling.pkl")
}

fn edit(edits: &Path, out: &Path, args: &[&str]) -> Command {
    let mut c = qean();
    c.arg("edit")
        .arg("--motion")
        .arg(excerpt())
        .arg("--edits")
        .arg(edits)
        .arg("--out")
        .arg(out)
        .args(args);
    c
}

fn motion(p: &Path) -> qean_motion::Motion {
    qean_motion::Motion::read_pkl(p).unwrap()
}

#[test]
fn edits_keep_the_outside_and_set_poses_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let input = motion(&excerpt());
    let pose: Vec<f64> = (0..72).map(|i| 0.005 * i as f64 - 0.1).collect();
    let edits = dir.path().join("edits.json");
    std::fs::write(
        &edits,
        format!(
            r#"{{"regenerate": [[10, 50], [70, 110]], "keep": "grid:5",
                "edits": [{{"frame": 40, "pose_aa": {pose:?}, "trans": [0.1, 0.8, -0.2]}}]}}"#
        ),
    )
    .unwrap();
    for method in ["slerp", "bezier"] {
        let out = dir.path().join(format!("{method}.pkl"));
        let log = run_ok(&mut edit(
            &edits,
            &out,
            &["--method", method, "--bpm", "120", "--render"],
        ));
        assert!(log.contains("range 10..50"), "{log}");
        let m = motion(&out);
        assert_eq!(m.frames, input.frames);
        for t in (0..10).chain(51..70).chain(111..input.frames) {
            assert_eq!(
                m.poses[t * 72..t * 72 + 72],
                input.poses[t * 72..t * 72 + 72],
                "{method} frame {t}"
            );
            assert_eq!(m.trans[t * 3..t * 3 + 3], input.trans[t * 3..t * 3 + 3]);
        }
        assert_eq!(m.poses[40 * 72..41 * 72], pose[..]);
        assert_eq!(m.trans[120..123], [0.1, 0.8, -0.2]);
        // Kept grid frames inside the ranges (30, 90) are untouched; the rest moved.
        for t in [30, 90] {
            assert_eq!(
                m.poses[t * 72..t * 72 + 72],
                input.poses[t * 72..t * 72 + 72]
            );
        }
        assert_ne!(m.poses[20 * 72..21 * 72], input.poses[20 * 72..21 * 72]);
        let report: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(out.with_extension("report.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(report["method"], method);
        assert_eq!(
            report["ranges"][0]["anchors"],
            serde_json::json!([10, 30, 40, 50])
        );
        assert!(report["ranges"][1]["mse_rotmat"].as_f64().unwrap() > 0.0);
        assert!(out.with_extension("png").is_file() && out.with_extension("gif").is_file());
    }
    // Keep every frame: the input comes back bit for bit.
    let all = dir.path().join("all.json");
    let frames: Vec<usize> = (0..input.frames).collect();
    std::fs::write(
        &all,
        format!(r#"{{"regenerate": [[0, 126]], "keep": {frames:?}}}"#),
    )
    .unwrap();
    let out = dir.path().join("same.pkl");
    run_ok(&mut edit(&all, &out, &[]));
    assert_eq!(motion(&out), input);
}

#[test]
fn bad_edits_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.pkl");
    let case = |name: &str, text: &str, needle: &str, extra: &[&str]| {
        let p = dir.path().join(format!("{name}.json"));
        std::fs::write(&p, text).unwrap();
        assert_clean_failure(&mut edit(&p, &out, extra), needle);
        std::fs::remove_file(&p).unwrap();
    };
    case("reversed", r#"{"regenerate": [[50, 10]]}"#, "reversed", &[]);
    case(
        "overlap",
        r#"{"regenerate": [[0, 50], [40, 60]]}"#,
        "overlap",
        &[],
    );
    case(
        "outside",
        r#"{"regenerate": [[0, 500]]}"#,
        "outside the motion",
        &[],
    );
    case(
        "keys",
        r#"{"regenerate": [[0, 50]], "keep": [3, 900]}"#,
        "keyframe 900",
        &[],
    );
    case(
        "rule",
        r#"{"regenerate": [[0, 50]], "keep": "spiral:3"}"#,
        "unknown keyframe rule",
        &[],
    );
    case(
        "pose",
        r#"{"regenerate": [[0, 50]], "edits": [{"frame": 5, "pose_aa": [0.1, 0.2, 0.3]}]}"#,
        "expected 72",
        &[],
    );
    case("notjson", "{regenerate", "notjson.json", &[]);
    case(
        "tempo",
        r#"{"regenerate": [[0, 50]], "keep": "grid:5"}"#,
        "no tempo",
        &[],
    );
    case(
        "onset",
        r#"{"regenerate": [[0, 50]], "keep": "onset:5"}"#,
        "needs the music",
        &["--bpm", "120"],
    );
    let ok = dir.path().join("ok.json");
    std::fs::write(&ok, r#"{"regenerate": [[0, 50]]}"#).unwrap();
    assert_clean_failure(
        &mut edit(&ok, &dir.path().join("no/out.pkl"), &[]),
        "does not exist",
    );
    assert_clean_failure(&mut edit(&ok, &dir.path().join("out.bvh"), &[]), ".pkl");
    assert_clean_failure(
        &mut edit(&dir.path().join("gone.json"), &out, &[]),
        "gone.json",
    );
    assert_eq!(listing(dir.path()), vec!["ok.json".to_string()]);
}
