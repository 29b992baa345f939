//! What the in-betweener reads besides its weights (SPEC §12.4): the features of a track's drums stem and
//! the base B its residual is added to.

use qean_config::inbetween::Base;
use qean_io::error::{Error, Result};
use qean_models::inbetween::MOTION_DIM;
use qean_motion::rotation::{axis_angle_to_matrix, matrix_to_quaternion, Mat3};

/// The 35-D features of a track's drums stem (M_full_drums of §12.4c comes from its columns): the stem file
/// `<stems>/drums.wav`, or librosa's HPSS percussive part of the full mix.
pub fn drums_features(
    music: Option<&std::path::Path>,
    stems: Option<&std::path::Path>,
    source: qean_config::inbetween::DrumSource,
    start_bpm: f64,
) -> Result<Vec<f32>> {
    use qean_config::inbetween::DrumSource;
    let opts = qean_audio::FeatureOptions::with_start_bpm(start_bpm);
    let samples = match (source, stems, music) {
        (DrumSource::Files, Some(dir), _) => {
            let path = dir.join("drums.wav");
            if !path.is_file() {
                return Err(Error::at(
                    &path,
                    "drums stem missing (inbetween.drums = \"files\"; or --set inbetween.drums=hpss)",
                ));
            }
            return Ok(qean_audio::features_for_file(&path, &opts)?.data);
        }
        (DrumSource::Files, None, _) => {
            return Err(Error::msg(
                "the drums in-betweeners need a stems directory (or --set inbetween.drums=hpss)",
            ))
        }
        (DrumSource::Hpss, _, Some(m)) => {
            qean_audio::hpss::percussive(&qean_audio::load_audio(m, &Default::default())?.samples)
        }
        (DrumSource::Hpss, _, None) => {
            return Err(Error::msg("the drums in-betweeners need the music"))
        }
    };
    Ok(qean_audio::music_features(&samples, &opts)?.data)
}

/// Quaternion → rotation matrix (through axis-angle, as the §12.4a SLERP writes poses).
fn quat_matrix(q: [f64; 4]) -> Mat3 {
    axis_angle_to_matrix(qean_keyframes::slerp::quat_to_axis_angle(q))
}

/// The base B of frames 0..len of a 225-D window (row-major) from its keys: translation lerped, each joint's
/// rotation SLERPed (§12.4a), or every value lerped (`elementwise_lerp`). Keys are copied.
pub fn base_225(rows: &[f32], len: usize, keys: &[usize], base: Base) -> Vec<f32> {
    let w = MOTION_DIM;
    let mut out = rows[..len * w].to_vec();
    for pair in keys.windows(2) {
        let (t1, t2) = (pair[0], pair[1]);
        let (r1, r2) = (&rows[t1 * w..(t1 + 1) * w], &rows[t2 * w..(t2 + 1) * w]);
        let quats = |r: &[f32]| -> Vec<[f64; 4]> {
            (0..24)
                .map(|j| matrix_to_quaternion(&std::array::from_fn(|k| r[9 + 9 * j + k] as f64)))
                .collect()
        };
        let (q1, q2) = if base == Base::Slerp {
            (quats(r1), quats(r2))
        } else {
            (vec![], vec![])
        };
        for t in t1 + 1..t2 {
            let u = (t - t1) as f64 / (t2 - t1) as f64;
            let row = &mut out[t * w..(t + 1) * w];
            let lerp = |a: f32, b: f32| ((1.0 - u) * a as f64 + u * b as f64) as f32;
            match base {
                Base::ElementwiseLerp => {
                    for k in 0..w {
                        row[k] = lerp(r1[k], r2[k]);
                    }
                }
                Base::Slerp => {
                    row[..9]
                        .iter_mut()
                        .zip(r1.iter().zip(r2))
                        .for_each(|(o, (&a, &b))| *o = lerp(a, b));
                    for j in 0..24 {
                        let m = quat_matrix(qean_keyframes::slerp::slerp(q1[j], q2[j], u));
                        for k in 0..9 {
                            row[9 + 9 * j + k] = m[k] as f32;
                        }
                    }
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slerp_base_copies_keys_and_equals_the_motion_slerp() {
        let m = qean_motion::Motion::read_pkl(
            &qean_io::testdata::shared_dir()
                .join("aistpp/motions/softcat477_sample_with_scaling.pkl"),
        )
        .unwrap();
        let rows = m.to_layout(qean_motion::Layout::L225);
        let keys = [0, 30, 60, 90, 120];
        let b = base_225(&rows, 121, &keys, Base::Slerp);
        let want = qean_keyframes::slerp::inbetween(&m.slice(0, 121), &keys)
            .to_layout(qean_motion::Layout::L225);
        let worst = b
            .iter()
            .zip(&want)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-5, "{worst}");
        for &k in &keys {
            assert_eq!(b[k * 225..(k + 1) * 225], rows[k * 225..(k + 1) * 225]);
        }
        // The element-wise lerp halfway between two keys is the mean of their vectors.
        let l = base_225(&rows, 121, &[0, 2], Base::ElementwiseLerp);
        assert!((l[225 + 20] - 0.5 * (rows[20] + rows[450 + 20])).abs() < 1e-6);
    }
}
