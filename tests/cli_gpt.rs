//! The music-to-dance GPT over a frozen VQ-VAE (SPEC §13.3–13.4, §13.8) through the binary: §13.9's counts,
//! a tiny VQ-VAE then a tiny GPT trained on a synthetic dataset with exact resume and an idle T-Base, a sampled
//! dance in every format, and bad inputs (missing or different-shaped VQ-VAE run, music shorter than one token).

use qean_checkpoint::registry::Weights;
mod common;
use common::*;
use std::path::Path;
use std::process::Command;

#[test]
fn inspect_prints_the_gpt_counts() {
    for (preset, count) in [
        ("control/gpt_tiny.toml", "381,952"),
        ("control/gpt_paper.toml", "131,195,904"),
    ] {
        let out = run_ok(qean().arg("inspect").arg(configs().join(preset)));
        assert!(
            out.contains(&format!("parameter count: {count}")),
            "{preset}: {out}"
        );
    }
}

const VQ_SMALL: [&str; 4] = ["vq.width=16", "vq.code_dim=8", "vq.codes=16", "vq.depth=1"];
const GPT_SMALL: [&str; 5] = [
    "gpt.codes=16",
    "gpt.hidden=16",
    "gpt.heads=2",
    "gpt.base_layers=1",
    "gpt.head_layers=1",
];

fn train(config: &str, data: &Path, run: &Path, sets: &[String], resume: bool) -> String {
    run_ok(&mut train_command(config, data, run, sets, resume))
}

/// `qean train` of `config` (or `--resume`) with `sets` as `--set`s, not yet run.
fn train_command(config: &str, data: &Path, run: &Path, sets: &[String], resume: bool) -> Command {
    let mut c = qean();
    c.arg("train").arg("--plain");
    if resume {
        c.arg("--resume").arg(run);
    } else {
        c.arg("--config")
            .arg(configs().join(config))
            .arg("--data")
            .arg(data)
            .arg("--run-dir")
            .arg(run);
    }
    for s in sets {
        c.arg("--set").arg(s);
    }
    c
}

/// A small tiny-preset VQ-VAE (`VQ_SMALL`) trained for `steps` at batch 4: the frozen tokenizer of a GPT.
fn train_small_vq(data: &Path, run: &Path, steps: u64) {
    let mut sets: Vec<String> = VQ_SMALL.iter().map(|s| s.to_string()).collect();
    sets.extend([format!("train.steps={steps}"), "train.batch_size=4".into()]);
    train("control/vqvae_tiny.toml", data, run, &sets, false);
}

/// A small tiny-preset GPT (`GPT_SMALL`) over the VQ-VAE run `vq`, 2 steps at batch 4, with `extra` sets.
fn train_small_gpt(data: &Path, vq: &Path, run: &Path, extra: &[&str]) {
    let mut sets: Vec<String> = GPT_SMALL.iter().map(|s| s.to_string()).collect();
    sets.extend([
        string_set("gpt.vqvae_run", vq),
        "train.steps=2".into(),
        "train.batch_size=4".into(),
    ]);
    sets.extend(extra.iter().map(|s| s.to_string()));
    train("control/gpt_tiny.toml", data, run, &sets, false);
}

/// The Adam state (moments, step counts) of a checkpoint's parameters whose module paths start with
/// `prefix`, as raw bytes by `path.field` (`optimizer.bpk` keys each state tensor `{param_id}.{field}` and
/// maps the id to the parameter's path in its metadata).
fn adam_state(checkpoint: &Path, prefix: &str) -> std::collections::BTreeMap<String, Vec<u8>> {
    let r = burn_pack::Reader::from_file(checkpoint.join("optimizer.bpk")).unwrap();
    let paths = r.metadata().clone();
    let names: Vec<String> = r.tensor_names().iter().map(|s| s.to_string()).collect();
    names
        .into_iter()
        .filter_map(|n| {
            let (id, field) = n.split_once('.')?;
            let path = paths.get(id)?;
            path.starts_with(prefix)
                .then(|| (format!("{path}.{field}"), r.tensor_data(&n).unwrap()))
        })
        .collect()
}

/// The trained parameters of a checkpoint whose names start with `prefix`.
fn named(checkpoint: &Path, prefix: &str) -> Vec<qean_models::params::NamedParam> {
    named_of(checkpoint, prefix, Weights::Trained)
}

/// `which` parameters of a checkpoint whose names start with `prefix`.
fn named_of(
    checkpoint: &Path,
    prefix: &str,
    which: Weights,
) -> Vec<qean_models::params::NamedParam> {
    let ck = qean_checkpoint::checkpoint::resolve(checkpoint).unwrap();
    ck.named_parameters_of(&burn::tensor::Device::flex(), which)
        .unwrap()
        .into_iter()
        .filter(|p| p.name.starts_with(prefix))
        .collect()
}

