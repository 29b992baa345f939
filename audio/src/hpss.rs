//! Harmonic/percussive separation and Bailando's music beats (SPEC §2.6, used by BeatAlign):
//! librosa 0.8.1 `effects.hpss` (`decompose.hpss` defaults: kernel 31, power 2, margin 1) with `istft`,
//! then `onset_strength(aggregate=np.median)` and `beat_track(start_bpm=120)`.

use rayon::prelude::*;
use realfft::num_complex::Complex64;
use realfft::RealFftPlanner;

use super::beat::{beat_track, BeatTrack};
use super::onset::{onset_strength, Aggregate};
use super::stft::{hann_periodic, stft, ComplexStft};
use super::{HOP, N_FFT};

const KERNEL: usize = 31;

/// scipy.ndimage 'reflect' (half-sample symmetric: d c b a | a b c d | d c b a).
fn sym_index(i: isize, n: usize) -> usize {
    let p = 2 * n as isize;
    let j = i.rem_euclid(p);
    if j >= n as isize {
        (p - 1 - j) as usize
    } else {
        j as usize
    }
}

/// Sliding median of width `KERNEL` (centred, scipy 'reflect' boundary) of a strided line, keeping the
/// window sorted (one removal and one insertion per step).
fn median_line(get: impl Fn(usize) -> f64, n: usize, out: &mut [f64]) {
    let h = (KERNEL / 2) as isize;
    let ext: Vec<f64> = (-h..n as isize + h).map(|i| get(sym_index(i, n))).collect();
    let mut win: Vec<f64> = ext[..KERNEL].to_vec();
    win.sort_by(|a, b| a.total_cmp(b));
    for i in 0..n {
        if i > 0 {
            let gone = ext[i - 1];
            let pos = win.partition_point(|v| v.total_cmp(&gone).is_lt());
            win.remove(pos);
            let new = ext[i + KERNEL - 1];
            let pos = win.partition_point(|v| v.total_cmp(&new).is_lt());
            win.insert(pos, new);
        }
        out[i] = win[KERNEL / 2];
    }
}

/// librosa 0.8.1 `decompose.hpss` soft masks of a complex STFT (kernel 31, power 2, margin 1):
/// (percussive, harmonic), frame-major like `d`; each pair sums to 1 (0.5 each where both medians vanish).
pub fn hpss_masks(d: &ComplexStft) -> (Vec<f64>, Vec<f64>) {
    let (nf, nb) = (d.n_frames, d.n_bins);
    let mag: Vec<f64> = d.data.iter().map(|c| c.norm()).collect();
    // Harmonic: median over time per bin. Percussive: median over bins per frame.
    let mut harm_t = vec![0.0; nb * nf]; // bin-major
    harm_t
        .par_chunks_mut(nf)
        .enumerate()
        .for_each(|(k, out)| median_line(|t| mag[t * nb + k], nf, out));
    let mut perc = vec![0.0; nf * nb]; // frame-major
    perc.par_chunks_mut(nb)
        .enumerate()
        .for_each(|(t, out)| median_line(|k| mag[t * nb + k], nb, out));
    // Soft masks p²/(p² + h²) and h²/(p² + h²), 0.5 where both vanish (split_zeros).
    let tiny = f32::MIN_POSITIVE as f64;
    let mut mask_p = vec![0.0; nf * nb];
    let mut mask_h = vec![0.0; nf * nb];
    for t in 0..nf {
        for k in 0..nb {
            let (p, h) = (perc[t * nb + k], harm_t[k * nf + t]);
            let z = p.max(h);
            let i = t * nb + k;
            if z < tiny {
                mask_p[i] = 0.5;
                mask_h[i] = 0.5;
            } else {
                let (a, b) = ((p / z).powi(2), (h / z).powi(2));
                mask_p[i] = a / (a + b);
                mask_h[i] = b / (a + b);
            }
        }
    }
    (mask_p, mask_h)
}

/// The STFT of `y` with librosa's defaults (n_fft 2048, hop 512, periodic Hann, centred).
pub fn default_stft(y: &[f64]) -> ComplexStft {
    stft(y, N_FFT, HOP, &hann_periodic(N_FFT))
}

/// Percussive part of `y` (librosa 0.8.1 `effects.hpss(y)[1]`), same length as `y`.
pub fn percussive(y: &[f64]) -> Vec<f64> {
    let d = default_stft(y);
    let (mask, _) = hpss_masks(&d);
    let mut masked = d.data.clone();
    for (c, m) in masked.iter_mut().zip(&mask) {
        *c *= m;
    }
    let spec = ComplexStft { data: masked, ..d };
    let mut out = istft(&spec);
    out.resize(y.len(), 0.0);
    out
}

