//! Slaney mel filterbank (librosa 0.8.1 `filters.mel`, htk=False, norm='slaney') and `power_to_db`
//! (SPEC §2.2).

use super::stft::Spectrogram;

const F_SP: f64 = 200.0 / 3.0;
const MIN_LOG_HZ: f64 = 1000.0;

fn logstep() -> f64 {
    6.4f64.ln() / 27.0
}

/// librosa `hz_to_mel` (Slaney): linear below 1 kHz, logarithmic above.
pub fn hz_to_mel(f: f64) -> f64 {
    let min_log_mel = MIN_LOG_HZ / F_SP;
    if f >= MIN_LOG_HZ {
        min_log_mel + (f / MIN_LOG_HZ).ln() / logstep()
    } else {
        f / F_SP
    }
}

/// librosa `mel_to_hz` (Slaney).
pub fn mel_to_hz(m: f64) -> f64 {
    let min_log_mel = MIN_LOG_HZ / F_SP;
    if m >= min_log_mel {
        MIN_LOG_HZ * (logstep() * (m - min_log_mel)).exp()
    } else {
        F_SP * m
    }
}

/// numpy `linspace(start, stop, num)` (endpoint included), computed as numpy does.
pub fn linspace(start: f64, stop: f64, num: usize) -> Vec<f64> {
    if num == 1 {
        return vec![start];
    }
    let step = (stop - start) / (num - 1) as f64;
    let mut v: Vec<f64> = (0..num).map(|i| i as f64 * step + start).collect();
    v[num - 1] = stop;
    v
}

/// A sparse filterbank: band m has weights `values` on bins `start .. start + values.len()`.
#[derive(Debug, Clone)]
pub struct MelBank {
    pub n_bins: usize,
    pub bands: Vec<(usize, Vec<f64>)>,
}

impl MelBank {
    /// librosa 0.8.1 `filters.mel(sr, n_fft, n_mels, fmin, fmax)` with Slaney scale and area norm.
    pub fn new(sr: f64, n_fft: usize, n_mels: usize, fmin: f64, fmax: f64) -> MelBank {
        let n_bins = n_fft / 2 + 1;
        let fftfreqs = linspace(0.0, sr / 2.0, n_bins);
        let mel_f: Vec<f64> = linspace(hz_to_mel(fmin), hz_to_mel(fmax), n_mels + 2)
            .into_iter()
            .map(mel_to_hz)
            .collect();
        let mut bands = Vec::with_capacity(n_mels);
        for m in 0..n_mels {
            let (f0, f1, f2) = (mel_f[m], mel_f[m + 1], mel_f[m + 2]);
            let enorm = 2.0 / (f2 - f0);
            let w: Vec<f64> = fftfreqs
                .iter()
                .map(|&fk| {
                    let lower = -(f0 - fk) / (f1 - f0);
                    let upper = (f2 - fk) / (f2 - f1);
                    lower.min(upper).max(0.0) * enorm
                })
                .collect();
            match w.iter().position(|&v| v != 0.0) {
                None => bands.push((0, Vec::new())),
                Some(s) => {
                    let e = w.iter().rposition(|&v| v != 0.0).unwrap();
                    bands.push((s, w[s..=e].to_vec()));
                }
            }
        }
        MelBank { n_bins, bands }
    }

    /// Dense weight of band m at bin k.
    pub fn weight(&self, m: usize, k: usize) -> f64 {
        let (s, v) = &self.bands[m];
        if k >= *s && k < s + v.len() {
            v[k - s]
        } else {
            0.0
        }
    }

    /// Apply to a frame-major power spectrogram: mel[t, m] = Σ_k W[m, k]·S[t, k].
    pub fn apply(&self, s: &Spectrogram) -> Spectrogram {
        assert_eq!(s.n_bins, self.n_bins);
        let n_mels = self.bands.len();
        let mut data = vec![0.0; s.n_frames * n_mels];
        for (t, out) in data.chunks_exact_mut(n_mels).enumerate() {
            let fr = s.frame(t);
            for (o, (start, w)) in out.iter_mut().zip(&self.bands) {
                *o = w.iter().zip(&fr[*start..]).map(|(a, b)| a * b).sum();
            }
        }
        Spectrogram {
            n_frames: s.n_frames,
            n_bins: n_mels,
            data,
        }
    }
}

/// librosa `power_to_db(S, ref=1.0, amin=1e-10, top_db=80)`, in place; the max is global.
pub fn power_to_db(s: &mut [f64]) {
    let mut max = f64::NEG_INFINITY;
    for v in s.iter_mut() {
        *v = 10.0 * v.max(1e-10).log10();
        max = max.max(*v);
    }
    let floor = max - 80.0;
    for v in s.iter_mut() {
        *v = v.max(floor);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mel_scale_round_trip_and_knee() {
        assert!((hz_to_mel(1000.0) - 15.0).abs() < 1e-12);
        assert!((hz_to_mel(500.0) - 7.5).abs() < 1e-12);
        for f in [0.0, 100.0, 999.0, 1000.0, 4321.0, 15360.0] {
            assert!((mel_to_hz(hz_to_mel(f)) - f).abs() < 1e-9 * f.max(1.0));
        }
    }

    #[test]
    fn triangles_have_unit_area_in_hz() {
        // Slaney norm: each triangle's area (in Hz) is 1.
        let bank = MelBank::new(30720.0, 2048, 128, 0.0, 15360.0);
        let df = 30720.0 / 2048.0;
        for m in 20..128 {
            let (_, w) = &bank.bands[m];
            let area: f64 = w.iter().sum::<f64>() * df;
            assert!((area - 1.0).abs() < 0.05, "band {m}: {area}");
        }
    }

    #[test]
    fn db_floor_is_global() {
        let mut s = vec![1.0, 1e-12, 1e-3, 100.0];
        power_to_db(&mut s);
        assert_eq!(s, vec![0.0, -60.0, -30.0, 20.0]);
        let mut s = vec![1.0, 1e-12];
        power_to_db(&mut s);
        assert_eq!(s, vec![0.0, -80.0]);
    }
}
