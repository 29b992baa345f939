//! Directory mode of the metrics: a directory of generated motions against a directory of
//! ground-truth motions, with music beats from audio files or a JSON file (`qean eval --generated
//! DIR --reference DIR`).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::config::{value_name, EvalConfig, MusicBeatSource};
use crate::io::{load_joints_dir, read_beats_json, sequence_name, write_json_atomic};
use crate::preset::ProtocolPreset;
use crate::protocol::{evaluate, music_key};
use crate::report::{render_markdown, MetricsReport};

/// What to evaluate in directory mode.
#[derive(Debug, Clone)]
pub struct DirRequest {
    /// Generated motions, seed frames first (any format `io::read_joints` reads).
    pub generated: PathBuf,
    /// Ground-truth motions: the normalisation and FID reference set.
    pub reference: PathBuf,
    /// Music directory (`<music ID>.wav|ogg|mp3|flac`), beats tracked as `ba_music_beats` says.
    pub music: Option<PathBuf>,
    /// Precomputed beats, `{"mBR0": [frame, ...]}` at 60 FPS (wins over `music`).
    pub beats: Option<PathBuf>,
    pub ba_music_beats: MusicBeatSource,
    /// One report per configuration (one per metrics mode).
    pub configs: Vec<EvalConfig>,
    /// Also write the reports here as JSON.
    pub json: Option<PathBuf>,
    /// Row label of the markdown table.
    pub label: String,
    /// Root convention of forward kinematics for .pkl motions.
    pub root: qean_motion::FkRoot,
    /// A CSV of `generated,music` rows pairing generated files (names or stems) with music keys (an
    /// audio file's stem in `music`, or a key of `beats`), for names without an AIST++ music ID.
    pub pairing: Option<PathBuf>,
}

/// The rows of a pairing file: generated name (a `.joints`/extension suffix dropped) → music key.
pub fn read_pairing(path: &Path) -> crate::Result<HashMap<String, String>> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| crate::Error::file(path, format!("cannot read: {e}")))?;
    let mut map = HashMap::new();
    for (k, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || (k == 0 && line.replace(' ', "") == "generated,music") {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let [generated, music] = fields[..] else {
            return Err(crate::Error::Invalid(format!(
                "{} line {}: expected two columns `generated,music`, got {line:?}",
                path.display(),
                k + 1
            )));
        };
        if generated.is_empty() || music.is_empty() {
            return Err(crate::Error::Invalid(format!(
                "{} line {}: an empty column",
                path.display(),
                k + 1
            )));
        }
        map.insert(sequence_name(generated).to_string(), music.to_string());
    }
    Ok(map)
}

/// Sets each generated sequence's music from the pairing; a row naming no loaded sequence is an error.
fn apply_pairing(
    generated: &mut [crate::positions::Sequence],
    pairing: &HashMap<String, String>,
    path: &Path,
) -> crate::Result<()> {
    for name in pairing.keys() {
        if !generated.iter().any(|s| &s.name == name) {
            return Err(crate::Error::file(
                path,
                format!("pairs {name:?}, which is not among the generated motions"),
            ));
        }
    }
    for s in generated {
        if let Some(m) = pairing.get(&s.name) {
            s.music = Some(m.clone());
        }
    }
    Ok(())
}

/// What `--json` writes: one report per metrics mode.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvaluationFile {
    pub reports: Vec<MetricsReport>,
}

