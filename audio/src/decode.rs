//! Decoding (symphonia 0.6) and `librosa.load(path, sr=30720)` semantics (SPEC §2.1): float32 samples
//! (PCM16/32768 etc., as libsndfile gives them), channels averaged, resampled with resampy 0.2.2.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::panic::AssertUnwindSafe;
use std::path::Path;

use symphonia::core::codecs::audio::well_known::CODEC_ID_MP3;
use symphonia::core::codecs::audio::AudioDecoderOptions;
use symphonia::core::errors::Error as SymError;
use symphonia::core::formats::probe::Hint;
use symphonia::core::formats::{FormatOptions, TrackType};
use symphonia::core::io::MediaSourceStream;
use symphonia::core::meta::MetadataOptions;

use super::resample::{resample_f32, Resampler};
use super::SR;
use qean_io::error::{Error, Result};

/// Options for [`load_audio`].
#[derive(Debug, Clone)]
pub struct LoadOptions {
    /// Resampling filter (default kaiser_best, librosa.load's default).
    pub resampler: Resampler,
    /// Refuse streams longer than this (seconds; default 30 min): a guard against absurd headers and
    /// decompression bombs, and against feature matrices that would not fit in memory.
    pub max_seconds: f64,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions {
            resampler: Resampler::KaiserBest,
            max_seconds: 30.0 * 60.0,
        }
    }
}

/// Decoded mono audio at [`SR`] Hz.
#[derive(Debug, Clone)]
pub struct Audio {
    /// Mono samples at 30720 Hz (values are f32-representable, as librosa's float32 signal).
    pub samples: Vec<f64>,
    /// Sample rate of the file.
    pub original_rate: u32,
    /// Channel count of the file.
    pub channels: usize,
    /// Duration of the decoded stream in seconds (frames / original rate).
    pub duration: f64,
}

/// Highest sample rate we accept (the widest PCM rates in use are 768 kHz).
const MAX_RATE: u32 = 1_536_000;
/// Most channels we accept.
const MAX_CHANNELS: usize = 256;

/// Mono float32 samples and the rate, exactly as decoded (no resampling).
#[derive(Debug, Clone)]
pub struct Decoded {
    pub samples: Vec<f32>,
    pub rate: u32,
    pub channels: usize,
}

fn sym_err(path: &Path, what: &str, e: SymError) -> Error {
    let msg = match e {
        SymError::IoError(ref io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            format!("{what}: the file is truncated")
        }
        SymError::IoError(io) => format!("{what}: {io}"),
        SymError::DecodeError(m) => format!("{what}: corrupt audio data ({m})"),
        SymError::Unsupported(m) => format!("{what}: unsupported format or codec ({m})"),
        SymError::LimitError(m) => format!("{what}: limit exceeded ({m})"),
        other => format!("{what}: {other}"),
    };
    Error::at(path, msg)
}

/// Check a RIFF/WAVE `fmt ` chunk before symphonia sees it: some absurd values (e.g. 60000 channels)
/// overflow inside its WAV reader.
fn precheck_wav(path: &Path, file: &mut File) -> Result<()> {
    let mut head = [0u8; 12];
    let n = file.read(&mut head).map_err(|e| Error::io(path, e))?;
    file.seek(SeekFrom::Start(0))
        .map_err(|e| Error::io(path, e))?;
    if n < 12 || &head[..4] != b"RIFF" || &head[8..12] != b"WAVE" {
        return Ok(());
    }
    let mut pos = 12u64;
    for _ in 0..64 {
        let mut ch = [0u8; 8];
        file.seek(SeekFrom::Start(pos))
            .map_err(|e| Error::io(path, e))?;
        if file.read_exact(&mut ch).is_err() {
            break;
        }
        let size = u32::from_le_bytes([ch[4], ch[5], ch[6], ch[7]]) as u64;
        if &ch[..4] == b"fmt " {
            let mut fmt = [0u8; 16];
            if file.read_exact(&mut fmt).is_err() {
                break;
            }
            let channels = u16::from_le_bytes([fmt[2], fmt[3]]) as usize;
            let rate = u32::from_le_bytes([fmt[4], fmt[5], fmt[6], fmt[7]]);
            if channels == 0 || channels > MAX_CHANNELS {
                return Err(Error::at(
                    path,
                    format!("implausible channel count {channels}"),
                ));
            }
            if rate == 0 || rate > MAX_RATE {
                return Err(Error::at(
                    path,
                    format!("implausible sample rate {rate} Hz"),
                ));
            }
            break;
        }
        pos += 8 + size + (size & 1);
    }
    file.seek(SeekFrom::Start(0))
        .map_err(|e| Error::io(path, e))?;
    Ok(())
}

