//! Onset curves from stems (SPEC §12.3c, Lin eq. 3.3) and the drum spectrogram NMFD factorises (§12.3d).
//! Lin separates stems with OpenUnmix, whose weights cannot be fetched here: stems are user-supplied WAVs
//! (`files`), or the HPSS masks stand in (`hpss`: drums := percussive, other := harmonic).

use qean_audio::hpss::{default_stft, hpss_masks};
use qean_audio::onset::{onset_strength, onset_strength_from_power, Aggregate};
use qean_audio::stft::Spectrogram;
use serde::{Deserialize, Serialize};

/// The four OpenUnmix targets, in the order of `stem_weights`.
pub const STEM_NAMES: [&str; 4] = ["drums", "bass", "vocals", "other"];

const SR: f64 = 30720.0;

/// Where the stems come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum StemSource {
    /// `<dir>/{drums,bass,vocals,other}.wav`, e.g. OpenUnmix's output.
    #[default]
    Files,
    /// librosa HPSS masks on the music's STFT (no bass or vocals).
    Hpss,
}

/// One stem as the keyframe strategies use it: its onset envelope (§2.3) and |STFT| (bins × frames).
#[derive(Debug, Clone)]
pub struct Stem {
    pub envelope: Vec<f64>,
    pub magnitude: Vec<f64>,
    pub bins: usize,
}

fn bins_major(data: impl Fn(usize, usize) -> f64, frames: usize, bins: usize) -> Vec<f64> {
    let mut out = vec![0.0; bins * frames];
    for k in 0..bins {
        for t in 0..frames {
            out[k * frames + t] = data(t, k);
        }
    }
    out
}

/// A stem from its samples at 30720 Hz.
pub fn stem_from_samples(y: &[f64]) -> Stem {
    let d = default_stft(y);
    Stem {
        envelope: onset_strength(y, SR, Aggregate::Mean),
        magnitude: bins_major(|t, k| d.data[t * d.n_bins + k].norm(), d.n_frames, d.n_bins),
        bins: d.n_bins,
    }
}

/// The HPSS stand-in: (drums, other) from the music's samples at 30720 Hz, features computed on the
/// masked STFT without an inverse transform.
pub fn hpss_stems(y: &[f64]) -> (Stem, Stem) {
    let d = default_stft(y);
    let (mask_p, mask_h) = hpss_masks(&d);
    let stem = |mask: &[f64]| {
        let mag: Vec<f64> = d.data.iter().zip(mask).map(|(c, m)| c.norm() * m).collect();
        let power = Spectrogram {
            n_frames: d.n_frames,
            n_bins: d.n_bins,
            data: mag.iter().map(|m| m * m).collect(),
        };
        Stem {
            envelope: onset_strength_from_power(&power, SR, Aggregate::Mean),
            magnitude: bins_major(|t, k| mag[t * d.n_bins + k], d.n_frames, d.n_bins),
            bins: d.n_bins,
        }
    };
    (stem(&mask_p), stem(&mask_h))
}

/// c = Σ w_s·o(s) over the stems present (absent stems count as silent); the length is the longest
/// envelope's.
pub fn weighted_curve(envelopes: &[Option<&[f64]>; 4], weights: [f64; 4]) -> Vec<f64> {
    let len = envelopes
        .iter()
        .flatten()
        .map(|e| e.len())
        .max()
        .unwrap_or(0);
    let mut c = vec![0.0; len];
    for (env, w) in envelopes.iter().zip(weights) {
        if let Some(e) = env {
            for (ci, v) in c.iter_mut().zip(e.iter()) {
                *ci += w * v;
            }
        }
    }
    c
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_mix_envelopes() {
        let (a, b) = (vec![1.0, 2.0, 3.0], vec![10.0, 0.0]);
        let c = weighted_curve(&[Some(&a), None, Some(&b), None], [2.0, 5.0, 0.5, 1.0]);
        assert_eq!(c, vec![7.0, 4.0, 6.0]);
    }

    #[test]
    fn hpss_drums_hear_clicks_and_other_hears_the_tone() {
        let n = 30720 * 2;
        let y: Vec<f64> = (0..n)
            .map(|i| {
                0.3 * (2.0 * std::f64::consts::PI * 440.0 * i as f64 / SR).sin()
                    + if i % 15360 == 7000 { 1.0 } else { 0.0 }
            })
            .collect();
        let (drums, other) = hpss_stems(&y);
        assert_eq!(drums.envelope.len(), other.envelope.len());
        let energy = |s: &Stem| s.magnitude.iter().map(|m| m * m).sum::<f64>();
        // The 440 Hz bin (~29) belongs to `other`; the clicks' broadband frames to `drums`.
        let bin440 = (440.0 * 2048.0 / SR).round() as usize;
        let frames = drums.magnitude.len() / drums.bins;
        let row = |s: &Stem| {
            s.magnitude[bin440 * frames..(bin440 + 1) * frames]
                .iter()
                .sum::<f64>()
        };
        assert!(row(&other) > 10.0 * row(&drums));
        assert!(energy(&drums) > 0.0);
        // Drum onsets peak at a click (samples 7000 + 15360·i, frames ≈ 14, 44, 74, 104).
        let peak = |e: &[f64]| (0..e.len()).max_by(|&a, &b| e[a].total_cmp(&e[b])).unwrap();
        let p = peak(&drums.envelope) as f64;
        assert!(
            (0..4).any(|i| (p - (7000.0 + 15360.0 * i as f64) / 512.0).abs() <= 3.0),
            "{p}"
        );
    }
}
