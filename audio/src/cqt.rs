//! Constant-Q transform magnitudes, librosa 0.8.1 `cqt` (= `vqt` with gamma 0) and its recursive
//! per-octave algorithm (`__cqt_filter_fft`, `__cqt_response`, `__early_downsample`, `__trim_stack`),
//! SPEC §2.7 step 2. Filters: Hann, filter_scale 1, L1 norm, sparsity 0.01, scale = True.

use realfft::num_complex::Complex64;
use rustfft::FftPlanner;

use super::resample::{resample, resample_with, Resampler};
use super::stft::{hann_periodic, map_frames, padded_frame, Spectrogram};
use qean_io::error::{Error, Result};
use rayon::prelude::*;

/// librosa's `WINDOW_BANDWIDTHS['hann']`.
const HANN_BANDWIDTH: f64 = 1.50018310546875;
/// resampy kaiser_fast's rolloff (librosa `audio.BW_FASTEST`).
const BW_FASTEST: f64 = 0.85;

/// C1 in Hz (librosa `note_to_hz('C1')`).
pub const C1_HZ: f64 = 32.70319566257483;

/// One octave's filters in the frequency domain, sparsified: per filter, the bins from its first to its
/// last kept one (dropped bins inside that span hold 0, which adds nothing), real and imaginary parts
/// apart.
struct OctaveBasis {
    n_fft: usize,
    rows: Vec<BasisRow>,
}

struct BasisRow {
    first_bin: usize,
    re: Vec<f64>,
    im: Vec<f64>,
}

impl BasisRow {
    fn new(kept: &[(usize, Complex64)]) -> Self {
        let first_bin = kept.first().map_or(0, |&(i, _)| i);
        let len = kept.last().map_or(0, |&(i, _)| i + 1 - first_bin);
        let (mut re, mut im) = (vec![0.0; len], vec![0.0; len]);
        for &(i, c) in kept {
            re[i - first_bin] = c.re;
            im[i - first_bin] = c.im;
        }
        BasisRow { first_bin, re, im }
    }

    /// |Σ basis[i]·spectrum[i]|.
    fn magnitude(&self, spec: &[Complex64]) -> f64 {
        let n = self.re.len();
        let xs = &spec[self.first_bin..self.first_bin + n];
        let mut acc_re = [0.0f64; 4];
        let mut acc_im = [0.0f64; 4];
        let chunks = n / 4 * 4;
        for j in (0..chunks).step_by(4) {
            for l in 0..4 {
                let (wr, wi, x) = (self.re[j + l], self.im[j + l], xs[j + l]);
                acc_re[l] += wr * x.re - wi * x.im;
                acc_im[l] += wr * x.im + wi * x.re;
            }
        }
        let mut re = (acc_re[0] + acc_re[1]) + (acc_re[2] + acc_re[3]);
        let mut im = (acc_im[0] + acc_im[1]) + (acc_im[2] + acc_im[3]);
        for ((&wr, &wi), x) in self.re[chunks..]
            .iter()
            .zip(&self.im[chunks..])
            .zip(&xs[chunks..])
        {
            re += wr * x.re - wi * x.im;
            im += wr * x.im + wi * x.re;
        }
        (re * re + im * im).sqrt()
    }
}

fn filter_lengths(sr: f64, fmin: f64, n_bins: usize, bins_per_octave: usize) -> Result<Vec<f64>> {
    let alpha = 2f64.powf(1.0 / bins_per_octave as f64) - 1.0;
    let q = 1.0 / alpha;
    let freqs: Vec<f64> = (0..n_bins)
        .map(|k| fmin * 2f64.powf(k as f64 / bins_per_octave as f64))
        .collect();
    if freqs[n_bins - 1] * (1.0 + 0.5 * HANN_BANDWIDTH / q) > sr / 2.0 {
        return Err(Error::msg("CQT filter pass-band lies beyond Nyquist"));
    }
    Ok(freqs.iter().map(|f| q * sr / f).collect())
}

