//! A synthetic dataset in exactly the AIST++ layout (see [`qean_aistpp::dataset`]): procedural music per music ID
//! and procedural dances phase-locked to it, with train/val/test splits that follow the AIST++ naming rules
//! (test = `sBM … _ch02` on the ten official test music IDs, val = the same with `_ch01`, train on the other
//! music IDs). Deterministic for a given seed.

pub mod dance;
pub mod layouts;
pub mod music;
pub mod text_set;

use std::collections::BTreeMap;
use std::path::Path;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use dance::{BeatGrid, DanceStyle};
use music::{Groove, MusicSpec};
use qean_aistpp::dataset::Split;
use qean_aistpp::layout::DataLayout;
use qean_aistpp::names::{tempo_prior, GENRES};
use qean_io::error::{Error, Result};
use qean_io::fsutil::atomic_write;
use qean_motion::motion::{Precision, FPS};

/// The official AIST++ test music ID of each genre (in [`GENRES`] order).
pub const TEST_MUSIC: [&str; 10] = [
    "mBR0", "mPO1", "mLO2", "mMH3", "mLH4", "mHO5", "mWA0", "mKR2", "mJS3", "mJB5",
];

/// AIST++ dancer IDs of each genre (in [`GENRES`] order), as in the official split lists.
const DANCERS: [[u32; 3]; 10] = [
    [4, 5, 6],
    [10, 11, 12],
    [13, 14, 15],
    [22, 23, 24],
    [16, 17, 18],
    [19, 20, 21],
    [25, 26, 27],
    [28, 29, 30],
    [1, 2, 3],
    [7, 8, 9],
];

#[derive(Debug, Clone)]
pub struct SynthOptions {
    /// Total number of sequences (train + val + test).
    pub sequences: usize,
    /// Length of each sequence in seconds (sequences vary between 85% and 100% of it).
    pub seconds: f64,
    pub seed: u64,
    /// Sample rate of the written music. 30720 Hz (the feature rate) avoids resampling later.
    pub sample_rate: u32,
    /// Real recordings that replace the procedural track of some music IDs (the dances then follow the
    /// recordings' tracked beats).
    pub real_music: Vec<RealTrack>,
    /// Vary each procedural track's loudness, mix and drum sections ([`music::Arrangement`]);
    /// false gives the plain tracks of datasets made before (docs/freezing.md, section 5).
    pub varied_music: bool,
    /// Give every genre its posture (`dance::genre_posture`): genres a classifier can tell apart, at a cost
    /// to models that hear no genre (docs/control.md). Off by default.
    pub genre_postures: bool,
    /// Give every genre's procedural music its riff ([`music::SIGNATURES`]): music that says its genre, as
    /// AIST++'s does. Off by default.
    pub genre_music: bool,
}

/// A real recording standing in for one music ID's procedural track.
#[derive(Debug, Clone)]
pub struct RealTrack {
    /// The AIST++ music ID it replaces (it must be one the dataset uses).
    pub music_id: String,
    /// Where it came from (recorded in synth.json).
    pub source: String,
    /// Mono samples at the feature rate, 30720 Hz.
    pub samples: Vec<f64>,
}

impl RealTrack {
    /// Decode an audio file (any format `qean features` reads) to stand in for `music_id`.
    pub fn load(path: &Path, music_id: &str) -> Result<RealTrack> {
        if qean_aistpp::names::tempo_prior(music_id).is_none() {
            return Err(Error::msg(format!(
                "'{music_id}' is not an AIST++ music ID (e.g. mBR1)"
            )));
        }
        let audio = qean_audio::decode::load_audio(path, &Default::default())?;
        Ok(RealTrack {
            music_id: music_id.to_string(),
            source: path
                .file_name()
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
            samples: audio.samples,
        })
    }
}

impl Default for SynthOptions {
    fn default() -> Self {
        SynthOptions {
            sequences: 60,
            seconds: 16.0,
            seed: 0,
            sample_rate: 30720,
            real_music: Vec::new(),
            varied_music: true,
            genre_postures: false,
            genre_music: false,
        }
    }
}

