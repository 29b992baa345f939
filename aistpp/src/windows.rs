//! Training windows (SPEC §1.5, mint `inputs_util.fact_preprocessing`) and the endless, resumable window stream
//! of SPEC §5.
//!
//! Per draw: s ~ U{0, …, T − 240}; motion_in = M[s, s+120), target = M[s+120, s+140), audio_in = A[s, s+240),
//! with T = min(T_motion, T_audio) [DECISION]; sequences with T < 240 are skipped.

use std::collections::HashMap;
use std::sync::Arc;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::dataset::{Dataset, Split};
use qean_io::error::{Error, Result};
use qean_motion::motion::Layout;

/// Number of columns of the music features.
pub const AUDIO_DIM: usize = 35;

/// Window lengths in frames.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct WindowSpec {
    /// Motion frames fed to the model (mint: 120).
    pub motion_len: usize,
    /// Supervised future frames (mint: 20).
    pub target_len: usize,
    /// Offset of the first target frame from the window start (mint: 120).
    pub target_shift: usize,
    /// Audio frames fed to the model (mint: 240).
    pub audio_len: usize,
}

impl Default for WindowSpec {
    fn default() -> Self {
        WindowSpec {
            motion_len: 120,
            target_len: 20,
            target_shift: 120,
            audio_len: 240,
        }
    }
}

impl WindowSpec {
    /// Frames a window spans: max(motion_len, target_shift + target_len, audio_len).
    pub fn span(&self) -> usize {
        self.motion_len
            .max(self.target_shift + self.target_len)
            .max(self.audio_len)
    }

    /// Number of possible window starts in a sequence of `frames` frames (0 if too short).
    pub fn starts(&self, frames: usize) -> usize {
        (frames + 1).saturating_sub(self.span())
    }
}

/// One training sequence: its motion in the model layout and its music features (shared per music ID).
#[derive(Debug, Clone)]
pub struct Sequence {
    pub name: String,
    /// frames_motion × layout dim.
    pub motion: Vec<f32>,
    pub motion_frames: usize,
    /// frames_audio × 35.
    pub audio: Arc<Vec<f32>>,
    pub audio_frames: usize,
}

impl Sequence {
    /// Usable length T = min(T_motion, T_audio).
    pub fn frames(&self) -> usize {
        self.motion_frames.min(self.audio_frames)
    }
}

/// The sequences of one split, ready for windowing.
#[derive(Debug, Clone)]
pub struct SequenceSet {
    pub layout: Layout,
    /// Values per motion frame (the layout's width, or what [`SequenceSet::remap`] made of it).
    pub dim: usize,
    /// Values per music frame (35, or what [`SequenceSet::remap`] made of it).
    pub audio_dim: usize,
    pub spec: WindowSpec,
    pub sequences: Vec<Sequence>,
    /// Names skipped because they are shorter than a window.
    pub skipped: Vec<String>,
    /// Visits of each sequence per epoch (empty: one each). A set that joins two sources balances them
    /// with it (the VQ-VAE's AIST++ + text set, SPEC §13.2.5 "drawn 1:1").
    pub visits: Vec<usize>,
}

/// Music features of one music ID: frames × 35 row-major, and the frame count.
pub type MusicFeatures = (Vec<f32>, usize);

