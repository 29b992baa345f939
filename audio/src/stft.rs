//! Centred short-time Fourier transform, librosa 0.8.1 `stft` (SPEC §2.2): reflect padding by n_fft/2,
//! frame t = padded[hop·t, hop·t + n_fft), window, real FFT.

use std::sync::Arc;

use rayon::prelude::*;

use realfft::num_complex::Complex64;
use realfft::{RealFftPlanner, RealToComplex};

/// A frame-major real matrix: `data[t * n_bins + k]`.
#[derive(Debug, Clone, PartialEq)]
pub struct Spectrogram {
    pub n_frames: usize,
    pub n_bins: usize,
    pub data: Vec<f64>,
}

impl Spectrogram {
    /// Frame `t` as a slice of `n_bins` values.
    pub fn frame(&self, t: usize) -> &[f64] {
        &self.data[t * self.n_bins..(t + 1) * self.n_bins]
    }
}

/// A frame-major complex STFT: `data[t * n_bins + k]`, n_bins = n_fft/2 + 1.
#[derive(Debug, Clone)]
pub struct ComplexStft {
    pub n_fft: usize,
    pub hop: usize,
    pub n_frames: usize,
    pub n_bins: usize,
    pub data: Vec<Complex64>,
}

/// Number of centred frames: 1 + floor(n_samples / hop).
pub fn n_frames(n_samples: usize, hop: usize) -> usize {
    1 + n_samples / hop
}

/// scipy `get_window('hann', n, fftbins=True)`: 0.5 − 0.5·cos(2πk/n), k < n.
pub fn hann_periodic(n: usize) -> Vec<f64> {
    let mut w = hann_symmetric(n + 1);
    w.truncate(n);
    w
}

/// scipy `hann(n, sym=True)` (general_cosine over linspace(−π, π, n)).
pub fn hann_symmetric(n: usize) -> Vec<f64> {
    if n == 1 {
        return vec![1.0];
    }
    let step = 2.0 * std::f64::consts::PI / (n - 1) as f64;
    (0..n)
        .map(|k| {
            let fac = if k == n - 1 {
                std::f64::consts::PI
            } else {
                -std::f64::consts::PI + k as f64 * step
            };
            0.5 + 0.5 * fac.cos()
        })
        .collect()
}

/// Index into `0..n` of position `i` (may be negative or ≥ n) under numpy's `reflect` padding
/// (mirror without repeating the edge; periodic with period 2(n−1) for long pads).
pub fn reflect_index(i: isize, n: usize) -> usize {
    if n == 1 {
        return 0;
    }
    let period = 2 * (n as isize - 1);
    let mut j = i.rem_euclid(period);
    if j >= n as isize {
        j = period - j;
    }
    j as usize
}

/// numpy `np.pad(y, pad, mode='reflect')`.
pub fn reflect_pad(y: &[f64], pad: usize) -> Vec<f64> {
    let n = y.len();
    let mut out = Vec::with_capacity(n + 2 * pad);
    out.extend((0..pad).map(|i| y[reflect_index(i as isize - pad as isize, n)]));
    out.extend_from_slice(y);
    out.extend((n + pad..n + 2 * pad).map(|i| y[reflect_index(i as isize - pad as isize, n)]));
    out
}

/// `out.len()` samples of `reflect_pad(y, pad)` from `start`, without building the padded signal: only
/// frames that overlap an end look indices up.
pub fn padded_frame(y: &[f64], start: usize, pad: usize, out: &mut [f64]) {
    let n = y.len();
    if start >= pad && start - pad + out.len() <= n {
        out.copy_from_slice(&y[start - pad..start - pad + out.len()]);
    } else {
        for (j, o) in out.iter_mut().enumerate() {
            *o = y[reflect_index((start + j) as isize - pad as isize, n)];
        }
    }
}

/// A planned real FFT of one size.
pub struct Fft {
    pub n: usize,
    plan: Arc<dyn RealToComplex<f64>>,
}

impl Fft {
    pub fn new(n: usize) -> Self {
        let plan = RealFftPlanner::<f64>::new().plan_fft_forward(n);
        Fft { n, plan }
    }

    /// Transform `input` (destroyed) into `output` (n/2 + 1 bins).
    pub fn forward(&self, input: &mut [f64], output: &mut [Complex64], scratch: &mut [Complex64]) {
        self.plan
            .process_with_scratch(input, output, scratch)
            .expect("FFT buffer sizes are fixed by construction");
    }

    pub fn scratch(&self) -> Vec<Complex64> {
        self.plan.make_scratch_vec()
    }
}

/// Complex centred STFT of `y` with the given window (length n_fft), reflect padding.
pub fn stft(y: &[f64], n_fft: usize, hop: usize, window: &[f64]) -> ComplexStft {
    assert_eq!(window.len(), n_fft);
    assert!(!y.is_empty() && hop > 0);
    let padded = reflect_pad(y, n_fft / 2);
    let n_frames = 1 + (padded.len() - n_fft) / hop;
    let n_bins = n_fft / 2 + 1;
    let fft = Fft::new(n_fft);
    let mut data = vec![Complex64::new(0.0, 0.0); n_frames * n_bins];
    let mut buf = vec![0.0; n_fft];
    let mut scratch = fft.scratch();
    for (t, out) in data.chunks_exact_mut(n_bins).enumerate() {
        let frame = &padded[t * hop..t * hop + n_fft];
        for ((b, &x), &w) in buf.iter_mut().zip(frame).zip(window) {
            *b = x * w;
        }
        fft.forward(&mut buf, out, &mut scratch);
    }
    ComplexStft {
        n_fft,
        hop,
        n_frames,
        n_bins,
        data,
    }
}