/// `__cqt_filter_fft(sr, fmin, n_bins, ...)` (hop_length None): time-domain Hann-windowed complex
/// exponentials, L1-normalised, centred in a power-of-two frame, scaled by length/n_fft, FFT'd,
/// first n_fft/2+1 bins, rows sparsified at quantile 0.01; then multiplied by `gain`.
fn filter_fft(
    sr: f64,
    fmin: f64,
    n_bins: usize,
    bins_per_octave: usize,
    gain: f64,
) -> Result<OctaveBasis> {
    let lengths = filter_lengths(sr, fmin, n_bins, bins_per_octave)?;
    let max_len = lengths.iter().cloned().fold(0.0, f64::max);
    let n_fft = 2f64.powf(max_len.log2().ceil()) as usize;
    let mut planner = FftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(n_fft);
    let mut rows = Vec::with_capacity(n_bins);
    for (k, &ilen) in lengths.iter().enumerate() {
        let freq = fmin * 2f64.powf(k as f64 / bins_per_octave as f64);
        // np.arange(-ilen // 2, ilen // 2) on floats.
        let a = (-ilen / 2.0).floor();
        let b = (ilen / 2.0).floor();
        let len = (b - a) as usize;
        let win = hann_periodic(len);
        let mut sig: Vec<Complex64> = (0..len)
            .map(|j| {
                let n = a + j as f64;
                let ph = n * 2.0 * std::f64::consts::PI * freq / sr;
                Complex64::new(ph.cos(), ph.sin()) * win[j]
            })
            .collect();
        let l1: f64 = sig.iter().map(|c| c.norm()).sum();
        if l1 > 0.0 {
            sig.iter_mut().for_each(|c| *c /= l1);
        }
        let mut buf = vec![Complex64::new(0.0, 0.0); n_fft];
        let lpad = (n_fft - len) / 2;
        let s = ilen / n_fft as f64;
        for (j, c) in sig.into_iter().enumerate() {
            buf[lpad + j] = c * s;
        }
        fft.process(&mut buf);
        buf.truncate(n_fft / 2 + 1);
        rows.push(BasisRow::new(&sparsify(&buf, 0.01, gain)));
    }
    Ok(OctaveBasis { n_fft, rows })
}

/// librosa `util.sparsify_rows` for one row: drop the smallest magnitudes whose share of the L1 mass
/// stays below `quantile`.
fn sparsify(row: &[Complex64], quantile: f64, gain: f64) -> Vec<(usize, Complex64)> {
    let mags: Vec<f64> = row.iter().map(|c| c.norm()).collect();
    let norm: f64 = mags.iter().sum();
    let mut sorted = mags.clone();
    sorted.sort_by(|a, b| a.total_cmp(b));
    let mut cum = 0.0;
    let mut idx = 0;
    for (i, &m) in sorted.iter().enumerate() {
        cum += m / norm;
        if cum >= quantile {
            idx = i;
            break;
        }
    }
    let thr = sorted[idx];
    row.iter()
        .zip(&mags)
        .enumerate()
        .filter(|(_, (_, &m))| m >= thr)
        .map(|(i, (&c, _))| (i, c * gain))
        .collect()
}

/// `__cqt_response`: |basis · STFT(y, n_fft, hop, window=ones, reflect)|, frame-major (frames × filters).
/// Small hops (the lower octaves: frames overlap 16× or more) take the overlap-save route.
fn response(y: &[f64], hop: usize, basis: &OctaveBasis) -> Spectrogram {
    if hop * 16 <= basis.n_fft {
        response_overlap_save(y, hop, basis)
    } else {
        response_by_frames(y, hop, basis)
    }
}

