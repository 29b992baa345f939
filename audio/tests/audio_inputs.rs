//! Decoding across formats, bad inputs (every one a clear error, never a panic), silence, and synthetic
//! click tracks at known tempi (SPEC §2.1, §2.6, §9 items 6–7).

mod common;

use std::path::Path;

use common::*;
use qean_audio::decode::decode_file;
use qean_audio::{self as audio, FeatureOptions, LoadOptions, FEATURE_DIM};
use qean_io::testdata::wav_bytes;

/// 16-bit PCM WAV of interleaved float samples in [−1, 1].
fn pcm16_wav(rate: u32, channels: u16, interleaved: &[f64]) -> Vec<u8> {
    let data: Vec<u8> = interleaved
        .iter()
        .flat_map(|&v| ((v * 32767.0).round() as i16).to_le_bytes())
        .collect();
    wav_bytes(1, rate, channels, 16, &data, data.len() as u32)
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> std::path::PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// The error for `path`, which must name the file; returns its text.
fn expect_err(path: &Path) -> String {
    let e = match audio::features_for_file(path, &FeatureOptions::default()) {
        Ok(f) => panic!("{}: accepted ({} frames)", path.display(), f.frames),
        Err(e) => e,
    };
    assert_eq!(
        e.path.as_deref(),
        Some(path),
        "error must name the file: {e}"
    );
    let s = e.to_string();
    println!("{}: {s}", path.file_name().unwrap().to_string_lossy());
    s
}

#[test]
fn every_format_decodes_like_libsndfile_and_matches_librosa() {
    let all = read_json(&fixture_dir().join("formats.json"));
    for (name, meta) in all.as_object().unwrap() {
        let path = fixture_dir().join("formats").join(name);
        let d = decode_file(&path, 60.0).unwrap();
        assert_eq!(d.rate as u64, meta["rate"].as_u64().unwrap(), "{name}");
        assert_eq!(
            d.channels as u64,
            meta["channels"].as_u64().unwrap(),
            "{name}"
        );
        let want_frames = meta["frames"].as_u64().unwrap() as usize;
        let head: Vec<f64> = meta["mono_head"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let head_err = head
            .iter()
            .zip(&d.samples)
            .map(|(a, &b)| (*a as f32 - b).abs() as f64)
            .fold(0.0, f64::max);
        let e: f64 = d.samples.iter().map(|&v| (v as f64).powi(2)).sum();
        let we = meta["mono_sum_sq"].as_f64().unwrap();
        let lossy = name.ends_with(".ogg") || name.ends_with(".mp3");

        let a = audio::load_audio(&path, &LoadOptions::default()).unwrap();
        let stride: Vec<f64> = meta["resampled_stride97"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_f64().unwrap())
            .collect();
        let res_err = stride
            .iter()
            .zip(a.samples.iter().step_by(97))
            // serde_json's float parsing may be 1 ulp off in f64: compare at the data's f32 precision.
            .map(|(x, y)| (*x as f32 as f64 - y).abs())
            .fold(0.0, f64::max);
        let f = audio::music_features(&a.samples, &FeatureOptions::default()).unwrap();
        let want: Vec<Vec<f64>> = meta["feat35"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| {
                r.as_array()
                    .unwrap()
                    .iter()
                    .map(|v| v.as_f64().unwrap())
                    .collect()
            })
            .collect();
        let mut worst = 0.0f64;
        for c in 0..21 {
            let col: Vec<f64> = want.iter().map(|r| r[c]).collect();
            let range = col.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
                - col.iter().cloned().fold(f64::INFINITY, f64::min);
            let err = (0..f.frames.min(want.len()))
                .map(|t| (col[t] - f.data[t * FEATURE_DIM + c] as f64).abs())
                .fold(0.0, f64::max);
            worst = worst.max(err / range.max(1e-12));
        }
        println!(
            "{name}: frames {} vs {want_frames}; head err {head_err:.2e}; energy {e:.6} vs {we:.6}; \
             resampled len {} vs {}, stride err {res_err:.2e}; env/MFCC worst {worst:.2e} of range; \
             beats {:?} vs {}; onsets {:?} vs {}",
            d.samples.len(),
            a.samples.len(),
            meta["resampled_len"],
            f.beats,
            meta["beats"],
            f.onsets,
            meta["onsets"]
        );
        assert_eq!(d.samples.len(), want_frames, "{name}: frame count");
        assert_eq!(
            a.samples.len() as u64,
            meta["resampled_len"].as_u64().unwrap(),
            "{name}"
        );
        assert_eq!(f.frames, want.len(), "{name}");
        if lossy {
            assert!((e - we).abs() < 1e-3 * we, "{name}: energy {e} vs {we}");
            assert!(head_err < 1e-3, "{name}");
            assert!(res_err < 1e-3, "{name}");
        } else {
            assert_eq!(head_err, 0.0, "{name}: lossless decode must be exact");
            assert!(res_err < 1e-6, "{name}: resampling must match resampy");
            assert!(worst <= 1e-3, "{name}: env/MFCC {worst}");
            assert_eq!(f.beats, usize_list(&meta["beats"]), "{name}");
            assert_eq!(f.onsets, usize_list(&meta["onsets"]), "{name}");
            assert_eq!(f.tempo_bpm, meta["tempo"].as_f64().unwrap(), "{name}");
        }
    }
}

#[test]
fn click_track_gives_its_tempo_and_spacing() {
    // Clicks every 0.5 s (120 BPM) and every 0.6 s (100 BPM): periods 30 and 36 frames, on the 3600/k
    // grid. Written as 44.1 kHz stereo 16-bit so decoding, downmix and resampling are exercised too.
    let dir = tempfile::tempdir().unwrap();
    for (bpm, period) in [(120.0, 30usize), (100.0, 36)] {
        let rate = 44100u32;
        let secs = 20.0;
        let n = (secs * rate as f64) as usize;
        let step = (60.0 / bpm * rate as f64) as usize;
        let mut x = vec![0.0; 2 * n];
        for start in (rate as usize / 10..n).step_by(step) {
            for k in 0..200.min(n - start) {
                // A short decaying 1 kHz burst.
                let v = 0.8
                    * (-(k as f64) / 40.0).exp()
                    * (2.0 * std::f64::consts::PI * 1000.0 * k as f64 / rate as f64).sin();
                x[2 * (start + k)] = v;
                x[2 * (start + k) + 1] = 0.5 * v;
            }
        }
        let path = write(
            dir.path(),
            &format!("clicks_{bpm}.wav"),
            &pcm16_wav(rate, 2, &x),
        );
        let f = audio::features_for_file(
            &path,
            &FeatureOptions {
                start_bpm: bpm,
                ..Default::default()
            },
        )
        .unwrap();
        println!("{bpm} BPM: tempo {} beats {:?}", f.tempo_bpm, f.beats);
        assert_eq!(f.tempo_bpm, bpm);
        assert!(
            f.beats.len() >= (secs * bpm / 60.0) as usize - 4,
            "{:?}",
            f.beats
        );
        for w in f.beats.windows(2) {
            assert!(
                w[1] - w[0] == period || w[1] - w[0] == period + 1 || w[1] - w[0] + 1 == period
            );
        }
        // Each click (at 0.1 s + k·step) is an onset peak within a frame or two.
        let n_clicks = (n - rate as usize / 10).div_ceil(step);
        assert!(f.onsets.len() >= n_clicks - 1, "{:?}", f.onsets);
    }
}

#[test]
fn silence_is_valid_with_no_beats() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "silence.wav",
        &pcm16_wav(22050, 1, &vec![0.0; 22050 * 3]),
    );
    let f = audio::features_for_file(&path, &FeatureOptions::default()).unwrap();
    assert_eq!(f.frames, 1 + (30720 * 3) / 512);
    assert!(f.beats.is_empty());
    assert!(f.onsets.is_empty());
    assert!(f.data.iter().all(|v| v.is_finite()));
}

