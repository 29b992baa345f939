//! `qean curves`: checkpoints evaluated on demand, metrics against steps as PNG, CSV and a table;
//! the motion-energy columns of checkpoint-mode reports; `qean sweep --only`.

mod common;
use common::*;

#[test]
fn curves_evaluate_every_checkpoint_and_plot_the_motion_energy() {
    let d = tempfile::tempdir().unwrap();
    let data = dataset(d.path());
    let run = d.path().join("tiny-seed0");
    run_ok(&mut train_cmd(
        "tiny/fact.toml",
        &data,
        &run,
        &[
            "train.steps=4",
            "train.checkpoint_every=2",
            "train.keep_last=5",
        ],
    ));
    let out = d.path().join("curves");
    let text = run_ok(
        qean()
            .arg("curves")
            .arg(&run)
            .args(["--evaluate", "--max-frames", "60", "--data"])
            .arg(&data)
            .arg("--out")
            .arg(&out),
    );
    // One group ("tiny": the seed part dropped), at its last step.
    assert!(text.contains("| tiny | 4 | 1 |"), "{text}");
    for f in ["curves.png", "curves.csv", "table.md"] {
        assert!(out.join(f).is_file(), "{f}: {text}");
    }
    let csv = std::fs::read_to_string(out.join("curves.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows.len(), 3, "{csv}");
    assert!(rows[0].starts_with("group,run,step,speed_ratio,"), "{csv}");
    assert!(rows[1].starts_with("tiny,tiny-seed0,2,"), "{csv}");
    // Every report carries the motion energy, and the markdown shows its columns.
    for step in [2, 4] {
        let dir = run.join("eval").join(format!("step-{step}"));
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(dir.join("report.json")).unwrap()).unwrap();
        let e = &json["reports"][0]["motion_energy"];
        assert!(e["speed_ratio"].as_f64().unwrap() >= 0.0, "{e}");
        assert_eq!(e["spans"].as_array().unwrap().len(), 1, "{e}");
        assert!(
            json["reports"][0]["energy_reference"]["speed"]
                .as_f64()
                .unwrap()
                > 0.0
        );
        // The dance recipe samples with 8 ensembled passes and projected feedback.
        assert_eq!(json["ensemble"], 8);
        assert_eq!(json["feedback_project"], true);
        let md = std::fs::read_to_string(dir.join("report.md")).unwrap();
        assert!(
            md.contains("speed ratio → 1 | accel ratio → 1 | frozen ↓"),
            "{md}"
        );
        assert!(md.contains("| chance: frozen seed pose |"), "{md}");
    }
    // A second call evaluates nothing new.
    let again = qean()
        .arg("curves")
        .arg(&run)
        .args(["--evaluate", "--max-frames", "60", "--data"])
        .arg(&data)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(again.status.success());
    assert!(
        !String::from_utf8_lossy(&again.stderr).contains("evaluating"),
        "{}",
        String::from_utf8_lossy(&again.stderr)
    );
    // Sampling overrides go to a tagged report beside the default one.
    run_ok(
        qean()
            .args(["eval", "--run"])
            .arg(&run)
            .args(["--checkpoint", "4", "--max-frames", "30", "--ensemble", "1"])
            .args(["--raw-feedback", "--tag", "raw", "--data"])
            .arg(&data),
    );
    let raw: serde_json::Value =
        serde_json::from_slice(&std::fs::read(run.join("eval/step-4-raw/report.json")).unwrap())
            .unwrap();
    assert_eq!(
        (raw["ensemble"].as_u64(), raw["feedback_project"].as_bool()),
        (Some(1), Some(false))
    );
    // Nothing to plot is one clear error line.
    let empty = d.path().join("empty-seed0");
    run_ok(&mut train_cmd(
        "tiny/fact.toml",
        &data,
        &empty,
        &["train.steps=1"],
    ));
    assert_clean_failure(
        qean()
            .arg("curves")
            .arg(&empty)
            .arg("--out")
            .arg(d.path().join("c2")),
        "no evaluation reports",
    );
    assert_clean_failure(
        qean()
            .args(["eval", "--run"])
            .arg(&run)
            .args(["--ensemble", "30", "--data"])
            .arg(&data),
        "--ensemble",
    );
}
