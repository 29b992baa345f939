//! Onset strength and onset (peak) detection, librosa 0.8.1 `onset.onset_strength` / `onset_detect` /
//! `util.peak_pick` (SPEC §2.3, §2.5).

use super::mel::{power_to_db, MelBank};
use super::stft::{power_spectrogram, Spectrogram};
use super::{HOP, N_FFT};

/// How onset strength aggregates the mel bands.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Aggregate {
    /// `np.mean` (librosa's default; the 35-D feature).
    #[default]
    Mean,
    /// `np.median` (Bailando's music beats).
    Median,
}

/// The mel fmax librosa 0.8.1's onset_strength uses when the caller gives none.
pub const ONSET_FMAX: f64 = 11025.0;

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Onset envelope from a frame-major dB mel spectrogram: lag 1, no max filter, centred (3 leading zeros),
/// truncated to the frame count.
pub fn onset_strength_from_db(mel_db: &Spectrogram, aggregate: Aggregate) -> Vec<f64> {
    let t_frames = mel_db.n_frames;
    let pad = 1 + N_FFT / (2 * HOP);
    let mut env = vec![0.0; t_frames];
    let mut diff = vec![0.0; mel_db.n_bins];
    for u in 0..t_frames.saturating_sub(1) {
        let t = u + pad;
        if t >= t_frames {
            break;
        }
        let (a, b) = (mel_db.frame(u), mel_db.frame(u + 1));
        for ((d, &x1), &x0) in diff.iter_mut().zip(b).zip(a) {
            *d = (x1 - x0).max(0.0);
        }
        env[t] = match aggregate {
            Aggregate::Mean => diff.iter().sum::<f64>() / diff.len() as f64,
            Aggregate::Median => median(&mut diff),
        };
    }
    env
}

/// Onset envelope from a power spectrogram (n_fft 2048) at `sr`: dB mel (128 bands, fmax 11025).
pub fn onset_strength_from_power(power: &Spectrogram, sr: f64, aggregate: Aggregate) -> Vec<f64> {
    let bank = MelBank::new(sr, N_FFT, 128, 0.0, ONSET_FMAX.min(sr / 2.0));
    let mut mel = bank.apply(power);
    power_to_db(&mut mel.data);
    onset_strength_from_db(&mel, aggregate)
}

/// librosa 0.8.1 `onset_strength(y, sr, aggregate)` with its defaults (n_fft 2048, hop 512, 128 mel
/// bands up to 11025 Hz, lag 1, centred).
pub fn onset_strength(y: &[f64], sr: f64, aggregate: Aggregate) -> Vec<f64> {
    let power = power_spectrogram(y, N_FFT, HOP);
    onset_strength_from_power(&power, sr, aggregate)
}

/// Parameters of `util.peak_pick`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PeakPick {
    pub pre_max: usize,
    pub post_max: usize,
    pub pre_avg: usize,
    pub post_avg: usize,
    pub delta: f64,
    pub wait: usize,
}

impl PeakPick {
    /// onset_detect's defaults in frames at (sr, hop): 30 ms pre-max and wait, 100 ms averages, δ 0.07.
    pub fn onset_defaults(sr: f64, hop: usize) -> PeakPick {
        let fl = |sec: f64| (sec * sr / hop as f64).floor() as usize;
        PeakPick {
            pre_max: fl(0.03),
            post_max: fl(0.0) + 1,
            pre_avg: fl(0.10),
            post_avg: fl(0.10) + 1,
            delta: 0.07,
            wait: fl(0.03),
        }
    }
}

