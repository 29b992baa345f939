//! AIST++ motion sequences (SPEC §1.2, §1.4): SMPL axis-angle poses plus root translation, read from and
//! written to the dataset's pickle format, and converted to the model layouts (225-D and 219-D).

use std::path::Path;

use crate::fk::{forward_kinematics, FkRoot};
use crate::rotation::{axis_angle_to_matrix, matrix_to_axis_angle, project_to_so3, Mat3};
use crate::skeleton::NUM_JOINTS;
use qean_io::error::{Error, Result};
use qean_io::fsutil::atomic_write;
use qean_io::pickle::{self, ArrayRef, DType};

/// Frames per second of AIST++ motion (and of the audio features).
pub const FPS: f64 = 60.0;

/// The per-frame vector the models read and write (SPEC §1.4). In configs and JSON it is its width,
/// the number 225 or 219 (a string "225" is read too).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Layout {
    /// [0×6 | trans | R_0 … R_23]: mint's FACT layout (translation padded to 9 dims). The default.
    #[default]
    L225,
    /// [trans | R_0 … R_23].
    L219,
}

impl serde::Serialize for Layout {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.serialize_u64(self.dim() as u64)
    }
}

impl<'de> serde::Deserialize<'de> for Layout {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        #[derive(serde::Deserialize)]
        #[serde(untagged)]
        enum Width {
            Number(u64),
            Text(String),
        }
        let n = match Width::deserialize(d)? {
            Width::Number(n) => n,
            Width::Text(t) => t.parse().map_err(|_| {
                serde::de::Error::custom(format!("layout must be 225 or 219, got {t:?}"))
            })?,
        };
        match n {
            225 => Ok(Layout::L225),
            219 => Ok(Layout::L219),
            other => Err(serde::de::Error::custom(format!(
                "layout must be 225 or 219, got {other}"
            ))),
        }
    }
}

impl Layout {
    pub fn dim(self) -> usize {
        match self {
            Layout::L225 => 225,
            Layout::L219 => 219,
        }
    }

    /// Index of the first translation value.
    pub fn trans_offset(self) -> usize {
        match self {
            Layout::L225 => 6,
            Layout::L219 => 0,
        }
    }

    pub fn from_dim(d: usize) -> Option<Layout> {
        match d {
            225 => Some(Layout::L225),
            219 => Some(Layout::L219),
            _ => None,
        }
    }
}

/// One motion sequence. Poses are axis-angle, joint-major (`poses[72·t + 3·j + a]`).
#[derive(Debug, Clone, PartialEq)]
pub struct Motion {
    pub frames: usize,
    /// Axis-angle, frames × 72.
    pub poses: Vec<f64>,
    /// Root translation as stored (before division by `scaling`), frames × 3.
    pub trans: Vec<f64>,
    /// `smpl_scaling`; every consumer divides the translation by it.
    pub scaling: f64,
    /// Extra integer entries written next to the arrays (e.g. `seed_frames`).
    pub extra: Vec<(String, i64)>,
}

/// Element precision of arrays we write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Precision {
    F32,
    F64,
}

impl Motion {
    /// Build a motion, checking shapes and values.
    pub fn new(
        poses: Vec<f64>,
        trans: Vec<f64>,
        scaling: f64,
    ) -> std::result::Result<Self, String> {
        if !trans.len().is_multiple_of(3) || !poses.len().is_multiple_of(72) {
            return Err("poses must be N×72 and trans N×3".into());
        }
        let frames = trans.len() / 3;
        if poses.len() != frames * 72 {
            return Err(format!(
                "smpl_poses has {} frames but smpl_trans has {frames}",
                poses.len() / 72
            ));
        }
        let m = Motion {
            frames,
            poses,
            trans,
            scaling,
            extra: vec![],
        };
        m.validate()?;
        Ok(m)
    }

