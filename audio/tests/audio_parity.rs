//! Parity of the audio front end with librosa 0.8.1 + resampy 0.2.2 on the shared tracks (SPEC §2.8).
//! Fixtures: tools/make_audio_fixtures.py. Each test prints its worst errors.

mod common;

use common::*;
use qean_audio::decode::decode_file;
use qean_audio::features::{COL_BEAT, COL_CHROMA, COL_ENV, COL_MFCC, COL_ONSET};
use qean_audio::mel::MelBank;
use qean_audio::{self as audio, FeatureOptions, LoadOptions, Resampler, FEATURE_DIM};

fn track_file(key: &str) -> std::path::PathBuf {
    let meta = read_json(&fixture_dir().join(format!("{key}.json")));
    music_dir().join(meta["file"].as_str().unwrap())
}

/// Compare our 35-D feature with the fixture at the SPEC §2.8 tolerances.
fn check_track(key: &str) {
    let meta = read_json(&fixture_dir().join(format!("{key}.json")));
    let (shape, want) = read_npy(&fixture_dir().join(format!("{key}_feat35.npy")));
    let path = music_dir().join(meta["file"].as_str().unwrap());
    let f = audio::features_for_file(&path, &FeatureOptions::default()).unwrap();
    assert_eq!(shape, vec![f.frames, FEATURE_DIM], "{key}: frame count");
    let t = f.frames;
    let col = |data: &dyn Fn(usize) -> f64| (0..t).map(data).collect::<Vec<f64>>();

    // Envelope and MFCC: max abs error relative to each column's range.
    let mut worst_env = 0.0f64;
    let mut worst_mfcc = (0.0f64, 0usize);
    for c in COL_ENV..COL_MFCC + 20 {
        let w = col(&|i| want[i * FEATURE_DIM + c]);
        let o = f.column(c);
        let range = w.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - w.iter().cloned().fold(f64::INFINITY, f64::min);
        let err = w
            .iter()
            .zip(&o)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max)
            / range;
        if c == COL_ENV {
            worst_env = err;
        } else if err > worst_mfcc.0 {
            worst_mfcc = (err, c - COL_MFCC);
        }
    }
    // Chroma: mean abs error over all 12 columns.
    let mut chroma_sum = 0.0;
    let mut chroma_max = 0.0f64;
    for i in 0..t {
        for c in COL_CHROMA..COL_CHROMA + 12 {
            let e = (want[i * FEATURE_DIM + c] - f.data[i * FEATURE_DIM + c] as f64).abs();
            chroma_sum += e;
            chroma_max = chroma_max.max(e);
        }
    }
    let chroma_mean = chroma_sum / (12 * t) as f64;
    // Guard against a vacuous comparison: the reference chroma is not all zero, and ours neither.
    let ours_mass: f64 = (0..t)
        .map(|i| f.data[i * FEATURE_DIM + COL_CHROMA] as f64)
        .sum();
    let want_mass: f64 = (0..t).map(|i| want[i * FEATURE_DIM + COL_CHROMA]).sum();
    assert!(ours_mass > 0.0 && want_mass > 0.0, "{key}: empty chroma");
    let want_onsets = usize_list(&meta["onsets"]);
    let want_beats = usize_list(&meta["beats_120"]);
    let on = event_diff(&f.onsets, &want_onsets);
    let be = event_diff(&f.beats, &want_beats);
    let tempo = meta["tempo_120"].as_f64().unwrap();
    let tuning = meta["tuning"].as_f64().unwrap();
    println!(
        "{key}: frames {t}; env max err {:.2e} of range; MFCC worst max err {:.2e} of range (coef {}); \
         chroma mean |err| {:.2e} (max {:.2e}); onsets {} vs {} (off-by-1 {}, further {}); \
         beats {} vs {} (off-by-1 {}, further {}); tempo {} vs {}; tuning {} vs {}",
        worst_env,
        worst_mfcc.0,
        worst_mfcc.1,
        chroma_mean,
        chroma_max,
        f.onsets.len(),
        want_onsets.len(),
        on.0,
        on.1,
        f.beats.len(),
        want_beats.len(),
        be.0,
        be.1,
        f.tempo_bpm,
        tempo,
        f.tuning,
        tuning
    );
    // One-hot columns agree with the event lists.
    for i in 0..t {
        assert_eq!(
            f.data[i * FEATURE_DIM + COL_ONSET] == 1.0,
            f.onsets.contains(&i)
        );
        assert_eq!(
            f.data[i * FEATURE_DIM + COL_BEAT] == 1.0,
            f.beats.contains(&i)
        );
    }
    assert!(worst_env <= 1e-3, "{key}: envelope error {worst_env}");
    assert!(worst_mfcc.0 <= 1e-3, "{key}: MFCC error {:?}", worst_mfcc);
    assert!(chroma_mean <= 0.02, "{key}: chroma error {chroma_mean}");
    for (what, d, n) in [
        ("onsets", on, want_onsets.len()),
        ("beats", be, want_beats.len()),
    ] {
        assert_eq!(d.2, 0, "{key}: {what} count differs");
        assert_eq!(d.1, 0, "{key}: {what} more than one frame off");
        assert!(
            d.0 as f64 <= 0.02 * n as f64,
            "{key}: {what}: {} off by one",
            d.0
        );
    }
    assert_eq!(f.tempo_bpm, tempo, "{key}: tempo");
}

