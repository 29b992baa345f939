//! Helpers shared by the end-to-end tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

pub fn qean() -> Command {
    Command::new(env!("CARGO_BIN_EXE_qean"))
}

pub fn shared() -> PathBuf {
    qean_io::testdata::shared_dir()
}

/// Whether python3 can import `module`. When QEAN_REQUIRE_PYTHON is set (CI), a missing module is a failure,
/// so the Python checks can never be skipped silently.
pub fn python_has(module: &str) -> bool {
    let ok = Command::new("python3")
        .args(["-c", &format!("import {module}")])
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    if !ok {
        assert!(
            std::env::var("QEAN_REQUIRE_PYTHON").is_err(),
            "QEAN_REQUIRE_PYTHON is set but python3 cannot import {module}"
        );
        eprintln!("skipping: python3 cannot import {module}");
    }
    ok
}

pub fn listing(dir: &Path) -> Vec<String> {
    let mut out = Vec::new();
    fn walk(d: &Path, base: &Path, out: &mut Vec<String>) {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            out.push(p.strip_prefix(base).unwrap().display().to_string());
            if p.is_dir() {
                walk(&p, base, out);
            }
        }
    }
    walk(dir, dir, &mut out);
    out.sort();
    out
}

/// Runs a command that must fail: non-zero exit, exactly one line on stderr naming `needle`, no panic.
pub fn assert_clean_failure(cmd: &mut Command, needle: &str) -> String {
    let out = cmd.output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(
        !out.status.success(),
        "expected failure, got success: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "panic: {stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "expected one error line, got: {stderr}");
    assert!(lines[0].starts_with("error: "), "{stderr}");
    assert!(
        stderr.contains(needle),
        "error does not mention {needle:?}: {stderr}"
    );
    stderr
}

// ---- Training runs (tiny presets shrunk so that a step takes well under a second in a debug build) ----

pub fn configs() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("configs")
}

/// A small synthetic AIST++-format dataset (8 train, 2 val, 2 test sequences of ~8 s).
pub fn dataset(dir: &Path) -> PathBuf {
    let out = dir.join("synth");
    let st = qean()
        .args(["synth", "--sequences", "12", "--seconds", "8", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    out
}

/// Overrides that make a tiny preset fast in debug builds.
pub const SMALL: [&str; 7] = [
    "model.hidden=16",
    "model.heads=2",
    "model.ffn=32",
    "model.motion_layers=1",
    "model.audio_layers=1",
    "model.cross_layers=1",
    "train.batch_size=2",
];

pub fn train_cmd(config: &str, data: &Path, run: &Path, extra: &[&str]) -> Command {
    let mut c = qean();
    c.arg("train")
        .arg("--config")
        .arg(configs().join(config))
        .arg("--data")
        .arg(data)
        .arg("--run-dir")
        .arg(run)
        .arg("--plain");
    for s in SMALL.iter().chain(extra) {
        c.arg("--set").arg(s);
    }
    c
}

pub fn run_ok(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    assert!(
        out.status.success(),
        "failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// metrics.csv without the wall-clock column.
pub fn losses(run: &Path) -> Vec<String> {
    std::fs::read_to_string(run.join("metrics.csv"))
        .unwrap()
        .lines()
        .map(|l| l.rsplit_once(',').unwrap().0.to_string())
        .collect()
}

pub fn params_hash(checkpoint: &Path) -> String {
    let text = run_ok(qean().arg("inspect").arg(checkpoint));
    text.lines()
        .find_map(|l| l.strip_prefix("params_hash: "))
        .unwrap_or_else(|| panic!("no params_hash line: {text}"))
        .to_string()
}

pub fn checkpoints(run: &Path) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(run.join("checkpoints"))
        .map(|d| d.map(|e| e.unwrap().path()).collect())
        .unwrap_or_default();
    v.retain(|p| {
        p.file_name()
            .unwrap()
            .to_string_lossy()
            .starts_with("step-")
    });
    v.sort_by_key(|p| checkpoint_step(p));
    v
}

/// The step of a checkpoint directory `step-N` (0 for another name).
pub fn checkpoint_step(dir: &Path) -> u64 {
    dir.file_name()
        .and_then(|n| n.to_str()?.strip_prefix("step-")?.parse().ok())
        .unwrap_or(0)
}

/// The training-set size a run's train.log reports ("(N train sequences").
pub fn train_sequences(run: &Path) -> usize {
    let log = std::fs::read_to_string(run.join("train.log")).unwrap();
    let (before, _) = log
        .split_once(" train sequences")
        .unwrap_or_else(|| panic!("no train-sequence count in {}", run.display()));
    before.rsplit('(').next().unwrap().parse().unwrap()
}

/// A copy of the directory tree `from` at `to`.
pub fn copy_tree(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        let target = to.join(path.file_name().unwrap());
        if path.is_dir() {
            copy_tree(&path, &target);
        } else {
            std::fs::copy(&path, &target).unwrap();
        }
    }
}