    fn validate(&self) -> std::result::Result<(), String> {
        if self.frames == 0 {
            return Err("the motion has no frames".into());
        }
        if !(self.scaling.is_finite() && self.scaling > 0.0) {
            return Err(format!(
                "smpl_scaling must be a positive number, got {}",
                self.scaling
            ));
        }
        if let Some(i) = self.poses.iter().position(|x| !x.is_finite()) {
            return Err(format!(
                "smpl_poses has a non-finite value at frame {}",
                i / 72
            ));
        }
        if let Some(i) = self.trans.iter().position(|x| !x.is_finite()) {
            return Err(format!(
                "smpl_trans has a non-finite value at frame {}",
                i / 3
            ));
        }
        Ok(())
    }

    /// A neutral standing pose held for `frames` frames: every joint rotation the identity (SMPL's T-pose
    /// rest), the root over the origin at the height that puts the lowest joint on the floor (y = 0).
    /// The sampler's seed when no seed motion is given.
    pub fn standing(frames: usize, root: FkRoot) -> Motion {
        let frames = frames.max(1);
        let mut m = Motion {
            frames: 1,
            poses: vec![0.0; 72],
            trans: vec![0.0; 3],
            scaling: 1.0,
            extra: vec![],
        };
        let lowest = m
            .joints(root)
            .iter()
            .map(|p| p[1])
            .fold(f64::INFINITY, f64::min);
        m.trans[1] = -lowest;
        Motion {
            frames,
            poses: m.poses.repeat(frames),
            trans: m.trans.repeat(frames),
            ..m
        }
    }

    /// Read an AIST++ motion pickle (`smpl_poses` (N,72) or (N,24,3), `smpl_trans` (N,3), optional
    /// `smpl_scaling` (1,) — 1.0 when absent; other keys are ignored).
    pub fn read_pkl(path: &Path) -> Result<Motion> {
        let items = pickle::read_dict(path)?;
        let get = |key: &str| items.iter().find(|(k, _)| k == key).map(|(_, v)| v);
        let arr = |key: &str| -> Result<pickle::NdArray> {
            let v = get(key).ok_or_else(|| {
                let keys: Vec<&str> = items.iter().map(|(k, _)| k.as_str()).collect();
                Error::at(
                    path,
                    format!("missing key '{key}' (keys present: {})", keys.join(", ")),
                )
            })?;
            v.to_array()
                .map_err(|m| Error::at(path, format!("'{key}': {m}")))
        };
        let poses = arr("smpl_poses")?;
        let trans = arr("smpl_trans")?;
        let ok_pose_shape = matches!(poses.shape.as_slice(), [_, 72] | [_, 24, 3]);
        if !ok_pose_shape {
            return Err(Error::at(
                path,
                format!(
                    "'smpl_poses' has shape {:?}, expected (N, 72) or (N, 24, 3)",
                    poses.shape
                ),
            ));
        }
        if !matches!(trans.shape.as_slice(), [_, 3]) {
            return Err(Error::at(
                path,
                format!("'smpl_trans' has shape {:?}, expected (N, 3)", trans.shape),
            ));
        }
        for (key, a) in [("smpl_poses", &poses), ("smpl_trans", &trans)] {
            if !matches!(a.dtype, DType::F4 | DType::F8 | DType::F2) {
                return Err(Error::at(
                    path,
                    format!(
                        "'{key}' has dtype {}, expected float32 or float64",
                        a.dtype.code()
                    ),
                ));
            }
        }
        let scaling = match get("smpl_scaling") {
            None => 1.0,
            Some(v) => {
                let a = v
                    .to_array()
                    .map_err(|m| Error::at(path, format!("'smpl_scaling': {m}")))?;
                if a.len() != 1 {
                    return Err(Error::at(
                        path,
                        format!("'smpl_scaling' has shape {:?}, expected (1,)", a.shape),
                    ));
                }
                a.data[0]
            }
        };
        let mut m = Motion::new(poses.data, trans.data, scaling).map_err(|e| Error::at(path, e))?;
        for (k, v) in &items {
            if let pickle::Value::Int(i) = v {
                m.extra.push((k.clone(), *i));
            }
        }
        Ok(m)
    }

