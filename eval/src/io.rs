//! The thin file layer of the `qean-eval` binary: motions from a directory (joint positions as `.npy`
//! (T, 24, 3) or (T, 72), model vectors (T, 225|219), AIST++ `.pkl` through forward kinematics, or `.bvh`),
//! precomputed music beats from JSON, the report written atomically.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use qean_motion::FkRoot;
use serde::Serialize;
use tracing::warn;

use crate::error::{Error, Result};
use crate::positions::{Frame, Sequence, N_JOINTS};

/// Joint positions of one motion file. `.npy` of shape (T, 72) is read as flattened joints (as Bailando saves
/// them); everything else goes through `qean_motion::joints_file` (FK with the given root for SMPL parameters).
pub fn read_joints(path: &Path, root: FkRoot) -> Result<Vec<Frame>> {
    let is_npy = path.extension().and_then(|e| e.to_str()) == Some("npy");
    let points: Vec<[f64; 3]> = if is_npy {
        let a = qean_io::npy::read(path)?;
        if matches!(a.shape.as_slice(), [_, 72]) {
            a.data.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect()
        } else {
            qean_motion::joints_file::load_joints(path, root)?
        }
    } else {
        qean_motion::joints_file::load_joints(path, root)?
    };
    Ok(points
        .chunks_exact(N_JOINTS)
        .map(|c| {
            let mut f = [[0.0; 3]; N_JOINTS];
            f.copy_from_slice(c);
            f
        })
        .collect())
}

/// The sequence name of a motion file: no directory, no motion extension (`.npy`, `.pkl`, `.bvh`), no
/// `.joints` suffix (as `qean sample` writes).
pub fn sequence_name(file: &str) -> &str {
    let base = file.rsplit('/').next().unwrap_or(file);
    let stem = [".npy", ".pkl", ".bvh"]
        .iter()
        .find_map(|e| base.strip_suffix(e))
        .unwrap_or(base);
    stem.strip_suffix(".joints").unwrap_or(stem)
}

/// Every motion (`.npy`, `.pkl`, `.bvh`) in `dir`, sorted by name, named by file stem (a `.joints` suffix,
/// as `qean sample` writes, is dropped). A `<name>.music` file beside a motion names its music (one line:
/// a music ID or an audio file's stem).
pub fn load_joints_dir(dir: &Path, root: FkRoot) -> Result<Vec<Sequence>> {
    let entries = std::fs::read_dir(dir).map_err(|e| Error::file(dir, e.to_string()))?;
    let mut paths: Vec<PathBuf> = Vec::new();
    for e in entries {
        let p = e.map_err(|e| Error::file(dir, e.to_string()))?.path();
        match p.extension().and_then(|x| x.to_str()) {
            Some("npy") | Some("pkl") | Some("bvh") => paths.push(p),
            Some("music") => {} // a sidecar naming a motion's music, read below
            _ if p.is_file() => warn!(file = %p.display(), "ignored: not a motion file"),
            _ => {}
        }
    }
    if paths.is_empty() {
        return Err(Error::file(
            dir,
            "no motion files (.npy, .pkl, .bvh) in this directory",
        ));
    }
    paths.sort();
    let mut seqs: Vec<Sequence> = Vec::with_capacity(paths.len());
    for p in &paths {
        let file = p
            .file_name()
            .and_then(|s| s.to_str())
            .ok_or_else(|| Error::file(p, "file name is not UTF-8"))?;
        let name = sequence_name(file);
        if seqs.iter().any(|s| s.name == name) {
            warn!(file = %p.display(), "ignored: another file of sequence {name} was loaded");
            continue;
        }
        let mut seq = Sequence::new(name, read_joints(p, root)?);
        let sidecar = dir.join(format!("{name}.music"));
        if sidecar.is_file() {
            let key = std::fs::read_to_string(&sidecar)
                .map_err(|e| Error::file(&sidecar, e.to_string()))?;
            let key = key.trim();
            if key.is_empty() || key.contains('\n') {
                return Err(Error::file(&sidecar, "expected one line: the music's key"));
            }
            seq.music = Some(key.to_string());
        }
        seqs.push(seq);
    }
    Ok(seqs)
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

/// Write `value` as pretty JSON atomically.
pub fn write_json_atomic<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let text = serde_json::to_string_pretty(value)
        .map_err(|e| Error::file(path, format!("cannot serialise: {e}")))?;
    qean_io::fsutil::atomic_write(path, (text + "\n").as_bytes()).map_err(Error::from)
}
