//! Checkpoints an earlier build wrote keep working (issue 37): tests/data/checkpoints/ holds one tiny run of
//! every family, trained for 2 updates, and what that build did with each (tools/make_checkpoint_fixtures.sh,
//! run with the build of commit 98f6669, before checkpoint loading moved below the trainer). This build must
//! read the same weights (the hash each checkpoint saved), draw the same dances from the same seed and song,
//! edit the same way, evaluate the same, and continue training to the same parameters.
//!
//! Weights read from a file are bit-exact; what is computed from them is compared with a tolerance, since the
//! CPU that runs the tests may have other vector units than the one that made the fixtures.

mod common;
use common::*;
use std::path::{Path, PathBuf};

const FAMILIES: [&str; 8] = [
    "fact",
    "qean",
    "tsmt",
    "inbetween",
    "vqvae",
    "gpt",
    "genre",
    "genre_clf",
];

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/checkpoints")
}

/// A fresh copy of the stored runs (commands write into run directories).
fn runs(dir: &Path) -> PathBuf {
    let runs = dir.join("runs");
    copy_tree(&fixtures().join("runs"), &runs);
    runs
}

fn expected(name: &str) -> PathBuf {
    fixtures().join("expected").join(name)
}

fn seed_motion() -> PathBuf {
    shared().join("aistpp/motions/softcat477_sample_with_scaling.pkl")
}

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol * (1.0 + a.abs().max(b.abs()))
}

/// Two motions with the same frame count, poses and translation within `tol` (relative).
fn assert_same_motion(got: &Path, want: &Path, tol: f64) {
    let (g, w) = (
        qean_motion::Motion::read_pkl(got).unwrap(),
        qean_motion::Motion::read_pkl(want).unwrap(),
    );
    assert_eq!(g.frames, w.frames, "{}", got.display());
    for (what, a, b) in [("poses", &g.poses, &w.poses), ("trans", &g.trans, &w.trans)] {
        let worst = a
            .iter()
            .zip(b.iter())
            .enumerate()
            .find(|(_, (x, y))| !close(**x, **y, tol));
        assert!(
            worst.is_none(),
            "{}: {what} differ from the stored build's at value {:?}",
            got.display(),
            worst
        );
    }
}

