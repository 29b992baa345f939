//! SPEC §12.8 parity: keys, DP, Euler, SLERP and Bézier on the shared AIST++ excerpt against the fixtures of
//! tools/make_keyframe_fixtures.py (numpy + scipy).

use qean_keyframes::bezier::{fit_pair, BezierParam};
use qean_keyframes::dp::{error_table, select, selection_cost, DpCombine, DpError};
use qean_keyframes::euler::{matrix_to_euler, motion_to_euler, EulerOrder};
use qean_keyframes::even::even_keys;
use qean_keyframes::select::{select_keys, Strategy};
use qean_keyframes::{slerp, KeyframeOptions};
use qean_motion::Motion;
use std::path::PathBuf;

fn fixture(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

fn excerpt() -> Motion {
    let p =
        qean_io::testdata::shared_dir().join("aistpp/motions/softcat477_sample_with_scaling.pkl");
    Motion::read_pkl(&p).unwrap()
}

fn npy(name: &str) -> (Vec<usize>, Vec<f64>) {
    let a = qean_io::npy::read(&fixture(name)).unwrap();
    (a.shape.clone(), a.data.clone())
}

fn json() -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(fixture("fixtures.json")).unwrap()).unwrap()
}

fn usizes(v: &serde_json::Value) -> Vec<usize> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_u64().unwrap() as usize)
        .collect()
}

#[test]
fn euler_xyz_equals_scipy() {
    let m = excerpt();
    let (shape, want) = npy("softcat_euler_xyz.npy");
    assert_eq!(shape, vec![127, 24, 3]);
    let mut worst: f64 = 0.0;
    for (i, r) in m.rotations().iter().enumerate() {
        let e = matrix_to_euler(r, EulerOrder::XYZ);
        for a in 0..3 {
            worst = worst.max((e[a] - want[3 * i + a]).abs());
        }
    }
    assert!(worst < 1e-13, "worst {worst:e}");
}

#[test]
fn dp_table_keys_and_costs_equal_the_numpy_transcription() {
    let m = excerpt();
    let opts = KeyframeOptions::default();
    let x = motion_to_euler(&m, opts.euler_order, true);
    let (shape, want) = npy("softcat_dp_E_40_52.npy");
    assert_eq!(shape, vec![13, 13]);
    let e = error_table(&x[40 * 75..53 * 75], 75, DpError::Chord);
    let worst = e
        .iter()
        .zip(&want)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(worst < 1e-12, "worst {worst:e}");

    let fx = json();
    let e = error_table(&x[..121 * 75], 75, DpError::Chord);
    for (n, key) in [(3, "dp_keys_n3"), (5, "dp_keys_n5"), (9, "dp_keys_n9")] {
        let (keys, _) = select(&e, 121, n, DpCombine::Max);
        assert_eq!(keys, usizes(&fx[key]), "N = {n}");
    }
    let (_, cost) = select(&e, 121, 5, DpCombine::Max);
    assert!((cost - fx["dp_cost_n5"].as_f64().unwrap()).abs() < 1e-12);
    let even = even_keys(0, 120, 5);
    assert_eq!(even, usizes(&fx["even_keys_n5"]));
    let even_cost = selection_cost(&e, 121, &even, DpCombine::Max);
    assert!((even_cost - fx["even_cost_n5"].as_f64().unwrap()).abs() < 1e-12);
    assert!(cost <= even_cost);
}

#[test]
fn strategies_on_the_excerpt_at_120_bpm() {
    let m = excerpt();
    let opts = KeyframeOptions::default();
    let even = select_keys(&m, None, Strategy::Even, 3, 120.0, 0, &opts).unwrap();
    assert_eq!(even.segments, vec![(0, 120), (120, 126)]);
    assert_eq!(&even.keyframes[..3], &[0, 60, 120]);
    let dp = select_keys(&m, None, Strategy::Dp, 5, 120.0, 0, &opts).unwrap();
    assert_eq!(&dp.keyframes[..5], &[0, 48, 72, 93, 120]);
    let even5 = select_keys(&m, None, Strategy::Even, 5, 120.0, 0, &opts).unwrap();
    for (d, e) in dp.segment_costs.iter().zip(&even5.segment_costs) {
        assert!(d <= e, "dp {d} > even {e}");
    }
    // Music strategies without a curve fail clearly.
    let err = select_keys(&m, None, Strategy::Onset, 5, 120.0, 0, &opts).unwrap_err();
    assert!(err.contains("needs music"), "{err}");
}

