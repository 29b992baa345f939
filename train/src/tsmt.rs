//! Li et al.'s two-stream motion transformer as a trainer [`Family`] (SPEC §11.7): the coordinate
//! bins fitted on the training split (stored in the run config and every checkpoint, never
//! recomputed), windows of W + 1 frames as bin tokens with TSMT's audio rows (MFCC + Δ over the
//! whole music, beat flags), the masked cross-entropy, and the teacher-forced validation loss at
//! s = 0. Adam with coupled L2, global-norm clipping and the step schedule come from the preset's
//! `[optim]` and `[schedule]`; `tsmt.lr_start_factor` scales the schedule.

use burn::tensor::{Device, Int, Tensor, TensorData};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::feature_cache;
use std::sync::Arc;

use qean_aistpp::windows::{Batch, Sequence, SequenceSet, WindowSpec};
use qean_audio::delta::TSMT_MFCC_DIM;
use qean_checkpoint::tsmt::heard_audio;
use qean_config::run::RunConfig;
use qean_config::tsmt::{RootMode, TsmtConfig, WindowMode};
use qean_config::AudioNorm;
use qean_io::error::{Error, Result};
use qean_models::tsmt::loss::{masked_cross_entropy, smoothed_cross_entropy};
use qean_models::tsmt::{pose_coords, Bins, Tsmt, TsmtInput};
use qean_motion::fk::FkRoot;
use qean_motion::motion::{Layout, Motion};

use crate::family::{Family, StepContext};
use qean_checkpoint::checkpoint::Checkpoint;

/// Columns of a TSMT music row in the window sets: 26 MFCC + Δ values, then the beat flag.
pub const AUDIO_COLS: usize = TSMT_MFCC_DIM + 1;

/// TSMT, as the run config's `[tsmt]` table says. Holds the bins once `prepare` has them.
#[derive(Debug, Clone, Default)]
pub struct TsmtFamily {
    bins: Option<Bins>,
}

/// The root-relative coordinates of a motion's frames (SPEC §11.2), from f64 forward kinematics.
pub fn motion_coords(motion: &Motion, root: RootMode) -> Vec<f64> {
    pose_coords(&motion.joints(FkRoot::Smpl), root)
}

/// Bins fitted on every frame of a split's motions (SPEC §11.2), one sequence at a time.
pub fn fit_bins(ds: &Dataset, split: Split, t: &TsmtConfig) -> Result<Bins> {
    let names = ds.split(split);
    if names.is_empty() {
        return Err(Error::at(
            &ds.root,
            format!("the {} split is empty: no bins to fit", split.name()),
        ));
    }
    let mut ranges = Vec::with_capacity(names.len());
    for name in &names {
        let path = ds.motion_path(name);
        let coords = motion_coords(&ds.read_motion(name)?, t.root_mode);
        // Keep each sequence's per-coordinate min and max as a two-frame summary.
        let fit = Bins::fit(&coords, t.coords(), 1, qean_config::tsmt::BinsMode::PerDim)
            .map_err(|m| Error::at(&path, m))?;
        ranges.push([fit.lo, fit.hi].concat());
    }
    Bins::fit_many(
        ranges.iter().map(Vec::as_slice),
        t.coords(),
        t.n_bins,
        t.bins_mode,
    )
    .map_err(Error::msg)
}

