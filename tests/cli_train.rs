//! End-to-end tests of `qean train`, `qean sweep`, `qean export` and checkpoint inspection.
//!
//! The runs use a small synthetic dataset and the tiny presets shrunk further with `--set`, so
//! that each takes seconds in a debug build.

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::*;

#[test]
fn kill_9_then_resume_equals_an_uninterrupted_run() {
    let d = tempfile::tempdir().unwrap();
    let data = dataset(d.path());
    // QEAN full: dropout, SPE and QRA all active, so dropout's RNG must resume exactly too.
    let extra = [
        "train.steps=12",
        "train.checkpoint_every=3",
        "train.log_every=1",
        "train.val_every=4",
        "train.keep_last=10",
    ];
    let straight = d.path().join("straight");
    run_ok(&mut train_cmd("tiny/full.toml", &data, &straight, &extra));

    // Kill -9 at a random moment after the first checkpoint, then resume.
    let killed = d.path().join("killed");
    let mut child = train_cmd("tiny/full.toml", &data, &killed, &extra)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while checkpoints(&killed).is_empty() {
        assert!(start.elapsed() < Duration::from_secs(300), "no checkpoint");
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(Duration::from_millis(5));
    }
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .subsec_nanos();
    std::thread::sleep(Duration::from_millis((nanos % 400) as u64));
    let _ = child.kill(); // SIGKILL
    child.wait().unwrap();
    // Every checkpoint left behind loads.
    for ck in checkpoints(&killed) {
        params_hash(&ck);
    }
    let mut resume = qean();
    resume
        .arg("train")
        .arg("--resume")
        .arg(&killed)
        .arg("--plain");
    run_ok(&mut resume);

    assert_eq!(losses(&straight), losses(&killed), "metrics.csv differs");
    let last = |run: &Path| checkpoints(run).last().unwrap().clone();
    assert!(last(&straight).ends_with("step-12"));
    assert_eq!(params_hash(&last(&straight)), params_hash(&last(&killed)));

    // The inspect report has the parts the issue asks for.
    let text = run_ok(qean().arg("inspect").arg(last(&killed)));
    for want in [
        "step: 12 of 12",
        "config: qean",
        "optimiser: adam",
        "params_hash: ",
    ] {
        assert!(text.contains(want), "{want}: {text}");
    }
    // A run directory is summarised too.
    let text = run_ok(qean().arg("inspect").arg(&killed));
    assert!(text.contains("checkpoints: 4"), "{text}");
}

