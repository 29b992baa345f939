//! Tuning estimation, librosa 0.8.1 `pitch.piptrack` + `estimate_tuning` + `pitch_tuning`
//! (SPEC §2.7 step 1).

use super::mel::linspace;
use super::stft::Spectrogram;

/// Parabolic-interpolated spectral peaks of one magnitude frame (librosa 0.8.1 `piptrack`, ref = 0.1·max):
/// pushes (pitch Hz, magnitude) for each local maximum in [fmin, fmax).
fn piptrack_frame(
    s: &[f64],
    sr: f64,
    n_fft: usize,
    fmin: f64,
    fmax: f64,
    out: &mut Vec<(f64, f64)>,
) {
    let n = s.len();
    if n < 3 {
        return;
    }
    let max = s.iter().cloned().fold(0.0f64, f64::max);
    let ref_value = 0.1 * max;
    let thr = |k: usize| if s[k] > ref_value { s[k] } else { 0.0 };
    let freqs = linspace(0.0, sr / 2.0, n);
    let tiny = f32::MIN_POSITIVE as f64;
    for k in 1..n - 1 {
        if !(fmin <= freqs[k] && freqs[k] < fmax) {
            continue;
        }
        let v = thr(k);
        if !(v > thr(k - 1) && v >= thr(k + 1)) {
            continue;
        }
        let avg = 0.5 * (s[k + 1] - s[k - 1]);
        let den = 2.0 * s[k] - s[k + 1] - s[k - 1];
        let shift = avg / (den + if den.abs() < tiny { 1.0 } else { 0.0 });
        let pitch = (k as f64 + shift) * sr / n_fft as f64;
        let mag = s[k] + 0.5 * avg * shift;
        out.push((pitch, mag));
    }
}

/// librosa 0.8.1 `pitch_tuning(frequencies, resolution=0.01, bins_per_octave)`: the left edge of the
/// most populated bin of the residuals bins·log2(f/27.5) mod 1 in [−0.5, 0.5).
pub fn pitch_tuning(freqs: &[f64], bins_per_octave: usize) -> f64 {
    let edges = linspace(-0.5, 0.5, 101);
    let mut counts = [0usize; 100];
    let mut any = false;
    for &f in freqs.iter().filter(|&&f| f > 0.0) {
        any = true;
        let mut r = (bins_per_octave as f64 * (f / 27.5).log2()).rem_euclid(1.0);
        if r >= 0.5 {
            r -= 1.0;
        }
        // bin k holds edges[k] <= r < edges[k+1]; the last bin is closed.
        let k = edges.partition_point(|&e| e <= r).saturating_sub(1).min(99);
        counts[k] += 1;
    }
    if !any {
        return 0.0;
    }
    let mut best = 0;
    for k in 1..100 {
        if counts[k] > counts[best] {
            best = k;
        }
    }
    edges[best]
}

/// librosa 0.8.1 `estimate_tuning(y, sr, bins_per_octave)` from a frame-major power spectrogram
/// (n_fft 2048, hop 512): piptrack on the magnitudes (150–4000 Hz), keep peaks with magnitude ≥ their
/// median, then [`pitch_tuning`].
pub fn estimate_tuning(power: &Spectrogram, sr: f64, n_fft: usize, bins_per_octave: usize) -> f64 {
    let fmax = 4000f64.min(sr / 2.0);
    let mut peaks = Vec::new();
    let mut mag = vec![0.0; power.n_bins];
    for t in 0..power.n_frames {
        for (m, &p) in mag.iter_mut().zip(power.frame(t)) {
            *m = p.sqrt();
        }
        piptrack_frame(&mag, sr, n_fft, 150.0, fmax, &mut peaks);
    }
    let pitched: Vec<(f64, f64)> = peaks.into_iter().filter(|&(p, _)| p > 0.0).collect();
    if pitched.is_empty() {
        return 0.0;
    }
    let mut mags: Vec<f64> = pitched.iter().map(|&(_, m)| m).collect();
    mags.sort_by(|a, b| a.total_cmp(b));
    let n = mags.len();
    let median = if n % 2 == 1 {
        mags[n / 2]
    } else {
        0.5 * (mags[n / 2 - 1] + mags[n / 2])
    };
    let freqs: Vec<f64> = pitched
        .iter()
        .filter(|&&(_, m)| m >= median)
        .map(|&(p, _)| p)
        .collect();
    pitch_tuning(&freqs, bins_per_octave)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stft::power_spectrogram;

    #[test]
    fn pitch_tuning_of_exact_and_detuned_notes() {
        // A440 and its 36-TET neighbours sit on residual 0.
        let f: Vec<f64> = (0..20)
            .map(|k| 440.0 * 2f64.powf(k as f64 / 36.0))
            .collect();
        assert!(pitch_tuning(&f, 36).abs() < 1e-12);
        // A quarter of a 36-TET bin sharp → bin [0.25, 0.26).
        let g: Vec<f64> = f.iter().map(|x| x * 2f64.powf(0.255 / 36.0)).collect();
        assert!((pitch_tuning(&g, 36) - 0.25).abs() < 1e-9);
        assert_eq!(pitch_tuning(&[], 36), 0.0);
    }

    #[test]
    fn sine_tuning_is_found() {
        // 440 Hz shifted by +0.205 of a 36-TET bin; parabolic interpolation on a Hann spectrum is biased,
        // and librosa 0.8.1 returns 0.15 for this exact signal.
        let sr = 30720.0;
        let f = 440.0 * 2f64.powf(0.205 / 36.0);
        let y: Vec<f64> = (0..30720)
            .map(|i| (2.0 * std::f64::consts::PI * f * i as f64 / sr).sin())
            .collect();
        let p = power_spectrogram(&y, 2048, 512);
        let t = estimate_tuning(&p, sr, 2048, 36);
        assert!((t - 0.15).abs() < 1e-9, "{t}");
    }
}
