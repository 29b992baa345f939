//! Chroma energy normalised statistics, librosa 0.8.1 `feature.chroma_cens(y, sr, hop_length=512,
//! n_chroma=12)` (SPEC §2.7): tuning, 7-octave CQT at 36 bins per octave, chroma folding, L1 norm,
//! quantisation, Hann(43) smoothing, L2 norm.

use super::cqt::{cqt_magnitude, C1_HZ};
use super::stft::{hann_symmetric, Spectrogram};
use super::tuning::estimate_tuning;
use super::N_FFT;
use qean_io::error::Result;

pub const BINS_PER_OCTAVE: usize = 36;
pub const N_OCTAVES: usize = 7;
pub const N_CHROMA: usize = 12;
pub const WIN_LEN_SMOOTH: usize = 41;

/// librosa `cq_to_chroma(n_bins, 36, 12)` folding of one CQT frame: chroma c sums bins 3c−1, 3c, 3c+1
/// of every octave block (circular within the block; C1 is pitch class 0, so no roll).
pub fn fold_chroma(cqt_frame: &[f64], out: &mut [f64; N_CHROMA]) {
    let merge = BINS_PER_OCTAVE / N_CHROMA;
    out.fill(0.0);
    for (b, &v) in cqt_frame.iter().enumerate() {
        let within = b % BINS_PER_OCTAVE;
        // Column j of the rolled matrix belongs to chroma ((j + 1) mod 36) / 3.
        let c = ((within + 1) % BINS_PER_OCTAVE) / merge;
        out[c] += v;
    }
}

/// CENS from a frame-major CQT magnitude (frames × 252): frame-major frames × 12.
pub fn cens_from_cqt(cqt: &Spectrogram) -> Spectrogram {
    let t_frames = cqt.n_frames;
    let mut quant = vec![0.0; t_frames * N_CHROMA];
    let mut ch = [0.0; N_CHROMA];
    for t in 0..t_frames {
        fold_chroma(cqt.frame(t), &mut ch);
        let l1: f64 = ch.iter().map(|v| v.abs()).sum();
        let len = if l1 < f64::MIN_POSITIVE { 1.0 } else { l1 };
        for c in 0..N_CHROMA {
            let x = ch[c] / len;
            let steps = [0.4, 0.2, 0.1, 0.05].iter().filter(|&&s| x > s).count();
            quant[t * N_CHROMA + c] = 0.25 * steps as f64;
        }
    }
    // Symmetric Hann of win_len_smooth + 2, normalised to sum 1, centred 'same' convolution, zero fill.
    let mut win = hann_symmetric(WIN_LEN_SMOOTH + 2);
    let sum: f64 = win.iter().sum();
    win.iter_mut().for_each(|w| *w /= sum);
    let half = (win.len() / 2) as isize;
    let mut cens = vec![0.0; t_frames * N_CHROMA];
    for t in 0..t_frames as isize {
        for (j, &w) in win.iter().enumerate() {
            if w == 0.0 {
                continue;
            }
            let s = t + j as isize - half;
            if s < 0 || s >= t_frames as isize {
                continue;
            }
            let (dst, src) = (t as usize * N_CHROMA, s as usize * N_CHROMA);
            for c in 0..N_CHROMA {
                cens[dst + c] += w * quant[src + c];
            }
        }
    }
    for fr in cens.chunks_exact_mut(N_CHROMA) {
        let l2 = fr.iter().map(|v| v * v).sum::<f64>().sqrt();
        if l2 >= f64::MIN_POSITIVE {
            fr.iter_mut().for_each(|v| *v /= l2);
        }
    }
    Spectrogram {
        n_frames: t_frames,
        n_bins: N_CHROMA,
        data: cens,
    }
}

/// chroma_cens of a 30720 Hz (or any `sr`) signal; `power` is its |STFT|² (n_fft 2048, hop 512), used for
/// the tuning estimate. Returns (CENS frames × 12, tuning in fractions of a 36-TET bin).
pub fn chroma_cens(
    y: &[f64],
    power: &Spectrogram,
    sr: f64,
    hop: usize,
) -> Result<(Spectrogram, f64)> {
    let tuning = estimate_tuning(power, sr, N_FFT, BINS_PER_OCTAVE);
    let fmin = C1_HZ * 2f64.powf(tuning / BINS_PER_OCTAVE as f64);
    let cqt = cqt_magnitude(
        y,
        sr,
        hop,
        fmin,
        N_OCTAVES * BINS_PER_OCTAVE,
        BINS_PER_OCTAVE,
    )?;
    Ok((cens_from_cqt(&cqt), tuning))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn folding_matches_rolled_matrix() {
        // Bin 0 (C) → class 0, bin 1 → 0, bin 2 → 1 (C#'s lower neighbour), bin 35 → 0 (wraps).
        let mut out = [0.0; N_CHROMA];
        for (b, want) in [
            (0usize, 0usize),
            (1, 0),
            (2, 1),
            (35, 0),
            (34, 11),
            (36 + 4, 1),
        ] {
            let mut fr = vec![0.0; 252];
            fr[b] = 1.0;
            fold_chroma(&fr, &mut out);
            assert_eq!(out[want], 1.0, "bin {b}");
            assert_eq!(out.iter().sum::<f64>(), 1.0);
        }
    }

    #[test]
    fn cens_frames_are_unit_or_zero() {
        let mut data = vec![0.0; 100 * 252];
        for t in 0..60 {
            data[t * 252 + 3 * (t % 12) + 36] = 1.0 + t as f64;
        }
        let c = cens_from_cqt(&Spectrogram {
            n_frames: 100,
            n_bins: 252,
            data,
        });
        for t in 0..100 {
            let n: f64 = c.frame(t).iter().map(|v| v * v).sum::<f64>();
            if t < 80 {
                assert!((n - 1.0).abs() < 1e-12, "frame {t}: {n}");
            } else {
                assert!(n == 0.0 || (n - 1.0).abs() < 1e-12);
            }
        }
        // Far past the last note the smoothing window no longer reaches: zero frames stay zero.
        assert!(c.frame(99).iter().all(|&v| v == 0.0));
    }
}
