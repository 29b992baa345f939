//! `qean check-data DIR`: what a user reads before training on a dataset of any layout — counts, lengths,
//! frame rates, genres, foot sliding, joint jumps — and every defect, one line each: a motion that cannot be
//! read (a NaN frame, a truncated file, a wrong width), a listed sequence without its motion, music that is
//! missing, unreadable or shorter than its dance, joints out of range, and duplicated clips.

use std::collections::{BTreeMap, HashMap};
use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::layout::DataLayout;
use qean_aistpp::parallel::in_parallel;
use qean_eval::motion_energy::{FOOT_JOINTS, ON_FLOOR};
use qean_motion::fk::FkRoot;
use qean_motion::motion::FPS;
use qean_motion::Motion;

use crate::Result;

/// A motion longer than its music by more than this (seconds) is a defect (FineDance's own pairs differ by
/// a frame or two, AIST++'s music runs longer than its dances).
pub const MUSIC_SLACK_S: f64 = 0.5;
/// A joint further than this from the origin (metres) is out of range.
pub const MAX_REACH_M: f64 = 50.0;
/// A joint moving further than this between two 60-fps frames (metres; 30 m/s) has jumped.
pub const MAX_JUMP_M: f64 = 0.5;
/// A foot on its floor (within `ON_FLOOR`) moving faster than this horizontally (m/s) slides.
pub const SLIDE_SPEED: f64 = 0.5;

/// One problem, as one line: the file at fault and what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct Defect {
    pub path: PathBuf,
    pub problem: String,
}

/// What was measured of one readable motion.
#[derive(Debug, Clone)]
pub struct SequenceFacts {
    pub name: String,
    pub seconds: f64,
    /// Share of foot-on-floor frames whose foot slides (faster than [`SLIDE_SPEED`]).
    pub slide: f64,
    /// Largest joint move between consecutive frames (metres).
    pub max_jump: f64,
    /// Largest distance of a joint coordinate from the origin (metres).
    pub reach: f64,
    fingerprint: u64,
}

/// The whole check.
#[derive(Debug)]
pub struct DataCheck {
    pub root: PathBuf,
    pub layout: DataLayout,
    /// Usable sequences per split (ignored ones removed).
    pub splits: Vec<(Split, usize)>,
    pub sequences: Vec<SequenceFacts>,
    pub music: usize,
    /// FineDance's genre labels, counted over the readable labels.
    pub genres: BTreeMap<String, usize>,
    pub defects: Vec<Defect>,
}

/// Check every motion of `ds` and the music they dance to; `progress(done, total)` after each file.
pub fn check_data(ds: &Dataset, progress: impl FnMut(usize, usize) + Send) -> Result<DataCheck> {
    let names = ds.all_sequences()?;
    let mut defects = Vec::new();
    let mut splits = Vec::new();
    for split in Split::ALL {
        let listed = ds.split(split);
        for n in &listed {
            if !ds.motion_path(n).is_file() {
                defects.push(Defect {
                    path: ds.motion_path(n),
                    problem: format!(
                        "listed in the {} split, but the motion file is missing",
                        split.name()
                    ),
                });
            }
        }
        splits.push((split, listed.len()));
    }
    let music_ids = ds.music_ids(&names);
    let total = names.len() + music_ids.len();
    let progress = Mutex::new((0usize, progress));
    let tick = || {
        let mut p = progress.lock().unwrap_or_else(|e| e.into_inner());
        p.0 += 1;
        let done = p.0;
        (p.1)(done, total);
    };
    let motions = in_parallel(&names, |n| {
        let r = ds.read_motion(n).map(|m| facts(n, &m));
        tick();
        r
    });
    let music_seconds = in_parallel(&music_ids, |id| {
        let r = ds
            .audio_path(id)
            .map(|p| qean_audio::decode::decode_file(&p, f64::INFINITY));
        tick();
        r
    });
    let mut sequences = Vec::new();
    for (name, r) in names.iter().zip(motions) {
        match r {
            Ok(f) => sequences.push(f),
            Err(e) => defects.push(Defect {
                path: ds.motion_path(name),
                problem: strip_path(&e.to_string(), &ds.motion_path(name)),
            }),
        }
    }
    let mut seconds_of = HashMap::new();
    for (id, r) in music_ids.iter().zip(music_seconds) {
        match r {
            None => defects.push(Defect {
                path: ds.audio_dir().join(id),
                problem: format!("no music file for {id} (looked for .wav, .ogg, .mp3, .flac)"),
            }),
            Some(Err(e)) => defects.push(Defect {
                path: ds.audio_dir().join(id),
                problem: e.to_string(),
            }),
            Some(Ok(d)) => {
                seconds_of.insert(id.clone(), d.samples.len() as f64 / d.rate.max(1) as f64);
            }
        }
    }
    defects.extend(motion_defects(ds, &sequences, &seconds_of));
    let genres = genre_counts(ds, &names, &mut defects);
    Ok(DataCheck {
        root: ds.root.clone(),
        layout: ds.layout,
        splits,
        sequences,
        music: music_ids.len(),
        genres,
        defects,
    })
}

