//! Helpers shared by the end-to-end tests.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

pub fn qean() -> Command {
    Command::new(env!("CARGO_BIN_EXE_qean"))
}

pub fn shared() -> PathBuf {
    qean_data::testdata::shared_dir()
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
