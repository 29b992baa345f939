//! The 35-D FACT music feature (SPEC §2; mint `tools/preprocessing.py: cache_audio_features`):
//! [onset envelope | 20 MFCC | 12 chroma_cens | onset-peak one-hot | beat one-hot], one row per 1/60 s.

use std::path::Path;

use super::beat::beat_track;
use super::chroma::chroma_cens;
use super::decode::{load_audio, LoadOptions};
use super::mel::{power_to_db, MelBank};
use super::mfcc::mfcc_from_db_mel;
use super::onset::{onset_detect, onset_strength_from_power, Aggregate};
use super::resample::Resampler;
use super::stft::{power_spectrogram, Spectrogram};
use super::{HOP, N_FFT, SR};
use qean_io::error::{Error, Result};

/// Columns of the feature.
pub const FEATURE_DIM: usize = 35;
pub const COL_ENV: usize = 0;
pub const COL_MFCC: usize = 1;
pub const N_MFCC: usize = 20;
pub const COL_CHROMA: usize = 21;
pub const COL_ONSET: usize = 33;
pub const COL_BEAT: usize = 34;

/// Options for [`music_features`].
#[derive(Debug, Clone)]
pub struct FeatureOptions {
    /// Beat tracker's tempo prior (librosa's `start_bpm`, BPM); AIST++ callers take it from the music ID
    /// (`qean_aistpp::names::start_bpm`).
    pub start_bpm: f64,
    /// Resampling filter used when loading a file.
    pub resampler: Resampler,
    /// Beat tracker tightness (mint: 100).
    pub tightness: f64,
    /// Longest accepted input, seconds.
    pub max_seconds: f64,
}

impl Default for FeatureOptions {
    fn default() -> Self {
        FeatureOptions {
            start_bpm: 120.0,
            resampler: Resampler::KaiserBest,
            tightness: 100.0,
            max_seconds: LoadOptions::default().max_seconds,
        }
    }
}

impl FeatureOptions {
    /// The options that change the features, as the feature cache records them: a cached file made with
    /// other options is recomputed.
    pub fn cache_key(&self) -> String {
        let resampler = match self.resampler {
            Resampler::KaiserBest => "kaiser_best",
            Resampler::KaiserFast => "kaiser_fast",
        };
        format!("start_bpm={} resampler={resampler}", self.start_bpm)
    }

    /// The default options with the beat tracker's tempo prior set to `start_bpm` (librosa's `start_bpm`).
    pub fn with_start_bpm(start_bpm: f64) -> Self {
        FeatureOptions {
            start_bpm,
            ..Default::default()
        }
    }
}

/// The 35-D feature of one track.
#[derive(Debug, Clone, PartialEq)]
pub struct MusicFeatures {
    pub frames: usize,
    /// Row-major frames × 35.
    pub data: Vec<f32>,
    /// Estimated tempo (BPM); 0 for silence.
    pub tempo_bpm: f64,
    /// Beat frames (column 34).
    pub beats: Vec<usize>,
    /// Onset-peak frames (column 33).
    pub onsets: Vec<usize>,
    /// Tuning estimate used for the CQT (fractions of a 36-TET bin).
    pub tuning: f64,
}

impl MusicFeatures {
    /// Row `t` (35 values).
    pub fn row(&self, t: usize) -> &[f32] {
        &self.data[t * FEATURE_DIM..(t + 1) * FEATURE_DIM]
    }

    /// Whether the track is silent: a flat onset envelope, so no onsets and no beats.
    pub fn is_silent(&self) -> bool {
        (0..self.frames).all(|t| self.data[t * FEATURE_DIM + COL_ENV] == 0.0)
    }

    /// Column `c` as f64.
    pub fn column(&self, c: usize) -> Vec<f64> {
        (0..self.frames)
            .map(|t| self.data[t * FEATURE_DIM + c] as f64)
            .collect()
    }
}

/// The 35-D feature of a mono signal already at 30720 Hz (librosa 0.8.1 semantics, SPEC §2).
pub fn music_features(samples: &[f64], opts: &FeatureOptions) -> Result<MusicFeatures> {
    if samples.len() < N_FFT {
        return Err(Error::msg(format!(
            "audio too short: {} samples at {SR} Hz (at least {N_FFT} needed)",
            samples.len()
        )));
    }
    if let Some(i) = samples.iter().position(|v| !v.is_finite()) {
        return Err(Error::msg(format!("audio sample {i} is not finite")));
    }
    if !(opts.start_bpm > 0.0 && opts.start_bpm.is_finite()) {
        return Err(Error::msg(format!(
            "start BPM must be positive, got {}",
            opts.start_bpm
        )));
    }
    let sr = SR as f64;
    let power = power_spectrogram(samples, N_FFT, HOP);

    let ((env, mfcc), chroma) = rayon::join(
        || {
            let env = onset_strength_from_power(&power, sr, Aggregate::Mean);
            let bank = MelBank::new(sr, N_FFT, 128, 0.0, sr / 2.0);
            let mut mel = bank.apply(&power);
            power_to_db(&mut mel.data);
            (env, mfcc_from_db_mel(&mel, N_MFCC))
        },
        || chroma_cens(samples, &power, sr, HOP),
    );
    let (cens, tuning) = chroma?;

    let onsets = onset_detect(&env, sr, HOP);
    let bt = beat_track(&env, sr, HOP, opts.start_bpm, opts.tightness);
    assemble(&env, &mfcc, &cens, onsets, bt.beats, bt.tempo_bpm, tuning)
}