/// `tsmt.frame_step` > 1: every sequence's token rows and music rows (MFCC + Δ, beat) at every `step`-th
/// frame from frame 0 ([`qean_models::tsmt::coarse::Grid`]), so windows are drawn at the coarse rate.
/// With `offsets` > 1 (`tsmt.shift_aug`, training split) also from frames 1..offsets−1, each such grid a
/// sequence of its own (`NAME@offset`), so no frame of the data is thrown away.
pub fn coarsened(set: SequenceSet, step: usize, offsets: usize) -> SequenceSet {
    use qean_models::tsmt::coarse::Grid;
    use qean_models::tsmt::sample::TsmtAudio;
    let d = set.dim;
    let mut music: std::collections::HashMap<(*const Vec<f32>, usize), Arc<Vec<f32>>> =
        Default::default();
    let mut sequences = Vec::new();
    for seq in &set.sequences {
        for offset in 0..offsets.clamp(1, step) {
            let grid = Grid { step, offset };
            let (motion_frames, audio_frames) =
                (grid.count(seq.motion_frames), grid.count(seq.audio_frames));
            if offset > 0 && motion_frames.min(audio_frames) < set.spec.span() {
                continue;
            }
            let audio = music
                .entry((Arc::as_ptr(&seq.audio), offset))
                .or_insert_with(|| {
                    let rows = &seq.audio[..seq.audio_frames * AUDIO_COLS];
                    let full = TsmtAudio {
                        mfcc: rows
                            .chunks_exact(AUDIO_COLS)
                            .flat_map(|r| r[..TSMT_MFCC_DIM].iter().copied())
                            .collect(),
                        beats: rows
                            .chunks_exact(AUDIO_COLS)
                            .map(|r| r[TSMT_MFCC_DIM] as u8)
                            .collect(),
                        frames: seq.audio_frames,
                    };
                    let c = grid.audio(&full);
                    Arc::new(
                        c.mfcc
                            .chunks_exact(TSMT_MFCC_DIM)
                            .zip(&c.beats)
                            .flat_map(|(r, &b)| r.iter().copied().chain([f32::from(b)]))
                            .collect(),
                    )
                })
                .clone();
            sequences.push(Sequence {
                name: if offset == 0 {
                    seq.name.clone()
                } else {
                    format!("{}@{offset}", seq.name)
                },
                motion: grid.rows(&seq.motion[..seq.motion_frames * d], d),
                motion_frames,
                audio_frames,
                audio,
            });
        }
    }
    SequenceSet {
        sequences,
        visits: Vec::new(),
        ..set
    }
}

/// `tsmt.windows = "segments"` (the reference's training unit): every sequence cut into blocks of
/// W + 1 frames starting every W/2 frames (the last block that fits; the rest dropped), each block a
/// sequence of its own, so every epoch visits each block once at its only window start.
pub fn segmented(set: SequenceSet) -> SequenceSet {
    let span = set.spec.span();
    let hop = (set.spec.motion_len / 2).max(1);
    let (d, ad) = (set.dim, set.audio_dim);
    let mut sequences = Vec::new();
    for seq in &set.sequences {
        let mut s = 0;
        while s + span <= seq.frames() {
            sequences.push(Sequence {
                name: format!("{}@{s}", seq.name),
                motion: seq.motion[s * d..(s + span) * d].to_vec(),
                motion_frames: span,
                audio: Arc::new(seq.audio[s * ad..(s + span) * ad].to_vec()),
                audio_frames: span,
            });
            s += hop;
        }
    }
    tracing::info!(
        "tsmt.windows = segments: {} sequences cut into {} blocks of {span} frames every {hop}",
        set.sequences.len(),
        sequences.len()
    );
    SequenceSet {
        sequences,
        visits: Vec::new(),
        ..set
    }
}

/// The `[tsmt]` table of a TSMT run.
fn tsmt_of(config: &RunConfig) -> &TsmtConfig {
    config.tsmt_table()
}

/// A batch of token windows as the model's input and its targets: tokens [B, W, n], MFCC rows and
/// beats of frames s+1..s+W, targets [B, W, n].
pub fn tensors(batch: &Batch, device: &Device) -> (TsmtInput, Tensor<3, Int>) {
    let (b, sp, n) = (batch.len(), batch.spec, batch.dim);
    let w = sp.motion_len;
    let ints = |v: &[f32]| v.iter().map(|&x| x as i64).collect::<Vec<i64>>();
    let mut mfcc = Vec::with_capacity(b * w * TSMT_MFCC_DIM);
    let mut beat = Vec::with_capacity(b * w);
    for row in batch.audio.chunks_exact(sp.audio_len * AUDIO_COLS) {
        // Audio rows s+1..s+W: the frame each token predicts (SPEC §11.4).
        for r in row.chunks_exact(AUDIO_COLS).skip(1).take(w) {
            mfcc.extend_from_slice(&r[..TSMT_MFCC_DIM]);
            beat.push(r[TSMT_MFCC_DIM] as i64);
        }
    }
    let input = TsmtInput {
        tokens: Tensor::from_data(TensorData::new(ints(&batch.motion), [b, w, n]), device),
        mfcc: Tensor::from_data(TensorData::new(mfcc, [b, w, TSMT_MFCC_DIM]), device),
        beat: Tensor::from_data(TensorData::new(beat, [b, w]), device),
        lengths: vec![w; b],
    };
    let targets = Tensor::from_data(
        TensorData::new(ints(&batch.target), [b, sp.target_len, n]),
        device,
    );
    (input, targets)
}