/// Frames per parallel work item.
const FRAMES_PER_TASK: usize = 64;

/// Apply `f(spectrum, out_row)` to every centred frame of `y` (reflect padding, `window`), in parallel;
/// `out` is frame-major with rows of `row_len`. Only one spectrum per thread lives at a time.
pub fn map_frames<F>(
    y: &[f64],
    n_fft: usize,
    hop: usize,
    window: &[f64],
    row_len: usize,
    f: F,
) -> Vec<f64>
where
    F: Fn(&[Complex64], &mut [f64]) + Sync,
{
    assert_eq!(window.len(), n_fft);
    assert!(!y.is_empty() && hop > 0);
    let n_frames = n_frames(y.len(), hop);
    let fft = Fft::new(n_fft);
    let mut out = vec![0.0; n_frames * row_len];
    out.par_chunks_mut(row_len * FRAMES_PER_TASK)
        .enumerate()
        .for_each(|(c, chunk)| {
            let mut buf = vec![0.0; n_fft];
            let mut spec = vec![Complex64::new(0.0, 0.0); n_fft / 2 + 1];
            let mut scratch = fft.scratch();
            for (i, row) in chunk.chunks_exact_mut(row_len).enumerate() {
                let t = c * FRAMES_PER_TASK + i;
                padded_frame(y, t * hop, n_fft / 2, &mut buf);
                for (b, &w) in buf.iter_mut().zip(window) {
                    *b *= w;
                }
                fft.forward(&mut buf, &mut spec, &mut scratch);
                f(&spec, row);
            }
        });
    out
}

/// |STFT|² with the periodic Hann window (librosa `melspectrogram`'s `power=2` spectrogram).
pub fn power_spectrogram(y: &[f64], n_fft: usize, hop: usize) -> Spectrogram {
    let n_bins = n_fft / 2 + 1;
    let data = map_frames(y, n_fft, hop, &hann_periodic(n_fft), n_bins, |spec, row| {
        for (r, c) in row.iter_mut().zip(spec) {
            *r = c.norm_sqr();
        }
    });
    Spectrogram {
        n_frames: data.len() / n_bins,
        n_bins,
        data,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_count_is_one_plus_floor() {
        for n in [1usize, 511, 512, 513, 2048, 30720, 163841] {
            let y = vec![0.1; n];
            let s = power_spectrogram(&y, 2048, 512);
            assert_eq!(s.n_frames, n_frames(n, 512), "n={n}");
            assert_eq!(s.n_bins, 1025);
        }
    }

    #[test]
    fn reflect_matches_numpy() {
        // np.pad([1,2,3], 5, 'reflect') == [2,1,2,3,2,1,2,3,2,1,2,3,2]
        let p = reflect_pad(&[1.0, 2.0, 3.0], 5);
        assert_eq!(p, vec![2., 1., 2., 3., 2., 1., 2., 3., 2., 1., 2., 3., 2.]);
        assert_eq!(reflect_pad(&[7.0], 2), vec![7.0; 5]);
        // Frames cut from the virtual padding equal slices of the padded signal.
        for (n, pad, len) in [
            (3usize, 5usize, 4usize),
            (50, 8, 16),
            (1, 2, 3),
            (40, 20, 40),
        ] {
            let y: Vec<f64> = (0..n).map(|i| i as f64 * 1.5 - 2.0).collect();
            let p = reflect_pad(&y, pad);
            for start in 0..=p.len() - len {
                let mut out = vec![0.0; len];
                padded_frame(&y, start, pad, &mut out);
                assert_eq!(out, &p[start..start + len], "n {n} pad {pad} start {start}");
            }
        }
    }

    #[test]
    fn hann_windows() {
        let w = hann_periodic(4);
        let want = [0.0, 0.5, 1.0, 0.5];
        for (a, b) in w.iter().zip(want) {
            assert!((a - b).abs() < 1e-15);
        }
        let s = hann_symmetric(5);
        for (a, b) in s.iter().zip([0.0, 0.5, 1.0, 0.5, 0.0]) {
            assert!((a - b).abs() < 1e-15);
        }
    }

    #[test]
    fn sine_peaks_at_its_bin() {
        let sr = 30720.0;
        let f = 64.0 * sr / 2048.0; // exactly bin 64
        let y: Vec<f64> = (0..8192)
            .map(|i| (2.0 * std::f64::consts::PI * f * i as f64 / sr).sin())
            .collect();
        let s = power_spectrogram(&y, 2048, 512);
        let fr = s.frame(8);
        let argmax = (0..fr.len())
            .max_by(|&a, &b| fr[a].partial_cmp(&fr[b]).unwrap())
            .unwrap();
        assert_eq!(argmax, 64);
        // Parseval-like amplitude: periodic Hann sum is 1024, so |X| = 512 at the peak.
        assert!((fr[64].sqrt() - 512.0).abs() < 1e-6);
    }
}