#[test]
fn bad_inputs_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let good = std::fs::read(fixture_dir().join("formats/s16_stereo_48000.wav")).unwrap();
    let ogg = std::fs::read(fixture_dir().join("formats/vorbis_stereo_44100.ogg")).unwrap();
    let flac = std::fs::read(fixture_dir().join("formats/flac_stereo_44100.flac")).unwrap();

    let s = expect_err(&d.join("missing.wav"));
    assert!(s.contains("no such file"), "{s}");
    let s = expect_err(d);
    assert!(!s.is_empty());
    let s = expect_err(&write(d, "empty.wav", b""));
    assert!(s.contains("empty"), "{s}");
    let s = expect_err(&write(
        d,
        "text.wav",
        b"this is not audio at all, just some text\n",
    ));
    assert!(s.contains("unrecognised audio format"), "{s}");
    let s = expect_err(&write(d, "header_only.wav", &good[..44]));
    assert!(
        s.contains("no audio samples") || s.contains("truncated"),
        "{s}"
    );
    let s = expect_err(&write(d, "cut_header.wav", &good[..30]));
    assert!(!s.is_empty());
    let s = expect_err(&write(d, "truncated.wav", &good[..good.len() / 2]));
    assert!(s.contains("truncated"), "{s}");
    let s = expect_err(&write(d, "truncated.ogg", &ogg[..ogg.len() / 2]));
    assert!(s.contains("truncated") || s.contains("corrupt"), "{s}");
    let s = expect_err(&write(d, "truncated.flac", &flac[..flac.len() / 2]));
    assert!(s.contains("truncated") || s.contains("corrupt"), "{s}");
    // Corrupt compressed data: flip bytes in the middle (Ogg page CRC, FLAC frame CRC).
    for (name, src) in [("corrupt.ogg", &ogg), ("corrupt.flac", &flac)] {
        let mut b = src.clone();
        let m = b.len() / 2;
        for v in &mut b[m..m + 64] {
            *v ^= 0x5a;
        }
        let s = expect_err(&write(d, name, &b));
        assert!(s.contains("corrupt") || s.contains("truncated"), "{s}");
    }
    // Unsupported codecs: Opus in Ogg, ADPCM (feature off) and an unknown tag in a WAV.
    let s = expect_err(&fixture_dir().join("unsupported_opus.ogg"));
    assert!(s.contains("unsupported"), "{s}");
    let s = expect_err(&write(
        d,
        "adpcm.wav",
        &wav_bytes(2, 22050, 1, 4, &[0; 1024], 1024),
    ));
    assert!(s.contains("unsupported") || s.contains("corrupt"), "{s}");
    let s = expect_err(&write(
        d,
        "tag.wav",
        &wav_bytes(0x1234, 22050, 1, 16, &[0; 1024], 1024),
    ));
    assert!(s.contains("unsupported"), "{s}");
    // Absurd headers: no channels, zero or huge rate, 7-bit samples, a 4 GiB data chunk.
    for (name, bytes) in [
        (
            "zero_channels.wav",
            wav_bytes(1, 22050, 0, 16, &[0; 64], 64),
        ),
        ("zero_rate.wav", wav_bytes(1, 0, 1, 16, &[0; 64], 64)),
        ("huge_rate.wav", wav_bytes(1, u32::MAX, 1, 16, &[0; 64], 64)),
        ("odd_bits.wav", wav_bytes(1, 22050, 1, 7, &[0; 64], 64)),
        (
            "huge_data.wav",
            wav_bytes(1, 22050, 1, 16, &[0; 4096], u32::MAX - 8),
        ),
        (
            "many_channels.wav",
            wav_bytes(1, 22050, 60000, 16, &[0; 4096], 4096),
        ),
    ] {
        let s = expect_err(&write(d, name, &bytes));
        assert!(!s.is_empty());
    }
    // RIFF and data sizes both claiming 4 GiB over 4 KiB of samples: no huge allocation, and the
    // missing samples are reported.
    let mut b = wav_bytes(1, 22050, 1, 16, &[0; 4096], u32::MAX - 8);
    b[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    let s = expect_err(&write(d, "huge_riff.wav", &b));
    assert!(s.contains("truncated"), "{s}");
    // Too short for a feature frame (under 2048 samples at 30720 Hz).
    let s = expect_err(&write(d, "tiny.wav", &pcm16_wav(22050, 1, &[0.1; 100])));
    assert!(s.contains("too short"), "{s}");
}

