//! Human summaries of the files and directories the project reads (`qean inspect`).

use std::fmt;
use std::path::{Path, PathBuf};

use crate::dataset::{Dataset, DatasetSummary, ListSource};
use crate::layout::DataLayout;
use qean_io::error::{Error, Result};
use qean_io::pickle::{self, Value};
use qean_motion::finedance;
use qean_motion::fk::FkRoot;
use qean_motion::motion::{joint_ranges, Motion, FPS};
use qean_motion::skeleton::NUM_JOINTS;

/// What `qean inspect` found.
#[derive(Debug)]
pub enum Summary {
    Motion(MotionSummary),
    Npy(NpySummary),
    Dataset(DatasetSummary),
}

#[derive(Debug)]
pub struct MotionSummary {
    pub path: PathBuf,
    /// Every key with a short description of its value.
    pub keys: Vec<(String, String)>,
    pub motion: Motion,
    /// Per-axis [min, max] of the joint positions (SMPL root convention), metres.
    pub joint_ranges: [[f64; 2]; 3],
}

#[derive(Debug)]
pub struct NpySummary {
    pub path: PathBuf,
    pub shape: Vec<usize>,
    pub dtype: String,
    pub kind: &'static str,
    pub ranges: Option<[[f64; 2]; 3]>,
    pub min: f64,
    pub max: f64,
    /// The frame rate of its frames (FineDance's 30, otherwise AIST++'s 60).
    pub fps: f64,
}

/// Summarise a motion pickle, a `.npy` file or an AIST++-layout directory.
pub fn inspect(path: &Path) -> Result<Summary> {
    if path.is_dir() {
        return Ok(Summary::Dataset(Dataset::open(path)?.summary()?));
    }
    if !path.exists() {
        return Err(Error::at(path, "no such file or directory"));
    }
    let ext = qean_io::fsutil::extension_lower(path);
    match ext.as_str() {
        "pkl" | "pickle" => inspect_motion(path).map(Summary::Motion),
        "npy" => inspect_npy(path).map(Summary::Npy),
        _ => Err(Error::at(
            path,
            "don't know how to inspect this file (expected .pkl, .npy or a dataset directory)",
        )),
    }
}

fn describe(v: &Value) -> String {
    match v.to_array() {
        Ok(a) if a.shape.is_empty() => format!("{} scalar {}", a.dtype.code(), a.data[0]),
        Ok(a) => format!("{} {:?}", a.dtype.code(), a.shape),
        Err(_) => match v {
            Value::Int(i) => format!("int {i}"),
            Value::Str(s) => format!("str {s:?}"),
            Value::Object(name) => format!("object {name}"),
            _ => "other".into(),
        },
    }
}

fn inspect_motion(path: &Path) -> Result<MotionSummary> {
    let keys = pickle::read_dict(path)?
        .iter()
        .map(|(k, v)| (k.clone(), describe(v)))
        .collect();
    let motion = Motion::read_pkl(path)?;
    let joints = motion.joints(FkRoot::Smpl);
    Ok(MotionSummary {
        path: path.to_path_buf(),
        keys,
        joint_ranges: joint_ranges(&joints),
        motion,
    })
}

fn inspect_npy(path: &Path) -> Result<NpySummary> {
    let a = qean_io::npy::read(path)?;
    let kind = match a.shape.as_slice() {
        [_, 24, 3] => "joint positions (frames × 24 × 3)",
        [_, 35] => "35-D music features (frames × 35)",
        [_, 225] => "motion, 225-D layout (frames × 225)",
        [_, 219] => "motion, 219-D layout (frames × 219)",
        [_, 72] => "SMPL axis-angle poses (frames × 72)",
        [_, finedance::WIDTH] => {
            "FineDance motion (frames × 315: translation + 52 joints × 6-D rotation, 30 fps)"
        }
        _ => "array",
    };
    let fine = matches!(a.shape.as_slice(), [_, finedance::WIDTH]);
    let ranges = if fine {
        // The 24 SMPL joints of the motion it reads as (qean_motion::finedance).
        let m = finedance::to_motion(&a.data, a.shape[0]).map_err(|e| Error::at(path, e))?;
        Some(joint_ranges(&m.joints(FkRoot::Smpl)))
    } else {
        (a.shape.len() == 3 && a.shape[1] == NUM_JOINTS && a.shape[2] == 3).then(|| {
            let pts: Vec<[f64; 3]> = a.data.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            joint_ranges(&pts)
        })
    };
    let (min, max) = a
        .data
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        });
    Ok(NpySummary {
        path: path.to_path_buf(),
        shape: a.shape,
        dtype: a.dtype.code().to_string(),
        kind,
        ranges,
        min,
        max,
        fps: if fine { finedance::FPS } else { FPS },
    })
}

