//! FACT and QEAN as a trainer [`Family`]: windows of the model's motion layout and the 35-D music
//! features, the recipe's input changes (noise, music shift, rollout lead frames), the L2 loss on the first
//! 20 output tokens (SPEC §5.3) plus the recipe's difference terms and QRA's penalty, and the teacher-forced
//! validation loss (SPEC §5.6).

use burn::tensor::{Device, Tensor, TensorData};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::windows::{Batch, SequenceSet, WindowSpec, AUDIO_DIM};
use qean_config::recipe::Predict;
use qean_io::error::{Error, Result};
use qean_models::loss::{difference_loss, motion_loss};
use qean_models::DanceModel;

use crate::family::{Family, StepContext};
use qean_checkpoint::checkpoint::Checkpoint;
use qean_config::run::RunConfig;

/// FACT or QEAN, as the run config's `[model]` table says.
#[derive(Debug, Clone, Copy, Default)]
pub struct FactQean;

/// Weights of the loss terms beyond SPEC §5.3's L2 (`[recipe]`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LossWeights {
    pub velocity: f64,
    pub accel: f64,
}

impl LossWeights {
    pub fn of(config: &RunConfig) -> Self {
        LossWeights {
            velocity: config.recipe.velocity_loss,
            accel: config.recipe.accel_loss,
        }
    }
}

/// The loss of one batch: forward with the QRA penalty, L2 on the first output tokens (SPEC §5.3), the
/// recipe's velocity and acceleration terms, the penalty.
pub fn batch_loss(
    model: &DanceModel,
    (motion, audio, target): (Tensor<3>, Tensor<3>, Tensor<3>),
    weights: LossWeights,
) -> Tensor<1> {
    let out = model.forward_with_penalty(motion, audio);
    let mut loss = motion_loss(out.prediction.clone(), target.clone());
    if weights.velocity > 0.0 {
        loss = loss
            + difference_loss(out.prediction.clone(), target.clone(), 1)
                .mul_scalar(weights.velocity);
    }
    if weights.accel > 0.0 {
        loss = loss + difference_loss(out.prediction, target, 2).mul_scalar(weights.accel);
    }
    if let Some(p) = out.penalty {
        loss = loss + p;
    }
    loss
}

/// One optimiser update of FACT or QEAN on one batch (benchmarks; the trainer goes through [`Family`]).
pub fn update(
    model: DanceModel,
    optim: &mut burn::optim::ModuleOptimizer,
    inputs: (Tensor<3>, Tensor<3>, Tensor<3>),
    weights: LossWeights,
    lr: f64,
    clip: f64,
) -> (DanceModel, f64) {
    let loss = batch_loss(&model, inputs, weights);
    crate::trainer::apply_update(model, optim, loss, lr, clip)
}

/// Model inputs and the training target of a batch: the future frames, or (`predict =
/// "offset"`) the future frames minus each window's last input frame.
pub fn tensors(
    batch: &Batch,
    device: &Device,
    predict: Predict,
) -> (Tensor<3>, Tensor<3>, Tensor<3>) {
    let b = batch.len();
    let sp = batch.spec;
    let d = batch.dim;
    let mut target = batch.target.clone();
    if predict == Predict::Offset {
        for i in 0..b {
            let last = &batch.motion[(i * sp.motion_len + sp.motion_len - 1) * d..][..d];
            for row in
                target[i * sp.target_len * d..(i + 1) * sp.target_len * d].chunks_exact_mut(d)
            {
                for (x, l) in row.iter_mut().zip(last) {
                    *x -= l;
                }
            }
        }
    }
    (
        Tensor::from_data(
            TensorData::new(batch.motion.clone(), [b, sp.motion_len, d]),
            device,
        ),
        Tensor::from_data(
            TensorData::new(batch.audio.clone(), [b, sp.audio_len, AUDIO_DIM]),
            device,
        ),
        Tensor::from_data(TensorData::new(target, [b, sp.target_len, d]), device),
    )
}

/// Teacher-forced validation loss (SPEC §5.6): the s = 0 window of every sequence of the split,
/// no dropout, the mean squared error of the predicted poses over all of them.
pub fn validation_loss(
    model: &DanceModel,
    set: &SequenceSet,
    batch_size: usize,
    device: &Device,
    predict: Predict,
) -> f64 {
    crate::family::mean_over_first_windows(set, batch_size, |chunk| {
        let (m, a, t) = tensors(&chunk, device, predict);
        motion_loss(model.forward(m, a), t)
    })
}

impl Family for FactQean {
    type Model = DanceModel;
    type Inputs = (Tensor<3>, Tensor<3>, Tensor<3>);

    fn init(&self, config: &RunConfig, device: &Device) -> Result<DanceModel> {
        DanceModel::new(&config.model, device).map_err(|e| Error::msg(e.to_string()))
    }

    /// The music statistics of `audio_norm = "standardize"`: a resumed run keeps those its model was
    /// trained with; a fresh one computes them on the training split.
    fn prepare(
        &mut self,
        config: &mut RunConfig,
        dataset: &Dataset,
        train: Split,
        resume: Option<&Checkpoint>,
    ) -> Result<()> {
        if let Some(ck) = resume.filter(|_| config.recipe.needs_audio_stats()) {
            config.recipe.audio_mean = ck.config.recipe.audio_mean.clone();
            config.recipe.audio_std = ck.config.recipe.audio_std.clone();
        }
        if config.recipe.needs_audio_stats() {
            let (mean, std) = crate::data::audio_stats(dataset, train)?;
            config.recipe.audio_mean = mean;
            config.recipe.audio_std = std;
        }
        Ok(())
    }

    fn draw_spec(&self, config: &RunConfig) -> WindowSpec {
        crate::recipe::draw_spec(config)
    }

    fn inputs(
        &self,
        drawn: Batch,
        model: &DanceModel,
        device: &Device,
        ctx: &StepContext,
    ) -> Self::Inputs {
        let batch = crate::recipe::model_inputs(
            drawn,
            ctx.config,
            model,
            ctx.plain,
            ctx.rng_seed,
            ctx.step,
        );
        tensors(&batch, device, ctx.config.recipe.predict)
    }

    fn loss(&self, model: &DanceModel, inputs: Self::Inputs, config: &RunConfig) -> Tensor<1> {
        batch_loss(model, inputs, LossWeights::of(config))
    }

    fn validation_loss(
        &self,
        model: &DanceModel,
        set: &SequenceSet,
        config: &RunConfig,
        device: &Device,
    ) -> f64 {
        validation_loss(
            model,
            set,
            config.train.batch_size,
            device,
            config.recipe.predict,
        )
    }
}