/// librosa 0.8.1 `istft(stft, hop_length=512, window='hann', center=True)`: windowed overlap-add divided
/// by the window's summed squares, centre padding removed.
pub fn istft(d: &ComplexStft) -> Vec<f64> {
    let n_fft = d.n_fft;
    let hop = d.hop;
    let win = hann_periodic(n_fft);
    let len = n_fft + hop * (d.n_frames - 1);
    let mut y = vec![0.0; len];
    let mut wss = vec![0.0; len];
    let inv = RealFftPlanner::<f64>::new().plan_fft_inverse(n_fft);
    let mut scratch = inv.make_scratch_vec();
    let mut spec = vec![Complex64::new(0.0, 0.0); d.n_bins];
    let mut frame = vec![0.0; n_fft];
    for t in 0..d.n_frames {
        spec.copy_from_slice(&d.data[t * d.n_bins..(t + 1) * d.n_bins]);
        // numpy's irfft ignores the imaginary parts of the DC and Nyquist bins.
        spec[0].im = 0.0;
        spec[d.n_bins - 1].im = 0.0;
        inv.process_with_scratch(&mut spec, &mut frame, &mut scratch)
            .expect("fixed sizes");
        let o = t * hop;
        for i in 0..n_fft {
            y[o + i] += win[i] * frame[i] / n_fft as f64;
            wss[o + i] += win[i] * win[i];
        }
    }
    let tiny = f32::MIN_POSITIVE as f64;
    for (v, w) in y.iter_mut().zip(&wss) {
        if *w > tiny {
            *v /= w;
        }
    }
    y[n_fft / 2..len - n_fft / 2].to_vec()
}

/// Bailando's music beats on a 30720 Hz signal: HPSS-percussive, median onset strength, beat_track at
/// start_bpm 120, tightness 100.
pub fn bailando_beats(y: &[f64], sr: f64) -> BeatTrack {
    let perc = percussive(y);
    let env = onset_strength(&perc, sr, Aggregate::Median);
    beat_track(&env, sr, HOP, 120.0, 100.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn istft_inverts_stft() {
        let y: Vec<f64> = (0..20000)
            .map(|i| ((i as f64) * 0.013).sin() + 0.3 * ((i as f64) * 0.2).cos())
            .collect();
        let d = stft(&y, N_FFT, HOP, &hann_periodic(N_FFT));
        let z = istft(&d);
        assert_eq!(z.len(), HOP * (d.n_frames - 1));
        for i in 0..z.len().min(y.len()) {
            assert!((z[i] - y[i]).abs() < 1e-9, "{i}");
        }
    }

    #[test]
    fn masks_sum_to_one() {
        let y: Vec<f64> = (0..30000)
            .map(|i| ((i as f64) * 0.05).sin() + if i % 7000 == 0 { 1.0 } else { 0.0 })
            .collect();
        let mut padded = y.clone();
        padded.extend(std::iter::repeat_n(0.0, 20000)); // silent tail: both medians vanish
        let (p, h) = hpss_masks(&default_stft(&padded));
        assert!(p
            .iter()
            .zip(&h)
            .all(|(a, b)| (a + b - 1.0).abs() < 1e-15 && *a >= 0.0 && *b >= 0.0));
        assert!(p.contains(&0.5));
    }

    #[test]
    fn clicks_are_percussive_and_a_tone_is_not() {
        let sr = 30720.0;
        let n = 30720 * 2;
        let tone: Vec<f64> = (0..n)
            .map(|i| 0.5 * (2.0 * std::f64::consts::PI * 440.0 * i as f64 / sr).sin())
            .collect();
        let p = percussive(&tone);
        let e_tone: f64 = tone[5000..55000].iter().map(|v| v * v).sum();
        let e_perc: f64 = p[5000..55000].iter().map(|v| v * v).sum();
        assert!(e_perc < 0.01 * e_tone, "{e_perc} vs {e_tone}");
        let mut clicks = vec![0.0; n];
        for k in (1000..n).step_by(15360) {
            clicks[k] = 1.0;
        }
        let pc = percussive(&clicks);
        let e_c: f64 = clicks.iter().map(|v| v * v).sum();
        let e_pc: f64 = pc.iter().map(|v| v * v).sum();
        assert!(e_pc > 0.5 * e_c, "{e_pc} vs {e_c}");
    }

    #[test]
    fn sliding_median_matches_brute_force() {
        let n = 200;
        let x: Vec<f64> = (0..n).map(|i| ((i * 7919) % 101) as f64 * 0.5).collect();
        let mut fast = vec![0.0; n];
        median_line(|i| x[i], n, &mut fast);
        for i in 0..n {
            let mut w: Vec<f64> = (0..KERNEL as isize)
                .map(|k| x[sym_index(i as isize + k - 15, n)])
                .collect();
            w.sort_by(|a, b| a.total_cmp(b));
            assert_eq!(fast[i], w[15], "{i}");
        }
        // Shorter than the kernel: the reflection wraps several times.
        let y = [3.0, 1.0, 2.0];
        let mut o = [0.0; 3];
        median_line(|i| y[i], 3, &mut o);
        assert_eq!(o, [2.0, 2.0, 2.0]);
    }

    #[test]
    fn sym_index_is_half_sample_symmetric() {
        let got: Vec<usize> = (-3..7).map(|i| sym_index(i, 4)).collect();
        assert_eq!(got, vec![2, 1, 0, 0, 1, 2, 3, 3, 2, 1]);
    }
}
