//! FineDance motion files (Li et al., ICCV 2023; `motion/*.npy`): [T, 315] rows of root translation and 52
//! joints in the 6-D rotation representation at 30 fps, read as the 24-joint SMPL [`Motion`] at 60 fps that
//! every model here takes (`qean_motion::finedance` states the reduction and the resampling). The release
//! is not redistributed: get it from the FineDance authors.

use std::path::Path;

use qean_io::error::{Error, Result};
use qean_motion::finedance::{to_motion, WIDTH};
use qean_motion::Motion;

/// A FineDance motion file as a 60-fps SMPL motion, or one error naming the file and what is wrong with it.
pub fn read_motion(path: &Path) -> Result<Motion> {
    let a = qean_io::npy::read(path)?;
    let frames = match a.shape[..] {
        [t, w] if w == WIDTH => t,
        _ => {
            return Err(Error::at(
                path,
                format!(
                    "a FineDance motion is [frames, {WIDTH}] (3 translation + 52 joints × 6-D rotation), this array is {:?}",
                    a.shape
                ),
            ))
        }
    };
    to_motion(&a.data, frames).map_err(|m| Error::at(path, m))
}

#[cfg(test)]
mod tests {
    use super::*;
    use qean_motion::finedance::from_motion;

    fn dance(frames: usize) -> Motion {
        let poses = (0..frames * 72)
            .map(|i| {
                if (i / 3) % 24 < 22 {
                    0.3 * ((i as f64) * 0.37).sin()
                } else {
                    0.0
                }
            })
            .collect();
        let trans = (0..frames * 3).map(|i| 0.01 * i as f64).collect();
        Motion::new(poses, trans, 1.0).unwrap()
    }

    /// Written in FineDance's layout (f32, as the release) and read back: the kept frames, within f32.
    #[test]
    fn a_written_file_reads_back() {
        let dir = tempfile::tempdir().unwrap();
        let m = dance(9);
        let rows: Vec<f32> = from_motion(&m).iter().map(|&v| v as f32).collect();
        let path = dir.path().join("001.npy");
        qean_io::npy::write_f32(&path, &[5, WIDTH], &rows).unwrap();
        let back = read_motion(&path).unwrap();
        assert_eq!(back.frames, 9);
        for f in (0..9).step_by(2) {
            for i in 0..72 {
                assert!((back.poses[f * 72 + i] - m.poses[f * 72 + i]).abs() < 1e-5);
            }
            for k in 0..3 {
                assert!((back.trans[f * 3 + k] - m.trans[f * 3 + k]).abs() < 1e-6);
            }
        }
    }

    /// `qean inspect` tells a FineDance file by its width, at its own 30 fps, with the joints it reads as; a
    /// NaN in it is one error naming the file and the frame.
    #[test]
    fn inspect_knows_a_finedance_file() {
        let dir = tempfile::tempdir().unwrap();
        let mut rows = from_motion(&dance(9));
        let path = dir.path().join("003.npy");
        qean_io::npy::write_f64(&path, &[5, WIDTH], &rows).unwrap();
        let text = crate::inspect::inspect(&path).unwrap().to_string();
        assert!(
            text.contains("FineDance motion") && text.contains("(0.167 s at 30 fps)"),
            "{text}"
        );
        assert!(text.contains("joint position ranges"), "{text}");
        rows[2 * WIDTH + 7] = f64::NAN;
        qean_io::npy::write_f64(&path, &[5, WIDTH], &rows).unwrap();
        let e = crate::inspect::inspect(&path).unwrap_err().to_string();
        assert!(e.contains("003.npy") && e.contains("frame 2"), "{e}");
    }

    #[test]
    fn the_wrong_width_names_the_file_and_the_layout() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("002.npy");
        qean_io::npy::write_f32(&path, &[4, 159], &[0.0; 4 * 159]).unwrap();
        let e = read_motion(&path).unwrap_err().to_string();
        assert!(
            e.contains("002.npy") && e.contains("315") && e.contains("[4, 159]"),
            "{e}"
        );
        assert!(!e.contains('\n'));
    }
}