#[test]
fn slerp_equals_scipy() {
    let m = excerpt();
    let (shape, want) = npy("softcat_slerp_even5.npy");
    assert_eq!(shape, vec![127, 24, 3, 3]);
    let out = slerp::inbetween(&m, &[0, 30, 60, 90, 120, 126]);
    let mut worst: f64 = 0.0;
    for (i, r) in out.rotations().iter().enumerate() {
        for k in 0..9 {
            worst = worst.max((r[k] - want[9 * i + k]).abs());
        }
    }
    assert!(worst < 1e-9, "worst {worst:e}");
    for k in [0, 30, 60, 90, 120, 126] {
        assert_eq!(out.poses[k * 72..k * 72 + 72], m.poses[k * 72..k * 72 + 72]);
        assert_eq!(out.trans[k * 3..k * 3 + 3], m.trans[k * 3..k * 3 + 3]);
    }
}

#[test]
fn bezier_normal_equations_equal_scipy_lm() {
    let m = excerpt();
    let x = motion_to_euler(&m, EulerOrder::XYZ, true);
    let (_, want) = npy("bezier_lm.npy");
    for (i, case) in json()["bezier_cases"]
        .as_array()
        .unwrap()
        .iter()
        .enumerate()
    {
        let c = usizes(case);
        let channel: Vec<f64> = x.chunks_exact(75).map(|r| r[c[0]]).collect();
        let th = fit_pair(&channel, c[1], c[2], BezierParam::Handles).unwrap();
        for a in 0..2 {
            let w = want[2 * i + a];
            assert!(
                (th[a] - w).abs() <= 1e-8 * w.abs().max(1e-3),
                "case {c:?}: {th:?} vs {w}"
            );
        }
    }
}

#[test]
fn nmfd_equals_libnmfd() {
    use qean_keyframes::nmfd::{nmfd, random_templates, NmfdSize};
    let (vshape, v) = npy("nmfd_V.npy");
    let (_, want_h) = npy("nmfd_H.npy");
    let (_, want_cost) = npy("nmfd_cost.npy");
    let size = NmfdSize::default();
    // The seed-42 templates start with numpy's first draw over (1 + ΣW).
    let w = random_templates(vshape[0], &size);
    assert!(w[0] > 0.0 && (w[0] * 1025.0 * 8.0 / 0.3745401188473625 - 2.0).abs() < 0.1);
    let out = nmfd(&v, vshape[0], &size);
    assert_eq!(out.activations.len(), want_h.len());
    let hmax = want_h.iter().cloned().fold(0.0, f64::max);
    let mut worst: f64 = 0.0;
    for (a, b) in out.activations.iter().zip(&want_h) {
        worst = worst.max((a - b).abs() / b.abs().max(1e-6 * hmax));
    }
    assert!(worst < 1e-9, "H relative error {worst:e}");
    for (i, (a, b)) in out.cost.iter().zip(&want_cost).enumerate() {
        assert!((a - b).abs() <= 1e-9 * b.abs(), "cost {i}: {a} vs {b}");
    }
    // KL cost never rises after the first update.
    for w in out.cost[1..].windows(2) {
        assert!(w[1] <= w[0] * (1.0 + 1e-12), "{:?}", out.cost);
    }
}

#[test]
fn nmfd_drum_templates_equal_libnmfd() {
    // nmfd_init = drums: three column ranges of the fixture spectrogram stand in for the kick, snare and
    // hi-hat samples (tools/make_keyframe_fixtures.py runs libnmfd's steps on the same columns).
    use qean_keyframes::nmfd::{drum_templates, nmfd_from, NmfdSize};
    let (vshape, v) = npy("nmfd_V.npy");
    let (_, want_w) = npy("nmfd_drums_W.npy");
    let (_, want_h) = npy("nmfd_drums_H.npy");
    let (bins, frames) = (vshape[0], vshape[1]);
    let columns = |a: usize, b: usize| -> Vec<f64> {
        (0..bins)
            .flat_map(|k| v[k * frames + a..k * frames + b].to_vec())
            .collect()
    };
    let classes = [columns(0, 30), columns(30, 60), columns(60, 100)];
    let size = NmfdSize::default();
    let refs: Vec<&[f64]> = classes.iter().map(Vec::as_slice).collect();
    let w = drum_templates(&refs, bins, &size);
    let relative = |got: &[f64], want: &[f64]| {
        let top = want.iter().cloned().fold(0.0, f64::max);
        got.iter()
            .zip(want)
            .map(|(a, b)| (a - b).abs() / b.abs().max(1e-6 * top))
            .fold(0.0, f64::max)
    };
    assert_eq!(w.len(), want_w.len());
    let worst = relative(&w, &want_w);
    assert!(worst < 1e-9, "W relative error {worst:e}");
    let out = nmfd_from(&v, bins, &size, w);
    let worst = relative(&out.activations, &want_h);
    assert!(worst < 1e-9, "H relative error {worst:e}");
}

