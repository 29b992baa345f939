//! The music-to-dance GPT as a trainer [`Family`] (SPEC §13.3.6, stage 2): every sequence tokenised once by the
//! frozen VQ-VAE of `gpt.vqvae_run`, cut into windows of n tokens with their music tokens, and the music step's
//! cross-entropy over B × n targets. Without text data every step is a music step; the T-Base then never
//! receives a gradient, so neither its weights nor its optimiser state move.

use std::sync::Arc;

use burn::tensor::{Device, Int, Tensor, TensorData};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::feature_cache;
use qean_aistpp::windows::{Batch, Sequence, SequenceSet, WindowSpec};
use qean_config::gpt::GptConfig;
use qean_config::run::RunConfig;
use qean_io::error::{Error, Result};
use qean_models::control::gpt::{music_token_dim, Gpt};
use qean_models::tsmt::loss::masked_cross_entropy;
use qean_models::vqvae::VqVae;
use qean_motion::motion::{Layout, Motion};
use qean_motion::pos72::POS72;
use rand::{Rng, SeedableRng};

use crate::checkpoint::Checkpoint;
use crate::family::{Family, StepContext};
use crate::vqvae::{motion_pos72, normalise, VqFamily};

/// Music feature columns.
const FEATURES: usize = 35;

/// The frozen VQ-VAE a GPT run predicts the tokens of.
pub struct FrozenVq {
    pub model: VqVae,
    pub checkpoint: Checkpoint,
}

impl FrozenVq {
    /// The newest checkpoint of `gpt.vqvae_run`, checked against the GPT's codes and rate.
    pub fn load(g: &GptConfig) -> Result<FrozenVq> {
        let run = g.vqvae_run.as_ref().ok_or_else(|| {
            Error::msg(
                "gpt.vqvae_run is not set: name the trained VQ-VAE run (--set gpt.vqvae_run=DIR)",
            )
        })?;
        let checkpoint = crate::checkpoint::resolve(run)
            .map_err(|e| Error::msg(format!("gpt.vqvae_run: {e}")))?;
        if !checkpoint.config.is_vqvae() {
            return Err(Error::at(
                &checkpoint.dir,
                format!(
                    "gpt.vqvae_run is not a VQ-VAE run (model.arch = {:?})",
                    checkpoint.config.model.arch
                ),
            ));
        }
        let vq = crate::vqvae::vq_of(&checkpoint.config);
        if vq.codes != g.codes || vq.rate() != g.rate {
            return Err(Error::at(
                &checkpoint.dir,
                format!(
                    "the VQ-VAE has {} codes at {} frames per token; this GPT is built for {} codes at {} (gpt.codes, gpt.rate)",
                    vq.codes,
                    vq.rate(),
                    g.codes,
                    g.rate
                ),
            ));
        }
        let model = crate::family::load_checkpoint_model(
            &VqFamily::default(),
            &checkpoint,
            &Device::flex(),
        )?;
        Ok(FrozenVq { model, checkpoint })
    }

    /// The tokens of a motion's first `frames` frames (a multiple of the rate).
    pub fn tokens(&self, motion: &Motion, frames: usize) -> Result<Vec<usize>> {
        let c = crate::vqvae::vq_of(&self.checkpoint.config);
        let mut rows = motion_pos72(motion, c);
        rows.truncate(frames * POS72);
        normalise(&mut rows, c);
        let x = Tensor::<3>::from_data(TensorData::new(rows, [1, frames, POS72]), &Device::flex());
        self.model.tokens(x).map_err(Error::msg)
    }
}

/// Music tokens a_i[35u + c] = A[rate·i + u, c] of the first `n` tokens of a feature matrix (frames × 35).
pub fn music_tokens(features: &[f32], n: usize, rate: usize) -> Vec<f32> {
    features[..n * rate * FEATURES].to_vec()
}

/// The GPT family: the frozen VQ-VAE once `prepare` has loaded it.
#[derive(Default)]
pub struct GptFamily {
    vq: Option<FrozenVq>,
}

