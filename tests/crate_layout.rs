//! The crates keep their concerns (docs/architecture.md): the metrics build without Burn, the config
//! without the audio and image stacks, the audio features without Burn or images; and functions stay
//! short enough to read.

use std::process::Command;

/// The package names in `cargo tree -p <package> -e normal` (normal dependencies only).
fn dependencies(package: &str) -> Vec<String> {
    let cargo = std::env::var("CARGO")
        .ok()
        .or(option_env!("CARGO").map(String::from))
        .unwrap_or_else(|| "cargo".into());
    let out = Command::new(cargo)
        .args([
            "tree",
            "--offline",
            "-e",
            "normal",
            "--prefix",
            "none",
            "-p",
            package,
        ])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "cargo tree -p {package}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .collect()
}

fn assert_none(package: &str, forbidden: impl Fn(&str) -> bool) {
    let deps = dependencies(package);
    assert!(deps.len() > 1, "{package}: no dependency tree");
    let bad: Vec<&String> = deps.iter().filter(|d| forbidden(d)).collect();
    assert!(bad.is_empty(), "{package} depends on {bad:?}");
}

#[test]
fn metrics_build_without_burn() {
    assert_none("qean-eval", |d| d.starts_with("burn"));
}

#[test]
fn config_builds_without_audio_or_images() {
    assert_none("qean-config", |d| {
        ["symphonia", "rustfft", "realfft", "png", "gif"].contains(&d) || d.starts_with("burn")
    });
}

#[test]
fn audio_features_build_without_burn_or_images() {
    assert_none("qean-audio", |d| {
        d.starts_with("burn") || d == "png" || d == "gif"
    });
}

/// anyhow belongs to the binaries: every library crate returns its own error type.
#[test]
fn libraries_have_their_own_error_types() {
    for package in [
        "qean-io",
        "qean-audio",
        "qean-motion",
        "qean-render",
        "qean-aistpp",
        "qean-synth",
        "qean-config",
        "qean-models",
        "qean-checkpoint",
        "qean-train",
        "qean-eval",
        "qean-pipeline",
        "qean-bench",
    ] {
        let deps = dependencies(package);
        assert!(
            !deps.iter().any(|d| d == "anyhow"),
            "{package} depends on anyhow"
        );
    }
}

/// No function outside tests is longer than 100 lines, except the pickle VM (one dispatch over
/// opcodes); tools/longest_functions.py prints the ten longest.
#[test]
fn functions_stay_short() {
    let root = env!("CARGO_MANIFEST_DIR");
    let out = Command::new("python3")
        .arg(format!("{root}/tools/longest_functions.py"))
        .args(["10", "--max", "100"])
        .output()
        .expect("python3 runs");
    assert!(
        out.status.success(),
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// The sampler and the evaluation (qean-pipeline) read checkpoints through qean-checkpoint, below the
/// trainer; only the benchmarks (qean-bench), which time the trainer's update, and the binary use it.
#[test]
fn sampler_does_not_depend_on_the_trainer() {
    assert_none("qean-pipeline", |d| d == "qean-train");
    assert_none("qean-checkpoint", |d| {
        d == "qean-train" || d == "qean-pipeline"
    });
}

/// No import loop inside qean-train: the families and the loop never name the registry (the one module
/// that names every family); only the crate root (its `train`) and the sweeps, which train any family, do.
#[test]
fn trainer_families_do_not_import_the_registry() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("train/src");
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        if ["lib.rs", "registry.rs", "sweep.rs"].contains(&name.as_str()) {
            continue;
        }
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(
            !text.contains("crate::registry") && !text.contains("crate::train("),
            "train/src/{name} imports the registry: a loop through the module that names every family"
        );
    }
}

#[test]
fn keyframes_build_without_burn_or_images() {
    assert_none("qean-keyframes", |d| {
        d.starts_with("burn") || d == "png" || d == "gif"
    });
}

/// The binary parses arguments and prints (issue 37): its sources (src/) stay under 2,500 lines; what it
/// runs lives in the library crates (the demo in qean-pipeline, the benchmarks in qean-bench).
#[test]
fn binary_stays_thin() {
    fn lines(dir: &std::path::Path) -> usize {
        std::fs::read_dir(dir)
            .expect("src/ is readable")
            .map(|e| e.expect("a directory entry").path())
            .map(|p| {
                if p.is_dir() {
                    lines(&p)
                } else if p.extension().is_some_and(|e| e == "rs") {
                    std::fs::read_to_string(&p)
                        .expect("a source file")
                        .lines()
                        .count()
                } else {
                    0
                }
            })
            .sum()
    }
    let n = lines(&std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    assert!(
        n < 2500,
        "src/ holds {n} lines; move what is not argument parsing or printing into a library crate"
    );
}