#[test]
fn tiny_vq_gpt_trains_resumes_and_dances() {
    let dir = tempfile::tempdir().unwrap();
    let data = dataset(dir.path());
    let vq = dir.path().join("vq");
    train_small_vq(&data, &vq, 4);

    let gpt_sets = |steps: u64| -> Vec<String> {
        let mut s: Vec<String> = GPT_SMALL.iter().map(|s| s.to_string()).collect();
        s.extend([
            string_set("gpt.vqvae_run", &vq),
            format!("train.steps={steps}"),
            "train.batch_size=4".into(),
            "train.checkpoint_every=3".into(),
            "train.val_every=3".into(),
        ]);
        s
    };
    let straight = dir.path().join("gpt");
    train(
        "control/gpt_tiny.toml",
        &data,
        &straight,
        &gpt_sets(6),
        false,
    );
    let split = dir.path().join("gpt_split");
    train("control/gpt_tiny.toml", &data, &split, &gpt_sets(3), false);
    train("control/gpt_tiny.toml", &data, &split, &gpt_sets(6), true);
    // `gpt.token_shift_aug`: every training sequence tokenised from frame offsets 0..8. Trained from the
    // temp directory with a relative link to its VQ-VAE (`gpt.vqvae_run = "vq"`, as the demo links its
    // runs), it still samples from any other directory: the link is found beside the run.
    let shifted = dir.path().join("gpt_shifted");
    let mut sets = gpt_sets(1);
    sets.retain(|s| !s.starts_with("gpt.vqvae_run"));
    sets.extend([
        "gpt.token_shift_aug=true".into(),
        "gpt.vqvae_run=\"vq\"".into(),
    ]);
    let mut c = train_command("control/gpt_tiny.toml", &data, &shifted, &sets, false);
    run_ok(c.current_dir(dir.path()));
    assert_eq!(train_sequences(&shifted), 8 * train_sequences(&straight));
    let elsewhere = tempfile::tempdir().unwrap();
    let printed = run_ok(
        qean()
            .current_dir(elsewhere.path())
            .args(["sample", "--frames", "120", "--run"])
            .arg(&shifted)
            .arg("--music")
            .arg(shared().join("music/Kevin_MacLeod_-_Vibe_Ace.ogg"))
            .arg("--out")
            .arg(elsewhere.path().join("dance")),
    );
    assert!(
        printed.contains("120 seed + 120 generated frames"),
        "{printed}"
    );
    let cks = checkpoints(&straight);
    let last = |r: &Path| checkpoints(r).last().unwrap().clone();
    assert_eq!(params_hash(&last(&straight)), params_hash(&last(&split)));
    assert_eq!(losses(&straight), losses(&split));
    // Music steps only (no text data): the T-Base is idle, bit for bit; the M-Base and the head move.
    assert_eq!(named(&cks[0], "t_base"), named(&cks[1], "t_base"));
    assert_ne!(named(&cks[0], "m_base"), named(&cks[1], "m_base"));
    assert_ne!(named(&cks[0], "head"), named(&cks[1], "head"));

    // A dance for the held-out song: seed 120 frames, 1200 generated, every export.
    let out = dir.path().join("dance");
    let song = shared().join("music/Kevin_MacLeod_-_Vibe_Ace.ogg");
    let printed = run_ok(
        qean()
            .args(["sample", "--run"])
            .arg(&straight)
            .arg("--music")
            .arg(&song)
            .arg("--view")
            .arg("--out")
            .arg(&out),
    );
    let page = out.join("Kevin_MacLeod_-_Vibe_Ace.view.html");
    assert!(printed.contains(&page.display().to_string()), "{printed}");
    assert!(std::fs::read_to_string(&page)
        .unwrap()
        .contains("qean-data"));
    assert!(
        printed.contains("120 seed + 1200 generated frames"),
        "{printed}"
    );
    assert!(printed.contains("speed per 5 s"), "{printed}");
    let joints = qean_io::npy::read(&out.join("Kevin_MacLeod_-_Vibe_Ace.joints.npy")).unwrap();
    assert_eq!(joints.shape, vec![1320, 24, 3]);
    for ext in ["pkl", "bvh"] {
        assert!(out
            .join(format!("Kevin_MacLeod_-_Vibe_Ace.{ext}"))
            .is_file());
    }
    // Greedy picking is deterministic.
    let again = dir.path().join("again");
    run_ok(
        qean()
            .args(["sample", "--run"])
            .arg(&straight)
            .arg("--music")
            .arg(&song)
            .arg("--out")
            .arg(&again),
    );
    assert_eq!(
        std::fs::read(out.join("Kevin_MacLeod_-_Vibe_Ace.joints.npy")).unwrap(),
        std::fs::read(again.join("Kevin_MacLeod_-_Vibe_Ace.joints.npy")).unwrap()
    );
    // The temporal filter (the preset's `gpt.smooth_sigma = 1`; `--smooth-sigma 0` is the paper's decoding):
    // the seed stays, the dance after it is calmer than unfiltered.
    let raw = dir.path().join("raw");
    run_ok(
        qean()
            .args(["sample", "--smooth-sigma", "0", "--run"])
            .arg(&straight)
            .arg("--music")
            .arg(&song)
            .arg("--out")
            .arg(&raw),
    );
    let (calm, joints) = (
        joints,
        qean_io::npy::read(&raw.join("Kevin_MacLeod_-_Vibe_Ace.joints.npy")).unwrap(),
    );
    let frame = 72;
    assert_eq!(joints.data[..120 * frame], calm.data[..120 * frame]);
    let accel = |d: &[f64]| -> f64 {
        (121..1319)
            .map(|t| {
                (0..frame)
                    .map(|k| {
                        (d[(t + 1) * frame + k] - 2.0 * d[t * frame + k] + d[(t - 1) * frame + k])
                            .abs()
                    })
                    .sum::<f64>()
            })
            .sum()
    };
    assert!(
        accel(&calm.data) < accel(&joints.data),
        "the filter did not calm the dance"
    );
    assert_clean_failure(
        qean()
            .args(["sample", "--smooth-sigma", "11", "--run"])
            .arg(&straight)
            .arg("--music")
            .arg(&song)
            .arg("--out")
            .arg(dir.path().join("bad_smooth")),
        "--smooth-sigma must be in [0, 10] frames",
    );
    assert!(!dir.path().join("bad_smooth").exists());

    // Checkpoint mode: §7 on the decoded dances of the test + val split.
    let table = run_ok(
        qean()
            .args(["eval", "--run"])
            .arg(&straight)
            .arg("--data")
            .arg(&data)
            .args(["--max-frames", "120"]),
    );
    assert!(
        table.contains("| VQ-VAE + GPT step 6 (corrected) |"),
        "{table}"
    );
    assert!(straight.join("eval/step-6/report.json").is_file());

    // Bad inputs: one line each, nothing written.
    let bad = dir.path().join("bad");
    let mut missing: Vec<String> = GPT_SMALL.iter().map(|s| s.to_string()).collect();
    missing.push(string_set("gpt.vqvae_run", &dir.path().join("nope")));
    let mut c = train_command("control/gpt_tiny.toml", &data, &bad, &missing, false);
    assert_clean_failure(&mut c, "gpt.vqvae_run");
    assert!(!bad.exists());
    let mut c = train_command(
        "control/gpt_tiny.toml",
        &data,
        &bad,
        &[string_set("gpt.vqvae_run", &vq)],
        false,
    );
    assert_clean_failure(
        &mut c,
        "the VQ-VAE has 16 codes at 8 frames per token; this GPT is built for 128",
    );
    assert!(!bad.exists());
    let short = dir.path().join("short.wav");
    let samples: Vec<u8> = (0..30720)
        .flat_map(|i| (((i as f64 * 0.05).sin() * 8000.0) as i16).to_le_bytes())
        .collect();
    std::fs::write(
        &short,
        qean_io::testdata::wav_bytes(1, 30720, 1, 16, &samples, samples.len() as u32),
    )
    .unwrap();
    assert_clean_failure(
        qean()
            .args(["sample", "--run"])
            .arg(&straight)
            .arg("--music")
            .arg(&short)
            .arg("--out")
            .arg(dir.path().join("short_out")),
        "short.wav",
    );
    assert!(!dir.path().join("short_out").join("short.pkl").exists());
    // Text control needs a trained T-Base: this GPT took music steps only.
    assert_clean_failure(
        qean()
            .args(["sample", "--frames", "240", "--run"])
            .arg(&straight)
            .arg("--music")
            .arg(&song)
            .args([
                "--text-embedding",
                "genre:KR",
                "--text-interval",
                "2.5..3.5",
            ])
            .arg("--out")
            .arg(dir.path().join("text_out")),
        "text control needs a GPT whose T-Base was trained",
    );
    assert!(!dir.path().join("text_out").exists());
}

