//! The keyframe-control stage as a trainer [`Family`] (SPEC §13.6 "Training (stage 3b)"): the GPT of
//! `keyframe.gpt_run` (and its VQ-VAE) frozen, and the keyframe module (attention copies and the Mask row)
//! trained on windows of n unshifted tokens: around 1 or 2 centres p the positions [p − k, p + k] \ {p}
//! hold Mask, the centre keeps its token or (with probability `static_prob`) takes its static-clip token,
//! and the cross-entropy counts the masked positions only.

use std::collections::{HashMap, HashSet};

use burn::module::{Module, ParamId};
use burn::tensor::activation::log_softmax;
use burn::tensor::{Device, Int, Tensor, TensorData};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::windows::{Batch, SequenceSet, WindowSpec};
use qean_config::gpt::GptConfig;
use qean_config::keyframe::{KeyframeConfig, KfTrainMask};
use qean_config::run::RunConfig;
use qean_io::error::{Error, Result};
use qean_models::control::keyframe::{mask_logits, KeyframeGpt, KeyframeModule};
use qean_motion::FkRoot;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::family::{param_ids, Family, StepContext};
use crate::gpt::{gpt_of, tensors, FrozenGpt, GptFamily};
use qean_checkpoint::checkpoint::Checkpoint;

/// The `[keyframe]` table of a keyframe-control run.
pub fn keyframe_of(config: &RunConfig) -> &KeyframeConfig {
    config.keyframe_table()
}

/// The keyframe family: the GPT family's token windows, the frozen GPT, and the static-clip tokens of the
/// training split.
#[derive(Default)]
pub struct KeyframeFamily {
    base: GptFamily,
    gpt: Option<FrozenGpt>,
    /// Per training sequence (by its window name), the static-clip token of every token p: the pose of
    /// frame d·p + d/2 held still.
    statics: HashMap<String, Vec<usize>>,
}

/// A batch: mask-mode input tokens [B, n] (Mask = K + 1 where masked), music tokens [B, n, 280], the true
/// tokens [B, n] and the loss weights [B, n] (1 at masked positions).
#[derive(Clone)]
pub struct KeyframeInputs {
    pub tokens: Tensor<2, Int>,
    pub music: Tensor<3>,
    pub targets: Tensor<2, Int>,
    pub weights: Tensor<2>,
}

/// One row's training mask (§13.6 `kf_train_mask`): 1 to `max_centres` centres uniform over the window's
/// `n` positions, each masking [p − k, p + k] \ {p}; `mixed` masks each other position with a probability
/// drawn from U(0.15, 0.5). Returns (masked, centres), a centre never masked.
pub fn train_mask(n: usize, c: &KeyframeConfig, rng: &mut impl Rng) -> (Vec<bool>, Vec<usize>) {
    let count = rng.random_range(1..=c.max_centres);
    let centres: Vec<usize> = (0..count).map(|_| rng.random_range(0..n)).collect();
    let mut masked = vec![false; n];
    for &p in &centres {
        for m in masked
            .iter_mut()
            .take((p + c.radius + 1).min(n))
            .skip(p.saturating_sub(c.radius))
        {
            *m = true;
        }
    }
    if c.train_mask == KfTrainMask::Mixed {
        let ratio = rng.random_range(0.15..0.5);
        for m in masked.iter_mut() {
            if rng.random_bool(ratio) {
                *m = true;
            }
        }
    }
    for &p in &centres {
        masked[p] = false;
    }
    (masked, centres)
}

