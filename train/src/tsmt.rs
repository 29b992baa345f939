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
use qean_audio::delta::{tsmt_audio, TSMT_MFCC_DIM};
use qean_config::run::RunConfig;
use qean_config::tsmt::{RootMode, TsmtConfig, WindowMode};
use qean_io::error::{Error, Result};
use qean_models::tsmt::loss::masked_cross_entropy;
use qean_models::tsmt::{pose_coords, Bins, Tsmt, TsmtInput};
use qean_motion::fk::FkRoot;
use qean_motion::motion::{Layout, Motion};

use crate::checkpoint::Checkpoint;
use crate::family::{Family, StepContext};

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
        let coords = motion_coords(&Motion::read_pkl(&path)?, t.root_mode);
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
    SequenceSet { sequences, ..set }
}

/// The `[tsmt]` table of a TSMT run.
fn tsmt_of(config: &RunConfig) -> &TsmtConfig {
    config
        .tsmt
        .as_ref()
        .expect("a TSMT run config has a [tsmt] table (RunConfig::from_table fills it)")
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

    fn init(&self, config: &RunConfig, device: &Device) -> Tsmt {
        Tsmt::new(tsmt_of(config), device)
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
        crate::data::ensure_features(dataset, &dataset.split(split))?;
        let set = SequenceSet::load(dataset, split, Layout::L219, spec, |id| {
            feature_cache::load(dataset, id)
        })?;
        let segments = t.windows == WindowMode::Segments && split == config.data.train_split;
        let set = set.remap(
            t.coords(),
            AUDIO_COLS,
            |seq| {
                let motion = Motion::read_pkl(&dataset.motion_path(&seq.name))?;
                let tokens = bins.encode(&motion_coords(&motion, t.root_mode));
                Ok(tokens.into_iter().map(f32::from).collect())
            },
            |features, frames| {
                let (rows, beats) = tsmt_audio(features, frames);
                rows.chunks_exact(TSMT_MFCC_DIM)
                    .zip(beats)
                    .flat_map(|(r, b)| r.iter().copied().chain([f32::from(b)]))
                    .collect()
            },
        )?;
        Ok(if segments { segmented(set) } else { set })
    }

    fn inputs(
        &self,
        drawn: Batch,
        _model: &Tsmt,
        device: &Device,
        _ctx: &StepContext,
    ) -> Self::Inputs {
        tensors(&drawn, device)
    }

    fn loss(&self, model: &Tsmt, (input, targets): Self::Inputs, _config: &RunConfig) -> Tensor<1> {
        let lengths = input.lengths.clone();
        masked_cross_entropy(model.forward(input), targets, &lengths)
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
        };
        let seg = segmented(set);
        // Starts 0, 5, ..., 25 (25 + 11 ≤ 40; 30 + 11 > 40).
        let starts: Vec<f32> = seg.sequences.iter().map(|s| s.motion[0]).collect();
        assert_eq!(starts, vec![0.0, 5.0, 10.0, 15.0, 20.0, 25.0]);
        for s in &seg.sequences {
            assert_eq!((s.frames(), spec.starts(s.frames())), (11, 1));
            assert_eq!(s.audio[0], s.motion[0]);
        }
    }
}