#[test]
fn parity_vibe_ace_wav() {
    check_track("vibe_ace_wav");
}

#[test]
fn parity_vibe_ace_ogg() {
    check_track("vibe_ace_ogg");
}

#[test]
fn parity_brahms_wav() {
    check_track("brahms_wav");
}

#[test]
fn parity_brahms_ogg() {
    check_track("brahms_ogg");
}

#[test]
fn parity_trumpet_wav() {
    check_track("trumpet_wav");
}

#[test]
fn parity_trumpet_ogg() {
    check_track("trumpet_ogg");
}

#[test]
fn decoding_matches_libsndfile() {
    for key in [
        "vibe_ace_wav",
        "vibe_ace_ogg",
        "brahms_wav",
        "brahms_ogg",
        "trumpet_wav",
        "trumpet_ogg",
    ] {
        let meta = read_json(&fixture_dir().join(format!("{key}.json")));
        let d = decode_file(&track_file(key), 3600.0).unwrap();
        let sum: f64 = d.samples.iter().map(|&v| v as f64).sum();
        let sum_sq: f64 = d.samples.iter().map(|&v| (v as f64) * (v as f64)).sum();
        let (ws, wsq) = (
            meta["native_sum"].as_f64().unwrap(),
            meta["native_sum_sq"].as_f64().unwrap(),
        );
        println!(
            "{key}: {} frames at {} Hz, {} ch; sum {sum:.6} vs {ws:.6}; energy {sum_sq:.6} vs {wsq:.6}",
            d.samples.len(),
            d.rate,
            d.channels
        );
        assert_eq!(
            d.samples.len() as u64,
            meta["native_frames"].as_u64().unwrap(),
            "{key}"
        );
        assert_eq!(
            d.rate as u64,
            meta["native_rate"].as_u64().unwrap(),
            "{key}"
        );
        assert_eq!(
            d.channels as u64,
            meta["native_channels"].as_u64().unwrap(),
            "{key}"
        );
        assert!((sum_sq - wsq).abs() <= 1e-4 * wsq, "{key}: energy");
        if key.ends_with("wav") {
            assert!((sum - ws).abs() < 1e-6, "{key}: PCM decode must be exact");
        }
    }
}