/// Decode a file to mono float32 at its own rate (channels averaged, librosa `to_mono`). A panic inside
/// the third-party decoder becomes an error naming the file.
pub fn decode_file(path: &Path, max_seconds: f64) -> Result<Decoded> {
    match std::panic::catch_unwind(AssertUnwindSafe(|| decode_inner(path, max_seconds))) {
        Ok(r) => r,
        Err(_) => Err(Error::at(
            path,
            "the decoder failed on this file (malformed or unsupported data)",
        )),
    }
}

/// Decodes every packet of the track into `mono` (channels averaged as librosa's `to_mono`); returns the
/// stream's rate (None when it held no samples) and channel count. Refuses streams that change their
/// parameters midway or run past `max_seconds`.
fn decode_packets(
    path: &Path,
    format: &mut dyn symphonia::core::formats::FormatReader,
    decoder: &mut dyn symphonia::core::codecs::audio::AudioDecoder,
    track_id: u32,
    max_seconds: f64,
    mono: &mut Vec<f32>,
) -> Result<(Option<u32>, usize)> {
    let mut rate: Option<u32> = None;
    let mut channels = 0usize;
    let mut planes: Vec<Vec<f32>> = Vec::new();
    loop {
        let packet = match format.next_packet() {
            Ok(Some(p)) => p,
            Ok(None) => break,
            Err(SymError::ResetRequired) => {
                return Err(Error::at(
                    path,
                    "the stream changes its parameters midway (unsupported)",
                ))
            }
            Err(e) => return Err(sym_err(path, "reading the stream", e)),
        };
        if packet.track_id != track_id {
            continue;
        }
        let buf = decoder
            .decode(&packet)
            .map_err(|e| sym_err(path, "decoding", e))?;
        let spec = buf.spec();
        let (r, ch) = (spec.rate(), spec.channels().count());
        if r == 0 || r > MAX_RATE {
            return Err(Error::at(path, format!("implausible sample rate {r} Hz")));
        }
        if ch == 0 || ch > MAX_CHANNELS {
            return Err(Error::at(path, format!("implausible channel count {ch}")));
        }
        match rate {
            None => {
                rate = Some(r);
                channels = ch;
            }
            Some(r0) if r0 != r || channels != ch => {
                return Err(Error::at(
                    path,
                    "the sample rate or channel count changes midway (unsupported)",
                ))
            }
            _ => {}
        }
        let frames = buf.frames();
        if frames == 0 {
            continue;
        }
        if (mono.len() + frames) as f64 > max_seconds * r as f64 {
            return Err(Error::at(
                path,
                format!("longer than the limit of {max_seconds} s"),
            ));
        }
        buf.copy_to_vecs_planar::<f32>(&mut planes);
        if ch == 1 {
            mono.extend_from_slice(&planes[0][..frames]);
        } else {
            // librosa `to_mono`: numpy's float32 mean over channels (sum in f32, then divide).
            let inv = ch as f32;
            for i in 0..frames {
                let mut s = 0.0f32;
                for p in planes.iter().take(ch) {
                    s += p[i];
                }
                mono.push(s / inv);
            }
        }
    }
    Ok((rate, channels))
}

/// The decoded samples are there, as many as an exact header announced, and finite.
fn check_decoded(path: &Path, mono: &[f32], announced: Option<u64>) -> Result<()> {
    if mono.is_empty() {
        return Err(Error::at(path, "no audio samples"));
    }
    if let Some(n) = announced {
        if (mono.len() as u64) < n {
            return Err(Error::at(
                path,
                format!(
                    "truncated or corrupt: the header announces {n} samples per channel, only {} decode",
                    mono.len()
                ),
            ));
        }
    }
    if let Some(i) = mono.iter().position(|v| !v.is_finite()) {
        return Err(Error::at(
            path,
            format!("sample {i} is not finite (corrupt float data)"),
        ));
    }
    Ok(())
}

