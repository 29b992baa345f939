//! FineDance's layout end to end through the real binary (issue 42): a synthetic set in that layout, read,
//! checked, trained on, sampled and scored; `qean check-data` finding defects planted in it.

use std::path::{Path, PathBuf};

mod common;
use common::*;

fn synth(dir: &Path, layout: &str, sequences: &str, seconds: &str) {
    let st = qean()
        .args(["synth", "--layout", layout, "--sample-rate", "8000"])
        .args(["--sequences", sequences, "--seconds", seconds, "--out"])
        .arg(dir)
        .status()
        .unwrap();
    assert!(st.success());
}

/// [`synth`], then `qean check-data` on the set: it passes, names the layout and finds no defect.
fn synth_clean(dir: &Path, layout: &str, sequences: &str, seconds: &str) {
    synth(dir, layout, sequences, seconds);
    let (ok, text) = stdout_of(qean().arg("check-data").arg(dir));
    assert!(
        ok && text.contains(&format!("{layout} layout")) && text.contains("defects: 0"),
        "{text}"
    );
}

/// `qean train` of `config` (under configs/) on `ds` into `run`, two steps and `sets`; must succeed.
fn train(ds: &Path, config: &str, run: &Path, sets: &[String]) {
    let configs = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs");
    let (ok, text) = stdout_of(
        qean()
            .arg("train")
            .arg("--config")
            .arg(configs.join(config))
            .arg("--data")
            .arg(ds)
            .arg("--run-dir")
            .arg(run)
            .args(["--set", "train.steps=2"])
            .args(sets.iter().flat_map(|s| ["--set".to_string(), s.clone()])),
    );
    assert!(ok, "{config}: {text}");
}

fn stdout_of(cmd: &mut std::process::Command) -> (bool, String) {
    let out = cmd.output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!stderr.contains("panicked"), "{stderr}");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).to_string(),
    )
}

/// Each planted defect is found, one line naming its file, and the check exits non-zero: a NaN frame, a
/// truncated file, a motion longer than its music, a duplicated clip, an unknown genre label.
#[test]
fn check_data_finds_each_planted_defect() {
    let tmp = tempfile::tempdir().unwrap();
    let ds = tmp.path().join("fd");
    synth_clean(&ds, "finedance", "12", "3");
    let motion = |id: &str| ds.join("motion").join(format!("{id}.npy"));
    let ids: Vec<String> = std::fs::read_to_string(ds.join("splits/train.txt"))
        .unwrap()
        .lines()
        .map(String::from)
        .collect();
    let [nan, cut, long, dup, copy, label] = [0, 1, 2, 3, 4, 5].map(|i| ids[i].clone());
    let mut a = qean_io::npy::read(&motion(&nan)).unwrap();
    a.data[2 * 315 + 10] = f64::NAN;
    qean_io::npy::write_f64(&motion(&nan), &a.shape, &a.data).unwrap();
    let bytes = std::fs::read(motion(&cut)).unwrap();
    std::fs::write(motion(&cut), &bytes[..bytes.len() / 2]).unwrap();
    qean_io::wav::write_pcm16(
        &ds.join(format!("music_wav/{long}.wav")),
        &[0.0; 8000],
        8000,
    )
    .unwrap();
    std::fs::copy(motion(&dup), motion(&copy)).unwrap();
    std::fs::write(
        ds.join(format!("label_json/{label}.json")),
        r#"{"name": "x", "style1": "Street", "style2": "Polka"}"#,
    )
    .unwrap();
    let out = qean().arg("check-data").arg(&ds).output().unwrap();
    assert!(!out.status.success());
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(text.contains("defects: 5"), "{text}");
    let line = |id: &str, what: &str| {
        let hits: Vec<&str> = text
            .lines()
            .filter(|l| l.contains(&format!("/{id}.")) && l.contains(what))
            .collect();
        assert_eq!(hits.len(), 1, "{id} {what}: {text}");
    };
    line(&nan, "frame 2");
    line(&cut, "truncated");
    line(&long, "its music");
    line(&copy, &format!("the same clip as {dup}"));
    line(&label, "unknown FineDance genre \"Polka\"");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(stderr.lines().count(), 1, "{stderr}");
    assert!(stderr.contains("5 defect(s)"), "{stderr}");
}

