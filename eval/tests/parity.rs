//! Parity with the reference formulas on the real AIST++ excerpt: values computed by the numpy/scipy
//! reimplementation in tools/crosscheck_metrics.py (`--write-fixture` regenerates the fixture). The
//! reference stores features as float32, hence the 1e-6 relative tolerance.

mod common;

use common::softcat_joints;
use qean_eval::beat_align::{score_generated, score_ground_truth};
use qean_eval::fid::fid;
use qean_eval::geometric::geometric_features;
use qean_eval::kinetic::kinetic_features;
use qean_eval::positions::prepare;
use qean_eval::{BaSegment, GeometricVariant, MetricsMode, PositionMode};
use serde_json::Value;

fn fixture() -> Value {
    let text = include_str!("fixtures/reference_metrics.json");
    serde_json::from_str(text).unwrap()
}

fn vec_of(v: &Value) -> Vec<f64> {
    serde_json::from_value(v.clone()).unwrap()
}

fn assert_close(name: &str, got: &[f64], want: &[f64]) {
    assert_eq!(got.len(), want.len(), "{name}");
    for (i, (g, w)) in got.iter().zip(want).enumerate() {
        let tol = 1e-6 * w.abs().max(1e-3);
        assert!((g - w).abs() <= tol, "{name}[{i}]: ours {g}, reference {w}");
    }
}

#[test]
fn kinetic_features_match_the_reference() {
    let f = fixture();
    let x = softcat_joints();
    assert_eq!(x.len(), 127);
    let zs = prepare(&x, PositionMode::ZeroStart);
    let e = &f["expected"];
    assert_close(
        "kinetic reference zero-start",
        &kinetic_features(&zs, MetricsMode::Reference).unwrap(),
        &vec_of(&e["kinetic_reference_zero_start"]),
    );
    assert_close(
        "kinetic corrected zero-start",
        &kinetic_features(&zs, MetricsMode::Corrected).unwrap(),
        &vec_of(&e["kinetic_corrected_zero_start"]),
    );
    assert_close(
        "kinetic reference absolute",
        &kinetic_features(
            &prepare(&x, PositionMode::MintAbsolute),
            MetricsMode::Reference,
        )
        .unwrap(),
        &vec_of(&e["kinetic_reference_absolute"]),
    );
}

#[test]
fn geometric_features_match_the_reference() {
    let f = fixture();
    let zs = prepare(&softcat_joints(), PositionMode::ZeroStart);
    let e = &f["expected"];
    for (key, variant, mode) in [
        (
            "geometric_manual_new_reference",
            GeometricVariant::ManualNew,
            MetricsMode::Reference,
        ),
        (
            "geometric_manual_new_corrected",
            GeometricVariant::ManualNew,
            MetricsMode::Corrected,
        ),
        (
            "geometric_legacy_reference",
            GeometricVariant::LegacyFairmotion,
            MetricsMode::Reference,
        ),
    ] {
        assert_close(
            key,
            &geometric_features(&zs, variant, mode).unwrap(),
            &vec_of(&e[key]),
        );
    }
}

#[test]
fn beat_align_matches_the_reference() {
    let f = fixture();
    let x = softcat_joints();
    let music: Vec<usize> = serde_json::from_value(f["music_beats"].clone()).unwrap();
    let seed = f["seed_frames"].as_u64().unwrap() as usize;
    let e = &f["expected"];
    let num = |k: &str| e[k].as_f64().unwrap();
    let gt = score_ground_truth(&x, &music);
    assert_close(
        "gt bailando",
        &[gt.bailando.unwrap()],
        &[num("gt_ba_bailando")],
    );
    assert_close("gt mint", &[gt.mint.unwrap()], &[num("gt_ba_mint")]);
    let gen = score_generated(&x, seed, x.len() - seed, &music, BaSegment::Generated);
    assert_close(
        "generated bailando",
        &[gen.bailando.unwrap()],
        &[num("gen_ba_bailando")],
    );
    assert_close(
        "generated mint",
        &[gen.mint.unwrap()],
        &[num("gen_ba_mint")],
    );
}

#[test]
fn fid_matches_scipy_sqrtm_on_full_rank_covariances() {
    let f = fixture();
    let rows = |k: &str| -> Vec<Vec<f64>> { serde_json::from_value(f[k].clone()).unwrap() };
    let got = fid(&rows("fid_a"), &rows("fid_b")).unwrap();
    let want = f["expected"]["fid_scipy"].as_f64().unwrap();
    assert!((got - want).abs() < 1e-9 * want, "ours {got}, scipy {want}");
}

#[test]
fn test_fk_reproduces_the_spec_sanity_values() {
    // SPEC §1.7 (edge root = smpl root − J0): frame-0 root and the head's height range.
    let x = softcat_joints();
    let root = x[0][0];
    let edge = [-0.2493, 1.8578, -0.1204];
    for a in 0..3 {
        assert!(
            (root[a] - common::J0[a] - edge[a]).abs() < 1e-4,
            "root {root:?}"
        );
    }
    let head: Vec<f64> = x.iter().map(|f| f[15][1] - common::J0[1]).collect();
    let (lo, hi) = head
        .iter()
        .fold((f64::MAX, f64::MIN), |(l, h), &y| (l.min(y), h.max(y)));
    assert!(
        (lo - 2.251).abs() < 1e-3 && (hi - 2.558).abs() < 1e-3,
        "head y in [{lo}, {hi}]"
    );
}

/// EDGE's PFC against its formula in numpy (tools/make_pfc_fixture.py) on the real excerpt: at our
/// 60 fps, at EDGE's 30 fps, the same frames turned z-up, with sliding feet, and held still.
#[test]
fn pfc_matches_edges_formula() {
    use qean_eval::pfc::{pfc, sequence_score, PfcVariant, SCALE};
    let f: Value = serde_json::from_str(include_str!("fixtures/pfc.json")).unwrap();
    let want = |k: &str| f["expected"][k].as_f64().unwrap();
    let x = softcat_joints();
    let close = |name: &str, got: f64, w: f64| {
        assert!(
            (got - w).abs() <= 1e-9 * w.abs().max(1e-12),
            "{name}: ours {got}, numpy {w}"
        );
    };
    close(
        "ours",
        pfc([x.as_slice()], PfcVariant::Ours).unwrap(),
        want("ours"),
    );
    close(
        "edge",
        pfc([x.as_slice()], PfcVariant::Edge).unwrap(),
        want("edge"),
    );
    let z_up: Vec<_> = x.iter().map(|f| f.map(|[a, b, c]| [a, -c, b])).collect();
    close(
        "edge_z_up",
        SCALE * sequence_score(&z_up, 2, 30.0, 2).unwrap(),
        want("edge_z_up"),
    );
    let sliding: Vec<_> = x
        .iter()
        .enumerate()
        .map(|(t, f)| f.map(|[a, b, c]| [a + 2e-4 * (t as f64).powf(1.5), b, c]))
        .collect();
    close(
        "sliding",
        pfc([sliding.as_slice()], PfcVariant::Ours).unwrap(),
        want("sliding"),
    );
    let still = vec![x[0]; 60];
    assert_eq!(
        pfc([still.as_slice()], PfcVariant::Ours),
        Some(want("still"))
    );
}
