//! `qean keyframes`: a motion (and optionally its music) to keyframes per measure (SPEC §12.2–12.3), with
//! the tempo from `--bpm`, an AIST++ name or the music's beat tracker.

use crate::{Error, Result};
use qean_audio::features::{features_for_file, FeatureOptions, COL_ENV};
use qean_keyframes::nmfd::{drum_templates, nmfd, nmfd_from, NmfdSize};
use qean_keyframes::options::{NmfdInit, DRUM_CLASSES};
use qean_keyframes::select::{select_keys, Selection, Strategy};
use qean_keyframes::stems::{
    hpss_stems, stem_from_samples, weighted_curve, Stem, StemSource, STEM_NAMES,
};
use qean_keyframes::KeyframeOptions;
use qean_motion::motion::read_motion;
use qean_motion::Motion;
use serde::Serialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// What to select.
#[derive(Debug, Clone)]
pub struct KeyframesRequest {
    pub motion: PathBuf,
    pub music: Option<PathBuf>,
    /// The directory with drums.wav, bass.wav, vocals.wav and other.wav (`stem_source = "files"`).
    pub stems: Option<PathBuf>,
    pub strategy: Strategy,
    pub n: usize,
    pub bpm: Option<f64>,
    pub options: KeyframeOptions,
}

/// The selection with where its inputs came from; written as the keyframes JSON.
#[derive(Debug, Clone, Serialize)]
pub struct KeyframesResult {
    pub motion: String,
    pub music: Option<String>,
    pub frames: usize,
    /// Where the tempo came from ("--bpm", "AIST++ music ID mBR0", "beat tracker").
    pub tempo_source: String,
    pub measure_offset: usize,
    #[serde(flatten)]
    pub selection: Selection,
    pub options: KeyframeOptions,
}

/// The onset curve and first beat of a music file, one value per 60-fps frame.
#[derive(Debug, Clone)]
pub struct MusicCurve {
    pub envelope: Vec<f64>,
    pub first_beat: Option<usize>,
    pub tempo_bpm: f64,
}

/// Column 0 (onset envelope) and the beats of the 35-D feature, computed on the whole track.
pub fn music_curve(path: &Path, start_bpm: f64) -> Result<MusicCurve> {
    let f = features_for_file(path, &FeatureOptions::with_start_bpm(start_bpm))?;
    Ok(MusicCurve {
        envelope: f.column(COL_ENV),
        first_beat: f.beats.first().copied(),
        tempo_bpm: f.tempo_bpm,
    })
}

/// The AIST++ tempo of the first name that carries a music ID (motion `…_mBR0_ch01`, music `mBR0`).
fn named_tempo(paths: &[&Path]) -> Option<(f64, String)> {
    paths.iter().find_map(|p| {
        let stem = p.file_stem()?.to_string_lossy().into_owned();
        let id = qean_aistpp::names::music_id_of(&stem)?;
        let bpm = qean_aistpp::names::tempo_prior(&id)?;
        Some((bpm, format!("AIST++ music ID {id}")))
    })
}

/// The tempo: `--bpm`, else an AIST++ name, else the music's beat tracker.
pub fn resolve_tempo(
    explicit: Option<f64>,
    motion: &Path,
    music: Option<&Path>,
    curve: Option<&MusicCurve>,
) -> Result<(f64, String)> {
    if let Some(b) = explicit {
        if !(b.is_finite() && b > 0.0) {
            return Err(Error::Invalid(format!(
                "--bpm must be a positive number, got {b}"
            )));
        }
        return Ok((b, "--bpm".into()));
    }
    let mut names = vec![motion];
    names.extend(music);
    if let Some(t) = named_tempo(&names) {
        return Ok(t);
    }
    match curve {
        Some(c) if c.tempo_bpm > 0.0 => Ok((c.tempo_bpm, "the music's beat tracker".into())),
        Some(_) => Err(Error::Invalid(format!(
            "{}: the music has no beats to take a tempo from; pass --bpm",
            music.map_or(motion, |m| m).display()
        ))),
        None => Err(Error::Invalid(format!(
            "{}: no tempo: pass --bpm, or --music for the beat tracker (the name carries no AIST++ music ID)",
            motion.display()
        ))),
    }
}

/// What a strategy reads besides the motion.
fn needs(req: &KeyframesRequest) -> (bool, bool) {
    let first_beat =
        req.options.measure_offset == qean_keyframes::options::MeasureOffset::FirstBeat;
    let stems = matches!(req.strategy, Strategy::Stems | Strategy::Nmfd);
    let music = req.strategy == Strategy::Onset
        || first_beat
        || (stems && req.options.stem_source == StemSource::Hpss);
    (music, stems && req.options.stem_source == StemSource::Files)
}

