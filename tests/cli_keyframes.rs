//! `qean keyframes` (SPEC §12.2–12.3) on the shared AIST++ excerpt at 120 BPM, and its bad inputs.

use std::path::{Path, PathBuf};
use std::process::Command;

mod common;
use common::*;

fn excerpt() -> PathBuf {
    shared().join("aistpp/motions/softcat477_sample_with_scaling.pkl")
}

fn keyframes(json: &Path, args: &[&str]) -> Command {
    let mut c = qean();
    c.arg("keyframes")
        .arg("--motion")
        .arg(excerpt())
        .arg("--json")
        .arg(json)
        .args(args);
    c
}

fn read(json: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap()
}

fn frames(v: &serde_json::Value) -> Vec<u64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap())
        .collect()
}

#[test]
fn even_and_dp_keys_on_the_excerpt() {
    let dir = tempfile::tempdir().unwrap();
    let even3 = dir.path().join("even3.json");
    run_ok(&mut keyframes(
        &even3,
        &["--bpm", "120", "--strategy", "even", "--n", "3"],
    ));
    let v = read(&even3);
    assert_eq!(v["strategy"], "even");
    assert_eq!(v["n"], 3);
    assert_eq!(v["segments"], serde_json::json!([[0, 120], [120, 126]]));
    assert_eq!(&frames(&v["keyframes"])[..3], &[0, 60, 120]);
    assert_eq!(*frames(&v["keyframes"]).last().unwrap(), 126);

    let even5 = dir.path().join("even5.json");
    run_ok(&mut keyframes(
        &even5,
        &["--bpm", "120", "--strategy", "even", "--n", "5"],
    ));
    let dp5 = dir.path().join("dp5.json");
    let out = run_ok(&mut keyframes(
        &dp5,
        &["--bpm", "120", "--strategy", "dp", "--n", "5"],
    ));
    assert!(out.contains("at 120 BPM (--bpm)"), "{out}");
    let (e, d) = (read(&even5), read(&dp5));
    assert_eq!(&frames(&d["keyframes"])[..5], &[0, 48, 72, 93, 120]);
    // Minimax cost of the first measure: the DP's keys never lose to even keys.
    let cost = |v: &serde_json::Value| v["segment_costs"][0].as_f64().unwrap();
    assert!(cost(&d) <= cost(&e), "dp {} > even {}", cost(&d), cost(&e));
    assert!((cost(&d) - 2.026).abs() < 1e-3 && (cost(&e) - 3.015).abs() < 1e-3);

    // Options travel through --set and land in the JSON.
    let sum = dir.path().join("sum.json");
    run_ok(&mut keyframes(
        &sum,
        &[
            "--bpm",
            "120",
            "--strategy",
            "dp",
            "--n",
            "5",
            "--set",
            "keyframes.dp_combine=sum",
        ],
    ));
    assert_eq!(read(&sum)["options"]["dp_combine"], "sum");
}

#[test]
fn onset_keys_from_music() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("onset.json");
    let music = shared().join("music/Kevin_MacLeod_-_Vibe_Ace.ogg");
    let mut c = keyframes(&json, &["--bpm", "120", "--strategy", "onset", "--n", "5"]);
    run_ok(c.arg("--music").arg(&music));
    let v = read(&json);
    let keys = frames(&v["keyframes"]);
    assert_eq!(&keys[..1], &[0]);
    assert!(keys.contains(&120) && keys.contains(&126));
    assert!(keys.windows(2).all(|w| w[0] < w[1]));
}

/// A mono 16-bit WAV at 30720 Hz of `seconds` seconds from f(sample index).
fn write_wav(path: &Path, seconds: f64, f: impl Fn(usize) -> f64) {
    let n = (30720.0 * seconds) as usize;
    let data: Vec<u8> = (0..n)
        .flat_map(|i| ((f(i).clamp(-1.0, 1.0) * 32000.0) as i16).to_le_bytes())
        .collect();
    std::fs::write(
        path,
        qean_io::testdata::wav_bytes(1, 30720, 1, 16, &data, data.len() as u32),
    )
    .unwrap();
}