#[test]
fn stored_checkpoints_load_and_sample_identically() {
    let dir = tempfile::tempdir().unwrap();
    let runs = runs(dir.path());
    let device = burn::tensor::Device::flex();
    for family in FAMILIES {
        let ck = qean_checkpoint::resolve(&runs.join(family)).unwrap();
        assert_eq!(ck.state.step, 2, "{family}");
        let params = ck.named_parameters(&device).unwrap();
        assert_eq!(
            qean_models::params::params_hash(&params),
            ck.state.params_hash,
            "{family}: the weights read differ from those the earlier build saved"
        );
    }
    let out = dir.path().join("dances");
    for family in ["fact", "qean", "tsmt", "gpt", "genre"] {
        let mut c = qean();
        c.current_dir(&runs)
            .args(["sample", "--run", family, "--music"])
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/hr3-desert_excerpt.ogg"))
            .arg("--seed-motion")
            .arg(seed_motion())
            .args(["--frames", "60", "--name", family, "--out"])
            .arg(&out);
        if family == "genre" {
            c.args(["--genre", "BR"]);
        }
        run_ok(&mut c);
        let name = format!("{family}.pkl");
        assert_same_motion(&out.join(&name), &expected(&name), 1e-4);
    }
    let edits = dir.path().join("edits.json");
    std::fs::write(&edits, r#"{"regenerate": [[20, 80]], "keep": "grid:5"}"#).unwrap();
    let edited = dir.path().join("inbetween.pkl");
    run_ok(
        qean()
            .current_dir(&runs)
            .args(["edit", "--method", "transformer", "--motion"])
            .arg(seed_motion())
            .arg("--edits")
            .arg(&edits)
            .args(["--bpm", "120", "--run", "inbetween", "--out"])
            .arg(&edited),
    );
    assert_same_motion(&edited, &expected("inbetween.pkl"), 1e-4);
}

/// Every number of a JSON report within `tol` of the stored one (strings and shapes equal; wall-clock
/// fields skipped).
fn assert_same_report(got: &serde_json::Value, want: &serde_json::Value, path: &str, tol: f64) {
    use serde_json::Value;
    match (got, want) {
        (Value::Number(a), Value::Number(b)) => {
            let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
            assert!(close(a, b, tol), "{path}: {a} vs the stored {b}");
        }
        (Value::Array(a), Value::Array(b)) => {
            assert_eq!(a.len(), b.len(), "{path}");
            for (k, (x, y)) in a.iter().zip(b).enumerate() {
                assert_same_report(x, y, &format!("{path}[{k}]"), tol);
            }
        }
        (Value::Object(a), Value::Object(b)) => {
            for (k, y) in b {
                if k.contains("seconds") || k.contains("time") || k == "created" || k == "path" {
                    continue;
                }
                let x = a
                    .get(k)
                    .unwrap_or_else(|| panic!("{path}.{k}: missing from the report"));
                assert_same_report(x, y, &format!("{path}.{k}"), tol);
            }
        }
        (Value::String(_), Value::String(_)) => {}
        (a, b) => assert_eq!(a, b, "{path}"),
    }
}

#[test]
fn stored_checkpoints_evaluate_and_resume_identically() {
    let dir = tempfile::tempdir().unwrap();
    let data = dataset(dir.path());
    let runs = runs(dir.path());
    for family in ["vqvae", "genre_clf"] {
        run_ok(
            qean()
                .current_dir(&runs)
                .args(["eval", "--run", family, "--data"])
                .arg(&data),
        );
        let report = |p: &Path| -> serde_json::Value {
            serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap()
        };
        assert_same_report(
            &report(&runs.join(family).join("eval/step-2/report.json")),
            &report(&expected(&format!("{family}.report.json"))),
            family,
            1e-4,
        );
    }
    let want: serde_json::Value =
        serde_json::from_slice(&std::fs::read(expected("resumed.json")).unwrap()).unwrap();
    let device = burn::tensor::Device::flex();
    // A stage checks that its frozen run is the one it was trained on: resume the stages before the runs
    // they froze, as the fixtures were made.
    for family in [
        "genre",
        "gpt",
        "vqvae",
        "fact",
        "qean",
        "tsmt",
        "inbetween",
        "genre_clf",
    ] {
        run_ok(
            qean()
                .current_dir(&runs)
                .args(["train", "--plain", "--resume", family, "--data"])
                .arg(&data)
                .args(["--set", "train.steps=3"]),
        );
        let ck = qean_checkpoint::resolve(&runs.join(family)).unwrap();
        assert_eq!(ck.state.step, 3, "{family}");
        let w = &want[family];
        let loss = ck.state.last_loss.unwrap();
        assert!(
            close(loss, w["last_loss"].as_f64().unwrap(), 1e-4),
            "{family}: loss {loss} after resuming, {} in the earlier build",
            w["last_loss"]
        );
        let params = ck.named_parameters(&device).unwrap();
        assert_eq!(
            params.len(),
            w["params"].as_object().unwrap().len(),
            "{family}"
        );
        for p in params {
            let sums = &w["params"][&p.name];
            let (s, s2) = p.values.iter().fold((0.0f64, 0.0f64), |(s, s2), &v| {
                (s + v as f64, s2 + (v as f64) * (v as f64))
            });
            // Sums over many values: compare against their scale, not their (possibly cancelling) value.
            let scale = (s2 * p.values.len() as f64).sqrt();
            assert!(
                (s - sums[0].as_f64().unwrap()).abs() <= 1e-4 * (1.0 + scale)
                    && close(s2, sums[1].as_f64().unwrap(), 1e-4),
                "{family}: parameter {} after resuming differs from the earlier build's",
                p.name
            );
        }
    }
}