/// The error text without its leading "PATH: " (the defect line names the file once).
fn strip_path(message: &str, path: &Path) -> String {
    let prefix = format!("{}: ", path.display());
    message.strip_prefix(&prefix).unwrap_or(message).to_string()
}

/// Foot sliding, joint jumps and a fingerprint of one motion.
fn facts(name: &str, m: &Motion) -> SequenceFacts {
    let joints = m.joints(FkRoot::Smpl);
    let frames: Vec<&[[f64; 3]]> = joints.chunks_exact(24).collect();
    let floor = frames
        .iter()
        .take(60)
        .flat_map(|f| FOOT_JOINTS.iter().map(|&j| f[j][1]))
        .fold(f64::INFINITY, f64::min);
    let (mut on, mut sliding, mut max_jump) = (0usize, 0usize, 0.0f64);
    for w in frames.windows(2) {
        for &j in &FOOT_JOINTS {
            let (a, b) = (w[0][j], w[1][j]);
            if (a[1] - floor).abs() <= ON_FLOOR && (b[1] - floor).abs() <= ON_FLOOR {
                on += 1;
                let speed = ((b[0] - a[0]).powi(2) + (b[2] - a[2]).powi(2)).sqrt() * FPS;
                sliding += usize::from(speed > SLIDE_SPEED);
            }
        }
        for (p, q) in w[0].iter().zip(w[1]) {
            let d = (0..3).map(|k| (q[k] - p[k]).powi(2)).sum::<f64>().sqrt();
            max_jump = max_jump.max(d);
        }
    }
    let reach = joints
        .iter()
        .map(|p| p.iter().fold(0.0f64, |a, v| a.max(v.abs())))
        .fold(0.0, f64::max);
    let mut fingerprint = 0xcbf2_9ce4_8422_2325u64 ^ m.frames as u64;
    for v in m.poses.iter().chain(&m.trans) {
        fingerprint =
            (fingerprint ^ ((v * 1e4).round() as i64 as u64)).wrapping_mul(0x100_0000_01b3);
    }
    SequenceFacts {
        name: name.to_string(),
        seconds: m.seconds(),
        slide: sliding as f64 / on.max(1) as f64,
        max_jump,
        reach,
        fingerprint,
    }
}

