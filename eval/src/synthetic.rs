//! Synthetic evaluation sets of AIST++'s sizes, for benchmarks: 1363 reference sequences (80 % basic
//! dances of 8–12 s, 20 % advanced of 30–50 s, 60 FPS) and 40 generated ones of seed + 1200 frames.
//! Every joint moves on a sum of sines, so the motion is smooth and its features are well defined.
//! A set is small to describe ([`SmoothMotion`]: a base pose and three (amplitude, frequency, phase)
//! triples per joint) and can be written as JSON, so a peer implementation rebuilds the same frames.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::positions::{Frame, Sequence, N_JOINTS};

/// One sequence: joint j, axis a at time t (seconds) is
/// `base[j][a] + amp · sin(2π · freq · t + phase)` with `(amp, freq, phase) = wave[j][a]`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SmoothMotion {
    pub name: String,
    pub frames: usize,
    pub base: Vec<[f64; 3]>,
    pub wave: Vec<[[f64; 3]; 3]>,
}

impl SmoothMotion {
    fn random(rng: &mut ChaCha8Rng, name: String, frames: usize) -> Self {
        let base = (0..N_JOINTS)
            .map(|_| {
                [
                    rng.random_range(-0.5..0.5),
                    rng.random_range(-1.0..0.7),
                    rng.random_range(-0.2..0.2),
                ]
            })
            .collect();
        let wave = (0..N_JOINTS)
            .map(|_| {
                [0; 3].map(|_| {
                    [
                        rng.random_range(0.01..0.2),
                        rng.random_range(0.3..3.0),
                        rng.random_range(0.0..std::f64::consts::TAU),
                    ]
                })
            })
            .collect();
        SmoothMotion {
            name,
            frames,
            base,
            wave,
        }
    }

    /// The joint positions, 60 FPS.
    pub fn joints(&self) -> Vec<Frame> {
        (0..self.frames)
            .map(|k| {
                let t = k as f64 / 60.0;
                let mut f = [[0.0; 3]; N_JOINTS];
                for (j, joint) in f.iter_mut().enumerate() {
                    for (a, x) in joint.iter_mut().enumerate() {
                        let [amp, freq, phase] = self.wave[j][a];
                        *x = self.base[j][a]
                            + amp * (std::f64::consts::TAU * freq * t + phase).sin();
                    }
                }
                f
            })
            .collect()
    }

    pub fn sequence(&self) -> Sequence {
        Sequence::new(self.name.clone(), self.joints())
    }
}

/// A generated set and its reference set.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct SyntheticSet {
    pub generated: Vec<SmoothMotion>,
    pub reference: Vec<SmoothMotion>,
    /// Beat period and offset of every music ID (frames): beats at `offset + period · k`.
    pub beat_period: usize,
    pub beat_offset: usize,
}

/// AIST++-style name of sequence `i` (ten genres, six music IDs each).
fn name(i: usize) -> String {
    const GENRES: [&str; 10] = ["BR", "PO", "LO", "MH", "LH", "HO", "WA", "KR", "JS", "JB"];
    let g = GENRES[i % 10];
    format!(
        "g{g}_sBM_cAll_d{:02}_m{g}{}_ch{:02}",
        i % 30,
        (i / 10) % 6,
        i % 100
    )
}

impl SyntheticSet {
    /// `generated` sequences of `generated_frames` frames and `reference` sequences of AIST++
    /// lengths; generated sequence i shares its name (and so its music) with reference sequence i.
    pub fn aist_sized(
        seed: u64,
        generated: usize,
        generated_frames: usize,
        reference: usize,
    ) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let reference: Vec<SmoothMotion> = (0..reference)
            .map(|i| {
                let frames = if rng.random_bool(0.8) {
                    rng.random_range(480..=720)
                } else {
                    rng.random_range(1800..=3000)
                };
                SmoothMotion::random(&mut rng, name(i), frames)
            })
            .collect();
        let generated = (0..generated)
            .map(|i| SmoothMotion::random(&mut rng, name(i), generated_frames))
            .collect();
        SyntheticSet {
            generated,
            reference,
            beat_period: 30,
            beat_offset: 13,
        }
    }

    /// Music beats (frames) of every music ID, up to `frames`.
    pub fn beats(&self, frames: usize) -> Vec<usize> {
        (self.beat_offset..frames)
            .step_by(self.beat_period)
            .collect()
    }

    /// Total reference frames.
    pub fn reference_frames(&self) -> usize {
        self.reference.iter().map(|s| s.frames).sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_names_and_smoothness() {
        let set = SyntheticSet::aist_sized(7, 4, 1320, 50);
        assert_eq!(set.generated.len(), 4);
        assert_eq!(set.reference.len(), 50);
        assert!(set
            .reference
            .iter()
            .all(|s| (480..=3000).contains(&s.frames)));
        assert_eq!(set.generated[3].name, set.reference[3].name);
        let j = set.generated[0].joints();
        assert_eq!(j.len(), 1320);
        // Largest per-frame step: amplitude 0.2 at 3 Hz moves at most 2π·3·0.2/60 ≈ 0.063 per frame.
        let step = j
            .windows(2)
            .flat_map(|w| {
                (0..N_JOINTS)
                    .flat_map(move |k| (0..3).map(move |a| (w[1][k][a] - w[0][k][a]).abs()))
            })
            .fold(0.0, f64::max);
        assert!(step > 0.0 && step < 0.07, "{step}");
        // The JSON a peer reads rebuilds the same frames.
        let back: SyntheticSet =
            serde_json::from_str(&serde_json::to_string(&set).unwrap()).unwrap();
        assert_eq!(back.reference[5].joints(), set.reference[5].joints());
        assert_eq!(set.beats(100), vec![13, 43, 73]);
    }
}