#[test]
fn length_cap_is_enforced() {
    let path = fixture_dir().join("formats/s16_stereo_48000.wav");
    let e = decode_file(&path, 0.1).unwrap_err();
    assert!(e.to_string().contains("longer than the limit"), "{e}");
    assert!(decode_file(&path, 1.0).is_ok());
}

#[test]
fn mutated_files_never_panic() {
    // Deterministic byte flips and cuts of every format fixture: each call returns Ok or a clear Err.
    let dir = tempfile::tempdir().unwrap();
    let mut state = 0x9e3779b97f4a7c15u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let mut n_err = 0;
    let mut n_ok = 0;
    for entry in std::fs::read_dir(fixture_dir().join("formats")).unwrap() {
        let src = entry.unwrap().path();
        let bytes = std::fs::read(&src).unwrap();
        let ext = src.extension().unwrap().to_string_lossy().to_string();
        for k in 0..8 {
            let mut b = bytes.clone();
            if k % 2 == 0 {
                // Flip a few bytes, often inside the header.
                for _ in 0..4 {
                    let limit = if next() % 2 == 0 {
                        64.min(b.len())
                    } else {
                        b.len()
                    };
                    let i = (next() as usize) % limit;
                    b[i] ^= (next() as u8) | 1;
                }
            } else {
                b.truncate((next() as usize) % b.len());
            }
            let p = write(dir.path(), &format!("m{k}.{ext}"), &b);
            match audio::features_for_file(&p, &FeatureOptions::default()) {
                Ok(f) => {
                    assert!(f.data.iter().all(|v| v.is_finite()));
                    n_ok += 1;
                }
                Err(e) => {
                    assert_eq!(e.path.as_deref(), Some(p.as_path()));
                    n_err += 1;
                }
            }
        }
    }
    println!("mutations: {n_ok} accepted, {n_err} rejected");
    assert!(n_err > 0);
}

#[test]
fn mp3_with_id3_tags_decodes() {
    // Most MP3s in the wild start with an ID3v2 tag: a minimal one (10 bytes of padding) in front.
    let mp3 = std::fs::read(fixture_dir().join("formats/mp3_mono_44100.mp3")).unwrap();
    let mut b = b"ID3\x03\x00\x00\x00\x00\x00\x0a".to_vec();
    b.extend_from_slice(&[0u8; 10]);
    b.extend_from_slice(&mp3);
    let dir = tempfile::tempdir().unwrap();
    let p = write(dir.path(), "tagged.mp3", &b);
    let plain = decode_file(&fixture_dir().join("formats/mp3_mono_44100.mp3"), 60.0).unwrap();
    let tagged = decode_file(&p, 60.0).unwrap();
    assert_eq!(plain.samples, tagged.samples);
    // And an ID3v1 tag (128 bytes starting with "TAG") at the end.
    let mut b1 = mp3.clone();
    b1.extend_from_slice(b"TAG");
    b1.extend_from_slice(&[b' '; 125]);
    let p1 = write(dir.path(), "tagged1.mp3", &b1);
    assert_eq!(decode_file(&p1, 60.0).unwrap().samples, plain.samples);
}
