//! End-to-end TSMT (SPEC §11): `qean train` with the tiny preset (shrunk with --set), exact resume,
//! the bins kept bit for bit in the checkpoint, `qean sample` of 120 + 1200 frames to the Vibe Ace
//! with the seed of the draws deciding the dance, `qean eval --run` with the TSMT paper's keys, and
//! `qean inspect` / `qean export` of a TSMT checkpoint.

use std::path::Path;
use std::process::Command;

mod common;
use common::*;

/// Tiny TSMT, smaller still: a 32-frame window, batch 4.
fn train(data: &Path, run: &Path, steps: u64) -> Command {
    let mut c = qean();
    c.arg("train")
        .arg("--config")
        .arg(configs().join("tsmt/tiny.toml"))
        .arg("--data")
        .arg(data)
        .arg("--run-dir")
        .arg(run)
        .arg("--plain");
    for s in [
        format!("train.steps={steps}"),
        "train.batch_size=4".into(),
        "train.checkpoint_every=3".into(),
        "train.val_every=3".into(),
        "tsmt.window=32".into(),
    ] {
        c.arg("--set").arg(s);
    }
    c
}

fn vibe_ace() -> std::path::PathBuf {
    shared().join("music/Kevin_MacLeod_-_Vibe_Ace.ogg")
}

fn sample(run: &Path, out: &Path, extra: &[&str]) -> String {
    let mut c = qean();
    c.arg("sample")
        .arg("--run")
        .arg(run)
        .arg("--music")
        .arg(vibe_ace())
        .args(["--frames", "1200", "--name", "dance", "--out"])
        .arg(out)
        .args(extra);
    run_ok(&mut c)
}

/// The bins of a checkpoint: from its config.toml and its family.json, as f64 bit patterns.
fn bins(checkpoint: &Path) -> (Vec<u64>, Vec<u64>) {
    let config: toml::Table =
        toml::from_str(&std::fs::read_to_string(checkpoint.join("config.toml")).unwrap()).unwrap();
    let from_config: Vec<u64> = config["tsmt"]["bins_lo"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_float().unwrap().to_bits())
        .collect();
    let family: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(checkpoint.join("family.json")).unwrap())
            .unwrap();
    let from_state: Vec<u64> = family["tsmt_bins"]["lo"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_f64().unwrap().to_bits())
        .collect();
    (from_config, from_state)
}