/// Moves every token (bins held as f32; the padding class `n_bins` stays) by round(σ·z) bins, z ~ N(0, 1)
/// from a stream seeded by `seed`, clamped to the bins: inputs like the model's own imperfect samples, so it
/// learns to read through frame-to-frame noise instead of passing it on (ours; the paper trains on clean
/// tokens).
pub fn jitter_tokens(tokens: &mut [f32], sigma: f64, n_bins: usize, seed: u64) {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x7473_6d74_6e6f_6973);
    let top = (n_bins - 1) as f64;
    for k in tokens.iter_mut() {
        if *k as usize >= n_bins {
            continue;
        }
        // Box–Muller: one normal from two uniforms.
        let (u1, u2): (f64, f64) = (rng.random(), rng.random());
        let z = (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
        *k = (*k as f64 + (sigma * z).round()).clamp(0.0, top) as f32;
    }
}

/// Teacher-forced validation loss (SPEC §11.7 step 5): the s = 0 window of every sequence, no
/// dropout, the masked cross-entropy averaged over the windows.
pub fn validation_loss(model: &Tsmt, set: &SequenceSet, batch_size: usize, device: &Device) -> f64 {
    crate::family::mean_over_first_windows(set, batch_size, |chunk| {
        let (input, targets) = tensors(&chunk, device);
        let lengths = input.lengths.clone();
        masked_cross_entropy(model.forward(input), targets, &lengths)
    })
}

impl Family for TsmtFamily {
    type Model = Tsmt;
    type Inputs = (TsmtInput, Tensor<3, Int>);

    fn init(&self, config: &RunConfig, device: &Device) -> Result<Tsmt> {
        Ok(Tsmt::new(tsmt_of(config), device))
    }

    /// The bins: a resumed run's from its checkpoint, a config's own when it names them, else
    /// fitted on the training split; written into the run config either way.
    fn prepare(
        &mut self,
        config: &mut RunConfig,
        dataset: &Dataset,
        train: Split,
        resume: Option<&Checkpoint>,
    ) -> Result<()> {
        if config.recipe.audio_norm == AudioNorm::Standardize {
            return Err(Error::msg(
                "recipe.audio_norm = \"standardize\" is not a TSMT option (its MFCC + delta rows have no split \
                 statistics): use \"none\" (the paper's) or \"per_track\"",
            ));
        }
        let t = config
            .tsmt
            .as_mut()
            .ok_or_else(|| Error::msg("model.arch = \"tsmt\" needs a [tsmt] table"))?;
        if let Some(ck) = resume {
            let saved = ck.config.tsmt.as_ref().and_then(Bins::from_config);
            let saved = saved
                .ok_or_else(|| Error::at(&ck.dir, "the checkpoint's config has no TSMT bins"))?;
            t.bins_lo = saved.lo;
            t.bins_hi = saved.hi;
        } else if t.bins_lo.is_empty() {
            let bins = fit_bins(dataset, train, t)?;
            tracing::info!(
                "fitted {} bins per coordinate on the {} split ({:?})",
                t.n_bins,
                train.name(),
                t.bins_mode
            );
            t.bins_lo = bins.lo;
            t.bins_hi = bins.hi;
        }
        t.validate().map_err(Error::msg)?;
        self.bins = Bins::from_config(t);
        Ok(())
    }