fn write_ranges(f: &mut fmt::Formatter<'_>, r: &[[f64; 2]; 3]) -> fmt::Result {
    for (axis, [lo, hi]) in ["x", "y", "z"].iter().zip(r) {
        writeln!(f, "  {axis}: [{lo:.4}, {hi:.4}] m")?;
    }
    Ok(())
}

impl fmt::Display for Summary {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Summary::Motion(m) => {
                writeln!(f, "motion: {}", m.path.display())?;
                writeln!(f, "frames: {}", m.motion.frames)?;
                writeln!(f, "seconds: {:.3} at {FPS} fps", m.motion.seconds())?;
                writeln!(f, "keys:")?;
                for (k, d) in &m.keys {
                    writeln!(f, "  {k}: {d}")?;
                }
                writeln!(f, "smpl_scaling: {}", m.motion.scaling)?;
                writeln!(f, "joint position ranges (SMPL root, +Y up):")?;
                write_ranges(f, &m.joint_ranges)
            }
            Summary::Npy(n) => {
                writeln!(f, "npy: {}", n.path.display())?;
                writeln!(f, "shape: {:?} {}", n.shape, n.dtype)?;
                writeln!(f, "looks like: {}", n.kind)?;
                if let Some(frames) = n.shape.first().filter(|_| n.shape.len() >= 2) {
                    writeln!(
                        f,
                        "frames: {frames} ({:.3} s at {} fps)",
                        *frames as f64 / n.fps,
                        n.fps
                    )?;
                }
                writeln!(f, "value range: [{:.6}, {:.6}]", n.min, n.max)?;
                if let Some(r) = &n.ranges {
                    writeln!(f, "joint position ranges:")?;
                    write_ranges(f, r)?;
                }
                Ok(())
            }
            Summary::Dataset(d) => {
                writeln!(
                    f,
                    "dataset: {} ({} layout)",
                    d.root.display(),
                    d.layout.name()
                )?;
                writeln!(f, "motion files (not ignored): {}", d.motion_files)?;
                for s in &d.splits {
                    let src = match (&s.source, d.layout) {
                        (ListSource::File(p), _) => p.display().to_string(),
                        (ListSource::Embedded, DataLayout::Aistpp) => {
                            "official AIST++ list (embedded)".into()
                        }
                        (ListSource::Embedded, DataLayout::FineDance) => {
                            "FineDance@Genre list (embedded)".into()
                        }
                        (ListSource::Embedded, DataLayout::Folder) => {
                            "no list: every tenth name held out".into()
                        }
                    };
                    writeln!(
                        f,
                        "{:<5}: {} sequences ({} listed, {} ignored), {} music IDs  [{}]",
                        s.split.name(),
                        s.usable,
                        s.listed,
                        s.ignored,
                        s.music_ids,
                        src
                    )?;
                    if !s.missing_motions.is_empty() {
                        writeln!(
                            f,
                            "       missing motions: {} (e.g. {})",
                            s.missing_motions.len(),
                            s.missing_motions[0]
                        )?;
                    }
                    if !s.missing_music.is_empty() {
                        writeln!(
                            f,
                            "       missing music: {} ({})",
                            s.missing_music.len(),
                            s.missing_music.join(", ")
                        )?;
                    }
                }
                Ok(())
            }
        }
    }
}