fn load_samples(path: &Path) -> Result<Vec<f64>> {
    Ok(qean_audio::decode::load_audio(path, &Default::default())?.samples)
}

/// The stems a strategy uses, in `STEM_NAMES` order (`None`: not used or not present).
fn stems(req: &KeyframesRequest, music: Option<&Path>) -> Result<[Option<Stem>; 4]> {
    let only_drums = req.strategy == Strategy::Nmfd;
    match req.options.stem_source {
        StemSource::Hpss => {
            let music = music.expect("checked by needs()");
            let (drums, other) = hpss_stems(&load_samples(music)?);
            Ok([Some(drums), None, None, (!only_drums).then_some(other)])
        }
        StemSource::Files => {
            let dir = req.stems.as_deref().expect("checked by needs()");
            let mut out: [Option<Stem>; 4] = Default::default();
            for (i, name) in STEM_NAMES.iter().enumerate() {
                let used = if only_drums {
                    i == 0
                } else {
                    req.options.stem_weights[i] != 0.0
                };
                if !used {
                    continue;
                }
                let path = dir.join(format!("{name}.wav"));
                if !path.is_file() {
                    return Err(Error::Invalid(format!(
                        "{}: stem missing (strategy {} with stem_source = \"files\" reads {} from --stems; \
                         or --set keyframes.stem_source=hpss)",
                        path.display(),
                        req.strategy.name(),
                        STEM_NAMES.join(", ")
                    )));
                }
                out[i] = Some(stem_from_samples(&load_samples(&path)?));
            }
            Ok(out)
        }
    }
}

/// `nmfd_init = "drums"`: templates learnt from the samples in `dir`/{kick,snare,hihat}/ as libnmfd does
/// (each file mono at 30720 Hz, scaled to peak 0.99, a class's files joined in name order, |STFT| of §2.2).
fn sample_templates(dir: &Path, bins: usize, size: &NmfdSize) -> Result<Vec<f64>> {
    let mut spectra = Vec::new();
    for class in DRUM_CLASSES {
        let folder = dir.join(class);
        let mut files: Vec<PathBuf> = std::fs::read_dir(&folder)
            .map_err(|e| {
                Error::Invalid(format!(
                    "{}: cannot read the drum samples: {e}",
                    folder.display()
                ))
            })?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_file())
            .collect();
        files.sort();
        if files.is_empty() {
            return Err(Error::Invalid(format!(
                "{}: no drum samples (nmfd_init = \"drums\" reads every audio file of kick/, snare/ and hihat/)",
                folder.display()
            )));
        }
        let mut joined = Vec::new();
        for f in &files {
            let y = load_samples(f)?;
            let peak = y.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            if peak == 0.0 {
                return Err(Error::Invalid(format!(
                    "{}: a silent drum sample",
                    f.display()
                )));
            }
            joined.extend(y.iter().map(|x| 0.99 * x / peak));
        }
        spectra.push(stem_from_samples(&joined).magnitude);
    }
    let refs: Vec<&[f64]> = spectra.iter().map(Vec::as_slice).collect();
    Ok(drum_templates(&refs, bins, size))
}

/// The curve whose peaks a music strategy keys on: onset envelope, stem-weighted onsets or NMFD drums.
fn strategy_curve(
    req: &KeyframesRequest,
    music: Option<&Path>,
    music_curve: Option<&MusicCurve>,
) -> Result<Option<Vec<f64>>> {
    Ok(match req.strategy {
        Strategy::Onset => music_curve.map(|c| c.envelope.clone()),
        Strategy::Stems => {
            let s = stems(req, music)?;
            let envs = std::array::from_fn(|i| s[i].as_ref().map(|x| x.envelope.as_slice()));
            Some(weighted_curve(&envs, req.options.stem_weights))
        }
        Strategy::Nmfd => {
            let [Some(drums), ..] = stems(req, music)? else {
                unreachable!("nmfd always loads the drums")
            };
            let size = req.options.nmfd_size();
            let f = match (req.options.nmfd_init, &req.options.nmfd_templates) {
                (NmfdInit::Drums, Some(dir)) => {
                    let w = sample_templates(dir, drums.bins, &size)?;
                    nmfd_from(&drums.magnitude, drums.bins, &size, w)
                }
                _ => nmfd(&drums.magnitude, drums.bins, &size),
            };
            Some(f.curve(&req.options.nmfd_weights))
        }
        Strategy::Even | Strategy::Dp => None,
    })
}

