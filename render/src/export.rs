//! Writing a generated (or any) dance in every output format at once: the AIST++ pickle (with `seed_frames`),
//! joint positions `.joints.npy` (frames × 24 × 3, float32), a BVH, and optionally the preview (GIF + PNG).
//! All files appear together or not at all.

use std::path::{Path, PathBuf};

use crate::{animation_gif, contact_sheet, Preview};
use qean_io::error::{Error, Result};
use qean_io::fsutil::temp_sibling;
use qean_io::pickle::ArrayRef;
use qean_motion::fk::FkRoot;
use qean_motion::motion::{Layout, Motion, Precision, FPS};

/// Paths written by [`export_dance`].
#[derive(Debug, Clone)]
pub struct ExportPaths {
    pub pkl: PathBuf,
    pub joints: PathBuf,
    pub bvh: PathBuf,
    pub preview_png: Option<PathBuf>,
    pub preview_gif: Option<PathBuf>,
}

impl ExportPaths {
    pub fn all(&self) -> Vec<&Path> {
        let mut v = vec![
            self.pkl.as_path(),
            self.joints.as_path(),
            self.bvh.as_path(),
        ];
        v.extend(self.preview_png.as_deref());
        v.extend(self.preview_gif.as_deref());
        v
    }
}

/// Options of [`export_dance`].
#[derive(Debug, Clone, Default)]
pub struct ExportOptions {
    pub seed_frames: usize,
    /// Music beat frames to mark in the preview.
    pub beats: Option<Vec<usize>>,
    pub render: bool,
    pub root: FkRoot,
}

/// Export model vectors (frames × layout dim) as `<dir>/<name>.{pkl,joints.npy,bvh}` (+ `.png`/`.gif` previews).
/// Rotation blocks are projected to SO(3) (SPEC §3.2) before anything is derived from them.
pub fn export_dance(
    dir: &Path,
    name: &str,
    vectors: &[f32],
    layout: Layout,
    opts: &ExportOptions,
) -> Result<ExportPaths> {
    if !dir.is_dir() {
        return Err(Error::at(dir, "output directory does not exist"));
    }
    let mut motion = Motion::from_layout(vectors, layout)
        .map_err(|m| Error::msg(format!("cannot export {name}: {m}")))?;
    motion.extra = vec![("seed_frames".into(), opts.seed_frames as i64)];
    let joints = motion.joints(opts.root);
    let flat = qean_motion::joints_file::joints_to_f32(&joints);

    let paths = ExportPaths {
        pkl: dir.join(format!("{name}.pkl")),
        joints: dir.join(format!("{name}.joints.npy")),
        bvh: dir.join(format!("{name}.bvh")),
        preview_png: opts.render.then(|| dir.join(format!("{name}.png"))),
        preview_gif: opts.render.then(|| dir.join(format!("{name}.gif"))),
    };
    let mut files: Vec<(PathBuf, Vec<u8>)> = vec![
        (paths.pkl.clone(), motion.to_pkl_bytes(Precision::F64)),
        (
            paths.joints.clone(),
            qean_io::npy::to_bytes(&[motion.frames, 24, 3], ArrayRef::F32(&flat)),
        ),
        (
            paths.bvh.clone(),
            qean_motion::bvh::to_bvh(&motion, opts.root).into_bytes(),
        ),
    ];
    if opts.render {
        let preview = Preview {
            title: name.to_string(),
            joints: &joints,
            fps: FPS,
            beats: opts.beats.as_deref(),
            seed_frames: opts.seed_frames,
        };
        files.push((
            paths.preview_png.clone().unwrap(),
            contact_sheet(&preview, 6, 2).to_png(),
        ));
        files.push((
            paths.preview_gif.clone().unwrap(),
            animation_gif(&preview, 320, 20.0),
        ));
    }
    write_all_or_nothing(&files)?;
    Ok(paths)
}

/// Write every file to a temporary sibling, then rename them all; on any failure remove what was written.
pub fn write_all_or_nothing(files: &[(PathBuf, Vec<u8>)]) -> Result<()> {
    let mut temps: Vec<PathBuf> = Vec::new();
    let cleanup = |temps: &[PathBuf]| {
        for t in temps {
            let _ = std::fs::remove_file(t);
        }
    };
    for (path, bytes) in files {
        let tmp = temp_sibling(path);
        if let Err(e) = std::fs::write(&tmp, bytes) {
            let _ = std::fs::remove_file(&tmp);
            cleanup(&temps);
            return Err(Error::io(path, e));
        }
        temps.push(tmp);
    }
    for (k, ((path, _), tmp)) in files.iter().zip(&temps).enumerate() {
        if let Err(e) = std::fs::rename(tmp, path) {
            for (p, _) in &files[..k] {
                let _ = std::fs::remove_file(p);
            }
            cleanup(&temps[k..]);
            return Err(Error::io(path, e));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exports_every_format() {
        let m = Motion::read_pkl(
            &qean_io::testdata::shared_dir()
                .join("aistpp/motions/softcat477_SMPL-to-FBX_sample.pkl"),
        )
        .unwrap();
        let v = m.to_layout(Layout::L225);
        let d = tempfile::tempdir().unwrap();
        let opts = ExportOptions {
            seed_frames: 20,
            beats: Some(vec![5, 35, 65]),
            render: true,
            root: FkRoot::Smpl,
        };
        let p = export_dance(d.path(), "dance", &v, Layout::L225, &opts).unwrap();
        assert_eq!(p.all().len(), 5);
        let back = Motion::read_pkl(&p.pkl).unwrap();
        assert_eq!(back.frames, 127);
        assert_eq!(back.extra, vec![("seed_frames".to_string(), 20)]);
        let j = qean_io::npy::read(&p.joints).unwrap();
        assert_eq!(j.shape, vec![127, 24, 3]);
        let b = qean_motion::bvh::read(&p.bvh).unwrap();
        assert_eq!(b.frames, 127);
        // Nothing but the five outputs is left in the directory.
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 5);
        // A missing directory fails without writing anything.
        assert!(export_dance(&d.path().join("nope"), "x", &v, Layout::L225, &opts).is_err());
    }
}