fn assemble(
    env: &[f64],
    mfcc: &Spectrogram,
    cens: &Spectrogram,
    onsets: Vec<usize>,
    beats: Vec<usize>,
    tempo_bpm: f64,
    tuning: f64,
) -> Result<MusicFeatures> {
    let lens = [env.len(), mfcc.n_frames, cens.n_frames];
    let frames = *lens.iter().min().unwrap();
    if lens.iter().any(|&l| l != frames) {
        // SPEC §2 [DECISION]: truncate every component to the shortest and log it.
        tracing::info!(
            "feature lengths differ (env {}, mfcc {}, chroma {}): truncating to {frames}",
            lens[0],
            lens[1],
            lens[2]
        );
    }
    let mut data = vec![0f32; frames * FEATURE_DIM];
    for t in 0..frames {
        let row = &mut data[t * FEATURE_DIM..(t + 1) * FEATURE_DIM];
        row[COL_ENV] = env[t] as f32;
        for (d, &v) in row[COL_MFCC..COL_MFCC + N_MFCC]
            .iter_mut()
            .zip(mfcc.frame(t))
        {
            *d = v as f32;
        }
        for (d, &v) in row[COL_CHROMA..COL_CHROMA + 12]
            .iter_mut()
            .zip(cens.frame(t))
        {
            *d = v as f32;
        }
    }
    let onsets: Vec<usize> = onsets.into_iter().filter(|&i| i < frames).collect();
    let beats: Vec<usize> = beats.into_iter().filter(|&i| i < frames).collect();
    for &i in &onsets {
        data[i * FEATURE_DIM + COL_ONSET] = 1.0;
    }
    for &i in &beats {
        data[i * FEATURE_DIM + COL_BEAT] = 1.0;
    }
    Ok(MusicFeatures {
        frames,
        data,
        tempo_bpm,
        beats,
        onsets,
        tuning,
    })
}

/// What `qean inspect` says of an audio file: duration, rate, channels, feature frames, tempo, beats, onsets.
pub fn describe_file(path: &Path, opts: &FeatureOptions) -> Result<String> {
    let audio = crate::load_audio(path, &crate::LoadOptions::default())?;
    let f = music_features(&audio.samples, opts)?;
    Ok(format!(
        "audio: {}\nduration: {:.3} s\nsample rate: {} Hz\nchannels: {}\nfeature frames: {} (60 fps)\n\
         tempo: {:.2} BPM (start_bpm {})\nbeats: {}\nonset peaks: {}\n",
        path.display(),
        audio.duration,
        audio.original_rate,
        audio.channels,
        f.frames,
        f.tempo_bpm,
        opts.start_bpm,
        f.beats.len(),
        f.onsets.len()
    ))
}

/// Load a file (`librosa.load(path, sr=30720)`) and compute its 35-D feature.
pub fn features_for_file(path: &Path, opts: &FeatureOptions) -> Result<MusicFeatures> {
    let audio = load_audio(
        path,
        &LoadOptions {
            resampler: opts.resampler,
            max_seconds: opts.max_seconds,
        },
    )?;
    music_features(&audio.samples, opts).map_err(|e| e.with_path(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn silence_gives_valid_features_without_events() {
        let y = vec![0.0; 30720 * 2];
        let f = music_features(&y, &FeatureOptions::default()).unwrap();
        assert_eq!(f.frames, 1 + y.len() / 512);
        assert_eq!(f.data.len(), f.frames * FEATURE_DIM);
        assert!(f.beats.is_empty() && f.onsets.is_empty());
        assert_eq!(f.tempo_bpm, 0.0);
        assert!(f.data.iter().all(|v| v.is_finite()));
        // Chroma of silence is all zero; MFCC c0 is the floor −100 dB · sqrt(128).
        assert!((f.row(10)[COL_MFCC] as f64 + 100.0 * 128f64.sqrt()).abs() < 1e-3);
        assert!(f.row(10)[COL_CHROMA..COL_CHROMA + 12]
            .iter()
            .all(|&v| v == 0.0));
    }

    #[test]
    fn rejects_short_and_nonfinite_input() {
        assert!(music_features(&[0.0; 100], &FeatureOptions::default()).is_err());
        let mut y = vec![0.0; 4096];
        y[7] = f64::NAN;
        assert!(music_features(&y, &FeatureOptions::default()).is_err());
        let bad = FeatureOptions {
            start_bpm: 0.0,
            ..Default::default()
        };
        assert!(music_features(&[0.0; 4096], &bad).is_err());
    }
}
