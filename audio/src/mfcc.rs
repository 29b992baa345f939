//! MFCC, librosa 0.8.1 `feature.mfcc(y, sr, n_mfcc)` (SPEC §2.4): orthonormal DCT-II (scipy.fftpack
//! `dct(type=2, norm='ortho')`) of the dB mel spectrogram over the mel axis, first n_mfcc coefficients.

use super::stft::Spectrogram;

/// DCT-II basis rows k < n_out over n inputs, orthonormal scaling.
pub fn dct_basis(n: usize, n_out: usize) -> Vec<f64> {
    let mut b = Vec::with_capacity(n * n_out);
    for k in 0..n_out {
        let a = if k == 0 {
            (1.0 / n as f64).sqrt()
        } else {
            (2.0 / n as f64).sqrt()
        };
        for i in 0..n {
            let arg = std::f64::consts::PI * k as f64 * (2 * i + 1) as f64 / (2 * n) as f64;
            b.push(a * arg.cos());
        }
    }
    b
}

/// MFCCs of a frame-major dB mel spectrogram: frame-major `n_frames × n_mfcc`.
pub fn mfcc_from_db_mel(mel_db: &Spectrogram, n_mfcc: usize) -> Spectrogram {
    let n = mel_db.n_bins;
    let basis = dct_basis(n, n_mfcc);
    let mut data = Vec::with_capacity(mel_db.n_frames * n_mfcc);
    for t in 0..mel_db.n_frames {
        let fr = mel_db.frame(t);
        for row in basis.chunks_exact(n) {
            data.push(row.iter().zip(fr).map(|(a, b)| a * b).sum());
        }
    }
    Spectrogram {
        n_frames: mel_db.n_frames,
        n_bins: n_mfcc,
        data,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn basis_is_orthonormal() {
        let b = dct_basis(128, 128);
        for i in 0..128 {
            for j in 0..128 {
                let d: f64 = (0..128).map(|k| b[i * 128 + k] * b[j * 128 + k]).sum();
                let want = if i == j { 1.0 } else { 0.0 };
                assert!((d - want).abs() < 1e-12, "{i},{j}: {d}");
            }
        }
    }

    #[test]
    fn constant_frame_has_only_c0() {
        let s = Spectrogram {
            n_frames: 1,
            n_bins: 128,
            data: vec![-20.0; 128],
        };
        let m = mfcc_from_db_mel(&s, 20);
        assert!((m.data[0] - (-20.0 * 128f64.sqrt())).abs() < 1e-9);
        assert!(m.data[1..].iter().all(|v| v.abs() < 1e-9));
    }

    /// SPEC §11.4: the orthonormal DCT truncates, so n_mfcc = 13 is the first 13 columns of n_mfcc = 20
    /// (TSMT's c_0..c_12 are §2 columns 1–13).
    #[test]
    fn thirteen_coefficients_are_the_first_thirteen_of_twenty() {
        let s = Spectrogram {
            n_frames: 3,
            n_bins: 128,
            data: (0..3 * 128)
                .map(|i| ((i * 37) % 101) as f64 - 50.0)
                .collect(),
        };
        let (a, b) = (mfcc_from_db_mel(&s, 13), mfcc_from_db_mel(&s, 20));
        for t in 0..3 {
            assert_eq!(a.data[t * 13..(t + 1) * 13], b.data[t * 20..t * 20 + 13]);
        }
    }
}