/// librosa 0.8.1 `util.peak_pick`.
pub fn peak_pick(x: &[f64], p: &PeakPick) -> Vec<usize> {
    let n = x.len();
    if n == 0 {
        return Vec::new();
    }
    let min = x.iter().cloned().fold(f64::INFINITY, f64::min);
    // scipy maximum_filter1d(size, mode='constant', cval=min, origin): window starts at
    // i − size/2 − origin.
    let max_len = p.pre_max + p.post_max;
    let max_origin = (0.5 * (p.pre_max as f64 - p.post_max as f64)).ceil() as isize;
    let max_start = -((max_len / 2) as isize) - max_origin;
    let avg_len = p.pre_avg + p.post_avg;
    let avg_origin = (0.5 * (p.pre_avg as f64 - p.post_avg as f64)).ceil() as isize;
    let avg_start = -((avg_len / 2) as isize) - avg_origin;
    let exact_mean = |i: usize| {
        let s = i.saturating_sub(p.pre_avg);
        let e = (i + p.post_avg).min(n);
        x[s..e].iter().sum::<f64>() / (e - s) as f64
    };
    let mut peaks = Vec::new();
    let mut last: Option<usize> = None;
    for i in 0..n {
        let mut mov_max = f64::NEG_INFINITY;
        for j in 0..max_len as isize {
            let k = i as isize + max_start + j;
            let v = if k < 0 || k >= n as isize {
                min
            } else {
                x[k as usize]
            };
            mov_max = mov_max.max(v);
        }
        if x[i] != mov_max || x[i] == 0.0 {
            continue;
        }
        // uniform_filter1d(mode='nearest'), overwritten by exact means near both ends.
        let mov_avg = if i < p.pre_avg || i + p.post_avg >= n {
            exact_mean(i)
        } else {
            let mut s = 0.0;
            for j in 0..avg_len as isize {
                let k = (i as isize + avg_start + j).clamp(0, n as isize - 1);
                s += x[k as usize];
            }
            s / avg_len as f64
        };
        if x[i] < mov_avg + p.delta {
            continue;
        }
        if last.is_none_or(|l| i > l + p.wait) {
            peaks.push(i);
            last = Some(i);
        }
    }
    peaks
}

/// librosa 0.8.1 `onset_detect(onset_envelope=env, sr, hop_length)`: peaks of a normalised copy of env.
pub fn onset_detect(env: &[f64], sr: f64, hop: usize) -> Vec<usize> {
    if env.is_empty() || env.iter().any(|v| !v.is_finite()) {
        return Vec::new();
    }
    let min = env.iter().cloned().fold(f64::INFINITY, f64::min);
    let mut x: Vec<f64> = env.iter().map(|v| v - min).collect();
    let max = x.iter().cloned().fold(0.0, f64::max);
    if max == 0.0 {
        return Vec::new();
    }
    for v in &mut x {
        *v /= max;
    }
    peak_pick(&x, &PeakPick::onset_defaults(sr, hop))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_at_30720() {
        let p = PeakPick::onset_defaults(30720.0, 512);
        assert_eq!(
            (p.pre_max, p.post_max, p.pre_avg, p.post_avg, p.wait),
            (1, 1, 6, 7, 1)
        );
    }

    #[test]
    fn unit_spikes_are_found_exactly() {
        // SPEC §9 item 7: spikes ≥ 8 frames apart on a flat envelope.
        let mut env = vec![0.0; 400];
        let spikes = [3usize, 11, 40, 48, 100, 250, 399];
        for &s in &spikes {
            env[s] = 1.0;
        }
        assert_eq!(onset_detect(&env, 30720.0, 512), spikes.to_vec());
        // Shifted and scaled envelopes give the same peaks (normalisation).
        let env2: Vec<f64> = env.iter().map(|v| 3.0 * v + 2.0).collect();
        assert_eq!(onset_detect(&env2, 30720.0, 512), spikes.to_vec());
    }

    #[test]
    fn flat_or_empty_envelope_has_no_peaks() {
        assert!(onset_detect(&[0.0; 50], 30720.0, 512).is_empty());
        assert!(onset_detect(&[5.0; 50], 30720.0, 512).is_empty());
        assert!(onset_detect(&[], 30720.0, 512).is_empty());
    }

    #[test]
    fn plateau_keeps_first_and_wait_applies() {
        // Equal neighbours: x[n] >= x[n-1] holds for both, wait=1 drops the second.
        let mut env = vec![0.0; 60];
        env[20] = 1.0;
        env[21] = 1.0;
        assert_eq!(onset_detect(&env, 30720.0, 512), vec![20]);
    }

    #[test]
    fn median_of_even_count() {
        assert_eq!(median(&mut [4.0, 1.0, 3.0, 2.0]), 2.5);
        assert_eq!(median(&mut [4.0, 1.0, 3.0]), 3.0);
    }
}