impl KeyframeFamily {
    /// Mask-mode inputs of a batch: its true tokens, masked per row by [`train_mask`] from `seed`; a
    /// centre takes its static-clip token with probability `static_prob` when the sequence has them.
    fn masked(
        &self,
        batch: &Batch,
        g: &GptConfig,
        c: &KeyframeConfig,
        seed: u64,
        device: &Device,
    ) -> KeyframeInputs {
        let n = g.window;
        let x = tensors(batch, g, 1.0, seed, device);
        let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6b65_7966);
        let mut tokens = Vec::with_capacity(batch.len() * n);
        let mut weights = Vec::with_capacity(batch.len() * n);
        for (row, truth) in batch.target.chunks_exact(n).enumerate() {
            let (masked, centres) = train_mask(n, c, &mut rng);
            let mut ids: Vec<i64> = truth.iter().map(|&t| t as i64).collect();
            for &p in &centres {
                if rng.random_bool(c.static_prob) {
                    // Target row u + 1 + p holds c_{u+p}: its static token is entry u + p.
                    let at = batch.starts[row] + p;
                    if let Some(&t) = self.statics.get(&batch.names[row]).and_then(|s| s.get(at)) {
                        ids[p] = t as i64;
                    }
                }
            }
            for (j, &m) in masked.iter().enumerate() {
                if m {
                    ids[j] = g.codes as i64 + 1;
                }
            }
            tokens.extend(ids);
            weights.extend(masked.iter().map(|&m| if m { 1f32 } else { 0.0 }));
        }
        let b = batch.len();
        KeyframeInputs {
            tokens: Tensor::from_data(TensorData::new(tokens, [b, n]), device),
            music: x.music,
            targets: x.targets,
            weights: Tensor::from_data(TensorData::new(weights, [b, n]), device),
        }
    }

    /// Static-clip tokens of every token of every training sequence (as the GPT family names its windows:
    /// `NAME`, or `NAME@o` for the frame offsets of `gpt.token_shift_aug`).
    fn static_tokens(
        &self,
        config: &RunConfig,
        dataset: &Dataset,
        train: Split,
    ) -> Result<HashMap<String, Vec<usize>>> {
        let g = gpt_of(config);
        let vq = self
            .base
            .frozen_vq()
            .expect("the GPT family loaded its VQ-VAE");
        let offsets = if g.token_shift_aug { g.rate } else { 1 };
        let mut out = HashMap::new();
        for name in dataset.split(train) {
            let motion = dataset.read_motion(&name)?;
            let joints = motion.joints(FkRoot::Smpl);
            for offset in 0..offsets {
                let n = motion.frames.saturating_sub(offset) / g.rate;
                let poses: Vec<&[[f64; 3]]> = (0..n)
                    .map(|p| {
                        let f = offset + p * g.rate + g.rate / 2;
                        &joints[f * 24..(f + 1) * 24]
                    })
                    .collect();
                let tokens = vq
                    .static_tokens(&poses)
                    .map_err(|e| Error::msg(format!("{name}: static-clip tokens: {e}")))?;
                let key = if offset == 0 {
                    name.clone()
                } else {
                    format!("{name}@{offset}")
                };
                out.insert(key, tokens);
            }
        }
        Ok(out)
    }
}

/// Cross-entropy over the positions of weight 1: −Σ w log p(target) / Σ w.
pub fn masked_position_loss(
    logits: Tensor<3>,
    targets: Tensor<2, Int>,
    weights: Tensor<2>,
) -> Tensor<1> {
    let [b, n, _] = logits.dims();
    let picked = log_softmax(logits, 2)
        .gather(2, targets.reshape([b, n, 1]))
        .reshape([b, n]);
    let count = weights.clone().sum().clamp_min(1.0);
    (picked * weights).sum().neg() / count
}

/// The masked cross-entropy of a batch through the GPT in mask mode with the keyframe module.
fn batch_loss(model: &KeyframeGpt, x: KeyframeInputs) -> Tensor<1> {
    let logits = mask_logits(&model.gpt, &model.keyframe, x.tokens, x.music);
    masked_position_loss(logits, x.targets, x.weights)
}

impl Family for KeyframeFamily {
    type Model = KeyframeGpt;
    type Inputs = KeyframeInputs;

    /// The GPT from `keyframe.gpt_run` (frozen: no gradients) and the module copied from it.
    fn init(&self, config: &RunConfig, device: &Device) -> Result<KeyframeGpt> {
        let weights = keyframe_of(config).weights;
        let mut model = KeyframeGpt::new(gpt_of(config), weights, device);
        if let Some(frozen) = &self.gpt {
            let gpt = frozen.load(device)?;
            model.keyframe = KeyframeModule::of(&gpt, weights);
            model.gpt = gpt.no_grad();
        }
        Ok(model)
    }

    /// Resolves the frozen GPT (its `[gpt]` sizes must equal this config's), takes its VQ-VAE, tokenises
    /// the training split's static clips; a resumed run must find the same GPT (its weights hash).
    fn prepare(
        &mut self,
        config: &mut RunConfig,
        dataset: &Dataset,
        train: Split,
        resume: Option<&Checkpoint>,
    ) -> Result<()> {
        let c = keyframe_of(config).clone();
        let frozen = FrozenGpt::resolve(c.gpt_run.as_deref(), "keyframe", gpt_of(config))?;
        frozen.adopt(config)?;
        self.base.prepare(config, dataset, train, resume)?;
        frozen.confirm(resume, "keyframe")?;
        self.gpt = Some(frozen);
        self.statics = self.static_tokens(config, dataset, train)?;
        Ok(())
    }