impl SequenceSet {
    /// Load a split: motions from the dataset, music features from `features(music_id)` (called once per
    /// music ID). Errors name the file at fault.
    pub fn load(
        dataset: &Dataset,
        split: Split,
        layout: Layout,
        spec: WindowSpec,
        mut features: impl FnMut(&str) -> Result<MusicFeatures>,
    ) -> Result<SequenceSet> {
        let names = dataset.split(split);
        if names.is_empty() {
            return Err(Error::at(
                &dataset.root,
                format!("the {} split is empty", split.name()),
            ));
        }
        let mut cache: HashMap<String, (Arc<Vec<f32>>, usize)> = HashMap::new();
        let mut sequences = Vec::new();
        let mut skipped = Vec::new();
        for name in names {
            let path = dataset.motion_path(&name);
            if !path.is_file() {
                return Err(Error::at(
                    &path,
                    format!("motion of {} sequence {name} is missing", split.name()),
                ));
            }
            let motion = dataset.read_motion(&name)?;
            let music = dataset
                .music_id(&name)
                .ok_or_else(|| Error::at(&path, "no music ID in the sequence name"))?;
            if !cache.contains_key(&music) {
                let (data, frames) = features(&music)?;
                if data.len() != frames * AUDIO_DIM {
                    return Err(Error::msg(format!(
                        "music features of {music}: expected frames × {AUDIO_DIM} values, got {}",
                        data.len()
                    )));
                }
                cache.insert(music.clone(), (Arc::new(data), frames));
            }
            let (audio, audio_frames) = cache[&music].clone();
            let seq = Sequence {
                name: name.clone(),
                motion: motion.to_layout(layout),
                motion_frames: motion.frames,
                audio,
                audio_frames,
            };
            if spec.starts(seq.frames()) == 0 {
                tracing::warn!(
                    "skipping {name}: {} usable frames, a window needs {}",
                    seq.frames(),
                    spec.span()
                );
                skipped.push(name);
            } else {
                sequences.push(seq);
            }
        }
        if sequences.is_empty() {
            return Err(Error::at(
                &dataset.root,
                format!(
                    "every {} sequence is shorter than a {}-frame window",
                    split.name(),
                    spec.span()
                ),
            ));
        }
        Ok(SequenceSet {
            layout,
            dim: layout.dim(),
            audio_dim: AUDIO_DIM,
            spec,
            sequences,
            skipped,
            visits: Vec::new(),
        })
    }

    /// Copy the window of sequence `i` starting at `s` into the batch buffers.
    fn push_window(&self, i: usize, s: usize, batch: &mut Batch) {
        let (d, ad) = (self.dim, self.audio_dim);
        let seq = &self.sequences[i];
        let sp = &self.spec;
        batch
            .motion
            .extend_from_slice(&seq.motion[s * d..(s + sp.motion_len) * d]);
        let t0 = s + sp.target_shift;
        batch
            .target
            .extend_from_slice(&seq.motion[t0 * d..(t0 + sp.target_len) * d]);
        batch
            .audio
            .extend_from_slice(&seq.audio[s * ad..(s + sp.audio_len) * ad]);
        batch.names.push(seq.name.clone());
        batch.starts.push(s);
    }

    /// The same windows over another representation: each sequence's motion becomes `motion(seq)`
    /// (frames × `dim`) and each music's features `audio(features, frames)` (frames × `audio_dim`,
    /// computed once per music and shared like the features). Errors of `motion` pass through.
    pub fn remap(
        self,
        dim: usize,
        audio_dim: usize,
        mut motion: impl FnMut(&Sequence) -> Result<Vec<f32>>,
        mut audio: impl FnMut(&[f32], usize) -> Vec<f32>,
    ) -> Result<SequenceSet> {
        let mut done: HashMap<*const Vec<f32>, Arc<Vec<f32>>> = HashMap::new();
        let mut sequences = Vec::with_capacity(self.sequences.len());
        for seq in self.sequences {
            let m = motion(&seq)?;
            if m.len() != seq.motion_frames * dim {
                return Err(Error::msg(format!(
                    "{}: the remapped motion has {} values, expected {} frames × {dim}",
                    seq.name,
                    m.len(),
                    seq.motion_frames
                )));
            }
            let a = done
                .entry(Arc::as_ptr(&seq.audio))
                .or_insert_with(|| Arc::new(audio(&seq.audio, seq.audio_frames)))
                .clone();
            assert_eq!(
                a.len(),
                seq.audio_frames * audio_dim,
                "remapped audio shape"
            );
            sequences.push(Sequence {
                motion: m,
                audio: a,
                ..seq
            });
        }
        Ok(SequenceSet {
            dim,
            audio_dim,
            sequences,
            ..self
        })
    }

    /// Windows at s = 0 of every sequence (teacher-forced validation, SPEC §5.6).
    pub fn first_windows(&self) -> Batch {
        let mut b = Batch::new(self);
        for i in 0..self.sequences.len() {
            self.push_window(i, 0, &mut b);
        }
        b
    }
}

/// A batch of windows, row-major: motion [B, motion_len, D], audio [B, audio_len, A] (A = 35 unless
/// remapped), target [B, target_len, D].
#[derive(Debug, Clone, PartialEq)]
pub struct Batch {
    pub motion: Vec<f32>,
    pub audio: Vec<f32>,
    pub target: Vec<f32>,
    pub names: Vec<String>,
    pub starts: Vec<usize>,
    pub dim: usize,
    pub audio_dim: usize,
    pub spec: WindowSpec,
}