/// What was generated.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SynthReport {
    pub seed: u64,
    pub seconds: f64,
    pub sample_rate: u32,
    pub varied_music: bool,
    /// Absent (false) in datasets made before the option existed.
    #[serde(default)]
    pub genre_postures: bool,
    /// Absent (false) in datasets made before the option existed.
    #[serde(default)]
    pub genre_music: bool,
    pub splits: BTreeMap<String, Vec<String>>,
    /// Per music ID: tempo, first beat (s) and the phrase chords.
    pub music: BTreeMap<String, MusicInfo>,
}

#[derive(Debug, Clone, serde::Serialize)]
pub struct MusicInfo {
    pub bpm: f64,
    pub first_beat: f64,
    pub seconds: f64,
    pub phrase_chords: Vec<usize>,
    /// Loudness, mix and drum sections of a varied procedural track.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub arrangement: Option<music::Arrangement>,
    /// The recording used instead of procedural music, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source: Option<String>,
}

/// One music ID's track as the dances see it: beat times and the chord of each phrase.
struct Track {
    info: MusicInfo,
    beat_times: Vec<f64>,
}

fn groove_of(genre: &str) -> Groove {
    match genre {
        "HO" | "PO" | "WA" => Groove::FourOnFloor,
        "JS" | "JB" | "LO" => Groove::Swing,
        _ => Groove::Breakbeat,
    }
}

/// A stable 64-bit hash (FNV-1a), so per-item seeds do not depend on generation order.
fn fnv(s: &str) -> u64 {
    s.bytes().fold(0xcbf29ce484222325, |h, b| {
        (h ^ b as u64).wrapping_mul(0x100000001b3)
    })
}

/// The sequence names of each split for `n` sequences in total.
pub fn plan_names(n: usize) -> Result<BTreeMap<Split, Vec<String>>> {
    if n < 3 {
        return Err(Error::msg("--sequences must be at least 3 (one per split)"));
    }
    let eval_each = (n / 6).clamp(1, 30);
    let train = n - 2 * eval_each;
    let mut out = BTreeMap::new();
    for (split, ch) in [(Split::Test, 2), (Split::Val, 1)] {
        let names = (0..eval_each)
            .map(|i| {
                let g = i % 10;
                let d = DANCERS[g][(i / 10) % 3];
                format!(
                    "g{}_sBM_cAll_d{d:02}_{}_ch{ch:02}",
                    GENRES[g], TEST_MUSIC[g]
                )
            })
            .collect();
        out.insert(split, names);
    }
    let mut names = Vec::with_capacity(train);
    for i in 0..train {
        let g = i % 10;
        let test_k = TEST_MUSIC[g].as_bytes()[3] - b'0';
        let ks: Vec<u8> = (0..6).filter(|&k| k != test_k).collect();
        // Several dancers share each track before the next track of the genre is used.
        let d = DANCERS[g][(i / 10) % 3];
        let k = ks[(i / 30) % 5];
        let round = i / 150;
        // Basic dances first, then advanced ones, as choreographies run out.
        let (sit, ch) = if round % 2 == 0 {
            ("sBM", 3 + round / 2)
        } else {
            ("sFM", 1 + round / 2)
        };
        names.push(format!(
            "g{}_{sit}_cAll_d{d:02}_m{}{k}_ch{ch:02}",
            GENRES[g], GENRES[g]
        ));
    }
    out.insert(Split::Train, names);
    Ok(out)
}

/// Generate the dataset into `out`, which must not exist or be empty. Built in a temporary sibling and renamed
/// into place, so an interrupted run leaves nothing behind.
pub fn generate(out: &Path, opts: &SynthOptions) -> Result<SynthReport> {
    let plan = prepare(out, opts)?;
    qean_io::fsutil::atomic_dir(out, |tmp| write_dataset(tmp, opts, &plan))
}

/// [`generate`] in another dataset layout (`layouts::convert` of the AIST++-layout set), as atomically.
pub fn generate_as(out: &Path, opts: &SynthOptions, layout: DataLayout) -> Result<SynthReport> {
    if layout == DataLayout::Aistpp {
        return generate(out, opts);
    }
    let plan = prepare(out, opts)?;
    qean_io::fsutil::atomic_dir(out, |tmp| {
        let aist = tmp.join("aistpp-source");
        std::fs::create_dir(&aist).map_err(|e| Error::io(&aist, e))?;
        let report = layouts::convert(&aist, tmp, layout, &write_dataset(&aist, opts, &plan)?)?;
        std::fs::remove_dir_all(&aist).map_err(|e| Error::io(&aist, e))?;
        let json = serde_json::to_vec_pretty(&report).map_err(|e| Error::msg(e.to_string()))?;
        atomic_write(&tmp.join("synth.json"), &json)?;
        Ok(report)
    })
}