    fn draw_spec(&self, config: &RunConfig) -> WindowSpec {
        self.base.draw_spec(config)
    }

    fn load_set(
        &self,
        dataset: &Dataset,
        split: Split,
        spec: WindowSpec,
        config: &RunConfig,
    ) -> Result<SequenceSet> {
        self.base.load_set(dataset, split, spec, config)
    }

    fn inputs(
        &self,
        drawn: Batch,
        _model: &KeyframeGpt,
        device: &Device,
        ctx: &StepContext,
    ) -> KeyframeInputs {
        self.masked(
            &drawn,
            gpt_of(ctx.config),
            keyframe_of(ctx.config),
            ctx.rng_seed,
            device,
        )
    }

    fn loss(&self, model: &KeyframeGpt, x: KeyframeInputs, _config: &RunConfig) -> Tensor<1> {
        batch_loss(model, x)
    }

    /// One optimiser over the keyframe module alone (the GPT stays as it was trained).
    fn param_groups(&self, model: &KeyframeGpt) -> Vec<HashSet<ParamId>> {
        vec![param_ids(&model.keyframe)]
    }

    fn group_loss(
        &self,
        model: &KeyframeGpt,
        x: &KeyframeInputs,
        _group: usize,
        _config: &RunConfig,
    ) -> Tensor<1> {
        batch_loss(model, x.clone())
    }

    /// The masked cross-entropy of every sequence's first window, masks from seed 0.
    fn validation_loss(
        &self,
        model: &KeyframeGpt,
        set: &SequenceSet,
        config: &RunConfig,
        device: &Device,
    ) -> f64 {
        let (g, c) = (gpt_of(config), keyframe_of(config));
        crate::family::mean_over_first_windows(set, config.train.batch_size, |batch| {
            batch_loss(model, self.masked(&batch, g, c, 0, device))
        })
    }

    /// The frozen GPT's and VQ-VAE's checkpoints and weights hashes (a resume checks the GPT's).
    fn checkpoint_state(&self) -> Option<serde_json::Value> {
        self.gpt.as_ref()?.stage_state(self.base.checkpoint_state())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Centres are never masked, their ±k spans are, and nothing else (`centres`); `mixed` masks more.
    #[test]
    fn training_masks_span_the_centres() {
        let c = KeyframeConfig::default();
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut sizes = HashSet::new();
        for _ in 0..200 {
            let (masked, centres) = train_mask(32, &c, &mut rng);
            assert!((1..=2).contains(&centres.len()));
            sizes.insert(centres.len());
            for (j, &m) in masked.iter().enumerate() {
                let near = centres.iter().any(|&p| p.abs_diff(j) <= 6);
                let centre = centres.contains(&j);
                assert_eq!(m, near && !centre, "position {j}, centres {centres:?}");
            }
        }
        assert_eq!(sizes.len(), 2, "1 and 2 centres both drawn");
        let mixed = KeyframeConfig {
            train_mask: KfTrainMask::Mixed,
            max_centres: 1,
            ..c
        };
        let more: usize = (0..200)
            .map(|_| {
                train_mask(32, &mixed, &mut rng)
                    .0
                    .iter()
                    .filter(|&&m| m)
                    .count()
            })
            .sum();
        assert!(more as f64 / 200.0 > 13.0, "{more}");
    }

    /// The loss counts weighted positions only: a wrong logit at an unweighted position changes nothing.
    #[test]
    fn the_loss_counts_masked_positions_only() {
        let device = Device::flex();
        let logits = |bad: f32| {
            Tensor::<3>::from_data(
                TensorData::new(vec![2.0, 0.0, 0.0, bad, 0.0, 1.0], [1, 2, 3]),
                &device,
            )
        };
        let targets = Tensor::<2, Int>::from_data(TensorData::new(vec![0i64, 2], [1, 2]), &device);
        let w = Tensor::<2>::from_data(TensorData::new(vec![1f32, 0.0], [1, 2]), &device);
        let a: f32 = masked_position_loss(logits(0.0), targets.clone(), w.clone()).into_scalar();
        let b: f32 = masked_position_loss(logits(9.0), targets, w).into_scalar();
        assert_eq!(a, b);
        let want = -(2f32.exp() / (2f32.exp() + 2.0)).ln();
        assert!((a - want).abs() < 1e-6, "{a} {want}");
    }
}
