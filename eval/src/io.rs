//! The thin file layer of the `qean-eval` binary: joint arrays from `.npy`, precomputed music beats
//! from JSON, the report written atomically. AIST++ `.pkl` motions (SMPL parameters) need qean-data's
//! pickle reader and forward kinematics, and are refused with a clear error until those are merged.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use serde::Serialize;
use tracing::warn;

use crate::error::{Error, Result};
use crate::npy::read_npy;
use crate::positions::{Frame, Sequence, N_JOINTS};

/// Joints from a `.npy` of shape (T, 24, 3) or (T, 72), float32 or float64.
pub fn read_joints_npy(path: &Path) -> Result<Vec<Frame>> {
    let a = read_npy(path)?;
    let ok = matches!(a.shape.as_slice(), [_, 24, 3] | [_, 72]);
    if !ok {
        return Err(Error::file(
            path,
            format!(
                "joint array of shape {:?}; expected (T, 24, 3) or (T, 72)",
                a.shape
            ),
        ));
    }
    Ok(a.data
        .chunks_exact(N_JOINTS * 3)
        .map(|c| {
            let mut f = [[0.0; 3]; N_JOINTS];
            for (j, p) in f.iter_mut().enumerate() {
                p.copy_from_slice(&c[3 * j..3 * j + 3]);
            }
            f
        })
        .collect())
}

/// Every `.npy` in `dir`, sorted by name, named by file stem.
pub fn load_joints_dir(dir: &Path) -> Result<Vec<Sequence>> {
    let entries = std::fs::read_dir(dir).map_err(|e| Error::file(dir, e.to_string()))?;
    let mut paths: Vec<PathBuf> = Vec::new();
    for e in entries {
        let p = e.map_err(|e| Error::file(dir, e.to_string()))?.path();
        match p.extension().and_then(|x| x.to_str()) {
            Some("npy") => paths.push(p),
            Some("pkl") => {
                return Err(Error::file(
                    &p,
                    "AIST++ .pkl motions need SMPL forward kinematics, which this build cannot do yet; \
                     pass joint positions as .npy (T, 24, 3)",
                ))
            }
            _ if p.is_file() => warn!(file = %p.display(), "ignored: not a .npy joint array"),
            _ => {}
        }
    }
    if paths.is_empty() {
        return Err(Error::file(dir, "no .npy joint arrays in this directory"));
    }
    paths.sort();
    paths
        .iter()
        .map(|p| {
            let name = p
                .file_stem()
                .and_then(|s| s.to_str())
                .ok_or_else(|| Error::file(p, "file name is not UTF-8"))?;
            Ok(Sequence::new(name, read_joints_npy(p)?))
        })
        .collect()
}

/// Music beats per music ID from a JSON object `{"mBR0": [frame, ...], ...}` (60 FPS frames).
pub fn read_beats_json(path: &Path) -> Result<HashMap<String, Vec<usize>>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::file(path, e.to_string()))?;
    serde_json::from_str(&text).map_err(|e| {
        Error::file(
            path,
            format!("expected {{\"<music id>\": [beat frame, ...]}}: {e}"),
        )
    })
}

/// Write `value` as pretty JSON through a temporary file and a rename.
pub fn write_json_atomic<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value)
        .map_err(|e| Error::file(path, format!("cannot serialise: {e}")))?;
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    std::fs::write(&tmp, text + "\n").map_err(|e| Error::file(&tmp, e.to_string()))?;
    std::fs::rename(&tmp, path).map_err(|e| Error::file(path, e.to_string()))
}