fn decode_inner(path: &Path, max_seconds: f64) -> Result<Decoded> {
    let mut file = File::open(path).map_err(|e| Error::io(path, e))?;
    let byte_len = file.metadata().map_err(|e| Error::io(path, e))?.len();
    if byte_len == 0 {
        return Err(Error::at(path, "empty file (0 bytes)"));
    }
    precheck_wav(path, &mut file)?;
    let mss = MediaSourceStream::new(Box::new(file), Default::default());
    let mut hint = Hint::new();
    if let Some(ext) = path.extension().and_then(|e| e.to_str()) {
        hint.with_extension(ext);
    }
    let mut format = symphonia::default::get_probe()
        .probe(
            &hint,
            mss,
            FormatOptions::default(),
            MetadataOptions::default(),
        )
        .map_err(|e| match e {
            SymError::Unsupported(m) => Error::at(
                path,
                format!(
                    "unsupported or unrecognised audio format ({m}); expected WAV (PCM or float), \
                     OGG Vorbis, MP3 or FLAC"
                ),
            ),
            other => sym_err(path, "cannot read the container", other),
        })?;
    let track = format
        .default_track(TrackType::Audio)
        .ok_or_else(|| Error::at(path, "no audio track"))?;
    let track_id = track.id;
    let header_frames = track.num_frames;
    let params = track
        .codec_params
        .as_ref()
        .and_then(|p| p.audio())
        .ok_or_else(|| Error::at(path, "the audio track has no codec parameters"))?
        .clone();
    let header_rate = params.sample_rate;
    // MP3 frame counts in headers are estimates; the other containers state them exactly.
    let exact_count = params.codec != CODEC_ID_MP3;
    if let Some(r) = header_rate {
        if r == 0 || r > MAX_RATE {
            return Err(Error::at(path, format!("implausible sample rate {r} Hz")));
        }
    }
    if let Some(ch) = &params.channels {
        if ch.count() == 0 || ch.count() > MAX_CHANNELS {
            return Err(Error::at(
                path,
                format!("implausible channel count {}", ch.count()),
            ));
        }
    }
    let mut decoder = symphonia::default::get_codecs()
        .make_audio_decoder(&params, &AudioDecoderOptions::default())
        .map_err(|e| match e {
            SymError::Unsupported(m) => Error::at(
                path,
                format!("unsupported audio codec ({m}); expected PCM, Vorbis, MP3 or FLAC"),
            ),
            other => sym_err(path, "cannot open the decoder", other),
        })?;

    let mut mono: Vec<f32> = Vec::new();
    // Reserve from the header only within what the file could plausibly hold (no header-driven huge
    // allocation): at most 64 samples per byte, and within max_seconds.
    if let (Some(n), Some(r)) = (track.num_frames, header_rate) {
        let cap = (n as f64)
            .min(byte_len as f64 * 64.0)
            .min(max_seconds * r as f64);
        mono.reserve(cap.max(0.0) as usize);
    }
    let (rate, channels) = decode_packets(
        path,
        format.as_mut(),
        decoder.as_mut(),
        track_id,
        max_seconds,
        &mut mono,
    )?;
    let rate = match rate {
        Some(r) => r,
        None => {
            return Err(Error::at(
                path,
                "no audio samples (the stream is empty or truncated)",
            ))
        }
    };
    check_decoded(path, &mono, header_frames.filter(|_| exact_count))?;
    Ok(Decoded {
        samples: mono,
        rate,
        channels,
    })
}

/// `librosa.load(path, sr=30720, res_type=opts.resampler)` (librosa 0.8.1 + resampy 0.2.2).
pub fn load_audio(path: &Path, opts: &LoadOptions) -> Result<Audio> {
    let dec = decode_file(path, opts.max_seconds)?;
    let duration = dec.samples.len() as f64 / dec.rate as f64;
    let samples = resample_f32(
        &dec.samples,
        dec.rate as f64,
        SR as f64,
        opts.resampler,
        false,
        true,
    )
    .map_err(|e| e.with_path(path))?;
    Ok(Audio {
        samples,
        original_rate: dec.rate,
        channels: dec.channels,
        duration,
    })
}