/// A batch: input tokens [B, n], music tokens [B, n, 280], targets [B, n].
pub struct GptInputs {
    pub tokens: Tensor<2, Int>,
    pub music: Tensor<3>,
    pub targets: Tensor<2, Int>,
}

/// The `[gpt]` table of a GPT run.
pub fn gpt_of(config: &RunConfig) -> &GptConfig {
    config
        .gpt
        .as_ref()
        .expect("a GPT run config has a [gpt] table (RunConfig::from_table fills it)")
}

/// Windows of n input tokens (rows u..u+n−1 of [Start, c_0, …]), targets one row later, music rows
/// u+1+δ.. (row i ≥ 1 holds a_{i−1}).
pub fn window_spec(g: &GptConfig) -> WindowSpec {
    WindowSpec {
        motion_len: g.window,
        target_len: g.window,
        target_shift: 1,
        audio_len: g.window + 1 + g.music_lookahead,
    }
}

/// A batch as tensors; `pkeep` < 1 replaces each input token by a uniform random code with
/// probability 1 − pkeep (seeded).
pub fn tensors(batch: &Batch, g: &GptConfig, pkeep: f64, seed: u64, device: &Device) -> GptInputs {
    let (b, n) = (batch.len(), g.window);
    let w = music_token_dim(g);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x6770_7400);
    let tokens: Vec<i64> = batch
        .motion
        .iter()
        .map(|&t| {
            if pkeep < 1.0 && t < g.codes as f32 && !rng.random_bool(pkeep) {
                rng.random_range(0..g.codes as i64)
            } else {
                t as i64
            }
        })
        .collect();
    let targets: Vec<i64> = batch.target.iter().map(|&t| t as i64).collect();
    let span = batch.spec.audio_len * w;
    let mut music = Vec::with_capacity(b * n * w);
    for row in batch.audio.chunks_exact(span) {
        let from = (1 + g.music_lookahead) * w;
        music.extend_from_slice(&row[from..from + n * w]);
    }
    GptInputs {
        tokens: Tensor::from_data(TensorData::new(tokens, [b, n]), device),
        music: Tensor::from_data(TensorData::new(music, [b, n, w]), device),
        targets: Tensor::from_data(TensorData::new(targets, [b, n]), device),
    }
}

/// Mean cross-entropy over every target.
pub fn cross_entropy(logits: Tensor<3>, targets: Tensor<2, Int>) -> Tensor<1> {
    let [b, n, k] = logits.dims();
    masked_cross_entropy(
        logits.reshape([b, n, 1, k]),
        targets.reshape([b, n, 1]),
        &vec![n; b],
    )
}

impl GptFamily {
    /// The frozen VQ-VAE, once `prepare` has loaded it.
    pub fn frozen_vq(&self) -> Option<&FrozenVq> {
        self.vq.as_ref()
    }
}

impl Family for GptFamily {
    type Model = Gpt;
    type Inputs = GptInputs;

    fn init(&self, config: &RunConfig, device: &Device) -> Gpt {
        Gpt::new(gpt_of(config), device)
    }

    /// Loads the frozen VQ-VAE; a resumed run must find the same one (its weights hash).
    fn prepare(
        &mut self,
        config: &mut RunConfig,
        _dataset: &Dataset,
        _train: Split,
        resume: Option<&Checkpoint>,
    ) -> Result<()> {
        let g = config
            .gpt
            .as_ref()
            .ok_or_else(|| Error::msg("model.arch = \"gpt\" needs a [gpt] table"))?;
        g.validate().map_err(Error::msg)?;
        let vq = FrozenVq::load(g)?;
        if let Some(ck) = resume {
            let saved = crate::family::read_family_state(ck)?;
            let hash = saved.as_ref().and_then(|s| s["vqvae_params_hash"].as_str());
            if let Some(h) = hash.filter(|h| *h != vq.checkpoint.state.params_hash) {
                return Err(Error::at(
                    &vq.checkpoint.dir,
                    format!(
                        "not the VQ-VAE this GPT was trained on (weights hash {} there, {h} when training began)",
                        &vq.checkpoint.state.params_hash
                    ),
                ));
            }
        }
        tracing::info!(
            "tokens from the frozen VQ-VAE {} (step {})",
            vq.checkpoint.dir.display(),
            vq.checkpoint.state.step
        );
        self.vq = Some(vq);
        Ok(())
    }