    /// Write in the AIST++ pickle format (`smpl_poses` (N,72), `smpl_trans` (N,3), `smpl_scaling` (1,),
    /// plus the `extra` integers). Atomic.
    pub fn write_pkl(&self, path: &Path, precision: Precision) -> Result<()> {
        let bytes = self.to_pkl_bytes(precision);
        atomic_write(path, &bytes)
    }

    pub fn to_pkl_bytes(&self, precision: Precision) -> Vec<u8> {
        let scaling = [self.scaling];
        let ints: Vec<(&str, i64)> = self.extra.iter().map(|(k, v)| (k.as_str(), *v)).collect();
        let n = self.frames;
        match precision {
            Precision::F64 => pickle::dumps_dict(
                &[
                    ("smpl_poses", &[n, 72], ArrayRef::F64(&self.poses)),
                    ("smpl_trans", &[n, 3], ArrayRef::F64(&self.trans)),
                    ("smpl_scaling", &[1], ArrayRef::F64(&scaling)),
                ],
                &ints,
            ),
            Precision::F32 => {
                let p: Vec<f32> = self.poses.iter().map(|&x| x as f32).collect();
                let t: Vec<f32> = self.trans.iter().map(|&x| x as f32).collect();
                let s = [self.scaling as f32];
                pickle::dumps_dict(
                    &[
                        ("smpl_poses", &[n, 72], ArrayRef::F32(&p)),
                        ("smpl_trans", &[n, 3], ArrayRef::F32(&t)),
                        ("smpl_scaling", &[1], ArrayRef::F32(&s)),
                    ],
                    &ints,
                )
            }
        }
    }

    pub fn seconds(&self) -> f64 {
        self.frames as f64 / FPS
    }

    /// Root translation divided by the scaling, frames × 3.
    pub fn root_positions(&self) -> Vec<[f64; 3]> {
        self.trans
            .chunks_exact(3)
            .map(|t| {
                [
                    t[0] / self.scaling,
                    t[1] / self.scaling,
                    t[2] / self.scaling,
                ]
            })
            .collect()
    }

    /// Joint rotation matrices, frames × 24.
    pub fn rotations(&self) -> Vec<Mat3> {
        self.poses
            .chunks_exact(3)
            .map(|r| axis_angle_to_matrix([r[0], r[1], r[2]]))
            .collect()
    }

    /// Joint positions (frames × 24) by forward kinematics.
    pub fn joints(&self, root: FkRoot) -> Vec<[f64; 3]> {
        forward_kinematics(&self.root_positions(), &self.rotations(), root)
    }

    /// The model's per-frame vectors, frames × layout.dim(), f32.
    pub fn to_layout(&self, layout: Layout) -> Vec<f32> {
        let d = layout.dim();
        let off = layout.trans_offset();
        let mut out = vec![0f32; self.frames * d];
        let roots = self.root_positions();
        let rots = self.rotations();
        for t in 0..self.frames {
            let row = &mut out[t * d..(t + 1) * d];
            for a in 0..3 {
                row[off + a] = roots[t][a] as f32;
            }
            for j in 0..NUM_JOINTS {
                for (k, &v) in rots[t * NUM_JOINTS + j].iter().enumerate() {
                    row[off + 3 + 9 * j + k] = v as f32;
                }
            }
        }
        out
    }