/// Select keyframes for the motion file of the request.
pub fn select_keyframes(req: &KeyframesRequest) -> Result<KeyframesResult> {
    req.options
        .validate()
        .map_err(|e| Error::Invalid(format!("keyframe options: {e}")))?;
    let motion = read_motion(&req.motion)?;
    select_keyframes_of(&motion, req)
}

/// Select keyframes for a motion already read (`req.motion` names it in messages and gives its tempo).
pub fn select_keyframes_of(motion: &Motion, req: &KeyframesRequest) -> Result<KeyframesResult> {
    select_keyframes_cached(motion, req, None)
}

/// What a music strategy computed from the music: the feature curve and the keyed curve.
type Curves = (Option<MusicCurve>, Option<Vec<f64>>);

/// The music curves of earlier selections, by (music, stems, strategy, start tempo, options): a
/// benchmark keys every sequence at several N and rows, and the curves (beat tracking, HPSS, NMFD)
/// do not depend on N.
#[derive(Default)]
pub struct CurveCache(Mutex<HashMap<String, Curves>>);

impl CurveCache {
    fn key(req: &KeyframesRequest, music: Option<&Path>, start_bpm: f64) -> String {
        format!(
            "{:?}|{:?}|{}|{start_bpm}|{}",
            music,
            req.stems,
            req.strategy.name(),
            serde_json::to_string(&req.options).expect("plain data")
        )
    }
}

/// [`select_keyframes_of`], reusing (and filling) `cache` for the music curves.
pub fn select_keyframes_cached(
    motion: &Motion,
    req: &KeyframesRequest,
    cache: Option<&CurveCache>,
) -> Result<KeyframesResult> {
    let (needs_music, needs_stems) = needs(req);
    if needs_stems && req.stems.is_none() {
        return Err(Error::Invalid(format!(
            "{}: strategy {} needs the stems: pass --stems DIR (drums.wav, bass.wav, vocals.wav, other.wav) \
             or --set keyframes.stem_source=hpss",
            req.motion.display(),
            req.strategy.name()
        )));
    }
    if let Some(dir) = req.stems.as_deref().filter(|_| needs_stems) {
        if !dir.is_dir() {
            return Err(Error::Invalid(format!(
                "{}: the stems directory does not exist",
                dir.display()
            )));
        }
    }
    let music = match (&req.music, needs_music) {
        (Some(m), _) => Some(m.as_path()),
        (None, true) => {
            return Err(Error::Invalid(format!(
                "{}: strategy {} needs the music: pass --music SONG",
                req.motion.display(),
                req.strategy.name()
            )))
        }
        (None, false) => None,
    };
    let start_bpm = req
        .bpm
        .or_else(|| named_tempo(&[req.motion.as_path()]).map(|t| t.0))
        .filter(|b| b.is_finite() && *b > 0.0)
        .unwrap_or(120.0);
    let key = CurveCache::key(req, music, start_bpm);
    let cached = cache.and_then(|c| c.0.lock().expect("not poisoned").get(&key).cloned());
    let (curve, keyed) = match cached {
        Some(c) => c,
        None => {
            let curve = music.map(|m| music_curve(m, start_bpm)).transpose()?;
            let keyed = strategy_curve(req, music, curve.as_ref())?;
            if let Some(c) = cache {
                let value = (curve.clone(), keyed.clone());
                c.0.lock().expect("not poisoned").insert(key, value);
            }
            (curve, keyed)
        }
    };
    let (bpm, tempo_source) = resolve_tempo(req.bpm, &req.motion, music, curve.as_ref())?;
    let offset = req
        .options
        .measure_offset
        .resolve(curve.as_ref().and_then(|c| c.first_beat))
        .map_err(|e| Error::Invalid(format!("{}: {e}", req.motion.display())))?;
    if let Some(c) = &keyed {
        if c.len() < motion.frames {
            tracing::warn!(
                "{}: the music curve has {} frames, the motion {}: frames past its end have no onsets",
                req.motion.display(),
                c.len(),
                motion.frames
            );
        }
    }
    let selection = select(motion, keyed.as_deref(), req, bpm, offset)?;
    Ok(KeyframesResult {
        motion: req.motion.display().to_string(),
        music: music.map(|m| m.display().to_string()),
        frames: motion.frames,
        tempo_source,
        measure_offset: offset,
        selection,
        options: req.options.clone(),
    })
}

fn select(
    motion: &Motion,
    curve: Option<&[f64]>,
    req: &KeyframesRequest,
    bpm: f64,
    offset: usize,
) -> Result<Selection> {
    select_keys(
        motion,
        curve,
        req.strategy,
        req.n,
        bpm,
        offset,
        &req.options,
    )
    .map_err(|e| Error::Invalid(format!("{}: {e}", req.motion.display())))
}