    /// Windows of bin tokens (f32-held integers) and TSMT's audio rows.
    fn load_set(
        &self,
        dataset: &Dataset,
        split: Split,
        spec: WindowSpec,
        config: &RunConfig,
    ) -> Result<SequenceSet> {
        let t = tsmt_of(config);
        let bins = self
            .bins
            .as_ref()
            .expect("prepare fits or restores the bins before the data loads");
        qean_checkpoint::features::ensure_features(dataset, &dataset.split(split))?;
        let set = SequenceSet::load(dataset, split, Layout::L219, spec, |id| {
            feature_cache::load(dataset, id)
        })?;
        let segments = t.windows == WindowMode::Segments && split == config.data.train_split;
        let set = set.remap(
            t.coords(),
            AUDIO_COLS,
            |seq| {
                let motion = dataset.read_motion(&seq.name)?;
                let tokens = bins.encode(&motion_coords(&motion, t.root_mode));
                Ok(tokens.into_iter().map(f32::from).collect())
            },
            |features, frames| {
                let (rows, beats) = heard_audio(features, frames, &config.recipe);
                rows.chunks_exact(TSMT_MFCC_DIM)
                    .zip(beats)
                    .flat_map(|(r, b)| r.iter().copied().chain([f32::from(b)]))
                    .collect()
            },
        )?;
        let set = if t.frame_step > 1 {
            let offsets = if t.shift_aug && split == config.data.train_split {
                t.frame_step
            } else {
                1
            };
            coarsened(set, t.frame_step, offsets)
        } else {
            set
        };
        Ok(if segments { segmented(set) } else { set })
    }

    /// The drawn windows as tensors; with `tsmt.input_noise` each input token first moves by a rounded
    /// N(0, σ²) number of bins (the targets stay clean).
    fn inputs(
        &self,
        drawn: Batch,
        _model: &Tsmt,
        device: &Device,
        ctx: &StepContext,
    ) -> Self::Inputs {
        let t = tsmt_of(ctx.config);
        if t.input_noise > 0.0 {
            let mut noisy = drawn;
            jitter_tokens(&mut noisy.motion, t.input_noise, t.n_bins, ctx.rng_seed);
            return tensors(&noisy, device);
        }
        tensors(&drawn, device)
    }

    /// The paper's cross-entropy, or against targets spread over neighbouring bins (`tsmt.target_sigma`);
    /// validation stays the plain cross-entropy either way.
    fn loss(&self, model: &Tsmt, (input, targets): Self::Inputs, config: &RunConfig) -> Tensor<1> {
        let lengths = input.lengths.clone();
        let sigma = tsmt_of(config).target_sigma;
        smoothed_cross_entropy(model.forward(input), targets, &lengths, sigma)
    }

    fn validation_loss(
        &self,
        model: &Tsmt,
        set: &SequenceSet,
        config: &RunConfig,
        device: &Device,
    ) -> f64 {
        validation_loss(model, set, config.train.batch_size, device)
    }

    fn lr_factor(&self, config: &RunConfig) -> f64 {
        tsmt_of(config).lr_start_factor
    }