    /// A motion from model vectors (frames × layout.dim()). Rotation blocks are projected to SO(3) first
    /// (SPEC §3.2) and converted to axis-angle; scaling is 1.
    pub fn from_layout(data: &[f32], layout: Layout) -> std::result::Result<Motion, String> {
        let d = layout.dim();
        if data.is_empty() || !data.len().is_multiple_of(d) {
            return Err(format!("expected frames × {d} values, got {}", data.len()));
        }
        let frames = data.len() / d;
        let off = layout.trans_offset();
        let mut poses = Vec::with_capacity(frames * 72);
        let mut trans = Vec::with_capacity(frames * 3);
        for row in data.chunks_exact(d) {
            trans.extend(row[off..off + 3].iter().map(|&x| x as f64));
            for j in 0..NUM_JOINTS {
                let b = off + 3 + 9 * j;
                let m: Mat3 = std::array::from_fn(|k| row[b + k] as f64);
                poses.extend(matrix_to_axis_angle(&project_to_so3(&m)));
            }
        }
        Motion::new(poses, trans, 1.0)
    }

    /// Frames [start, end) as a new motion.
    pub fn slice(&self, start: usize, end: usize) -> Motion {
        let end = end.min(self.frames);
        Motion {
            frames: end - start,
            poses: self.poses[start * 72..end * 72].to_vec(),
            trans: self.trans[start * 3..end * 3].to_vec(),
            scaling: self.scaling,
            extra: self.extra.clone(),
        }
    }
}

/// Read a motion from an AIST++ pickle, a `.npy` of model vectors (frames, 225 | 219) or a FineDance motion
/// (frames, 315) at 30 fps, read as 60-fps SMPL (`crate::finedance`).
pub fn read_motion(path: &Path) -> Result<Motion> {
    let ext = qean_io::fsutil::extension_lower(path);
    match ext.as_str() {
        "pkl" | "pickle" => Motion::read_pkl(path),
        "npy" => {
            let a = qean_io::npy::read(path)?;
            if let [frames, crate::finedance::WIDTH] = a.shape[..] {
                return crate::finedance::to_motion(&a.data, frames)
                    .map_err(|m| Error::at(path, m));
            }
            let layout = match a.shape.as_slice() {
                [_, d] => Layout::from_dim(*d),
                _ => None,
            }
            .ok_or_else(|| {
                Error::at(
                    path,
                    format!(
                        "array of shape {:?} is not a motion (expected model vectors (frames, 225|219) or FineDance rows (frames, 315))",
                        a.shape
                    ),
                )
            })?;
            let v: Vec<f32> = a.data.iter().map(|&x| x as f32).collect();
            Motion::from_layout(&v, layout).map_err(|m| Error::at(path, m))
        }
        _ => Err(Error::at(
            path,
            "unknown motion format (expected .pkl or .npy)",
        )),
    }
}