#[test]
fn tsmt_trains_resumes_samples_and_evaluates() {
    let d = tempfile::tempdir().unwrap();
    let data = dataset(d.path());
    let straight = d.path().join("straight");
    run_ok(&mut train(&data, &straight, 6));
    let cks = checkpoints(&straight);
    assert_eq!(cks.len(), 2, "{cks:?}");
    // The bins: fitted once, identical in the run config, every checkpoint and family.json.
    let (lo, lo_state) = bins(&cks[0]);
    assert_eq!(lo.len(), 69);
    assert_eq!(lo, lo_state);
    assert_eq!(bins(&cks[1]).0, lo);

    // Stopped at 3 and resumed to 6: the same weights as straight through.
    let resumed = d.path().join("resumed");
    run_ok(&mut train(&data, &resumed, 3));
    run_ok(
        qean()
            .args(["train", "--plain", "--set", "train.steps=6", "--resume"])
            .arg(&resumed),
    );
    assert_eq!(
        params_hash(&checkpoints(&resumed)[1]),
        params_hash(&cks[1]),
        "resume is exact"
    );
    assert_eq!(bins(&checkpoints(&resumed)[1]).0, lo);

    // 120 seed + 1200 generated frames in every export.
    let out = d.path().join("dances");
    let text = sample(&straight, &out, &["--sample-seed", "1"]);
    assert!(text.contains("120 seed + 1200 generated frames"), "{text}");
    let motion = qean_motion::motion::Motion::read_pkl(&out.join("dance.pkl")).unwrap();
    assert_eq!((motion.frames, motion.poses.len()), (1320, 1320 * 72));
    let joints = qean_io::npy::read(&out.join("dance.joints.npy")).unwrap();
    assert_eq!(joints.shape, vec![1320, 24, 3]);
    let bvh = std::fs::read_to_string(out.join("dance.bvh")).unwrap();
    assert!(
        bvh.contains("Frames: 1320"),
        "{}",
        &bvh[..200.min(bvh.len())]
    );
    // The seed of the draws decides the dance.
    let again = d.path().join("again");
    sample(&straight, &again, &["--sample-seed", "1"]);
    let other = d.path().join("other");
    sample(&straight, &other, &["--sample-seed", "2"]);
    let read = |dir: &Path| std::fs::read(dir.join("dance.pkl")).unwrap();
    assert_eq!(read(&out), read(&again), "same seed, same dance");
    assert_ne!(read(&out), read(&other), "another seed, another dance");

    // Every decoding dances the same length; coherent and mean move less from frame to frame than the
    // paper's independent draws (docs/tsmt.md measures them); `bin` is the run's default here.
    let accel = |dir: &Path| {
        let j = qean_io::npy::read(&dir.join("dance.joints.npy")).unwrap();
        let v = &j.data;
        let frame = |t: usize| &v[t * 72..(t + 1) * 72];
        (121..1319)
            .map(|t| {
                (0..72)
                    .map(|i| (frame(t + 1)[i] - 2.0 * frame(t)[i] + frame(t - 1)[i]).abs())
                    .sum::<f64>()
            })
            .sum::<f64>()
    };
    let paper = d.path().join("decode-bin");
    sample(
        &straight,
        &paper,
        &["--sample-seed", "1", "--decode", "bin"],
    );
    assert_eq!(read(&paper), read(&out), "bin is the run's decoding");
    for decode in ["subbin", "coherent", "mean"] {
        let dir = d.path().join(format!("decode-{decode}"));
        let text = sample(&straight, &dir, &["--sample-seed", "1", "--decode", decode]);
        assert!(text.contains("120 seed + 1200 generated frames"), "{text}");
        if decode != "subbin" {
            assert!(
                accel(&dir) < accel(&paper),
                "{decode}: {} vs {}",
                accel(&dir),
                accel(&paper)
            );
        }
    }
    // A coarser model grid (20 fps) still dances 1200 frames at 60 fps.
    let coarse = d.path().join("coarse");
    run_ok(train(&data, &coarse, 3).args(["--set", "tsmt.frame_step=3"]));
    let dir = d.path().join("decode-coarse");
    let text = sample(&coarse, &dir, &["--decode", "coherent"]);
    assert!(text.contains("120 seed + 1200 generated frames"), "{text}");
    // `tsmt.shift_aug`: the coarse grids from frames 1 and 2 train too (every sequence is long enough).
    let shifted = d.path().join("coarse-shifted");
    run_ok(train(&data, &shifted, 1).args([
        "--set",
        "tsmt.frame_step=3",
        "--set",
        "tsmt.shift_aug=true",
    ]));
    assert_eq!(train_sequences(&shifted), 3 * train_sequences(&coarse));
    // A decoding that does not exist, or one asked of another family: one line, nothing written.
    let bad = d.path().join("bad");
    let mut c = qean();
    c.arg("sample")
        .arg("--run")
        .arg(&straight)
        .arg("--music")
        .arg(vibe_ace())
        .args(["--decode", "smooth", "--out"])
        .arg(&bad);
    assert_clean_failure(
        &mut c,
        "unknown TSMT decoding `smooth`: expected one of bin, subbin, coherent, mean",
    );
    assert!(!bad.exists());
    // Music standardised per track (`recipe.audio_norm = "per_track"`) trains and dances; split statistics
    // are not a TSMT option: one line, nothing written.
    let per_track = d.path().join("per-track");
    let mut c = train(&data, &per_track, 3);
    run_ok(c.args(["--set", "recipe.audio_norm=\"per_track\""]));
    let text = sample(&per_track, &d.path().join("per-track-dance"), &[]);
    assert!(text.contains("per 5 s: speed ratio"), "{text}");
    let refused = d.path().join("standardized");
    let mut c = train(&data, &refused, 3);
    c.args(["--set", "recipe.audio_norm=\"standardize\""]);
    assert_clean_failure(
        &mut c,
        "recipe.audio_norm = \"standardize\" is not a TSMT option",
    );
    assert!(!refused.exists());

    // Checkpoint-mode evaluation: the TSMT paper's keys in the report.
    let report = run_ok(
        qean()
            .args([
                "eval",
                "--music-rollouts",
                "2",
                "--max-frames",
                "240",
                "--run",
            ])
            .arg(&straight)
            .arg("--data")
            .arg(&data),
    );
    assert!(
        report.contains("| Methods (Li et al. 2020 metrics) |"),
        "{report}"
    );
    let json: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(straight.join("eval/step-6/report.json")).unwrap(),
    )
    .unwrap();
    let first = &json["reports"][0];
    for key in [
        "beat_precision",
        "beat_recall",
        "beat_f1",
        "a_seq_d",
        "i_seq_d",
        "s_music_d",
        "authenticity",
        "coherence",
        "gt_authenticity",
        "gt_coherence",
    ] {
        assert!(first.get(key).is_some(), "{key} missing");
    }
    assert!(first["s_music_d"].as_f64().unwrap() > 0.0);

    // Inspection and export take TSMT checkpoints.
    let text = run_ok(qean().arg("inspect").arg(&cks[1]));
    assert!(text.contains("params_hash: "), "{text}");
    let st = d.path().join("w.safetensors");
    run_ok(qean().arg("export").arg(&straight).arg("--out").arg(&st));
    assert!(st.is_file());
}

/// `qean sweep` runs TSMT variants unchanged (here the single and split audio streams).
#[test]
fn tsmt_variants_sweep() {
    let d = tempfile::tempdir().unwrap();
    let data = dataset(d.path());
    let tiny = configs().join("tsmt/tiny.toml");
    let sweep = d.path().join("tsmt-sweep.toml");
    std::fs::write(
        &sweep,
        format!(
            "base = {tiny:?}\nseeds = [0]\n\n[set]\n\"train.steps\" = 3\n\"train.checkpoint_every\" = 3\n\
             \"train.batch_size\" = 4\n\"tsmt.window\" = 32\n\n[[variant]]\nname = \"single\"\nconfig = {tiny:?}\n\n\
             [[variant]]\nname = \"split\"\nconfig = {tiny:?}\nset = {{ \"tsmt.audio_streams\" = \"split\" }}\n"
        ),
    )
    .unwrap();
    let text = run_ok(
        qean()
            .arg("sweep")
            .arg("--config")
            .arg(&sweep)
            .arg("--data")
            .arg(&data),
    );
    assert!(text.contains("| single-seed0 | single | 0 | 3 |"), "{text}");
    assert!(text.contains("| split-seed0 | split | 0 | 3 |"), "{text}");
    let config =
        std::fs::read_to_string(d.path().join("tsmt-sweep-runs/split-seed0/config.toml")).unwrap();
    assert!(config.contains("audio_streams = \"split\""), "{config}");
}