#[test]
fn resampler_matches_resampy() {
    let path = track_file("trumpet_wav");
    for (filter, file) in [
        (Resampler::KaiserBest, "trumpet_resampled_best.npy"),
        (Resampler::KaiserFast, "trumpet_resampled_fast.npy"),
    ] {
        let (shape, want) = read_npy(&fixture_dir().join(file));
        let a = audio::load_audio(
            &path,
            &LoadOptions {
                resampler: filter,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(shape, vec![a.samples.len()]);
        let mut max = 0.0f64;
        let mut n_diff = 0;
        for (x, y) in a.samples.iter().zip(&want) {
            let d = (x - y).abs();
            if d > 0.0 {
                n_diff += 1;
            }
            max = max.max(d);
        }
        println!(
            "{filter}: {} samples, {n_diff} differ from resampy 0.2.2, max abs diff {max:.3e}",
            a.samples.len()
        );
        assert!(max < 1e-6, "{filter}: {max}");
        assert_eq!(a.original_rate, 22050);
        assert!((a.duration - 117601.0 / 22050.0).abs() < 1e-12);
    }
}

#[test]
fn mel_filterbanks_match_librosa() {
    let banks = read_json(&fixture_dir().join("mel_filterbanks.json"));
    for (name, fmax) in [("fmax_11025", 11025.0), ("fmax_sr2", 15360.0)] {
        let ours = MelBank::new(30720.0, 2048, 128, 0.0, fmax);
        let rows = banks[name].as_array().unwrap();
        assert_eq!(rows.len(), 128);
        let mut worst = 0.0f64;
        for (m, row) in rows.iter().enumerate() {
            let start = row["start"].as_u64().unwrap() as usize;
            let vals: Vec<f64> = row["values"]
                .as_array()
                .unwrap()
                .iter()
                .map(|v| v.as_f64().unwrap())
                .collect();
            for k in 0..1025 {
                let w = if k >= start && k < start + vals.len() {
                    vals[k - start]
                } else {
                    0.0
                };
                worst = worst.max((ours.weight(m, k) - w).abs());
            }
        }
        println!("mel {name}: max abs weight error {worst:.3e}");
        assert!(worst < 1e-12, "{name}: {worst}");
    }
}

#[test]
fn trumpet_loop_tempo_is_120_even_with_a_90_prior() {
    // SPEC §2.8: the loop is stated 90 BPM, but librosa 0.8.1 locks to 120 BPM (period 30 frames).
    let meta = read_json(&fixture_dir().join("trumpet_wav.json"));
    for bpm in [90.0, 120.0] {
        let f = audio::features_for_file(
            &track_file("trumpet_wav"),
            &FeatureOptions {
                start_bpm: bpm,
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!(f.tempo_bpm, 120.0, "start_bpm {bpm}");
        let want = usize_list(&meta[if bpm == 90.0 { "beats_90" } else { "beats_120" }]);
        assert_eq!(f.beats, want, "start_bpm {bpm}");
        // Period 30 frames: the mean spacing is 30 ± 1 (the DP lets single gaps stretch, e.g. 32 or 28).
        let n = f.beats.len();
        let mean = (f.beats[n - 1] - f.beats[0]) as f64 / (n - 1) as f64;
        assert!((mean - 30.0).abs() <= 1.0, "spacing {:?}", f.beats);
    }
}

#[test]
fn bailando_hpss_beats_match_librosa() {
    for key in ["trumpet_wav", "brahms_wav", "vibe_ace_wav"] {
        let meta = read_json(&fixture_dir().join(format!("{key}.json")));
        let a = audio::load_audio(&track_file(key), &LoadOptions::default()).unwrap();
        let bt = audio::hpss::bailando_beats(&a.samples, 30720.0);
        let want = usize_list(&meta["hpss_beats"]);
        let d = event_diff(&bt.beats, &want);
        println!(
            "{key}: HPSS beats {} vs {} (off-by-1 {}, further {}), tempo {} vs {}",
            bt.beats.len(),
            want.len(),
            d.0,
            d.1,
            bt.tempo_bpm,
            meta["hpss_tempo"]
        );
        assert_eq!(bt.tempo_bpm, meta["hpss_tempo"].as_f64().unwrap(), "{key}");
        assert_eq!(d.2, 0, "{key}");
        assert_eq!(d.1, 0, "{key}");
        assert!(d.0 as f64 <= 0.02 * want.len() as f64, "{key}");
    }
}

/// SPEC §11.4/§11.13.4: librosa 0.8.1's delta (width 9, order 1, interp) equals scipy's
/// `savgol_filter(9, 1, deriv=1, mode='interp')` on the MFCC columns 1–13 of the librosa fixture
/// (fixture: tools/make_tsmt_fixtures.py); TSMT's audio rows carry the same values.
#[test]
fn tsmt_deltas_match_scipy_savgol() {
    let (shape, feat) = read_npy(&fixture_dir().join("vibe_ace_wav_feat35.npy"));
    let (dshape, want) = read_npy(&fixture_dir().join("vibe_ace_wav_delta13.npy"));
    let frames = shape[0];
    assert_eq!(dshape, vec![frames, 13]);
    let feat32: Vec<f32> = feat.iter().map(|&x| x as f32).collect();
    let mfcc: Vec<f64> = (0..frames)
        .flat_map(|t| (1..14).map(move |c| t * FEATURE_DIM + c))
        .map(|i| feat32[i] as f64)
        .collect();
    let got = qean_audio::delta::delta(&mfcc, frames, 13, 9);
    let worst = got
        .iter()
        .zip(&want)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f64, f64::max);
    println!("delta vs scipy: worst abs error {worst:.3e} over {frames} frames");
    assert!(worst < 1e-10, "{worst}");
    let (rows, beats) = qean_audio::delta::tsmt_audio(&feat32, frames);
    for t in [0, 3, 4, 1000, frames - 1] {
        for k in 0..13 {
            assert_eq!(rows[t * 26 + k], feat32[t * FEATURE_DIM + 1 + k]);
            assert!((rows[t * 26 + 13 + k] as f64 - want[t * 13 + k]).abs() < 1e-4);
        }
    }
    let n_beats = beats.iter().filter(|&&b| b == 1).count();
    let want_beats = (0..frames)
        .filter(|t| feat32[t * FEATURE_DIM + 34] == 1.0)
        .count();
    assert_eq!(n_beats, want_beats);
    assert!(n_beats > 10);
}