fn string_set(key: &str, path: &Path) -> String {
    format!("{key}={:?}", path.display().to_string())
}

/// The genre classifier of §13.10: §13.9's count, a few steps, its accuracy report on the test + val split.
#[test]
fn genre_classifier_trains_and_reports_accuracy() {
    let out = run_ok(
        qean()
            .arg("inspect")
            .arg(configs().join("control/genre_clf_paper.toml")),
    );
    assert!(out.contains("parameter count: 845,322"), "{out}");
    let dir = tempfile::tempdir().unwrap();
    let data = dataset(dir.path());
    let run = dir.path().join("clf");
    let sets: Vec<String> = [
        "genre_clf.width=8",
        "genre_clf.window=64",
        "train.steps=4",
        "train.batch_size=4",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    train("control/genre_clf_tiny.toml", &data, &run, &sets, false);
    let table = run_ok(
        qean()
            .args(["eval", "--run"])
            .arg(&run)
            .arg("--data")
            .arg(&data),
    );
    assert!(
        table.contains("Accuracy on 4 ground-truth test + val sequences"),
        "{table}"
    );
    let report: serde_json::Value =
        serde_json::from_slice(&std::fs::read(run.join("eval/step-4/report.json")).unwrap())
            .unwrap();
    let confusion = report["confusion"].as_array().unwrap();
    assert_eq!(confusion.len(), 10);
    let total: u64 = confusion
        .iter()
        .flat_map(|r| r.as_array().unwrap().iter().map(|c| c.as_u64().unwrap()))
        .sum();
    assert_eq!(total, 4);
}

/// Genre control (SPEC §13.5, §13.10) through the binary: §13.9's counts, a tiny genre stage over a frozen
/// tiny GPT with two optimisers, exact resume at an odd step inside the stage, the GPT bit-identical to its
/// run while the genre module and D move, `qean sample --genre`, the control test, and bad inputs.
#[test]
fn genre_stage_trains_resumes_exactly_and_steers_sampling() {
    let out = run_ok(
        qean()
            .arg("inspect")
            .arg(configs().join("control/genre_tiny.toml")),
    );
    for count in ["88,448", "33,184", "95,562", "381,952"] {
        assert!(out.contains(count), "{count}: {out}");
    }
    let out = run_ok(
        qean()
            .arg("inspect")
            .arg(configs().join("control/genre_paper.toml")),
    );
    for count in ["12,599,808", "14,169,792", "23,271,178", "131,195,904"] {
        assert!(out.contains(count), "{count}: {out}");
    }

    let dir = tempfile::tempdir().unwrap();
    let data = dataset(dir.path());
    let vq = dir.path().join("vq");
    train_small_vq(&data, &vq, 2);
    let gpt = dir.path().join("gpt");
    train_small_gpt(&data, &vq, &gpt, &[]);

    let genre_sets = |steps: u64, run: &Path| -> Vec<String> {
        let mut s: Vec<String> = GPT_SMALL.iter().map(|s| s.to_string()).collect();
        s.extend(
            [
                "genre.code_dim=8",
                "genre.z_dim=4",
                "genre.xattn_on=\"all\"",
                // A few steps at the preset's 1e-4 leave greedy picks unchanged: a larger step shows the
                // steering.
                "schedule.initial=1e-2",
                "genre.disc_width=8",
                "genre.disc_layers=1",
                "genre.disc_ff=16",
                "genre.disc_heads=2",
                "train.batch_size=4",
                "train.checkpoint_every=3",
                "train.val_every=3",
            ]
            .iter()
            .map(|s| s.to_string()),
        );
        s.push(string_set("genre.gpt_run", run));
        s.push(format!("train.steps={steps}"));
        s
    };
    let straight = dir.path().join("genre");
    train(
        "control/genre_tiny.toml",
        &data,
        &straight,
        &genre_sets(5, &gpt),
        false,
    );
    let split = dir.path().join("genre_split");
    train(
        "control/genre_tiny.toml",
        &data,
        &split,
        &genre_sets(3, &gpt),
        false,
    );
    train(
        "control/genre_tiny.toml",
        &data,
        &split,
        &genre_sets(5, &gpt),
        true,
    );
    let last = |r: &Path| checkpoints(r).last().unwrap().clone();
    assert_eq!(params_hash(&last(&straight)), params_hash(&last(&split)));
    assert_eq!(losses(&straight), losses(&split));
    for f in ["optimizer.bpk", "optimizer-1.bpk"] {
        assert!(last(&straight).join(f).is_file(), "{f}");
    }
    // Only the genre module and D move; the GPT stays the GPT run's, bit for bit (the weights it
    // samples with: its moving average).
    let cks = checkpoints(&straight);
    let frozen: Vec<(String, Vec<f32>)> = named_of(&last(&gpt), "", Weights::Sampled)
        .into_iter()
        .map(|p| (format!("gpt.{}", p.name), p.values))
        .collect();
    let inside: Vec<(String, Vec<f32>)> = named(&cks[1], "gpt.")
        .into_iter()
        .map(|p| (p.name, p.values))
        .collect();
    assert_eq!(frozen, inside);
    assert_ne!(named(&cks[0], "genre."), named(&cks[1], "genre."));
    assert_ne!(named(&cks[0], "disc."), named(&cks[1], "disc."));

    // --genre: a dance per requested genre, deterministic for one draw seed; another genre, another dance
    // (sharp draws: a 2-step GPT's logits are nearly flat, so its greedy picks hardly depend on anything).
    let song = shared().join("music/Kevin_MacLeod_-_Vibe_Ace.ogg");
    let sample_with = |genre: &str, out: &str, extra: &[&str]| {
        let out = dir.path().join(out);
        run_ok(
            qean()
                .args(["sample", "--run"])
                .arg(&straight)
                .arg("--music")
                .arg(&song)
                .args(["--frames", "240", "--top-k", "0", "--temperature", "0.05"])
                .args(["--sample-seed", "1"])
                .args(extra)
                .args(["--genre", genre, "--out"])
                .arg(&out),
        );
        std::fs::read(out.join("Kevin_MacLeod_-_Vibe_Ace.joints.npy")).unwrap()
    };
    let sample = |genre: &str, out: &str| sample_with(genre, out, &[]);
    let br = sample("BR", "br");
    assert_eq!(br, sample("br", "br2"));
    assert_ne!(br, sample("JB", "jb"));
    // No flag samples with the run's guidance (the tiny preset's 4); 1, the paper's sampling, draws otherwise.
    assert_eq!(br, sample_with("BR", "br-g4", &["--genre-guidance", "4"]));
    assert_ne!(br, sample_with("BR", "br-g1", &["--genre-guidance", "1"]));

    // Checkpoint mode (own genre per track) and the control test with a tiny classifier.
    let table = run_ok(
        qean()
            .args(["eval", "--run"])
            .arg(&straight)
            .arg("--data")
            .arg(&data)
            .args(["--max-frames", "120"]),
    );
    assert!(
        table.contains("VQ-VAE + GPT + genre control step 5"),
        "{table}"
    );
    let clf = dir.path().join("clf");
    let sets: Vec<String> = ["genre_clf.width=8", "genre_clf.window=64", "train.steps=2"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    train("control/genre_clf_tiny.toml", &data, &clf, &sets, false);
    let md = run_ok(
        qean()
            .args(["eval", "--run"])
            .arg(&straight)
            .arg("--data")
            .arg(&data)
            .args(["--max-frames", "120", "--tag", "control", "--classifier"])
            .arg(&clf),
    );
    assert!(md.contains("Accuracy w.r.t. the requested genre"), "{md}");
    let report: serde_json::Value = serde_json::from_slice(
        &std::fs::read(straight.join("eval/step-5-control/control.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(report["samples"].as_u64(), Some(40));
    let confusion = report["confusion"].as_array().unwrap();
    for row in confusion {
        let n: u64 = row
            .as_array()
            .unwrap()
            .iter()
            .map(|c| c.as_u64().unwrap())
            .sum();
        assert_eq!(n, 4);
    }

    // Bad inputs: one line each, nothing written.
    assert_clean_failure(
        qean()
            .args(["sample", "--run"])
            .arg(&gpt)
            .arg("--music")
            .arg(&song)
            .args(["--genre", "BR", "--out"])
            .arg(dir.path().join("plain")),
        "--genre needs a genre-control run",
    );
    for (args, wanted) in [
        (&["--genre", "XX"][..], "unknown genre `XX`"),
        (
            &["--genre", "BR", "--genre-guidance=-1"][..],
            "between 0 and 20",
        ),
        (&["--genre-guidance", "2"][..], "give --genre"),
    ] {
        assert_clean_failure(
            qean()
                .args(["sample", "--run"])
                .arg(&straight)
                .arg("--music")
                .arg(&song)
                .args(args)
                .arg("--out")
                .arg(dir.path().join("guided")),
            wanted,
        );
        assert!(!dir.path().join("guided").exists());
    }
    let bad = dir.path().join("bad");
    for (run, wanted) in [
        (dir.path().join("nope"), "genre.gpt_run"),
        (vq.clone(), "not a music-to-dance GPT run"),
    ] {
        let mut c = qean();
        c.args(["train", "--plain", "--config"])
            .arg(configs().join("control/genre_tiny.toml"))
            .arg("--data")
            .arg(&data)
            .arg("--run-dir")
            .arg(&bad);
        for s in genre_sets(2, &run) {
            c.arg("--set").arg(s);
        }
        assert_clean_failure(&mut c, wanted);
        assert!(!bad.exists());
    }
    let mut c = qean();
    c.args(["train", "--plain", "--config"])
        .arg(configs().join("control/genre_tiny.toml"))
        .arg("--data")
        .arg(&data)
        .arg("--run-dir")
        .arg(&bad)
        .arg("--set")
        .arg(string_set("genre.gpt_run", &gpt));
    assert_clean_failure(&mut c, "the GPT run is");
    assert!(!bad.exists());
}

/// Text steps on synthetic (genre embedding, motion) pairs (SPEC §13.3.6 "Alternation", §13.11 test 8 both
/// ways): even updates are music steps, odd ones text steps; a music step leaves the T-Base bit-identical and a
/// text step the M-Base, while the shared head moves in both; the alternation resumes exactly.
#[test]
fn text_steps_alternate_with_music_steps_and_leave_the_idle_base_alone() {
    let dir = tempfile::tempdir().unwrap();
    let data = dataset(dir.path());
    // A text–motion set in the HumanML3D layout (22 joints at 20 fps, two captions per motion): its five
    // training motions join the VQ-VAE's training windows (SPEC §13.2.5) and its captions the text steps.
    let text_set = dir.path().join("text_set");
    run_ok(
        qean()
            .args(["synth", "--sequences", "6", "--seconds", "3", "--out"])
            .arg(dir.path().join("synth_small"))
            .arg("--text-set")
            .arg(&text_set),
    );
    let vq = dir.path().join("vq");
    let mut vq_sets: Vec<String> = VQ_SMALL.iter().map(|s| s.to_string()).collect();
    vq_sets.extend([
        "train.steps=2".into(),
        "train.batch_size=4".into(),
        string_set("vq.text_set", &text_set),
    ]);
    train("control/vqvae_tiny.toml", &data, &vq, &vq_sets, false);
    let log = std::fs::read_to_string(vq.join("train.log")).unwrap();
    assert!(log.contains("text set: 5 motions join"), "{log}");
    let gpt_sets = |steps: u64| -> Vec<String> {
        let mut s: Vec<String> = GPT_SMALL.iter().map(|s| s.to_string()).collect();
        s.extend([
            string_set("gpt.vqvae_run", &vq),
            "gpt.synthetic_text=true".into(),
            string_set("gpt.text_set", &text_set),
            format!("train.steps={steps}"),
            "train.batch_size=4".into(),
            "train.checkpoint_every=1".into(),
            "train.keep_last=10".into(),
        ]);
        s
    };
    let straight = dir.path().join("gpt");
    train(
        "control/gpt_tiny.toml",
        &data,
        &straight,
        &gpt_sets(3),
        false,
    );
    let cks = checkpoints(&straight);
    assert_eq!(cks.len(), 3);
    // Update 1 (step-1 → step-2) is a text step, update 2 a music step.
    assert_eq!(named(&cks[0], "m_base"), named(&cks[1], "m_base"));
    assert_ne!(named(&cks[0], "t_base"), named(&cks[1], "t_base"));
    assert_ne!(named(&cks[0], "head"), named(&cks[1], "head"));
    assert_eq!(named(&cks[1], "t_base"), named(&cks[2], "t_base"));
    assert_ne!(named(&cks[1], "m_base"), named(&cks[2], "m_base"));
    assert_ne!(named(&cks[1], "head"), named(&cks[2], "head"));
    // The idle base's Adam moments stay too: no T-Base state before the first text step, the M-Base's
    // unchanged across it, the T-Base's unchanged across the next music step.
    assert!(adam_state(&cks[0], "t_base").is_empty());
    assert!(!adam_state(&cks[0], "m_base").is_empty());
    assert_eq!(adam_state(&cks[0], "m_base"), adam_state(&cks[1], "m_base"));
    assert!(!adam_state(&cks[1], "t_base").is_empty());
    assert_eq!(adam_state(&cks[1], "t_base"), adam_state(&cks[2], "t_base"));
    assert_ne!(adam_state(&cks[1], "m_base"), adam_state(&cks[2], "m_base"));
    assert_ne!(adam_state(&cks[0], "head"), adam_state(&cks[1], "head"));
    // One pair per synthetic-text training sequence and per caption of the text set's training motions.
    let log = std::fs::read_to_string(straight.join("train.log")).unwrap();
    let lines = |p: &Path| {
        std::fs::read_to_string(p)
            .unwrap()
            .lines()
            .filter(|l| !l.is_empty())
            .count()
    };
    let pairs =
        lines(&data.join("splits/crossmodal_train.txt")) + 2 * lines(&text_set.join("train.txt"));
    assert!(
        log.contains(&format!("text steps: {pairs} (embedding, motion) pairs")),
        "{log}"
    );
    // Resumed after the text step: the same weights and losses.
    let split = dir.path().join("split");
    train("control/gpt_tiny.toml", &data, &split, &gpt_sets(2), false);
    train("control/gpt_tiny.toml", &data, &split, &gpt_sets(3), true);
    let last = |r: &Path| checkpoints(r).last().unwrap().clone();
    assert_eq!(params_hash(&last(&straight)), params_hash(&last(&split)));
    assert_eq!(losses(&straight), losses(&split));

    // Text control (SPEC §13.7): the T-Base's view of krump fused in over 2.5–3.5 s of the dance.
    let song = shared().join("music/Kevin_MacLeod_-_Vibe_Ace.ogg");
    let sample = |out: &Path, extra: &[&str]| {
        let mut c = qean();
        c.args(["sample", "--frames", "240", "--run"])
            .arg(&straight)
            .arg("--music")
            .arg(&song)
            .args(extra)
            .arg("--out")
            .arg(out);
        c
    };
    let joints = |out: &Path| {
        qean_io::npy::read(&out.join("Kevin_MacLeod_-_Vibe_Ace.joints.npy"))
            .unwrap()
            .data
    };
    let plain = dir.path().join("plain");
    run_ok(&mut sample(&plain, &[]));
    let texted = dir.path().join("texted");
    let interval = [
        "--text-embedding",
        "genre:KR",
        "--text-interval",
        "2.5..3.5",
    ];
    run_ok(&mut sample(&texted, &interval));
    let (a, b) = (joints(&plain), joints(&texted));
    assert_eq!(a.len(), b.len());
    // The seed stays; the tokens from the interval's first on (2.5 s = frame 150: token 18) change the dance.
    let frame = 72;
    assert_eq!(a[..120 * frame], b[..120 * frame]);
    assert_ne!(a, b, "text control changed nothing");
    let again = dir.path().join("texted_again");
    run_ok(&mut sample(&again, &interval));
    assert_eq!(joints(&again), b, "text control is deterministic");

    // Bad inputs: one line each, nothing written.
    let wrong = dir.path().join("wrong.npy");
    std::fs::write(
        &wrong,
        qean_io::testdata::npy_bytes("<f4", "(7,)", &[0u8; 28]),
    )
    .unwrap();
    let bad = dir.path().join("bad_text");
    for (extra, message) in [
        (
            vec![
                "--text-embedding",
                wrong.to_str().unwrap(),
                "--text-interval",
                "2.5..3.5",
            ],
            "a text embedding of 7 values; this GPT's T-Base takes gpt.text_dim = 512",
        ),
        (
            vec![
                "--text-embedding",
                "genre:KR",
                "--text-interval",
                "3.5..2.5",
            ],
            "the interval is empty or reversed",
        ),
        (
            vec![
                "--text-embedding",
                "genre:KR",
                "--text-interval",
                "0.5..1.0",
            ],
            "starts inside the seed",
        ),
        (
            vec!["--text-embedding", "genre:KR", "--text-interval", "2.5..30"],
            "ends after the dance",
        ),
        (
            vec![
                "--text-embedding",
                "genre:XX",
                "--text-interval",
                "2.5..3.5",
            ],
            "unknown genre `XX`",
        ),
        (
            vec![
                "--text-embedding",
                "genre:KR",
                "--text-interval",
                "2.5..3.5",
                "--text-embedding",
                "genre:WA",
                "--text-interval",
                "3.0..4.0",
            ],
            "--text-interval 2.5..3.5 overlaps 3..4: one text at a time",
        ),
        (
            vec![
                "--text-embedding",
                "genre:KR",
                "--text-interval",
                "2.5..3.05",
                "--text-embedding",
                "genre:WA",
                "--text-interval",
                "3.05..4.0",
            ],
            "--text-interval 2.5..3.05 and 3.05..4 share the token at 2.933 s (8 frames a token): start the second at 3.067 s or later",
        ),
        (
            vec![
                "--text-embedding",
                "genre:KR",
                "--text-embedding",
                "genre:WA",
                "--text-interval",
                "3.0..4.0",
            ],
            "2 --text-embedding for 1 --text-interval",
        ),
    ] {
        assert_clean_failure(&mut sample(&bad, &extra), message);
        assert!(
            !bad.join("Kevin_MacLeod_-_Vibe_Ace.pkl").exists(),
            "{message}"
        );
    }

    // The text evaluation (SPEC §13.10) with the set's test captions: three sets of dances, the distances.
    let mut c = qean();
    c.args([
        "eval",
        "--max-frames",
        "240",
        "--text-interval",
        "2.5..3.5",
        "--run",
    ])
    .arg(&straight)
    .arg("--data")
    .arg(&data)
    .arg("--text-set")
    .arg(&text_set);
    let out = run_ok(&mut c);
    assert!(out.contains("| fused (the run's schedule) |"), "{out}");
    let report: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(straight.join("eval/step-3/text.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(report["prompts"], 2, "{report}");
    assert!(report["dances"].as_u64().unwrap() > 0, "{report}");
    for key in ["fused_to_text_only", "plain_to_text_only"] {
        assert!(report[key].as_f64().unwrap().is_finite(), "{report}");
    }
    assert!(
        report["plain_to_text_only"].as_f64().unwrap() > 0.0,
        "{report}"
    );
    let mut c = qean();
    c.args(["eval", "--text-interval", "3.5..2.5", "--run"])
        .arg(&straight)
        .arg("--data")
        .arg(&data)
        .arg("--text-set")
        .arg(&text_set);
    assert_clean_failure(&mut c, "the interval is empty or reversed");

    // A broken text set: one line naming the file, no run directory.
    let broken = dir.path().join("broken_set");
    copy_tree(&text_set, &broken);
    qean_io::npy::write_f32(&broken.join("text_emb/000001.npy"), &[2, 7], &[0.0; 14]).unwrap();
    let bad_run = dir.path().join("bad_text_run");
    let mut sets = gpt_sets(1);
    sets.push(string_set("gpt.text_set", &broken));
    assert_clean_failure(
        &mut train_command("control/gpt_tiny.toml", &data, &bad_run, &sets, false),
        "000001.npy: embeddings of shape [2, 7]; expected (lines, 512)",
    );
    assert!(!bad_run.exists());
}

/// Keyframe control (SPEC §13.6): §13.9's counts, stage 3b over a frozen GPT with exact resume (only the
/// keyframe module moves), `qean sample --keyframe` editing the dance around the keyframe and nowhere
/// before it, and its bad inputs.
#[test]
fn keyframe_stage_trains_resumes_exactly_and_edits_around_the_keyframe() {
    for (preset, counts) in [
        ("control/keyframe_tiny.toml", ["66,560", "66,624"]),
        ("control/keyframe_paper.toml", ["28,348,416", "28,349,184"]),
    ] {
        let out = run_ok(qean().arg("inspect").arg(configs().join(preset)));
        for count in counts {
            assert!(out.contains(count), "{preset} {count}: {out}");
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let data = dataset(dir.path());
    let vq = dir.path().join("vq");
    train_small_vq(&data, &vq, 2);
    let gpt = dir.path().join("gpt");
    train_small_gpt(&data, &vq, &gpt, &[]);

    let kf_sets = |steps: u64, run: &Path| -> Vec<String> {
        let mut s: Vec<String> = GPT_SMALL.iter().map(|s| s.to_string()).collect();
        s.extend(
            [
                "train.batch_size=4",
                "train.checkpoint_every=2",
                "train.val_every=2",
            ]
            .iter()
            .map(|s| s.to_string()),
        );
        s.push(string_set("keyframe.gpt_run", run));
        s.push(format!("train.steps={steps}"));
        s
    };
    let straight = dir.path().join("kf");
    train(
        "control/keyframe_tiny.toml",
        &data,
        &straight,
        &kf_sets(4, &gpt),
        false,
    );
    let split = dir.path().join("kf_split");
    let cfg = "control/keyframe_tiny.toml";
    train(cfg, &data, &split, &kf_sets(2, &gpt), false);
    train(cfg, &data, &split, &kf_sets(4, &gpt), true);
    let last = |r: &Path| checkpoints(r).last().unwrap().clone();
    assert_eq!(params_hash(&last(&straight)), params_hash(&last(&split)));
    assert_eq!(losses(&straight), losses(&split));
    // The GPT is the GPT run's sampled weights, bit for bit; the module starts as their copy and moves.
    let frozen: Vec<(String, Vec<f32>)> = named_of(&last(&gpt), "", Weights::Sampled)
        .into_iter()
        .map(|p| (format!("gpt.{}", p.name), p.values))
        .collect();
    let inside: Vec<(String, Vec<f32>)> = named(&last(&straight), "gpt.")
        .into_iter()
        .map(|p| (p.name, p.values))
        .collect();
    assert_eq!(frozen, inside);
    let cks = checkpoints(&straight);
    assert_ne!(named(&cks[0], "keyframe."), named(&cks[1], "keyframe."));

    // A keyframe at frame 400 (token 50: tokens 44–56 predicted again) from frame 100 of a training motion.
    let motions = data.join("motions");
    let source = std::fs::read_dir(&motions)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| p.extension().is_some_and(|e| e == "pkl"))
        .unwrap();
    let song = shared().join("music/Kevin_MacLeod_-_Vibe_Ace.ogg");
    let sample = |run: &Path, out: &Path, extra: &[String]| {
        let mut c = qean();
        c.args([
            "sample",
            "--frames",
            "480",
            "--floor-window",
            "0",
            "--slide-window",
            "0",
        ])
        .arg("--run")
        .arg(run)
        .arg("--music")
        .arg(&song)
        .args(extra)
        .arg("--out")
        .arg(out);
        c
    };
    let joints = |out: &Path| {
        qean_io::npy::read(&out.join("Kevin_MacLeod_-_Vibe_Ace.joints.npy"))
            .unwrap()
            .data
    };
    let source_arg = source.display().to_string();
    let key: Vec<String> = ["--keyframes-from", &source_arg, "--keyframe-frames", "400"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let plain = dir.path().join("kf_plain");
    run_ok(&mut sample(&straight, &plain, &[]));
    let keyed = dir.path().join("kf_keyed");
    run_ok(sample(&straight, &keyed, &key).arg("--view"));
    // The page marks the keyframe on the dance's timeline.
    let page = std::fs::read_to_string(keyed.join("Kevin_MacLeod_-_Vibe_Ace.view.html")).unwrap();
    assert!(
        page.contains(r#""marks":[{"from":400,"label":"keyframe","to":400}]"#),
        "no keyframe mark in the page"
    );
    let (a, b) = (joints(&plain), joints(&keyed));
    assert_eq!(a.len(), b.len());
    // Before the masked span (token 44 = frame 352) less the decoder's reach, the dance is the same.
    let frame = 72;
    assert_eq!(a[..250 * frame], b[..250 * frame]);
    assert_ne!(a, b, "the keyframe changed nothing");
    // The same keyframe as a JSON file (frame 400's pose of the motion, axis-angle and translation).
    let motion = qean_motion::motion::read_motion(&source).unwrap();
    let pose: Vec<String> = motion.poses[400 * 72..401 * 72]
        .iter()
        .map(|v| v.to_string())
        .collect();
    let trans: Vec<String> = motion.trans[400 * 3..401 * 3]
        .iter()
        .map(|v| (v / motion.scaling).to_string())
        .collect();
    let json = dir.path().join("keys.json");
    let entry = |frame: usize, n: usize| {
        format!(
            r#"{{"keyframes": [{{"frame": {frame}, "pose_aa": [{}], "trans": [{}]}}]}}"#,
            pose[..n].join(", "),
            trans.join(", ")
        )
    };
    std::fs::write(&json, entry(400, 72)).unwrap();
    let from_json = dir.path().join("kf_json");
    let json_arg = json.display().to_string();
    run_ok(&mut sample(
        &straight,
        &from_json,
        &["--keyframes".into(), json_arg.clone()],
    ));
    assert_eq!(
        joints(&from_json),
        b,
        "the JSON keyframe is the motion's frame"
    );

    // keyframe.weights = "full_copy" (SPEC §13.6 option): a copy of the whole M-Base and head trains, the
    // GPT stays frozen, and the keyframe edits the dance after its masked span only.
    let full = dir.path().join("kf_full");
    let mut sets = kf_sets(2, &gpt);
    sets.push("keyframe.weights=\"full_copy\"".into());
    train(cfg, &data, &full, &sets, false);
    let inside_full: Vec<(String, Vec<f32>)> = named(&last(&full), "gpt.")
        .into_iter()
        .map(|p| (p.name, p.values))
        .collect();
    assert_eq!(frozen, inside_full);
    assert!(!named(&last(&full), "keyframe.full.m_base.blocks").is_empty());
    assert!(named(&last(&full), "keyframe.m_attn").is_empty());
    let full_keyed = dir.path().join("kf_full_keyed");
    run_ok(&mut sample(&full, &full_keyed, &key));
    let c = joints(&full_keyed);
    assert_eq!(a[..250 * frame], c[..250 * frame]);
    assert_ne!(a, c, "the full copy's keyframe changed nothing");

    // Bad inputs: one line each, nothing written.
    let bad = dir.path().join("bad_kf");
    let frames = |f: &str| -> Vec<String> {
        vec![
            "--keyframes-from".into(),
            source_arg.clone(),
            "--keyframe-frames".into(),
            f.into(),
        ]
    };
    let short = dir.path().join("short.json");
    std::fs::write(&short, entry(400, 69)).unwrap();
    for (run, extra, message) in [
        (&gpt, key.clone(), "--keyframe needs a keyframe-control run"),
        (&straight, frames("60"), "is inside the seed"),
        (&straight, frames("9999"), "the motion has"),
        (
            &straight,
            vec!["--keyframes".into(), short.display().to_string()],
            "pose_aa has 69 values",
        ),
    ] {
        assert_clean_failure(&mut sample(run, &bad, &extra), message);
        assert!(
            !bad.join("Kevin_MacLeod_-_Vibe_Ace.joints.npy").exists(),
            "{message}"
        );
    }
    // After the dance of 120 + 480 frames.
    std::fs::write(&json, entry(700, 72)).unwrap();
    let mut c = sample(&straight, &bad, &["--keyframes".into(), json_arg]);
    assert_clean_failure(&mut c, "is after the dance");
    // The fidelity test (SPEC §13.10): ground-truth poses at generated frame 240 of each test + val dance.
    let table = run_ok(
        qean()
            .args(["eval", "--run"])
            .arg(&straight)
            .arg("--data")
            .arg(&data)
            .args(["--max-frames", "300"]),
    );
    assert!(
        table.contains("# Keyframe fidelity") && table.contains("with keyframes"),
        "{table}"
    );
    let report: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(straight.join("eval/step-4/keyframe.json")).unwrap(),
    )
    .unwrap();
    assert!(report["keyframes"].as_u64().unwrap() >= 1, "{report}");
    for set in ["edited", "plain"] {
        let e = report[set]["kf_mpjpe"].as_f64().unwrap();
        assert!(e.is_finite() && e > 0.0, "{set}: {report}");
    }
    // Unified sampling (SPEC §13.8): the GPT run with the keyframe run's module dances the keyframe run's
    // dance; a module trained over another GPT is refused.
    let unified = dir.path().join("kf_unified");
    let mut extra = key.clone();
    extra.extend(["--keyframe-run".to_string(), straight.display().to_string()]);
    run_ok(&mut sample(&gpt, &unified, &extra));
    assert_eq!(
        joints(&unified),
        b,
        "the plugged-in module gives the keyframe run's dance"
    );
    let other_gpt = dir.path().join("gpt_other");
    train_small_gpt(&data, &vq, &other_gpt, &["train.seed=7"]);
    assert_clean_failure(
        &mut sample(&other_gpt, &dir.path().join("kf_other"), &extra),
        "trained over another GPT",
    );
    // `keyframe.tokenize = "paste"`: the pose written into the decoded dance and encoded again.
    let paste = dir.path().join("kf_paste");
    let mut sets = kf_sets(1, &gpt);
    sets.push("keyframe.tokenize=\"paste\"".into());
    train(cfg, &data, &paste, &sets, false);
    run_ok(&mut sample(
        &paste,
        &dir.path().join("kf_paste_dance"),
        &key,
    ));
    let no_gpt = dir.path().join("kf_none");
    let mut c = train_command(cfg, &data, &no_gpt, &["train.steps=1".to_string()], false);
    assert_clean_failure(&mut c, "keyframe.gpt_run is not set");
}