/// Load, evaluate each configuration, write the JSON (if asked) and return the reports with their
/// markdown table.
pub fn evaluate_dirs(req: &DirRequest) -> crate::Result<(EvaluationFile, String)> {
    let root = req.root;
    let mut generated = load_joints_dir(&req.generated, root)
        .map_err(|e| e.context("loading generated motions"))?;
    if let Some(path) = &req.pairing {
        apply_pairing(&mut generated, &read_pairing(path)?, path)?;
    }
    let reference = load_joints_dir(&req.reference, root)
        .map_err(|e| e.context("loading reference motions"))?;
    let beats: Option<(PathBuf, HashMap<String, Vec<usize>>)> = match (&req.beats, &req.music) {
        (Some(p), _) => Some((p.clone(), read_beats_json(p)?)),
        (None, Some(dir)) => {
            let keys = generated.iter().chain(&reference).filter_map(music_key);
            Some((dir.clone(), music_beats(dir, keys, req.ba_music_beats)?))
        }
        (None, None) => None,
    };
    let lookup = |id: &str| -> crate::Result<Vec<usize>> {
        let (path, map) = beats.as_ref().expect("lookup only passed with beats");
        map.get(id)
            .cloned()
            .ok_or_else(|| crate::Error::file(path, format!("no beats for music ID '{id}'")))
    };
    let lookup_ref = beats
        .as_ref()
        .map(|_| &lookup as crate::protocol::BeatLookup);
    let reports = req
        .configs
        .iter()
        .map(|cfg| evaluate(&generated, &reference, lookup_ref, cfg))
        .collect::<crate::Result<Vec<_>>>()?;
    let file = EvaluationFile { reports };
    if let Some(path) = &req.json {
        write_json_atomic(path, &file)?;
    }
    let label_of = |r: &MetricsReport| {
        let mut parts = Vec::new();
        if req.configs.iter().any(|c| c.preset != r.config.preset) {
            parts.extend(r.config.preset.map(value_name));
        }
        if req
            .configs
            .iter()
            .any(|c| c.metrics_mode != r.config.metrics_mode)
        {
            parts.push(value_name(r.config.metrics_mode));
        }
        match parts.is_empty() {
            true => req.label.clone(),
            false => format!("{} ({})", req.label, parts.join(", ")),
        }
    };
    // One table per protocol preset: numbers of two protocols never share a column.
    let mut presets: Vec<Option<ProtocolPreset>> = Vec::new();
    for r in &file.reports {
        if !presets.contains(&r.config.preset) {
            presets.push(r.config.preset);
        }
    }
    let labels: Vec<String> = file.reports.iter().map(label_of).collect();
    let table = presets
        .iter()
        .map(|p| {
            let rows: Vec<(&str, &MetricsReport)> = labels
                .iter()
                .map(String::as_str)
                .zip(&file.reports)
                .filter(|(_, r)| r.config.preset == *p)
                .collect();
            render_markdown(&rows)
        })
        .collect::<Vec<_>>()
        .join("\n");
    Ok((file, table))
}

/// The beats of music `id` in a map made by [`music_beats`] from `dir`; an ID it left out (no audio file)
/// is an error naming `dir`. This is the protocol's [`crate::protocol::BeatLookup`] over such a map.
pub fn beats_of(
    beats: &HashMap<String, Vec<usize>>,
    dir: &Path,
    id: &str,
) -> crate::Result<Vec<usize>> {
    beats
        .get(id)
        .cloned()
        .ok_or_else(|| crate::Error::file(dir, format!("no audio for music ID '{id}'")))
}

/// Music beats of every music key (an AIST++ music ID or an audio file's stem), from
/// `dir/<key>.(wav|ogg|mp3|flac)`:
/// Bailando's HPSS-percussive beats (start BPM 120), or column 34 of our 35-D features (start BPM from the
/// music ID's tempo prior). IDs without an audio file are left out (their sequences are then excluded from
/// BeatAlign with a logged reason).
pub fn music_beats(
    dir: &Path,
    keys: impl Iterator<Item = String>,
    source: MusicBeatSource,
) -> crate::Result<HashMap<String, Vec<usize>>> {
    use qean_audio as audio;
    if !dir.is_dir() {
        return Err(crate::Error::file(dir, "music directory does not exist"));
    }
    let mut ids: Vec<String> = keys.collect();
    ids.sort();
    ids.dedup();
    let mut out = HashMap::new();
    for id in ids {
        let Some(path) = qean_aistpp::dataset::AUDIO_EXTENSIONS
            .iter()
            .map(|e| dir.join(format!("{id}.{e}")))
            .find(|p| p.is_file())
        else {
            tracing::warn!("no audio for music {id} in {}", dir.display());
            continue;
        };
        let beats = match source {
            MusicBeatSource::Bailando => {
                let a = audio::load_audio(&path, &audio::LoadOptions::default())?;
                audio::hpss::bailando_beats(&a.samples, audio::SR as f64).beats
            }
            MusicBeatSource::Feature35 => {
                audio::features_for_file(
                    &path,
                    &audio::FeatureOptions::with_start_bpm(qean_aistpp::names::start_bpm(&id)),
                )?
                .beats
            }
        };
        out.insert(id, beats);
    }
    Ok(out)
}