/// Checks the options and that `out` is absent or empty (removing it then); the names of each split.
fn prepare(out: &Path, opts: &SynthOptions) -> Result<BTreeMap<Split, Vec<String>>> {
    if !(opts.seconds >= 1.0 && opts.seconds <= 600.0) {
        return Err(Error::msg(format!(
            "--seconds must be between 1 and 600, got {}",
            opts.seconds
        )));
    }
    if out.exists() {
        let empty = out
            .read_dir()
            .map_err(|e| Error::io(out, e))?
            .next()
            .is_none();
        if !empty {
            return Err(Error::at(out, "output directory exists and is not empty"));
        }
        std::fs::remove_dir(out).map_err(|e| Error::io(out, e))?;
    }
    plan_names(opts.sequences)
}

/// Music: one track per music ID under `dir/wav/`, a little longer than the longest dance (a real
/// recording where `opts` gives one for the ID).
fn write_music(
    dir: &Path,
    opts: &SynthOptions,
    music_ids: &[String],
) -> Result<BTreeMap<String, Track>> {
    let music_seconds = opts.seconds + 1.0;
    let mut music = BTreeMap::new();
    for id in music_ids {
        let mut rng = ChaCha8Rng::seed_from_u64(opts.seed ^ fnv(id));
        let bpm = tempo_prior(id).expect("planned IDs are valid");
        let genre = &id[1..3];
        let mut spec = MusicSpec::random(&mut rng, bpm, groove_of(genre), music_seconds);
        if opts.genre_music {
            spec.signature = qean_aistpp::names::GENRES.iter().position(|g| *g == genre);
        }
        if opts.varied_music {
            // Its own stream: the plain tracks stay what they were.
            let mut arr_rng = ChaCha8Rng::seed_from_u64(opts.seed ^ fnv(id) ^ fnv("arrangement"));
            spec.arrangement = music::Arrangement::random(&mut arr_rng, spec.phrase_chords.len());
        }
        let path = dir.join("wav").join(format!("{id}.wav"));
        let track = match opts.real_music.iter().find(|t| &t.music_id == id) {
            Some(real) => write_real_track(&path, real, spec, music_seconds, opts.sample_rate)?,
            None => {
                let samples = music::render(&spec, opts.sample_rate, &mut rng);
                qean_io::wav::write_pcm16(&path, &samples, opts.sample_rate)?;
                Track {
                    beat_times: spec.beat_times(),
                    info: MusicInfo {
                        bpm: spec.bpm,
                        first_beat: spec.first_beat,
                        seconds: spec.seconds,
                        arrangement: opts.varied_music.then(|| spec.arrangement.clone()),
                        phrase_chords: spec.phrase_chords,
                        source: None,
                    },
                }
            }
        };
        music.insert(id.clone(), track);
    }
    Ok(music)
}