/// Per-axis minimum and maximum of joint positions (frames × 24), for summaries.
pub fn joint_ranges(joints: &[[f64; 3]]) -> [[f64; 2]; 3] {
    let mut r = [[f64::INFINITY, f64::NEG_INFINITY]; 3];
    for p in joints {
        for a in 0..3 {
            r[a][0] = r[a][0].min(p[a]);
            r[a][1] = r[a][1].max(p[a]);
        }
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn standing_pose_has_feet_on_the_floor() {
        for root in [FkRoot::Smpl, FkRoot::Edge] {
            let m = Motion::standing(5, root);
            assert_eq!(m.frames, 5);
            let j = m.joints(root);
            let lowest = j[..24].iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
            assert!(lowest.abs() < 1e-12, "{lowest}");
            let head = j[15][1];
            assert!(head > 1.2 && head < 2.0, "head height {head}");
            assert_eq!(j[..24], j[24 * 4..]);
        }
    }
    use qean_io::testdata::shared_dir;

    fn sample_json() -> (Vec<f64>, Vec<f64>) {
        let txt =
            std::fs::read_to_string(shared_dir().join("aistpp/motions/softcat477_sample.json"))
                .unwrap();
        let v: serde_json::Value = serde_json::from_str(&txt).unwrap();
        let flat = |x: &serde_json::Value| -> Vec<f64> {
            fn go(x: &serde_json::Value, out: &mut Vec<f64>) {
                match x {
                    serde_json::Value::Array(a) => a.iter().for_each(|y| go(y, out)),
                    serde_json::Value::Number(n) => out.push(n.as_f64().unwrap()),
                    _ => {}
                }
            }
            let mut out = vec![];
            go(x, &mut out);
            out
        };
        (flat(&v["smpl_poses"]), flat(&v["smpl_trans"]))
    }

    #[test]
    fn both_sample_pickles_load_and_match_json() {
        let (poses, trans) = sample_json();
        for name in [
            "softcat477_SMPL-to-FBX_sample.pkl",
            "softcat477_sample_with_scaling.pkl",
        ] {
            let m = Motion::read_pkl(&shared_dir().join("aistpp/motions").join(name)).unwrap();
            assert_eq!(m.frames, 127);
            assert_eq!(m.poses.len(), 127 * 72);
            assert_eq!(m.scaling, 1.0);
            for (a, b) in m.poses.iter().zip(&poses) {
                assert!((a - b).abs() < 1e-12);
            }
            for (a, b) in m.trans.iter().zip(&trans) {
                assert!((a - b).abs() < 1e-6); // stored as float32
            }
        }
    }

    #[test]
    fn layout_round_trip() {
        let m = Motion::read_pkl(
            &shared_dir().join("aistpp/motions/softcat477_sample_with_scaling.pkl"),
        )
        .unwrap();
        for layout in [Layout::L225, Layout::L219] {
            let v = m.to_layout(layout);
            assert_eq!(v.len(), 127 * layout.dim());
            if layout == Layout::L225 {
                assert!(v[..6].iter().all(|&x| x == 0.0));
                // element (a, b) of joint j at 9 + 9j + 3a + b
                let r =
                    axis_angle_to_matrix([m.poses[3 * 5], m.poses[3 * 5 + 1], m.poses[3 * 5 + 2]]);
                assert!((v[9 + 9 * 5 + 3] as f64 - r[3]).abs() < 1e-6);
            }
            let back = Motion::from_layout(&v, layout).unwrap();
            let j1 = m.joints(FkRoot::Smpl);
            let j2 = back.joints(FkRoot::Smpl);
            let err = j1
                .iter()
                .zip(&j2)
                .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
                .fold(0.0, f64::max);
            assert!(err < 1e-5, "{err}");
        }
    }

    #[test]
    fn pickle_round_trip_both_precisions() {
        let m = Motion::read_pkl(
            &shared_dir().join("aistpp/motions/softcat477_SMPL-to-FBX_sample.pkl"),
        )
        .unwrap();
        let dir = tempfile::tempdir().unwrap();
        for p in [Precision::F64, Precision::F32] {
            let path = dir.path().join("m.pkl");
            let mut m2 = m.clone();
            m2.extra = vec![("seed_frames".into(), 120)];
            m2.write_pkl(&path, p).unwrap();
            let back = Motion::read_pkl(&path).unwrap();
            assert_eq!(back.frames, m.frames);
            assert_eq!(back.extra, vec![("seed_frames".to_string(), 120)]);
            let tol = if p == Precision::F64 { 0.0 } else { 1e-6 };
            for (a, b) in back.poses.iter().zip(&m.poses) {
                assert!((a - b).abs() <= tol * a.abs().max(1.0));
            }
        }
    }

    #[test]
    fn rejects_bad_motions() {
        assert!(Motion::new(vec![0.0; 72], vec![0.0; 6], 1.0).is_err());
        assert!(Motion::new(vec![f64::NAN; 72], vec![0.0; 3], 1.0).is_err());
        assert!(Motion::new(vec![0.0; 72], vec![0.0; 3], 0.0).is_err());
        assert!(Motion::new(vec![], vec![], 1.0).is_err());
    }
}