#[test]
fn stem_and_nmfd_keys() {
    let dir = tempfile::tempdir().unwrap();
    let stems = dir.path().join("stems");
    std::fs::create_dir(&stems).unwrap();
    // Drum hits every 0.4 s (frames ≈ 24k); a bass line, quiet vocals and a pad without onsets.
    let tau = std::f64::consts::TAU;
    write_wav(&stems.join("drums.wav"), 2.5, |i| {
        if i % 12288 < 200 {
            0.8 * ((i % 12288) as f64 * 0.9).sin()
        } else {
            0.0
        }
    });
    write_wav(&stems.join("bass.wav"), 2.5, |i| {
        0.3 * (tau * 55.0 * i as f64 / 30720.0).sin()
    });
    write_wav(&stems.join("vocals.wav"), 2.5, |_| 0.0);
    write_wav(&stems.join("other.wav"), 2.5, |i| {
        0.2 * (tau * 330.0 * i as f64 / 30720.0).sin()
    });
    let mut keys = vec![];
    for strategy in ["stems", "nmfd"] {
        let json = dir.path().join(format!("{strategy}.json"));
        let mut c = keyframes(&json, &["--bpm", "120", "--strategy", strategy, "--n", "5"]);
        run_ok(c.arg("--stems").arg(&stems));
        let v = read(&json);
        keys.push(frames(&v["keyframes"]));
    }
    for (k, lead) in keys.iter().zip([0, 8]) {
        assert_eq!((k[0], *k.last().unwrap()), (0, 126));
        // The drum hits at multiples of 24 frames are the peaks both strategies key on; an NMFD activation
        // marks where its 8-frame template starts, so it may lead the hit.
        let near_hit = |f: usize| (1..5).any(|h| f + lead + 1 >= 24 * h && f <= 24 * h + 2);
        let on_hits = k
            .iter()
            .filter(|&&f| f > 0 && f < 120 && near_hit(f as usize))
            .count();
        assert!(on_hits >= 2, "{k:?}");
    }
    // nmfd_init = drums: templates learnt from kick/snare/hihat samples; the hits are still found.
    let samples = dir.path().join("drum_samples");
    for (class, hz) in [("kick", 60.0), ("snare", 900.0), ("hihat", 7000.0)] {
        std::fs::create_dir_all(samples.join(class)).unwrap();
        write_wav(&samples.join(class).join("a.wav"), 0.3, |i| {
            let t = i as f64 / 30720.0;
            (-t * 30.0).exp() * (tau * hz * t).sin()
        });
    }
    let json = dir.path().join("nmfd_drums.json");
    let templates = format!(
        "keyframes.nmfd_templates={:?}",
        samples.display().to_string()
    );
    let mut c = keyframes(
        &json,
        &[
            "--bpm",
            "120",
            "--strategy",
            "nmfd",
            "--n",
            "5",
            "--set",
            "keyframes.nmfd_init=drums",
            "--set",
            &templates,
        ],
    );
    run_ok(c.arg("--stems").arg(&stems));
    let k = frames(&read(&json)["keyframes"]);
    let near_hit = |f: usize| (1..5).any(|h| f + 9 >= 24 * h && f <= 24 * h + 2);
    assert!(
        k.iter()
            .filter(|&&f| f > 0 && f < 120 && near_hit(f as usize))
            .count()
            >= 2,
        "{k:?}"
    );
    std::fs::remove_file(samples.join("snare/a.wav")).unwrap();
    let json = dir.path().join("no_snare.json");
    let mut c = keyframes(
        &json,
        &[
            "--bpm",
            "120",
            "--strategy",
            "nmfd",
            "--set",
            "keyframes.nmfd_init=drums",
            "--set",
            &templates,
        ],
    );
    assert_clean_failure(c.arg("--stems").arg(&stems), "snare: no drum samples");
    let mut c = keyframes(
        &json,
        &[
            "--bpm",
            "120",
            "--strategy",
            "nmfd",
            "--set",
            "keyframes.nmfd_init=drums",
        ],
    );
    assert_clean_failure(c.arg("--stems").arg(&stems), "needs nmfd_templates");
    assert!(!json.exists());
    // The HPSS stand-in needs only the music.
    let json = dir.path().join("hpss.json");
    let music = shared().join("music/Kevin_MacLeod_-_Vibe_Ace.ogg");
    let mut c = keyframes(
        &json,
        &[
            "--bpm",
            "120",
            "--strategy",
            "stems",
            "--set",
            "keyframes.stem_source=hpss",
        ],
    );
    run_ok(c.arg("--music").arg(&music));
    assert_eq!(read(&json)["options"]["stem_source"], "hpss");
    // A missing stem names itself; nothing is written.
    std::fs::remove_file(stems.join("bass.wav")).unwrap();
    let json = dir.path().join("missing.json");
    let mut c = keyframes(&json, &["--bpm", "120", "--strategy", "stems"]);
    assert_clean_failure(c.arg("--stems").arg(&stems), "bass.wav: stem missing");
    assert_clean_failure(
        &mut keyframes(&json, &["--bpm", "120", "--strategy", "nmfd"]),
        "needs the stems",
    );
    assert!(!json.exists());
}

#[test]
fn bad_inputs_fail_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("k.json");
    assert_clean_failure(
        &mut keyframes(&json, &["--bpm", "120", "--strategy", "zigzag"]),
        "zigzag",
    );
    assert_clean_failure(
        &mut keyframes(&json, &["--bpm=0"]),
        "--bpm must be a positive",
    );
    assert_clean_failure(
        &mut keyframes(&json, &["--bpm=-80"]),
        "--bpm must be a positive",
    );
    assert_clean_failure(&mut keyframes(&json, &["--strategy", "even"]), "no tempo");
    assert_clean_failure(
        &mut keyframes(&json, &["--bpm", "120", "--strategy", "onset"]),
        "needs the music",
    );
    assert_clean_failure(
        &mut keyframes(&json, &["--bpm", "120", "--n", "1"]),
        "at least 2",
    );
    assert_clean_failure(
        &mut keyframes(
            &json,
            &["--bpm", "120", "--set", "keyframes.dp_space=quaternions"],
        ),
        "dp_space",
    );
    assert_clean_failure(
        &mut keyframes(&json, &["--bpm", "120", "--set", "train.steps=3"]),
        "only keyframes.*",
    );
    assert!(!json.exists());
    let missing_dir = dir.path().join("nope/k.json");
    assert_clean_failure(
        &mut keyframes(&missing_dir, &["--bpm", "120"]),
        "does not exist",
    );
    let mut c = qean();
    c.args(["keyframes", "--bpm", "120", "--json"])
        .arg(&json)
        .arg("--motion")
        .arg(dir.path().join("gone.pkl"));
    assert_clean_failure(&mut c, "gone.pkl");
    assert!(listing(dir.path()).is_empty());
}
