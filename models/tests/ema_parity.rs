//! SPEC §13.11 test 5: the EMA quantiser step equals the numpy transcription of T2M-GPT's
//! `QuantizeEMAReset` (tools/make_control_fixtures.py) step by step: indices exactly, perplexity, codebook,
//! sums and counts to f32 rounding, on the same SplitMix64 stream.

use qean_models::vqvae::quantize::{EmaCodebook, EmaOptions, SplitMix64};
use std::path::PathBuf;

fn floats(v: &serde_json::Value) -> Vec<f32> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap() as f32)
        .collect()
}

fn close(got: &[f32], want: &[f32], what: &str) {
    assert_eq!(got.len(), want.len(), "{what}");
    for (i, (a, b)) in got.iter().zip(want).enumerate() {
        assert!(
            (a - b).abs() <= 1e-5 * b.abs().max(1.0),
            "{what}[{i}]: {a} vs {b}"
        );
    }
}

fn run(name: &str) {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(format!("ema_{name}.json"));
    let f: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let (k, c) = (
        f["codes"].as_u64().unwrap() as usize,
        f["dim"].as_u64().unwrap() as usize,
    );
    let opts = EmaOptions {
        mu: f["mu"].as_f64().unwrap() as f32,
        randperm: f["randperm"].as_bool().unwrap(),
        reset_stats: f["reset_stats"].as_bool().unwrap(),
    };
    let mut rng = SplitMix64(f["seed"].as_u64().unwrap());
    let mut cb = EmaCodebook::new(k, c);
    for (s, step) in f["steps"].as_array().unwrap().iter().enumerate() {
        let z = floats(&step["z"]);
        let out = cb.train_step(&z, &mut rng, &opts);
        let want: Vec<usize> = step["indices"]
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_u64().unwrap() as usize)
            .collect();
        assert_eq!(out.indices, want, "{name} step {s}: indices");
        let p = step["perplexity"].as_f64().unwrap();
        assert!(
            (out.perplexity - p).abs() < 1e-5 * p,
            "{name} step {s}: {} vs {p}",
            out.perplexity
        );
        close(
            &cb.codebook,
            &floats(&step["codebook"]),
            &format!("{name} step {s}: codebook"),
        );
        close(
            &cb.code_sum,
            &floats(&step["code_sum"]),
            &format!("{name} step {s}: code_sum"),
        );
        close(
            &cb.code_count,
            &floats(&step["code_count"]),
            &format!("{name} step {s}: code_count"),
        );
    }
}

#[test]
fn ema_steps_equal_the_reference() {
    for name in ["n_ge_k", "n_lt_k", "randperm", "reset", "reset_stats"] {
        run(name);
    }
}

#[test]
fn a_reset_code_takes_its_candidate_row() {
    // The "reset" fixture: a code unused in the batch (count 0.99 < 1) becomes candidate row k.
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/ema_reset.json");
    let f: serde_json::Value = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let first = &f["steps"][0];
    let counts = floats(&first["code_count"]);
    let z = floats(&first["z"]);
    let codebook = floats(&first["codebook"]);
    let reset: Vec<usize> = (0..4).filter(|&k| counts[k] < 1.0).collect();
    assert!(!reset.is_empty(), "{counts:?}");
    for k in reset {
        assert_eq!(&codebook[k * 3..k * 3 + 3], &z[k * 3..k * 3 + 3]);
    }
}