    /// The bins, as f64 (also in the checkpoint's config.toml).
    fn checkpoint_state(&self) -> Option<serde_json::Value> {
        let b = self.bins.as_ref()?;
        Some(serde_json::json!({
            "tsmt_bins": { "n_bins": b.n_bins, "lo": b.lo, "hi": b.hi }
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segments_are_half_overlapping_blocks_of_the_window_span() {
        let spec = WindowSpec {
            motion_len: 10,
            target_len: 10,
            target_shift: 1,
            audio_len: 11,
        };
        let frames = 40;
        let set = SequenceSet {
            layout: Layout::L219,
            dim: 2,
            audio_dim: 1,
            spec,
            sequences: vec![Sequence {
                name: "s".into(),
                motion: (0..frames * 2).map(|x| (x / 2) as f32).collect(),
                motion_frames: frames,
                audio: Arc::new((0..frames + 5).map(|x| x as f32).collect()),
                audio_frames: frames + 5,
            }],
            skipped: vec![],
            visits: vec![],
        };
        let seg = segmented(set.clone());
        // Starts 0, 5, ..., 25 (25 + 11 ≤ 40; 30 + 11 > 40).
        let starts: Vec<f32> = seg.sequences.iter().map(|s| s.motion[0]).collect();
        assert_eq!(starts, vec![0.0, 5.0, 10.0, 15.0, 20.0, 25.0]);
        for s in &seg.sequences {
            assert_eq!((s.frames(), spec.starts(s.frames())), (11, 1));
            assert_eq!(s.audio[0], s.motion[0]);
        }
    }

    #[test]
    fn a_coarse_set_keeps_every_third_frame_and_every_beat() {
        let frames = 30;
        let cols = AUDIO_COLS;
        let audio: Vec<f32> = (0..frames)
            .flat_map(|f| {
                (0..TSMT_MFCC_DIM)
                    .map(move |k| (f * 100 + k) as f32)
                    .chain([f32::from(u8::from(f % 7 == 0))])
            })
            .collect();
        let set = SequenceSet {
            layout: Layout::L219,
            dim: 2,
            audio_dim: cols,
            spec: WindowSpec {
                motion_len: 4,
                target_len: 4,
                target_shift: 1,
                audio_len: 5,
            },
            sequences: vec![Sequence {
                name: "s".into(),
                motion: (0..frames * 2).map(|x| (x / 2) as f32).collect(),
                motion_frames: frames,
                audio: Arc::new(audio),
                audio_frames: frames,
            }],
            skipped: vec![],
            visits: vec![],
        };
        let shifted = coarsened(set.clone(), 3, 3);
        let c = coarsened(set, 3, 1);
        assert_eq!(c.sequences.len(), 1);
        // `tsmt.shift_aug`: grids from frames 1 and 2 too, each its own sequence.
        let names: Vec<&str> = shifted.sequences.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(names, ["s", "s@1", "s@2"]);
        assert_eq!(shifted.sequences[0].motion, c.sequences[0].motion);
        let s2 = &shifted.sequences[2];
        assert_eq!((s2.motion_frames, s2.audio_frames), (10, 10));
        assert_eq!(&s2.motion[..6], &[2.0, 2.0, 5.0, 5.0, 8.0, 8.0]);
        assert_eq!(
            s2.audio[cols], 500.0,
            "coarse frame 1 of offset 2 is real frame 5"
        );
        let s = &c.sequences[0];
        assert_eq!((s.motion_frames, s.audio_frames), (10, 10));
        assert_eq!(&s.motion[..6], &[0.0, 0.0, 3.0, 3.0, 6.0, 6.0]);
        // Coarse frame 2 is real frame 6: its MFCC row, and the beat of frame 7 (within ±1 frame).
        assert_eq!(s.audio[2 * cols], 600.0);
        let beats: Vec<f32> = s
            .audio
            .chunks_exact(cols)
            .map(|r| r[TSMT_MFCC_DIM])
            .collect();
        assert_eq!(
            beats,
            vec![1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 1.0]
        );
    }

    #[test]
    fn input_noise_moves_tokens_within_the_bins_and_leaves_padding() {
        let n_bins = 300;
        let clean: Vec<f32> = (0..4000).map(|i| (i % 300) as f32).chain([300.0]).collect();
        let mut noisy = clean.clone();
        jitter_tokens(&mut noisy, 2.0, n_bins, 7);
        assert_eq!(*noisy.last().unwrap(), 300.0, "the padding class stays");
        assert!(noisy
            .iter()
            .all(|&k| k.fract() == 0.0 && (0.0..=300.0).contains(&k)));
        let moved: Vec<f64> = clean
            .iter()
            .zip(&noisy)
            .filter(|(c, _)| (10.0..290.0).contains(*c))
            .map(|(c, n)| (n - c) as f64)
            .collect();
        let m = moved.len() as f64;
        let mean = moved.iter().sum::<f64>() / m;
        let sd = (moved.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / m).sqrt();
        assert!(mean.abs() < 0.1 && (sd - 2.0).abs() < 0.15, "{mean} {sd}");
        let mut again = clean.clone();
        jitter_tokens(&mut again, 2.0, n_bins, 7);
        assert_eq!(again, noisy, "a function of the seed");
    }
}