impl Batch {
    fn new(set: &SequenceSet) -> Batch {
        Batch {
            motion: vec![],
            audio: vec![],
            target: vec![],
            names: vec![],
            starts: vec![],
            dim: set.dim,
            audio_dim: set.audio_dim,
            spec: set.spec,
        }
    }

    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// Windows `start..end` of the batch.
    pub fn slice(&self, start: usize, end: usize) -> Batch {
        let sp = self.spec;
        let (m, a, t) = (
            sp.motion_len * self.dim,
            sp.audio_len * self.audio_dim,
            sp.target_len * self.dim,
        );
        Batch {
            motion: self.motion[start * m..end * m].to_vec(),
            audio: self.audio[start * a..end * a].to_vec(),
            target: self.target[start * t..end * t].to_vec(),
            names: self.names[start..end].to_vec(),
            starts: self.starts[start..end].to_vec(),
            ..*self
        }
    }

    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }
}

/// Position of the endless window stream: everything needed to resume it exactly.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct SamplerState {
    pub seed: u64,
    pub epoch: u64,
    /// Index of the next visit within the epoch's permutation.
    pub position: usize,
}

/// The endless stream of SPEC §5: every epoch visits each sequence once in a fresh random order, drawing one
/// random window per visit; batches run across epoch boundaries. The order and each window start are pure
/// functions of (seed, epoch, position), so the stream resumes exactly from a [`SamplerState`].
#[derive(Debug, Clone)]
pub struct WindowSampler {
    state: SamplerState,
    order: Vec<usize>,
}

impl WindowSampler {
    pub fn new(seed: u64, set: &SequenceSet) -> Self {
        Self::resume(
            SamplerState {
                seed,
                epoch: 0,
                position: 0,
            },
            set,
        )
    }

    pub fn resume(state: SamplerState, set: &SequenceSet) -> Self {
        let order = epoch_order(state.seed, state.epoch, set);
        WindowSampler { state, order }
    }

    pub fn state(&self) -> SamplerState {
        self.state
    }

    /// The next `batch_size` windows.
    pub fn next_batch(&mut self, set: &SequenceSet, batch_size: usize) -> Batch {
        let mut b = Batch::new(set);
        for _ in 0..batch_size {
            if self.state.position >= self.order.len() {
                self.state.epoch += 1;
                self.state.position = 0;
                self.order = epoch_order(self.state.seed, self.state.epoch, set);
            }
            let i = self.order[self.state.position];
            let mut rng = ChaCha8Rng::seed_from_u64(mix(
                self.state.seed,
                self.state.epoch,
                self.state.position as u64 + 1,
            ));
            let s = rng.random_range(0..set.spec.starts(set.sequences[i].frames()));
            set.push_window(i, s, &mut b);
            self.state.position += 1;
        }
        b
    }
}

fn mix(seed: u64, a: u64, b: u64) -> u64 {
    // SplitMix64 finaliser over the combined words.
    let mut z = seed ^ a.wrapping_mul(0x9E3779B97F4A7C15) ^ b.wrapping_mul(0xC2B2AE3D27D4EB4F);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
    z ^ (z >> 31)
}