/// The same sums as [`response_by_frames`], reordered. Filter k's response at frame t is
/// Σ_n padded[t·hop + n]·g_k[n] with g_k = DFT(basis row k) (the STFT is linear), i.e. a correlation of
/// the padded signal with g_k read every hop samples. Blocks of N = 4·n_fft samples are transformed once
/// (overlap-save); per filter the product spectrum is folded onto N/hop bins, which is exactly reading
/// every hop-th sample of its inverse, and a short inverse FFT gives the block's frames.
fn response_overlap_save(y: &[f64], hop: usize, basis: &OctaveBasis) -> Spectrogram {
    let n_fft = basis.n_fft;
    let n = 4 * n_fft;
    let q = n / hop;
    let n_rows = basis.rows.len();
    let pad = n_fft / 2;
    let padded_len = y.len() + 2 * pad;
    let n_frames = 1 + (padded_len - n_fft) / hop;
    let per_block = (n - n_fft) / hop;
    let mut planner = FftPlanner::<f64>::new();
    let small = planner.plan_fft_forward(n_fft);
    let forward = planner.plan_fft_forward(n);
    let inverse = planner.plan_fft_inverse(n);
    let inverse_q = planner.plan_fft_inverse(q);
    // Per filter: G[f] = Σ_m g[m]·e^{+2πi·f·m/N}, so that IDFT_N(X·G)[j] = N·Σ_m x[j + m]·g[m].
    let zero = Complex64::new(0.0, 0.0);
    let kernels: Vec<Vec<Complex64>> = basis
        .rows
        .par_iter()
        .map(|row| {
            let mut g = vec![zero; n_fft];
            for (j, (&re, &im)) in row.re.iter().zip(&row.im).enumerate() {
                g[row.first_bin + j] = Complex64::new(re, im);
            }
            small.process(&mut g);
            g.resize(n, zero);
            inverse.process(&mut g);
            g
        })
        .collect();
    let scale = 1.0 / n as f64;
    let mut data = vec![0.0; n_frames * n_rows];
    data.par_chunks_mut(per_block * n_rows)
        .enumerate()
        .for_each(|(b, out)| {
            let start = b * per_block * hop;
            let mut real = vec![0.0; n];
            let avail = (padded_len - start).min(n);
            padded_frame(y, start, pad, &mut real[..avail]);
            let mut x: Vec<Complex64> = real.iter().map(|&v| Complex64::new(v, 0.0)).collect();
            forward.process(&mut x);
            let mut w = vec![zero; q];
            for (k, g) in kernels.iter().enumerate() {
                w.fill(zero);
                for (xs, gs) in x.chunks_exact(q).zip(g.chunks_exact(q)) {
                    for ((acc, &a), &b) in w.iter_mut().zip(xs).zip(gs) {
                        *acc += a * b;
                    }
                }
                inverse_q.process(&mut w);
                for (frame, c) in out.chunks_exact_mut(n_rows).zip(&w) {
                    frame[k] = c.norm() * scale;
                }
            }
        });
    Spectrogram {
        n_frames,
        n_bins: n_rows,
        data,
    }
}

/// [`response`] frame by frame: one real FFT per frame, then each basis row's dot product.
fn response_by_frames(y: &[f64], hop: usize, basis: &OctaveBasis) -> Spectrogram {
    let n_rows = basis.rows.len();
    let ones = vec![1.0; basis.n_fft];
    let data = map_frames(y, basis.n_fft, hop, &ones, n_rows, |spec, out| {
        for (o, row) in out.iter_mut().zip(&basis.rows) {
            *o = row.magnitude(spec);
        }
    });
    Spectrogram {
        n_frames: data.len() / n_rows,
        n_bins: n_rows,
        data,
    }
}

fn num_two_factors(x: usize) -> usize {
    if x == 0 {
        0
    } else {
        x.trailing_zeros() as usize
    }
}