#[test]
fn lr_in_metrics_is_exactly_the_configured_step_function() {
    let d = tempfile::tempdir().unwrap();
    let data = dataset(d.path());
    let run = d.path().join("run");
    run_ok(&mut train_cmd(
        "tiny/fact.toml",
        &data,
        &run,
        &[
            "train.steps=10",
            "train.log_every=1",
            "train.checkpoint_every=10",
            "schedule.initial=3e-4",
            "schedule.boundaries=[3, 7]",
            "schedule.values=[2e-5, 1e-6]",
        ],
    ));
    let rows = qean_train::metrics_log::read(&run.join("metrics.csv")).unwrap();
    assert_eq!(rows.len(), 10);
    for r in &rows {
        // Row `step` counts updates applied; its update had 0-based index step - 1.
        let i = r.step - 1;
        let want = if i < 3 {
            3e-4
        } else if i < 7 {
            2e-5
        } else {
            1e-6
        };
        assert_eq!(r.lr, want, "step {}", r.step);
        assert!(r.loss.unwrap().is_finite());
    }
    assert!(rows.last().unwrap().val_loss.is_some());
    // The artefacts of a run.
    for f in ["config.toml", "metrics.csv", "train.log", "loss.png"] {
        assert!(run.join(f).is_file(), "{f}");
    }
    let png = std::fs::read(run.join("loss.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let log = std::fs::read_to_string(run.join("train.log")).unwrap();
    assert!(log.contains("step 10"), "{log}");

    // Export: every parameter, f32, same values as the checkpoint.
    let st = d.path().join("w.safetensors");
    let out = run_ok(qean().arg("export").arg(&run).arg("--out").arg(&st));
    assert!(out.contains("params_hash: "), "{out}");
    let (tensors, meta) = qean_models::params::read_safetensors(&st).unwrap();
    let ck = qean_checkpoint::checkpoint::resolve(&run).unwrap();
    let model = ck.load_model(&burn::tensor::Device::flex()).unwrap();
    let mut want = qean_models::params::named_parameters(&model);
    want.sort_by(|a, b| a.name.cmp(&b.name));
    assert_eq!(tensors, want);
    assert_eq!(meta["params_hash"], ck.state.params_hash);
    assert!(meta["model_config"].contains("hidden = 16"));
    // An independent reader: the safetensors layout parsed with json + numpy.
    if python_has("numpy") {
        let script = r#"
import json, struct, sys
import numpy as np
raw = open(sys.argv[1], 'rb').read()
n = struct.unpack('<Q', raw[:8])[0]
header = json.loads(raw[8:8 + n])
body = raw[8 + n:]
total = 0
for name, t in header.items():
    if name == '__metadata__':
        continue
    a, b = t['data_offsets']
    x = np.frombuffer(body[a:b], dtype='<f4').reshape(t['shape'])
    assert t['dtype'] == 'F32' and np.isfinite(x).all(), name
    total += x.size
print(len(header) - 1, total)
"#;
        let out = Command::new("python3")
            .args(["-c", script])
            .arg(&st)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let text = String::from_utf8_lossy(&out.stdout);
        let values: usize = want.iter().map(|p| p.values.len()).sum();
        assert_eq!(text.trim(), format!("{} {values}", want.len()));
    }
}

#[test]
fn sweep_of_the_tiny_ablation_summarises_variants_over_seeds() {
    let d = tempfile::tempdir().unwrap();
    let data = dataset(d.path());
    let out = d.path().join("sweep");
    let mut cmd = qean();
    cmd.arg("sweep")
        .arg("--config")
        .arg(configs().join("sweeps/tiny-ablation.toml"))
        .arg("--data")
        .arg(&data)
        .arg("--out")
        .arg(&out)
        .args(["--seeds", "0,1", "--only", "baseline,full"])
        .arg("--plain");
    for s in SMALL
        .iter()
        .chain(&["train.steps=2", "train.checkpoint_every=2"])
    {
        cmd.arg("--set").arg(s);
    }
    let text = run_ok(&mut cmd);
    let md = std::fs::read_to_string(out.join("summary.md")).unwrap();
    for v in ["baseline", "full"] {
        for seed in [0, 1] {
            assert!(
                md.contains(&format!("| {v}-seed{seed} | {v} | {seed} | 2 |")),
                "{v}: {md}"
            );
        }
        // Over the two seeds: an interval of every quantity (t with 1 degree of freedom).
        assert!(md.contains(&format!("| {v} | 2 | ")), "{md}");
    }
    assert!(md.contains("| full − baseline | 2 | "), "{md}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(json[1]["against"], "baseline", "{json}");
    assert!(text.contains("summary.csv"), "{text}");
    let csv = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5, "{csv}");
    // Again: every run is already finished and skipped.
    let again = run_ok(&mut cmd);
    let md2 = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert_eq!(md2.matches("finished earlier").count(), 4, "{again}\n{md2}");
}

/// configs/sweeps/table1-tiny.toml shortened (2 updates a stage, 2 seeds, 60 frames): every family,
/// the VQ-VAE → GPT → genre chain by `{runs}`/`{seed}`, and table1.{md,json}.
#[test]
fn table1_tiny_sweep_scores_every_family_over_seeds() {
    let d = tempfile::tempdir().unwrap();
    let data = dataset(d.path());
    let out = d.path().join("table1");
    let mut cmd = qean();
    cmd.arg("sweep")
        .arg("--config")
        .arg(configs().join("sweeps/table1-tiny.toml"))
        .arg("--data")
        .arg(&data)
        .arg("--out")
        .arg(&out)
        .args(["--seeds", "0,1", "--eval-frames", "60", "--plain"]);
    for s in SMALL.iter().chain(&[
        "train.steps=2",
        "train.checkpoint_every=2",
        "train.val_every=2",
        "train.log_every=1",
    ]) {
        cmd.arg("--set").arg(s);
    }
    run_ok(&mut cmd);
    let md = std::fs::read_to_string(out.join("table1.md")).unwrap();
    for v in ["fact", "qean", "tsmt", "gpt", "genre"] {
        assert!(md.contains(&format!("\n| {v} | 2 | ")), "{v}: {md}");
    }
    assert!(
        !md.contains("| vqvae |"),
        "the tokenizer is not a row: {md}"
    );
    assert!(md.contains("| ground truth, scored as fact, qean"), "{md}");
    assert!(
        md.contains("| QEAN | 30.1 | 11.5 | 7.82 | 9.37 | 0.239 |"),
        "{md}"
    );
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("table1.json")).unwrap()).unwrap();
    assert_eq!(json["rows"].as_array().unwrap().len(), 5, "{json}");
    let gpt = std::fs::read_to_string(out.join("gpt-seed1/config.toml")).unwrap();
    assert!(gpt.contains("vqvae-seed1"), "{gpt}");
    assert!(out.join("table1.png").is_file());

    // `qean report` rebuilds the same table from the runs' records, without training or evaluating.
    for f in ["table1.md", "table1.json", "table1.png", "summary.md"] {
        std::fs::remove_file(out.join(f)).unwrap();
    }
    let text = run_ok(qean().arg("report").arg(&out));
    assert!(text.contains("12 runs"), "{text}");
    assert_eq!(std::fs::read_to_string(out.join("table1.md")).unwrap(), md);
    assert!(out.join("table1.png").is_file());
    // Laid out as Table 2 with FACT as the baseline: paired differences.
    run_ok(
        qean()
            .arg("report")
            .arg(&out)
            .args(["--table", "table2", "--baseline", "fact"]),
    );
    let t2 = std::fs::read_to_string(out.join("table2.md")).unwrap();
    assert!(t2.contains("| qean − fact | 2 | "), "{t2}");
    assert_clean_failure(
        qean().arg("report").arg(&out).args(["--baseline", "nope"]),
        "baseline `nope`: no run of that variant here",
    );
    assert_clean_failure(
        qean().arg("report").arg(d.path().join("nowhere")),
        "nowhere",
    );

    // The same runs scored again under a named protocol: re-evaluated (another evaluator), and the
    // summary and the table say which protocol scored them.
    let mut cmd = qean();
    cmd.arg("sweep")
        .arg("--config")
        .arg(configs().join("sweeps/table1-tiny.toml"))
        .arg("--data")
        .arg(&data)
        .arg("--out")
        .arg(&out)
        .args(["--seeds", "0,1", "--eval-frames", "60", "--plain"])
        .args(["--only", "fact,qean", "--protocol-preset", "lodge"]);
    for s in SMALL.iter().chain(&[
        "train.steps=2",
        "train.checkpoint_every=2",
        "train.val_every=2",
        "train.log_every=1",
    ]) {
        cmd.arg("--set").arg(s);
    }
    run_ok(&mut cmd);
    let lodge = std::fs::read_to_string(out.join("table1.md")).unwrap();
    assert!(lodge.contains("Protocol: preset `lodge`"), "{lodge}");
    assert!(md.contains("Protocol: ours (no preset named"), "{md}");
    let row = |t: &str| {
        t.lines()
            .find(|l| l.starts_with("| qean | 2 |"))
            .unwrap()
            .to_string()
    };
    assert_ne!(
        row(&lodge),
        row(&md),
        "the same numbers under another protocol"
    );
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(summary.contains("Protocol: preset `lodge`"), "{summary}");
    let record = std::fs::read_to_string(out.join("qean-seed0/sweep.json")).unwrap();
    assert!(record.contains("protocol preset lodge"), "{record}");

    let bad = d.path().join("bad-preset.toml");
    std::fs::write(
        &bad,
        format!(
            "base = \"{}\"\nprotocol_preset = \"mint\"\n[[variant]]\nname = \"a\"\n",
            configs().join("tiny/fact.toml").display()
        ),
    )
    .unwrap();
    assert_clean_failure(
        qean()
            .arg("sweep")
            .arg("--config")
            .arg(&bad)
            .arg("--dry-run"),
        "protocol_preset: unknown protocol preset `mint`; expected bailando, edge or lodge",
    );
}