/// The families train on a FineDance-layout set as on AIST++'s, sample a dance to one of its songs and are
/// scored under Lodge's protocol; genre control, which needs AIST++'s genres, refuses in one line.
#[test]
fn finedance_set_trains_samples_and_scores() {
    let tmp = tempfile::tempdir().unwrap();
    let ds = tmp.path().join("fd");
    synth(&ds, "finedance", "12", "5");
    let (ok, text) = stdout_of(qean().arg("inspect").arg(ds.join("music_wav/063.wav")));
    assert!(
        ok && text.contains("sample rate: 8000 Hz") && text.contains("feature frames: "),
        "{text}"
    );
    let run = |name: &str| tmp.path().join(name);
    train(&ds, "tiny/fact.toml", &run("fact"), &[]);
    train(&ds, "control/vqvae_tiny.toml", &run("vq"), &[]);
    let vq: PathBuf = run("vq");
    let gpt_set = format!("gpt.vqvae_run={}", vq.display());
    train(&ds, "control/gpt_tiny.toml", &run("gpt"), &[gpt_set]);
    let (ok, text) = stdout_of(
        qean()
            .args(["sample", "--run"])
            .arg(run("fact"))
            .arg("--data")
            .arg(&ds)
            .args(["--sequence", "063", "--frames", "240", "--out"])
            .arg(tmp.path().join("dances"))
            .arg("--music")
            .arg(ds.join("music_wav/063.wav")),
    );
    assert!(ok, "{text}");
    assert!(tmp.path().join("dances/063.pkl").is_file());
    let (ok, text) = stdout_of(
        qean()
            .args(["eval", "--protocol-preset", "lodge", "--run"])
            .arg(run("gpt"))
            .arg("--data")
            .arg(&ds),
    );
    assert!(ok && text.contains("protocol preset lodge"), "{text}");
    assert!(
        text.contains("| FineDance |") && !text.contains("| AIST++ |"),
        "{text}"
    );
    assert!(run("gpt").join("eval/step-2/report.md").is_file());
    // The genre judge learns FineDance's sixteen genres from its labels and reports on them.
    train(&ds, "control/genre_clf_tiny.toml", &run("clf"), &[]);
    let (ok, text) = stdout_of(
        qean()
            .arg("eval")
            .arg("--run")
            .arg(run("clf"))
            .arg("--data")
            .arg(&ds),
    );
    assert!(
        ok && text.contains("| Breaking |") && text.contains("(chance 0.06)"),
        "{text}"
    );
    let config = std::fs::read_to_string(run("clf").join("config.toml")).unwrap();
    assert!(config.contains("genres = \"finedance\""), "{config}");
    // Genre control over FineDance's sixteen: trains, dances a requested genre by its label, refuses an
    // AIST++ code, and runs the control test with the judge above.
    let gpt_set = format!("genre.gpt_run={}", run("gpt").display());
    train(&ds, "control/genre_tiny.toml", &run("genre"), &[gpt_set]);
    let (ok, text) = stdout_of(
        qean()
            .args(["sample", "--genre", "dai", "--frames", "240", "--run"])
            .arg(run("genre"))
            .arg("--music")
            .arg(ds.join("music_wav/063.wav"))
            .arg("--out")
            .arg(tmp.path().join("dai")),
    );
    assert!(ok && tmp.path().join("dai/063.pkl").is_file(), "{text}");
    assert_clean_failure(
        qean()
            .args(["sample", "--genre", "KR", "--run"])
            .arg(run("genre"))
            .arg("--music")
            .arg(ds.join("music_wav/063.wav"))
            .arg("--out")
            .arg(tmp.path().join("kr")),
        "unknown genre `KR`: expected one of Breaking",
    );
    let (ok, text) = stdout_of(
        qean()
            .args(["eval", "--max-frames", "240", "--run"])
            .arg(run("genre"))
            .arg("--data")
            .arg(&ds)
            .arg("--classifier")
            .arg(run("clf")),
    );
    assert!(
        ok && text.contains("× 16 requested genres") && text.contains("| Dai |"),
        "{text}"
    );
}

/// A FineDance set whose splits/ lacks a list, or whose motion has the wrong width: one error line naming the
/// file, and nothing written.
#[test]
fn bad_finedance_sets_fail_in_one_line() {
    let tmp = tempfile::tempdir().unwrap();
    let ds = tmp.path().join("fd");
    synth(&ds, "finedance", "6", "2");
    let config = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/tiny/fact.toml");
    let train = || {
        let mut c = qean();
        c.arg("train")
            .arg("--config")
            .arg(&config)
            .arg("--data")
            .arg(&ds);
        c.arg("--run-dir").arg(tmp.path().join("run"));
        c
    };
    std::fs::remove_file(ds.join("splits/test.txt")).unwrap();
    assert_clean_failure(&mut train(), "test.txt: split list missing");
    assert!(!tmp.path().join("run").exists());
    std::fs::write(ds.join("splits/test.txt"), "063\n").unwrap();
    let first = std::fs::read_to_string(ds.join("splits/train.txt")).unwrap();
    let first = first.lines().next().unwrap();
    qean_io::npy::write_f32(
        &ds.join(format!("motion/{first}.npy")),
        &[4, 159],
        &[0.0; 4 * 159],
    )
    .unwrap();
    assert_clean_failure(&mut train(), "315");
    assert!(!tmp.path().join("run").exists());
    // A genre run reads every label: an unknown one is one error line naming its file.
    std::fs::write(
        ds.join(format!("label_json/{first}.json")),
        r#"{"name": "x", "style1": "Street", "style2": "Polka"}"#,
    )
    .unwrap();
    let clf = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs/control/genre_clf_tiny.toml");
    assert_clean_failure(
        qean()
            .arg("train")
            .arg("--config")
            .arg(&clf)
            .arg("--data")
            .arg(&ds)
            .arg("--run-dir")
            .arg(tmp.path().join("clf")),
        &format!("{first}.json: unknown FineDance genre \"Polka\""),
    );
    assert!(!tmp.path().join("clf").exists());
}

/// A folder of a user's own dances (each NAME.pkl beside NAME.wav) trains and is scored like the others.
#[test]
fn a_folder_of_dances_trains_and_scores() {
    let tmp = tempfile::tempdir().unwrap();
    let ds = tmp.path().join("mine");
    synth_clean(&ds, "folder", "12", "5");
    let vq = tmp.path().join("vq");
    train(&ds, "control/vqvae_tiny.toml", &vq, &[]);
    let gpt_set = format!("gpt.vqvae_run={}", vq.display());
    train(
        &ds,
        "control/gpt_tiny.toml",
        &tmp.path().join("gpt"),
        &[gpt_set],
    );
    let (ok, text) = stdout_of(
        qean()
            .arg("eval")
            .arg("--run")
            .arg(tmp.path().join("gpt"))
            .arg("--data")
            .arg(&ds),
    );
    assert!(ok && text.contains("FID_k"), "{text}");
}