/// librosa's `__trim_stack`: the octaves' responses (top octave first) stacked into frames × n_bins, filling
/// bins from the top down, cut to the shortest response; with that frame count.
fn trim_stack(responses: &[Spectrogram], n_bins: usize) -> (Vec<f64>, usize) {
    let max_col = responses.iter().map(|r| r.n_frames).min().unwrap_or(0);
    let mut out = vec![0.0; max_col * n_bins];
    let mut end = n_bins;
    for r in responses {
        let n_oct = r.n_bins;
        let (dst0, src0, cnt) = if end < n_oct {
            (0, n_oct - end, end)
        } else {
            (end - n_oct, 0, n_oct)
        };
        for t in 0..max_col {
            let src = &r.frame(t)[src0..src0 + cnt];
            out[t * n_bins + dst0..t * n_bins + dst0 + cnt].copy_from_slice(src);
        }
        end = end.saturating_sub(n_oct);
        if end == 0 {
            break;
        }
    }
    (out, max_col)
}

/// |CQT| (librosa 0.8.1 `np.abs(cqt(y, sr, hop_length, fmin, n_bins, bins_per_octave, tuning=0))`),
/// frame-major: frames × n_bins, bin 0 = fmin.
pub fn cqt_magnitude(
    y: &[f64],
    sr: f64,
    hop: usize,
    fmin: f64,
    n_bins: usize,
    bins_per_octave: usize,
) -> Result<Spectrogram> {
    if y.is_empty() || n_bins == 0 || bins_per_octave == 0 {
        return Err(Error::msg(
            "CQT needs a non-empty signal and at least one bin",
        ));
    }
    let mut n_octaves = n_bins.div_ceil(bins_per_octave);
    let n_filters = bins_per_octave.min(n_bins);
    let alpha = 2f64.powf(1.0 / bins_per_octave as f64) - 1.0;
    let q = 1.0 / alpha;
    let top: Vec<f64> = (n_bins - n_filters..n_bins)
        .map(|k| fmin * 2f64.powf(k as f64 / bins_per_octave as f64))
        .collect();
    let mut fmin_t = top[0];
    let fmax_t = top[n_filters - 1];
    let filter_cutoff = fmax_t * (1.0 + 0.5 * HANN_BANDWIDTH / q);
    let nyquist = sr / 2.0;
    let fast = filter_cutoff < BW_FASTEST * nyquist;

    // __early_downsample (only with kaiser_fast).
    let mut y = y.to_vec();
    let mut sr = sr;
    let mut hop = hop;
    let count1 =
        ((BW_FASTEST * nyquist / filter_cutoff).log2().ceil() as i64 - 1 - 1).max(0) as usize;
    let count2 = (num_two_factors(hop) as i64 - n_octaves as i64 + 1).max(0) as usize;
    let count = count1.min(count2);
    if count > 0 && fast {
        let factor = 1usize << count;
        hop /= factor;
        if y.len() < factor {
            return Err(Error::msg("signal too short for the CQT"));
        }
        let new_sr = sr / factor as f64;
        y = resample(&y, sr, new_sr, Resampler::KaiserFast, true)?;
        sr = new_sr;
    }

    let mut responses: Vec<Spectrogram> = Vec::new();
    if !fast {
        // Top octave at full rate with kaiser_best quality, then kaiser_fast halvings.
        let basis = filter_fft(sr, fmin_t, n_filters, bins_per_octave, 1.0)?;
        responses.push(response(&y, hop, &basis));
        fmin_t /= 2.0;
        n_octaves -= 1;
    }
    if num_two_factors(hop) + 1 < n_octaves {
        return Err(Error::msg(format!(
            "hop length must be a multiple of 2^{} for a {n_octaves}-octave CQT",
            n_octaves - 1
        )));
    }
    let (mut my_y, mut my_sr, mut my_hop) = (y, sr, hop);
    for i in 0..n_octaves {
        if i > 0 {
            if my_y.len() < 2 {
                return Err(Error::msg("signal too short for the CQT"));
            }
            // f64 accumulation here: librosa's CQT basis is complex64, so bit-exact halvings buy nothing
            // (chroma parity is tested).
            my_y = resample_with(&my_y, 2.0, 1.0, Resampler::KaiserFast, true, false)?;
            my_sr /= 2.0;
            my_hop /= 2;
        }
        let gain = 2f64.powi(i as i32).sqrt();
        let basis = filter_fft(
            my_sr,
            fmin_t * 2f64.powi(-(i as i32)),
            n_filters,
            bins_per_octave,
            gain,
        )?;
        responses.push(response(&my_y, my_hop, &basis));
    }

    let (mut out, max_col) = trim_stack(&responses, n_bins);
    // scale=True: divide every bin by sqrt(filter length at the (possibly early-downsampled) rate).
    let lengths = filter_lengths(sr, fmin, n_bins, bins_per_octave)?;
    let inv: Vec<f64> = lengths.iter().map(|l| 1.0 / l.sqrt()).collect();
    for fr in out.chunks_exact_mut(n_bins) {
        for (v, s) in fr.iter_mut().zip(&inv) {
            *v *= s;
        }
    }
    Ok(Spectrogram {
        n_frames: max_col,
        n_bins,
        data: out,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overlap_save_equals_frame_by_frame() {
        // A chirp plus noise at the bottom octave's rate, through one octave's real basis.
        let sr = 480.0;
        let mut state = 7u64;
        let y: Vec<f64> = (0..20000)
            .map(|i| {
                state = state
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                let t = i as f64 / sr;
                (2.0 * std::f64::consts::PI * (30.0 + 40.0 * t / 40.0) * t).sin()
                    + 0.3 * ((state >> 40) as f64 / (1u64 << 24) as f64 - 0.5)
            })
            .collect();
        let basis = filter_fft(sr, C1_HZ, 36, 36, 8f64.sqrt()).unwrap();
        for hop in [8, 16, 32, 64] {
            let a = response_by_frames(&y, hop, &basis);
            let b = response_overlap_save(&y, hop, &basis);
            assert_eq!((a.n_frames, a.n_bins), (b.n_frames, b.n_bins));
            let top = a.data.iter().cloned().fold(0.0, f64::max);
            let worst = a
                .data
                .iter()
                .zip(&b.data)
                .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
            assert!(worst <= 1e-12 * top, "hop {hop}: {worst:e} of {top:e}");
        }
    }

    #[test]
    fn sine_lands_in_its_bin() {
        // A4 = 440 Hz (MIDI 69) is 45 semitones above C1 (MIDI 24): bin 3·45 = 135 (librosa 0.8.1 agrees).
        let sr = 30720.0;
        let y: Vec<f64> = (0..61440)
            .map(|i| (2.0 * std::f64::consts::PI * 440.0 * i as f64 / sr).sin())
            .collect();
        let c = cqt_magnitude(&y, sr, 512, C1_HZ, 252, 36).unwrap();
        assert_eq!(c.n_frames, 1 + 61440 / 512);
        let fr = c.frame(60);
        let argmax = (0..252)
            .max_by(|&a, &b| fr[a].partial_cmp(&fr[b]).unwrap())
            .unwrap();
        assert_eq!(argmax, 135);
    }

    #[test]
    fn sparsify_keeps_the_mass() {
        let row: Vec<Complex64> = (0..100)
            .map(|i| Complex64::new(1.0 / (1.0 + i as f64), 0.0))
            .collect();
        let s = sparsify(&row, 0.01, 1.0);
        let kept: f64 = s.iter().map(|(_, c)| c.norm()).sum();
        let total: f64 = row.iter().map(|c| c.norm()).sum();
        assert!(kept / total > 0.99 - 1e-12);
        assert!(s.len() < 100);
    }

    #[test]
    fn short_signal_errors_not_panics() {
        // 3 samples halve to 2, then 1: librosa raises for the 4th octave, so do we.
        assert!(cqt_magnitude(&[0.1; 3], 30720.0, 512, C1_HZ, 252, 36).is_err());
        assert!(cqt_magnitude(&[0.1; 4096], 30720.0, 512, C1_HZ, 252, 36).is_ok());
    }
}