#[test]
fn bad_configs_and_resumes_fail_with_one_clear_line() {
    let d = tempfile::tempdir().unwrap();
    let data = dataset(d.path());
    let bad = d.path().join("bad.toml");
    std::fs::write(
        &bad,
        "extends = \"CONFIGS/tiny/fact.toml\"\n[train]\nsteps = 3\nbatchsize = 2\n"
            .replace("CONFIGS", &configs().display().to_string()),
    )
    .unwrap();
    let run = d.path().join("r");
    // Unknown key: file and line.
    assert_clean_failure(
        qean()
            .args(["train", "--config"])
            .arg(&bad)
            .arg("--data")
            .arg(&data),
        "bad.toml:4: unknown field `batchsize`",
    );
    // Wrong type from --set.
    assert_clean_failure(
        &mut train_cmd("tiny/fact.toml", &data, &run, &["train.steps=three"]),
        "--set train.steps=three",
    );
    // Missing dataset.
    assert_clean_failure(
        &mut train_cmd("tiny/fact.toml", &d.path().join("nowhere"), &run, &[]),
        "nowhere",
    );
    // No data given at all.
    assert_clean_failure(
        qean()
            .args(["train", "--config"])
            .arg(configs().join("tiny/fact.toml"))
            .arg("--run-dir")
            .arg(&run),
        "data.dir is not set",
    );
    // A short run, then: a fresh run into it, and a resume with another model.
    run_ok(&mut train_cmd(
        "tiny/fact.toml",
        &data,
        &run,
        &["train.steps=2", "train.checkpoint_every=2"],
    ));
    assert_clean_failure(
        &mut train_cmd("tiny/fact.toml", &data, &run, &["train.steps=2"]),
        "already holds a run",
    );
    let mut c = qean();
    c.arg("train").arg("--resume").arg(&run).args([
        "--set",
        "model.hidden=32",
        "--set",
        "train.steps=4",
    ]);
    assert_clean_failure(&mut c, "different model");
    // A checkpoint whose weights do not fit its config.
    let ck = checkpoints(&run).pop().unwrap();
    let cfg = ck.join("config.toml");
    let text = std::fs::read_to_string(&cfg).unwrap();
    std::fs::write(&cfg, text.replace("hidden = 16", "hidden = 32")).unwrap();
    assert_clean_failure(qean().arg("inspect").arg(&ck), "model.bpk");
    // Resume of something that is not a run.
    assert_clean_failure(
        qean()
            .arg("train")
            .arg("--resume")
            .arg(d.path().join("nothing")),
        "nothing",
    );
}