#[test]
fn onset_detect_on_the_envelope_is_column_33() {
    // SPEC §12.3b: with the default picker, the peaks of M_onset (column 0) are column 33's onsets. The
    // librosa 0.8.1 feature fixtures of qean-audio carry both.
    use qean_keyframes::onset_keys::{peaks, PeakPicker};
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../audio/tests/fixtures");
    for name in ["vibe_ace_wav_feat35.npy", "brahms_wav_feat35.npy"] {
        let a = qean_io::npy::read(&dir.join(name)).unwrap();
        let frames = a.shape[0];
        let env: Vec<f64> = (0..frames).map(|t| a.data[t * 35]).collect();
        let want: Vec<usize> = (0..frames)
            .filter(|&t| a.data[t * 35 + 33] != 0.0)
            .collect();
        assert!(want.len() > 10, "{name}");
        assert_eq!(peaks(&env, PeakPicker::OnsetDetect), want, "{name}");
    }
}

#[test]
fn bezier_training_mean_is_deterministic_and_keys_stay_exact() {
    use qean_keyframes::bezier::{inbetween, BezierSettings, MeanTheta, ThetaSource};
    let m = excerpt();
    let keys = [0, 30, 60, 90, 120];
    let settings = BezierSettings::default();
    let fit = || {
        let mut t = MeanTheta::default();
        t.add(&m, &keys, &settings);
        t.add(&m, &[0, 40, 80, 120], &settings);
        t
    };
    assert_eq!(fit(), fit());
    let mean = fit();
    let out = inbetween(&m, &keys, ThetaSource::Mean(&mean), &settings);
    for &k in &keys {
        assert_eq!(
            out.poses[k * 72..(k + 1) * 72],
            m.poses[k * 72..(k + 1) * 72]
        );
        assert_eq!(out.trans[k * 3..(k + 1) * 3], m.trans[k * 3..(k + 1) * 3]);
    }
}

#[test]
fn a_saved_training_mean_draws_the_same_curves_and_refuses_other_settings() {
    use qean_keyframes::bezier::{
        inbetween, BezierParam, BezierSettings, MeanTheta, ThetaFile, ThetaSource,
    };
    use qean_keyframes::euler::EulerOrder;
    let m = excerpt();
    let keys = [0, 30, 60, 90, 120];
    let settings = BezierSettings::default();
    let mut mean = MeanTheta::default();
    mean.add(&m, &keys, &settings);
    mean.add(&m, &[0, 40, 80, 120], &settings);
    let file = ThetaFile::new(&mean, &settings, "even", 5, 2);
    let text = serde_json::to_string_pretty(&file).unwrap();
    let back: ThetaFile = serde_json::from_str(&text).unwrap();
    assert_eq!(back, file);
    let loaded = back.mean_for(&settings).unwrap();
    let direct = inbetween(&m, &keys, ThetaSource::Mean(&mean), &settings);
    let saved = inbetween(&m, &keys, ThetaSource::Mean(&loaded), &settings);
    assert_eq!(direct, saved, "θ survives the JSON round trip bit for bit");
    let chord = BezierSettings {
        param: BezierParam::Chord,
        ..settings
    };
    let e = back.mean_for(&chord).unwrap_err();
    assert!(e.contains("inbetween.bezier_param = handles"), "{e}");
    let yxz = BezierSettings {
        order: EulerOrder::YXZ,
        ..settings
    };
    assert!(back
        .mean_for(&yxz)
        .unwrap_err()
        .contains("keyframes.euler_order = XYZ"));
    let mut short = back.clone();
    short.theta.pop();
    assert!(short
        .mean_for(&settings)
        .unwrap_err()
        .contains("74 channels"));
    let mut nan = back;
    nan.theta[3] = Some([f64::NAN, 0.0]);
    assert!(nan.mean_for(&settings).unwrap_err().contains("channel 3"));
}
