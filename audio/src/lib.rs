//! Audio front end: decoding, resampling and the 35-D FACT music feature (SPEC §2).
//!
//! Everything reproduces librosa 0.8.1 with resampy 0.2.2 ("0.8.1 semantics", SPEC §0): the numerical
//! pipeline runs in f64, the feature matrix comes out as f32.
//!
//! - [`load_audio`]: symphonia decoding (WAV PCM 8/16/24/32 and float, OGG Vorbis, MP3, FLAC; any
//!   channel count, averaged), then `librosa.load(sr=30720)` resampling ([`Resampler`], bit-exact with
//!   resampy 0.2.2 on float32 input).
//! - [`music_features`] / [`features_for_file`]: the 35-D matrix ([`MusicFeatures`]), with
//!   [`FeatureOptions::with_start_bpm`] setting the beat tracker's tempo prior.
//! - Building blocks for other metrics: [`onset_strength`], [`onset_detect`], [`beats::beat_track`],
//!   [`hpss::bailando_beats`] (BeatAlign's music beats).
//! - [`delta::delta`]: librosa's delta features, and [`delta::tsmt_audio`], TSMT's MFCC + Δ rows and beat flags (SPEC §11.4).
//!
//! Parity with librosa 0.8.1 is tested in `audio/tests/audio_parity.rs` on fixtures made by
//! `tools/make_audio_fixtures.py`.

pub mod beat;
pub mod chroma;
pub mod cqt;
pub mod decode;
pub mod delta;
pub mod features;
pub mod hpss;
pub mod mel;
pub mod mfcc;
pub mod onset;
pub mod resample;
pub mod stft;
pub mod tuning;

/// Alias so callers can write `audio::beats::beat_track` (BeatAlign).
pub use beat as beats;

pub use beat::{beat_track, tempo, BeatTrack};
pub use decode::{load_audio, Audio, LoadOptions};
pub use features::{features_for_file, music_features, FeatureOptions, MusicFeatures, FEATURE_DIM};
pub use onset::{onset_detect, onset_strength, Aggregate};
pub use resample::Resampler;

/// Feature sample rate: 60 frames per second at hop 512 (SPEC §2).
pub const SR: u32 = 30720;
/// STFT hop in samples.
pub const HOP: usize = 512;
/// STFT size in samples.
pub const N_FFT: usize = 2048;
/// Feature frames per second.
pub const FPS: f64 = 60.0;