/// One epoch's visits in a seeded random order: each sequence once, or `set.visits[i]` times.
fn epoch_order(seed: u64, epoch: u64, set: &SequenceSet) -> Vec<usize> {
    let mut order: Vec<usize> = if set.visits.is_empty() {
        (0..set.sequences.len()).collect()
    } else {
        assert_eq!(
            set.visits.len(),
            set.sequences.len(),
            "one visit count per sequence"
        );
        set.visits
            .iter()
            .enumerate()
            .flat_map(|(i, &k)| std::iter::repeat_n(i, k))
            .collect()
    };
    let n = order.len();
    let mut rng = ChaCha8Rng::seed_from_u64(mix(seed, epoch, 0));
    for i in (1..n).rev() {
        let j = rng.random_range(0..=i);
        order.swap(i, j);
    }
    order
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toy_set(lengths: &[usize]) -> SequenceSet {
        let layout = Layout::L225;
        let d = layout.dim();
        let sequences = lengths
            .iter()
            .enumerate()
            .map(|(k, &t)| Sequence {
                name: format!("s{k}"),
                // Value encodes (sequence, frame) so windows can be checked.
                motion: (0..t * d).map(|x| (k * 100_000 + x / d) as f32).collect(),
                motion_frames: t,
                audio: Arc::new(
                    (0..(t + 10) * AUDIO_DIM)
                        .map(|x| (k * 100_000 + x / AUDIO_DIM) as f32)
                        .collect(),
                ),
                audio_frames: t + 10,
            })
            .collect();
        SequenceSet {
            layout,
            dim: d,
            audio_dim: AUDIO_DIM,
            spec: WindowSpec::default(),
            sequences,
            skipped: vec![],
            visits: vec![],
        }
    }

    #[test]
    fn window_arithmetic() {
        let sp = WindowSpec::default();
        assert_eq!(sp.span(), 240);
        assert_eq!(sp.starts(239), 0);
        assert_eq!(sp.starts(240), 1);
        assert_eq!(sp.starts(300), 61);
    }

    #[test]
    fn windows_slice_the_right_frames() {
        let set = toy_set(&[300, 500]);
        let mut sampler = WindowSampler::new(1, &set);
        let b = sampler.next_batch(&set, 6);
        let d = 225;
        for (k, (&s, name)) in b.starts.iter().zip(&b.names).enumerate() {
            let seq: usize = name[1..].parse().unwrap();
            let base = (seq * 100_000) as f32;
            assert!(s + 240 <= set.sequences[seq].frames());
            let m = &b.motion[k * 120 * d..(k + 1) * 120 * d];
            assert_eq!(m[0], base + s as f32);
            assert_eq!(m[119 * d], base + (s + 119) as f32);
            let t = &b.target[k * 20 * d..(k + 1) * 20 * d];
            assert_eq!(t[0], base + (s + 120) as f32);
            assert_eq!(t[19 * d], base + (s + 139) as f32);
            let a = &b.audio[k * 240 * 35..(k + 1) * 240 * 35];
            assert_eq!(a[0], base + s as f32);
            assert_eq!(a[239 * 35], base + (s + 239) as f32);
        }
    }

    #[test]
    fn epochs_visit_every_sequence_once() {
        let set = toy_set(&[240, 250, 260, 270, 280]);
        let mut sampler = WindowSampler::new(9, &set);
        let b = sampler.next_batch(&set, 10);
        for epoch in b.names.chunks(5) {
            let mut e: Vec<&String> = epoch.iter().collect();
            e.sort();
            e.dedup();
            assert_eq!(e.len(), 5);
        }
        assert_eq!(sampler.state().epoch, 1);
        assert_eq!(sampler.state().position, 5);
    }

    #[test]
    fn visit_counts_repeat_sequences_within_an_epoch() {
        let plain = toy_set(&[240, 250, 260]);
        let ones = SequenceSet {
            visits: vec![1, 1, 1],
            ..plain.clone()
        };
        // One visit each is the plain stream.
        assert_eq!(
            WindowSampler::new(5, &plain).next_batch(&plain, 9),
            WindowSampler::new(5, &ones).next_batch(&ones, 9)
        );
        let weighted = SequenceSet {
            visits: vec![3, 1, 0],
            ..plain
        };
        let mut sampler = WindowSampler::new(5, &weighted);
        let b = sampler.next_batch(&weighted, 8);
        for epoch in b.names.chunks(4) {
            let count = |n: &str| epoch.iter().filter(|x| *x == n).count();
            assert_eq!((count("s0"), count("s1"), count("s2")), (3, 1, 0));
        }
        assert_eq!(sampler.state().epoch, 1);
    }

    #[test]
    fn resume_continues_the_same_stream() {
        let set = toy_set(&[300, 400, 500]);
        let mut straight = WindowSampler::new(42, &set);
        let all: Vec<Batch> = (0..7).map(|_| straight.next_batch(&set, 4)).collect();
        let mut first = WindowSampler::new(42, &set);
        for b in &all[..3] {
            assert_eq!(&first.next_batch(&set, 4), b);
        }
        let mut resumed = WindowSampler::resume(first.state(), &set);
        for b in &all[3..] {
            assert_eq!(&resumed.next_batch(&set, 4), b);
        }
        // Another seed gives another stream.
        let mut other = WindowSampler::new(43, &set);
        assert_ne!(other.next_batch(&set, 4), all[0]);
    }

    #[test]
    fn first_windows_start_at_zero() {
        let set = toy_set(&[300, 400]);
        let b = set.first_windows();
        assert_eq!(b.starts, vec![0, 0]);
        assert_eq!(b.len(), 2);
    }
}