    fn draw_spec(&self, config: &RunConfig) -> WindowSpec {
        window_spec(gpt_of(config))
    }

    /// Every sequence as token rows [Start, c_0, …] (1 value each) with music rows [0, a_0, …].
    fn load_set(
        &self,
        dataset: &Dataset,
        split: Split,
        spec: WindowSpec,
        config: &RunConfig,
    ) -> Result<SequenceSet> {
        let g = gpt_of(config);
        let vq = self.vq.as_ref().expect("prepare loads the VQ-VAE");
        crate::data::ensure_features(dataset, &dataset.split(split))?;
        let span = spec.span() * g.rate;
        let frame_spec = WindowSpec {
            motion_len: span,
            target_len: span,
            target_shift: 0,
            audio_len: span,
        };
        let frames = SequenceSet::load(dataset, split, Layout::L219, frame_spec, |id| {
            feature_cache::load(dataset, id)
        })?;
        let w = music_token_dim(g);
        let mut sequences = Vec::new();
        let mut skipped = frames.skipped.clone();
        for seq in &frames.sequences {
            let n = seq.motion_frames.min(seq.audio_frames) / g.rate;
            if n + 1 < spec.span() {
                skipped.push(seq.name.clone());
                continue;
            }
            let motion = Motion::read_pkl(&dataset.motion_path(&seq.name))?;
            let tokens = vq
                .tokens(&motion, n * g.rate)
                .map_err(|e| Error::msg(format!("{}: {e}", seq.name)))?;
            let mut rows = vec![g.codes as f32];
            rows.extend(tokens.iter().map(|&t| t as f32));
            let mut audio = vec![0f32; w];
            audio.extend(music_tokens(&seq.audio, n, g.rate));
            sequences.push(Sequence {
                name: seq.name.clone(),
                motion: rows,
                motion_frames: n + 1,
                audio: Arc::new(audio),
                audio_frames: n + 1,
            });
        }
        if sequences.is_empty() {
            return Err(Error::at(
                &dataset.root,
                format!(
                    "no {} sequence is long enough for a window of {} tokens ({} frames)",
                    split.name(),
                    g.window,
                    (spec.span() - 1) * g.rate
                ),
            ));
        }
        Ok(SequenceSet {
            layout: Layout::L219,
            dim: 1,
            audio_dim: w,
            spec,
            sequences,
            skipped,
        })
    }

    fn inputs(&self, drawn: Batch, _model: &Gpt, device: &Device, ctx: &StepContext) -> GptInputs {
        let g = gpt_of(ctx.config);
        tensors(&drawn, g, g.m_pkeep, ctx.rng_seed, device)
    }

    fn loss(&self, model: &Gpt, inputs: GptInputs, _config: &RunConfig) -> Tensor<1> {
        cross_entropy(
            model.music_logits(inputs.tokens, inputs.music),
            inputs.targets,
        )
    }

    /// Teacher-forced cross-entropy of every sequence's first window.
    fn validation_loss(
        &self,
        model: &Gpt,
        set: &SequenceSet,
        config: &RunConfig,
        device: &Device,
    ) -> f64 {
        let g = gpt_of(config);
        crate::family::mean_over_first_windows(set, config.train.batch_size, |batch| {
            let x = tensors(&batch, g, 1.0, 0, device);
            cross_entropy(model.music_logits(x.tokens, x.music), x.targets)
        })
    }

    /// The frozen VQ-VAE's checkpoint and weights hash (a resume checks it).
    fn checkpoint_state(&self) -> Option<serde_json::Value> {
        let vq = self.vq.as_ref()?;
        Some(serde_json::json!({
            "vqvae_checkpoint": vq.checkpoint.dir,
            "vqvae_params_hash": vq.checkpoint.state.params_hash,
        }))
    }
}