/// Joints out of range, motions longer than their music, and clips that repeat another.
fn motion_defects(
    ds: &Dataset,
    sequences: &[SequenceFacts],
    music: &HashMap<String, f64>,
) -> Vec<Defect> {
    let mut out = Vec::new();
    let mut seen: HashMap<u64, &str> = HashMap::new();
    for s in sequences {
        let path = ds.motion_path(&s.name);
        if s.reach > MAX_REACH_M {
            out.push(Defect {
                path: path.clone(),
                problem: format!("a joint lies over {MAX_REACH_M} m from the origin"),
            });
        } else if s.max_jump > MAX_JUMP_M {
            out.push(Defect {
                path: path.clone(),
                problem: format!(
                    "a joint jumps {:.2} m between two frames (over {MAX_JUMP_M} m: a glitch)",
                    s.max_jump
                ),
            });
        }
        let id = ds.music_id(&s.name);
        if let Some(&music_s) = id.as_ref().and_then(|id| music.get(id)) {
            if s.seconds > music_s + MUSIC_SLACK_S {
                out.push(Defect {
                    path: path.clone(),
                    problem: format!(
                        "the motion lasts {:.2} s, its music {} only {music_s:.2} s",
                        s.seconds,
                        id.unwrap_or_default()
                    ),
                });
            }
        }
        match seen.get(&s.fingerprint) {
            Some(first) => out.push(Defect {
                path,
                problem: format!("the same clip as {first}"),
            }),
            None => {
                seen.insert(s.fingerprint, &s.name);
            }
        }
    }
    out
}

/// FineDance's genre labels, counted; a malformed or unknown label is a defect.
fn genre_counts(
    ds: &Dataset,
    names: &[String],
    defects: &mut Vec<Defect>,
) -> BTreeMap<String, usize> {
    let mut genres = BTreeMap::new();
    for n in names {
        match ds.genre_label(n) {
            Ok(Some(g)) => *genres.entry(g).or_insert(0) += 1,
            Ok(None) => {}
            Err(e) => {
                let path = ds.root.join("label_json").join(format!("{n}.json"));
                defects.push(Defect {
                    problem: strip_path(&e.to_string(), &path),
                    path,
                });
            }
        }
    }
    genres
}

impl fmt::Display for DataCheck {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let source_fps = match self.layout {
            DataLayout::FineDance => {
                "30 fps in the files, read at 60 fps (rotations' geodesic midpoints)"
            }
            DataLayout::Aistpp | DataLayout::Folder => "60 fps",
        };
        writeln!(
            f,
            "dataset: {} ({} layout; {source_fps})",
            self.root.display(),
            self.layout.name()
        )?;
        let splits: Vec<String> = self
            .splits
            .iter()
            .map(|(s, n)| format!("{} {n}", s.name()))
            .collect();
        writeln!(
            f,
            "sequences: {} readable motions; splits: {}; {} music files",
            self.sequences.len(),
            splits.join(", "),
            self.music
        )?;
        let mut secs: Vec<f64> = self.sequences.iter().map(|s| s.seconds).collect();
        secs.sort_by(f64::total_cmp);
        if let (Some(lo), Some(hi)) = (secs.first(), secs.last()) {
            let total: f64 = secs.iter().sum();
            writeln!(
                f,
                "lengths: {lo:.1} s shortest, {:.1} s median, {hi:.1} s longest; {:.2} h in all",
                secs[secs.len() / 2],
                total / 3600.0
            )?;
            let mut slides: Vec<&SequenceFacts> = self.sequences.iter().collect();
            slides.sort_by(|a, b| b.slide.total_cmp(&a.slide));
            let mean = slides.iter().map(|s| s.slide).sum::<f64>() / slides.len() as f64;
            let worst: Vec<String> = slides
                .iter()
                .take(3)
                .map(|s| format!("{} {:.0} %", s.name, 100.0 * s.slide))
                .collect();
            writeln!(f, "foot sliding (feet on the floor moving over {SLIDE_SPEED} m/s): {:.1} % of contact frames; most: {}", 100.0 * mean, worst.join(", "))?;
            let jump = self
                .sequences
                .iter()
                .map(|s| s.max_jump)
                .fold(0.0, f64::max);
            writeln!(f, "largest joint move between frames: {jump:.3} m")?;
        }
        if !self.genres.is_empty() {
            let g: Vec<String> = self
                .genres
                .iter()
                .map(|(g, n)| format!("{g} {n}"))
                .collect();
            writeln!(f, "genres: {}", g.join(", "))?;
        }
        writeln!(f, "defects: {}", self.defects.len())?;
        for d in &self.defects {
            writeln!(f, "  {}: {}", d.path.display(), d.problem)?;
        }
        Ok(())
    }
}