fn write_dataset(
    dir: &Path,
    opts: &SynthOptions,
    plan: &BTreeMap<Split, Vec<String>>,
) -> Result<SynthReport> {
    for sub in ["motions", "wav", "splits"] {
        std::fs::create_dir(dir.join(sub)).map_err(|e| Error::io(dir.join(sub), e))?;
    }
    let all: Vec<&String> = plan.values().flatten().collect();
    let mut music_ids: Vec<String> = all
        .iter()
        .filter_map(|n| qean_aistpp::names::music_id_of(n))
        .collect();
    music_ids.sort();
    music_ids.dedup();

    for t in &opts.real_music {
        if !music_ids.contains(&t.music_id) {
            return Err(Error::msg(format!(
                "real track {}: music ID {} is not used by a {}-sequence dataset (used: {})",
                t.source,
                t.music_id,
                all.len(),
                music_ids.join(" ")
            )));
        }
    }

    let music = write_music(dir, opts, &music_ids)?;

    for name in &all {
        let parsed = qean_aistpp::names::SequenceName::parse(name)?;
        let track = &music[&parsed.music_id];
        let mut rng = ChaCha8Rng::seed_from_u64(opts.seed ^ fnv(name));
        let seconds = opts.seconds * rng.random_range(0.85..=1.0);
        let frames = (seconds * FPS).round() as usize;
        let grid = BeatGrid {
            beat_times: track.beat_times.clone(),
            phrase_chords: track.info.phrase_chords.clone(),
        };
        let style = DanceStyle {
            genre: parsed.genre.clone(),
            choreo: parsed.choreo as usize,
            energy: rng.random_range(0.8..1.2),
            seed: rng.random(),
            scaling: rng.random_range(85.0..105.0),
            posture: opts.genre_postures,
        };
        let motion = dance::generate(&grid, &style, frames);
        motion.write_pkl(
            &dir.join("motions").join(format!("{name}.pkl")),
            Precision::F32,
        )?;
    }

    for (split, names) in plan {
        let text = names.join("\n");
        atomic_write(&dir.join("splits").join(split.file_name()), text.as_bytes())?;
    }
    atomic_write(&dir.join("ignore_list.txt"), b"")?;

    let report = SynthReport {
        seed: opts.seed,
        seconds: opts.seconds,
        sample_rate: opts.sample_rate,
        varied_music: opts.varied_music,
        genre_postures: opts.genre_postures,
        genre_music: opts.genre_music,
        splits: plan
            .iter()
            .map(|(s, n)| (s.name().to_string(), n.clone()))
            .collect(),
        music: music.into_iter().map(|(id, t)| (id, t.info)).collect(),
    };
    let json = serde_json::to_vec_pretty(&report).map_err(|e| Error::msg(e.to_string()))?;
    atomic_write(&dir.join("synth.json"), &json)?;
    Ok(report)
}

