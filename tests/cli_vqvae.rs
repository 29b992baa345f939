//! The motion VQ-VAE (SPEC §13.2) through the binary: `qean inspect` prints §13.9's counts, a tiny run trains
//! and resumes exactly (weights and EMA codebook), `qean eval --run` scores its reconstruction, and bad
//! configs fail with one line.

mod common;
use common::*;

#[test]
fn inspect_prints_the_vq_vae_counts() {
    for (preset, count) in [
        ("control/vqvae_tiny.toml", "349,384"),
        ("control/vqvae_paper.toml", "26,983,496"),
    ] {
        let out = run_ok(qean().arg("inspect").arg(configs().join(preset)));
        assert!(
            out.contains(&format!("parameter count: {count}")),
            "{preset}: {out}"
        );
        assert!(out.contains("not counted"), "{out}");
    }
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.toml");
    std::fs::write(&bad, "[model]\narch = \"vqvae\"\n[vq]\nwindow = 60\n").unwrap();
    assert_clean_failure(
        qean().arg("inspect").arg(&bad),
        "vq.window = 60 must be a positive multiple of 2^down_t = 8",
    );
    std::fs::write(&bad, "[model]\narch = \"fact\"\n[vq]\nwidth = 8\n").unwrap();
    assert_clean_failure(
        qean()
            .args(["train", "--config"])
            .arg(&bad)
            .arg("--data")
            .arg(dir.path())
            .arg("--run-dir")
            .arg(dir.path().join("r")),
        "a [vq] table is for",
    );
    assert!(!dir.path().join("r").exists());
}

#[test]
fn tiny_vq_vae_trains_resumes_exactly_and_is_scored() {
    let dir = tempfile::tempdir().unwrap();
    let data = dataset(dir.path());
    let train = |run: &std::path::Path, steps: u64, resume: bool| {
        let mut c = qean();
        c.arg("train").arg("--plain");
        if resume {
            c.arg("--resume").arg(run);
        } else {
            c.arg("--config")
                .arg(configs().join("control/vqvae_tiny.toml"))
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
            "vq.width=16".into(),
            "vq.code_dim=8".into(),
            "vq.codes=16".into(),
            "vq.depth=1".into(),
        ] {
            c.arg("--set").arg(s);
        }
        run_ok(&mut c)
    };
    // 3 + 3 steps equal 6 straight: weights, codebook and EMA statistics (all in the weights file).
    let straight = dir.path().join("straight");
    train(&straight, 6, false);
    let split = dir.path().join("split");
    train(&split, 3, false);
    train(&split, 6, true);
    let last = |r: &std::path::Path| checkpoints(r).last().unwrap().clone();
    assert_eq!(params_hash(&last(&straight)), params_hash(&last(&split)));
    assert_eq!(losses(&straight), losses(&split));
    // The reconstruction report: MPJPE, codebook use, the decoded ground truth's metrics.
    let out = run_ok(
        qean()
            .args(["eval", "--run"])
            .arg(&straight)
            .arg("--data")
            .arg(&data),
    );
    assert!(out.contains("root-relative MPJPE (cm)"), "{out}");
    assert!(out.contains("| decoded ground truth |"), "{out}");
    assert!(
        out.contains("Motion of the decoded ground truth against the data's")
            && out.contains("speed ratio"),
        "{out}"
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(straight.join("eval/step-6/report.json")).unwrap())
            .unwrap();
    assert_eq!(report["sequences"], 4);
    assert_eq!(report["codes"], 16);
    let mpjpe = report["mpjpe"].as_f64().unwrap();
    assert!(mpjpe.is_finite() && mpjpe > 0.0, "{mpjpe}");
    // A VQ-VAE does not generate dances from music.
    assert_clean_failure(
        qean()
            .args(["sample", "--run"])
            .arg(&straight)
            .arg("--music")
            .arg(shared().join("music/Kevin_MacLeod_-_Vibe_Ace.ogg"))
            .arg("--out")
            .arg(dir.path().join("s")),
        "VQ-VAE",
    );
}
