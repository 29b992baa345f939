//! Delta features, librosa 0.8.1 `feature.delta(data, width=9, order=1, axis=-1, mode='interp')`,
//! and the TSMT audio rows built on them (SPEC §11.4).
//!
//! librosa's delta is scipy's `savgol_filter(data, width, polyorder=order, deriv=order, mode='interp')`.
//! For a first-order fit the interior value is the least-squares slope over the window,
//! Δ[t] = Σ_{k=−h..h} k·c[t+k] / Σ k², and `interp` fits one line to the first (last) `width` frames,
//! whose slope is the interior value at frame h (T − 1 − h): the edge frames copy it.

use crate::features::{COL_BEAT, COL_MFCC, FEATURE_DIM};

/// librosa's default delta width (9 frames).
pub const DELTA_WIDTH: usize = 9;

/// First-order delta of every column of a frame-major `frames × dims` matrix (f64), as librosa 0.8.1
/// `delta(width, order=1, mode='interp')` along time. `width` must be odd and ≥ 3; sequences
/// shorter than `width` have no interp fit in scipy (it raises) and get zeros here.
pub fn delta(data: &[f64], frames: usize, dims: usize, width: usize) -> Vec<f64> {
    assert!(
        width >= 3 && width % 2 == 1,
        "delta width must be odd and ≥ 3"
    );
    assert_eq!(
        data.len(),
        frames * dims,
        "delta: data is not frames × dims"
    );
    let mut out = vec![0.0; frames * dims];
    if frames < width {
        return out;
    }
    let h = width / 2;
    let denom: f64 = (1..=h).map(|k| 2.0 * (k * k) as f64).sum();
    for t in h..frames - h {
        for d in 0..dims {
            let mut s = 0.0;
            for k in 1..=h {
                s += k as f64 * (data[(t + k) * dims + d] - data[(t - k) * dims + d]);
            }
            out[t * dims + d] = s / denom;
        }
    }
    for t in 0..h {
        let (first, last) = (h * dims, (frames - 1 - h) * dims);
        out.copy_within(first..first + dims, t * dims);
        out.copy_within(last..last + dims, (frames - 1 - t) * dims);
    }
    out
}

/// Number of MFCC coefficients TSMT takes (c_0..c_12).
pub const TSMT_MFCC: usize = 13;
/// Width of TSMT's MFCC row: 13 coefficients and their deltas.
pub const TSMT_MFCC_DIM: usize = 2 * TSMT_MFCC;

/// TSMT's audio of one music (SPEC §11.4) from its 35-D feature matrix (frame-major, f32): the
/// `frames × 26` rows [c_0..c_12 | Δc_0..Δc_12] (§2 columns 1–13 and their librosa deltas over the
/// whole music) and the beat flag of each frame (§2 column 34; 1 = beat).
pub fn tsmt_audio(features: &[f32], frames: usize) -> (Vec<f32>, Vec<u8>) {
    assert_eq!(features.len(), frames * FEATURE_DIM);
    let mfcc: Vec<f64> = (0..frames)
        .flat_map(|t| {
            features[t * FEATURE_DIM + COL_MFCC..t * FEATURE_DIM + COL_MFCC + TSMT_MFCC]
                .iter()
                .map(|&x| x as f64)
        })
        .collect();
    let d = delta(&mfcc, frames, TSMT_MFCC, DELTA_WIDTH);
    let mut rows = Vec::with_capacity(frames * TSMT_MFCC_DIM);
    for t in 0..frames {
        let c = &mfcc[t * TSMT_MFCC..(t + 1) * TSMT_MFCC];
        let dc = &d[t * TSMT_MFCC..(t + 1) * TSMT_MFCC];
        rows.extend(c.iter().chain(dc).map(|&x| x as f32));
    }
    let beats = (0..frames)
        .map(|t| u8::from(features[t * FEATURE_DIM + COL_BEAT] > 0.5))
        .collect();
    (rows, beats)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_line_has_its_slope_everywhere_and_edges_copy_the_first_fit() {
        // c[t] = 3t + 1 in column 0, t² in column 1.
        let frames = 20;
        let data: Vec<f64> = (0..frames)
            .flat_map(|t| [3.0 * t as f64 + 1.0, (t * t) as f64])
            .collect();
        let d = delta(&data, frames, 2, 9);
        for t in 0..frames {
            assert!((d[t * 2] - 3.0).abs() < 1e-12);
        }
        // The slope of t² over a symmetric window centred at t is 2t; edges copy frames 4 and 15.
        for t in 4..16 {
            assert!((d[t * 2 + 1] - 2.0 * t as f64).abs() < 1e-9, "{t}");
        }
        for t in 0..4 {
            assert_eq!(d[t * 2 + 1], d[4 * 2 + 1]);
            assert_eq!(d[(frames - 1 - t) * 2 + 1], d[15 * 2 + 1]);
        }
    }

    #[test]
    fn the_interior_is_the_sum_over_sixty() {
        let data: Vec<f64> = (0..12).map(|t| ((t * 7) % 5) as f64).collect();
        let d = delta(&data, 12, 1, 9);
        let want: f64 = (-4i64..=4)
            .map(|k| k as f64 * data[(6 + k) as usize])
            .sum::<f64>()
            / 60.0;
        assert!((d[6] - want).abs() < 1e-15);
    }

    #[test]
    fn too_short_gives_zeros() {
        assert_eq!(delta(&[1.0, 2.0, 3.0], 3, 1, 9), vec![0.0; 3]);
    }

    #[test]
    fn tsmt_audio_takes_columns_one_to_thirteen_and_the_beat_column() {
        let frames = 10;
        let mut f = vec![0f32; frames * FEATURE_DIM];
        for t in 0..frames {
            for k in 0..FEATURE_DIM {
                f[t * FEATURE_DIM + k] = (k * 100 + t) as f32;
            }
            f[t * FEATURE_DIM + COL_BEAT] = (t % 3 == 0) as u8 as f32;
        }
        let (rows, beats) = tsmt_audio(&f, frames);
        assert_eq!(rows.len(), frames * 26);
        assert_eq!(rows[5 * 26], 105.0);
        assert_eq!(rows[5 * 26 + 12], 1305.0);
        assert!((rows[5 * 26 + 13] - 1.0).abs() < 1e-6, "Δ of a unit ramp");
        assert_eq!(beats, vec![1, 0, 0, 1, 0, 0, 1, 0, 0, 1]);
    }
}