/// Write a recording as `path` (looped or cut to `seconds`) and track its beats as the features will
/// (the music ID's tempo prior), so the dances follow what the model will hear.
fn write_real_track(
    path: &Path,
    real: &RealTrack,
    spec: MusicSpec,
    seconds: f64,
    sample_rate: u32,
) -> Result<Track> {
    use qean_audio::features::{music_features, FeatureOptions, COL_BEAT};
    let sr = qean_audio::SR as f64;
    let n = (seconds * sr).round() as usize;
    if real.samples.len() < sr as usize {
        return Err(Error::msg(format!(
            "real track {}: shorter than 1 s",
            real.source
        )));
    }
    let samples: Vec<f64> = real.samples.iter().copied().cycle().take(n).collect();
    let feats = music_features(
        &samples,
        &FeatureOptions::with_start_bpm(qean_aistpp::names::start_bpm(&real.music_id)),
    )?;
    let beat_times: Vec<f64> = feats
        .column(COL_BEAT)
        .iter()
        .enumerate()
        .filter(|(_, &v)| v > 0.5)
        .map(|(i, _)| i as f64 / FPS)
        .collect();
    if beat_times.len() < 4 {
        return Err(Error::msg(format!(
            "real track {}: only {} beats found in {seconds} s",
            real.source,
            beat_times.len()
        )));
    }
    let out = if sample_rate == qean_audio::SR {
        samples
    } else {
        qean_audio::resample::resample(
            &samples,
            sr,
            sample_rate as f64,
            qean_audio::resample::Resampler::KaiserFast,
            false,
        )?
    };
    qean_io::wav::write_pcm16(path, &out, sample_rate)?;
    let span = beat_times[beat_times.len() - 1] - beat_times[0];
    Ok(Track {
        info: MusicInfo {
            bpm: 60.0 * (beat_times.len() - 1) as f64 / span,
            first_beat: beat_times[0],
            seconds,
            phrase_chords: spec.phrase_chords,
            arrangement: None,
            source: Some(real.source.clone()),
        },
        beat_times,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use qean_aistpp::dataset::Dataset;
    use qean_aistpp::names::SequenceName;

    #[test]
    fn names_follow_aist_rules() {
        let plan = plan_names(120).unwrap();
        let test = &plan[&Split::Test];
        let val = &plan[&Split::Val];
        let train = &plan[&Split::Train];
        assert_eq!(test.len(), 20);
        assert_eq!(val.len(), 20);
        assert_eq!(train.len(), 80);
        let mut all: Vec<&String> = plan.values().flatten().collect();
        let n = all.len();
        all.sort();
        all.dedup();
        assert_eq!(all.len(), n, "names are unique");
        for t in test {
            let p = SequenceName::parse(t).unwrap();
            assert_eq!(p.situation, "sBM");
            assert_eq!(p.choreo, 2);
            assert!(TEST_MUSIC.contains(&p.music_id.as_str()));
        }
        for v in val {
            assert!(test.contains(&v.replace("_ch01", "_ch02")));
        }
        for t in train {
            let p = SequenceName::parse(t).unwrap();
            assert!(!TEST_MUSIC.contains(&p.music_id.as_str()), "{t}");
        }
        assert!(plan_names(2).is_err());
        // Large requests stay unique too.
        let big = plan_names(1000).unwrap();
        let mut all: Vec<&String> = big.values().flatten().collect();
        all.sort();
        all.dedup();
        assert_eq!(all.len(), 1000);
    }

    #[test]
    fn real_track_replaces_a_music_id_and_the_dances_follow_its_beats() {
        let trumpet = qean_io::testdata::shared_dir().join("music/sorohanro_-_solo-trumpet-06.ogg");
        let real = RealTrack::load(&trumpet, "mBR1").unwrap();
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("ds");
        let opts = SynthOptions {
            sequences: 12,
            seconds: 6.0,
            seed: 3,
            real_music: vec![real.clone()],
            ..Default::default()
        };
        let report = generate(&dir, &opts).unwrap();
        let info = &report.music["mBR1"];
        assert_eq!(
            info.source.as_deref(),
            Some("sorohanro_-_solo-trumpet-06.ogg")
        );
        // The dances follow the tracked beats of the loop (whatever tempo the tracker hears in it).
        assert!(info.bpm > 60.0 && info.bpm < 200.0, "bpm {}", info.bpm);
        assert!(info.first_beat < 2.0, "first beat {}", info.first_beat);
        assert!(report.music.values().filter(|m| m.source.is_none()).count() >= 5);
        // The written track is the recording, looped to 7 s.
        let a = qean_audio::load_audio(&dir.join("wav/mBR1.wav"), &Default::default()).unwrap();
        assert!((a.duration - 7.0).abs() < 0.01, "{}", a.duration);
        let n = real.samples.len().min(a.samples.len());
        let err = real.samples[..n]
            .iter()
            .zip(&a.samples[..n])
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-3, "max error {err}");
        // A music ID the dataset does not use is refused.
        let bad = SynthOptions {
            real_music: vec![RealTrack {
                music_id: "mKR5".into(),
                ..real
            }],
            ..opts
        };
        let e = generate(&root.path().join("ds2"), &bad).unwrap_err();
        assert!(e.to_string().contains("mKR5"), "{e}");
        assert!(!root.path().join("ds2").exists());
    }

    #[test]
    fn generate_small_dataset_deterministically() {
        let root = tempfile::tempdir().unwrap();
        let opts = SynthOptions {
            sequences: 12,
            seconds: 5.0,
            seed: 11,
            sample_rate: 8000,
            real_music: Vec::new(),
            varied_music: true,
            genre_postures: false,
            genre_music: false,
        };
        let a = root.path().join("a");
        let b = root.path().join("b");
        generate(&a, &opts).unwrap();
        generate(&b, &opts).unwrap();
        let ds = Dataset::open(&a).unwrap();
        let summary = ds.summary().unwrap();
        assert_eq!(summary.motion_files, 12);
        for s in &summary.splits {
            assert!(
                s.missing_motions.is_empty() && s.missing_music.is_empty(),
                "{s:?}"
            );
        }
        for name in ds.all_sequences().unwrap() {
            let pa = std::fs::read(ds.motion_path(&name)).unwrap();
            let pb = std::fs::read(b.join("motions").join(format!("{name}.pkl"))).unwrap();
            assert_eq!(pa, pb, "{name} differs between runs");
            let m = ds.read_motion(&name).unwrap();
            assert!(m.frames >= 255 && m.frames <= 300);
            assert!(m.scaling > 80.0);
        }
        // Existing non-empty output is refused and left alone.
        assert!(generate(&a, &opts).is_err());
        assert!(a.join("synth.json").is_file());
    }
}