/// Runs a Python script with arguments; returns its stdout (python3 must be there: see python_has).
fn python(script: &str, args: &[&Path]) -> String {
    let out = Command::new("python3")
        .args(["-c", script])
        .args(args)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "python failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).trim().to_string()
}

#[test]
fn sample_writes_a_1200_frame_dance_for_vibe_ace_in_every_format() {
    let d = tempfile::tempdir().unwrap();
    let data = dataset(d.path());
    let run = d.path().join("run");
    run_ok(&mut train_cmd(
        "tiny/fact.toml",
        &data,
        &run,
        &["train.steps=2", "train.checkpoint_every=2"],
    ));
    let out = d.path().join("dances");
    let song = shared().join("music/Kevin_MacLeod_-_Vibe_Ace.ogg");
    let text = run_ok(
        qean()
            .args(["sample", "--run"])
            .arg(&run)
            .arg("--music")
            .arg(&song)
            .args(["--frames", "1200", "--render", "--name", "vibe", "--out"])
            .arg(&out),
    );
    assert!(
        text.contains("vibe: 120 seed + 1200 generated frames"),
        "{text}"
    );
    // The speed profile against the run's dataset, four 5-s spans, and a verdict.
    let motion = text
        .lines()
        .find(|l| l.trim_start().starts_with("motion: speed per 5 s "))
        .unwrap_or_else(|| panic!("no speed profile: {text}"));
    assert!(motion.contains("(reference "), "{motion}");
    assert!(
        ["dances", "FROZE", "JITTERS"]
            .iter()
            .any(|v| motion.ends_with(v)),
        "{motion}"
    );
    for f in [
        "vibe.pkl",
        "vibe.joints.npy",
        "vibe.bvh",
        "vibe.png",
        "vibe.gif",
    ] {
        assert!(out.join(f).is_file(), "{f}: {text}");
    }
    let joints = qean_io::npy::read(&out.join("vibe.joints.npy")).unwrap();
    assert_eq!(joints.shape, vec![1320, 24, 3]);
    let png = std::fs::read(out.join("vibe.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // IHDR: width and height of a real contact sheet.
    let width = u32::from_be_bytes(png[16..20].try_into().unwrap());
    let height = u32::from_be_bytes(png[20..24].try_into().unwrap());
    assert!(width >= 400 && height >= 200, "{width}×{height}");
    assert!(png.len() > 2_000, "{} bytes", png.len());
    if python_has("numpy") {
        let pkl = out.join("vibe.pkl");
        let got = python(
            r#"
import pickle, sys, numpy as np
d = pickle.load(open(sys.argv[1], "rb"))
p, t = d["smpl_poses"], d["smpl_trans"]
assert p.shape == (1320, 72) and t.shape == (1320, 3), (p.shape, t.shape)
assert np.isfinite(p).all() and np.isfinite(t).all()
print(int(d["seed_frames"]), float(d["smpl_scaling"][0]))
"#,
            &[&pkl],
        );
        assert_eq!(got, "120 1.0");
    }
    if python_has("bvh") {
        let bvh = out.join("vibe.bvh");
        let got = python(
            r#"
import sys
from bvh import Bvh
m = Bvh(open(sys.argv[1]).read())
print(len(m.get_joints_names()), m.nframes)
"#,
            &[&bvh],
        );
        assert_eq!(got, "24 1320");
    }

    // Bad inputs: one clear line, no partial files.
    let before = listing(&out);
    let short = d.path().join("short.wav");
    let st = qean()
        .args(["synth", "--sequences", "3", "--seconds", "2", "--out"])
        .arg(d.path().join("tiny-synth"))
        .status()
        .unwrap();
    assert!(st.success());
    let wav = std::fs::read_dir(d.path().join("tiny-synth/wav"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    std::fs::copy(&wav, &short).unwrap();
    let sample = |music: &Path, out: &Path| {
        let mut c = qean();
        c.args(["sample", "--run"])
            .arg(&run)
            .arg("--music")
            .arg(music)
            .arg("--out")
            .arg(out);
        c
    };
    assert_clean_failure(&mut sample(&short, &out), "short.wav");
    let garbage = d.path().join("garbage.ogg");
    std::fs::write(&garbage, b"not audio at all").unwrap();
    assert_clean_failure(&mut sample(&garbage, &out), "garbage.ogg");
    let blocker = d.path().join("file");
    std::fs::write(&blocker, b"x").unwrap();
    assert_clean_failure(&mut sample(&song, &blocker.join("sub")), "file");
    let mut c = sample(&song, &out);
    c.args(["--checkpoint", "step-7"]);
    assert_clean_failure(&mut c, "step-7");
    // A checkpoint whose weights do not fit its config (hidden 16 in the weights, 32 in the config).
    let ck = checkpoints(&run).last().unwrap().clone();
    let config = std::fs::read_to_string(ck.join("config.toml")).unwrap();
    assert!(config.contains("\nhidden = 16\n"), "{config}");
    let bad = d.path().join("bad-checkpoint");
    std::fs::create_dir(&bad).unwrap();
    for f in ["model.bpk", "optimizer.bpk", "state.json"] {
        std::fs::copy(ck.join(f), bad.join(f)).unwrap();
    }
    std::fs::write(
        bad.join("config.toml"),
        config.replace("\nhidden = 16\n", "\nhidden = 32\n"),
    )
    .unwrap();
    let mut c = sample(&song, &out);
    c.arg("--checkpoint").arg(&bad);
    assert_clean_failure(&mut c, "bad-checkpoint");
    assert_eq!(before, listing(&out), "a failed sample wrote files");
}

/// A run that diverges stops with one error line naming the last good checkpoint; no checkpoint with
/// non-finite weights is ever written, and the good ones still load.
#[test]
fn a_diverging_run_stops_cleanly_and_keeps_only_finite_checkpoints() {
    let d = tempfile::tempdir().unwrap();
    let data = dataset(d.path());
    let run = d.path().join("r");
    run_ok(&mut train_cmd(
        "tiny/fact.toml",
        &data,
        &run,
        &["train.steps=2", "train.checkpoint_every=1"],
    ));
    // Continue with a learning rate of 1e30: the first update breaks every weight.
    let mut c = qean();
    c.arg("train").arg("--resume").arg(&run).arg("--plain");
    for s in [
        "train.steps=5",
        "schedule.initial=1e30",
        "schedule.values=[1e30]",
    ] {
        c.arg("--set").arg(s);
    }
    // Progress lines (--plain) go to stderr too; the error is the one `error:` line.
    let out = c.output().unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    let errors: Vec<&str> = stderr
        .lines()
        .filter(|l| l.starts_with("error: "))
        .collect();
    assert_eq!(errors.len(), 1, "{stderr}");
    let err = errors[0];
    assert!(err.contains("training diverged"), "{err}");
    assert!(err.contains("after update 3"), "{err}");
    assert!(
        err.contains("last good checkpoint") && err.contains("step-2"),
        "{err}"
    );
    let left: Vec<String> = checkpoints(&run)
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(left, ["step-1", "step-2"]);
    for ck in checkpoints(&run) {
        params_hash(&ck);
    }
    let log = std::fs::read_to_string(run.join("train.log")).unwrap();
    assert!(log.contains("training diverged"), "{log}");
}

/// `--seed-start random:SEED` (SPEC §1.6, QEAN's "random motion seeds") in checkpoint-mode evaluation and
/// in `qean sample`: seeded draws recorded in report.json, the default staying mint's frame 0.
#[test]
fn seeds_start_at_zero_or_at_seeded_random_frames() {
    let d = tempfile::tempdir().unwrap();
    let data = dataset(d.path());
    let run = d.path().join("run");
    run_ok(&mut train_cmd(
        "tiny/fact.toml",
        &data,
        &run,
        &["train.steps=2", "train.checkpoint_every=2"],
    ));
    let eval = |extra: &[&str]| {
        let mut c = qean();
        c.args(["eval", "--run"])
            .arg(&run)
            .arg("--data")
            .arg(&data)
            .args(["--max-frames", "30", "--metrics-mode", "reference"])
            .args(extra);
        run_ok(&mut c);
    };
    let starts = |dir: &str| -> (String, Vec<u64>) {
        let text = std::fs::read_to_string(run.join("eval").join(dir).join("report.json")).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        let starts = v["pairings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p["seed_start"].as_u64().unwrap())
            .collect();
        (v["seed_start"].as_str().unwrap().to_string(), starts)
    };
    eval(&[]);
    let (mode, zero) = starts("step-2");
    assert_eq!(mode, "zero");
    assert!(zero.iter().all(|&s| s == 0), "{zero:?}");
    eval(&["--seed-start", "random:5", "--tag", "rnd"]);
    let (mode, random) = starts("step-2-rnd");
    assert_eq!(mode, "random:5");
    assert_eq!(random.len(), zero.len());
    assert!(random.iter().any(|&s| s > 0), "{random:?}");
    let md = std::fs::read_to_string(run.join("eval/step-2-rnd/report.md")).unwrap();
    assert!(md.contains("from a random start (random:5)"), "{md}");
    let bad = qean()
        .args(["eval", "--run"])
        .arg(&run)
        .arg("--data")
        .arg(&data)
        .args(["--seed-start", "sometimes"])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(
        err.contains("expected zero, random or random:SEED"),
        "{err}"
    );

    // qean sample: the seed's first frame comes from another place in the sequence.
    let ds = qean_aistpp::dataset::Dataset::open(&data).unwrap();
    let name = ds.split(qean_aistpp::dataset::Split::Test).remove(0);
    let song = shared().join("music/sorohanro_-_solo-trumpet-06.ogg");
    let sample = |start: &str, out: &str| {
        let dir = d.path().join(out);
        run_ok(
            qean()
                .args(["sample", "--run"])
                .arg(&run)
                .arg("--music")
                .arg(&song)
                .arg("--data")
                .arg(&data)
                .args(["--sequence", &name, "--seed-start", start, "--frames", "10"])
                .args(["--name", "s", "--out"])
                .arg(&dir),
        );
        qean_io::npy::read(&dir.join("s.joints.npy")).unwrap().data[..72].to_vec()
    };
    assert_ne!(sample("zero", "a"), sample("random:5", "b"));
}
