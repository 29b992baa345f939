//! What a model family brings to the trainer. The loop (`trainer.rs`), the LR schedule, Adam, atomic
//! checkpoints, exact resume, the NaN stop, sweeps, logs and plots are the same for every family; a family
//! says what its model is, how a drawn batch of windows becomes its inputs, its loss and validation loss,
//! and what extra state its checkpoints carry. FACT and QEAN are one family ([`crate::fact_qean`]).
//!
//! The batch source is shared: windows of the dataset's sequences ([`SequenceSet`], drawn by the
//! resumable `WindowSampler`). A family that needs another representation (joint coordinates, tokens)
//! builds it from the windows in [`Family::inputs`].

use std::collections::HashSet;

use burn::module::{Module, ModuleVisitor, Param, ParamId};
use burn::tensor::{Device, Tensor};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::windows::{Batch, SequenceSet, WindowSpec};
use qean_io::error::Result;

use qean_checkpoint::checkpoint::Checkpoint;
use qean_config::run::RunConfig;

/// The mean of a batch loss over every sequence's first window, in batches of `batch_size` (weighted by
/// batch size): the validation loss most families report.
pub fn mean_over_first_windows(
    set: &SequenceSet,
    batch_size: usize,
    mut loss: impl FnMut(Batch) -> Tensor<1>,
) -> f64 {
    let all = set.first_windows();
    let n = all.len();
    let (mut sum, mut start) = (0.0, 0);
    while start < n {
        let end = (start + batch_size.max(1)).min(n);
        sum += loss(all.slice(start, end)).into_scalar::<f32>() as f64 * (end - start) as f64;
        start = end;
    }
    sum / n.max(1) as f64
}

/// The ids of a module's float parameters (for [`Family::param_groups`]).
pub fn param_ids<M: Module>(module: &M) -> HashSet<ParamId> {
    struct Ids(HashSet<ParamId>);
    impl ModuleVisitor for Ids {
        fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
            self.0.insert(param.id);
        }
    }
    let mut ids = Ids(HashSet::new());
    module.visit(&mut ids);
    ids.0
}

/// What one update knows besides the batch.
pub struct StepContext<'a> {
    pub config: &'a RunConfig,
    /// The plain (non-autodiff) device, for rollouts that must not be tracked.
    pub plain: &'a Device,
    /// The seed of this update's randomness (dropout masks, input noise).
    pub rng_seed: u64,
    /// Updates applied so far.
    pub step: u64,
}

/// A model family the trainer can train.
pub trait Family {
    /// The Burn module trained (also what checkpoints store and samplers load).
    type Model: Module;
    /// A batch as the model takes it (tensors on the autodiff device).
    type Inputs;

    /// A fresh model on `device` (the trainer seeds the device first).
    fn init(&self, config: &RunConfig, device: &Device) -> Result<Self::Model>;

    /// Before the data loads: fill config values the family derives from the training split, taking
    /// them from `resume` when continuing (a resumed run never recomputes them), and restore the
    /// family's own state from the checkpoint ([`read_family_state`]). Default: nothing to do.
    fn prepare(
        &mut self,
        _config: &mut RunConfig,
        _dataset: &Dataset,
        _train: Split,
        _resume: Option<&Checkpoint>,
    ) -> Result<()> {
        Ok(())
    }

    /// The windows a training draw takes (may be longer than the model's, e.g. for rollouts).
    fn draw_spec(&self, config: &RunConfig) -> WindowSpec {
        config.window_spec()
    }

    /// The sequences of one split, cut to `spec`'s windows.
    fn load_set(
        &self,
        dataset: &Dataset,
        split: Split,
        spec: WindowSpec,
        config: &RunConfig,
    ) -> Result<SequenceSet> {
        crate::data::load_split(dataset, split, config.layout(), spec, &config.recipe)
    }

    /// A drawn batch as the model's inputs on `device` (the autodiff device).
    fn inputs(
        &self,
        drawn: Batch,
        model: &Self::Model,
        device: &Device,
        ctx: &StepContext,
    ) -> Self::Inputs;

    /// The training loss of one batch, a scalar tensor [1] (the trainer differentiates it).
    fn loss(&self, model: &Self::Model, inputs: Self::Inputs, config: &RunConfig) -> Tensor<1>;

    /// The validation loss of a whole split (model without autodiff, plain device).
    fn validation_loss(
        &self,
        model: &Self::Model,
        set: &SequenceSet,
        config: &RunConfig,
        device: &Device,
    ) -> f64;

    /// After each successful update: state the optimiser does not own (e.g. the VQ-VAE's EMA codebook)
    /// written into the model. Default: the model unchanged.
    fn after_update(&self, model: Self::Model) -> Self::Model {
        model
    }

    /// Families trained by several optimisers in turn (the genre stage: generator, then discriminator) name
    /// each group's parameters. Every update then runs one backward pass and one Adam step per group, in
    /// order, on [`Family::group_loss`]; a group's step moves only its own parameters, and later groups see
    /// the model the earlier ones updated. Called once per session, after the weights load (parameter ids
    /// survive updates). Default: none (one optimiser over every parameter, on [`Family::loss`]).
    fn param_groups(&self, _model: &Self::Model) -> Vec<HashSet<ParamId>> {
        Vec::new()
    }

    /// The loss of group `group` (families with [`Family::param_groups`]). The trainer reports group 0's.
    fn group_loss(
        &self,
        _model: &Self::Model,
        _inputs: &Self::Inputs,
        _group: usize,
        _config: &RunConfig,
    ) -> Tensor<1> {
        unreachable!("a family with param_groups implements group_loss")
    }

    /// A factor on the schedule's learning rate at every step (e.g. TSMT's `lr_start_factor`).
    /// Default: 1.
    fn lr_factor(&self, _config: &RunConfig) -> f64 {
        1.0
    }

    /// Extra state every checkpoint carries (e.g. coordinate bins fitted on the training split), written to
    /// `family.json`. Default: none.
    fn checkpoint_state(&self) -> Option<serde_json::Value> {
        None
    }
}

/// A checkpoint's model for `family`, on `device` (a family outside the registry, e.g. a test's; the
/// sampler loads the registry's families with [`Checkpoint::load_family`]).
pub fn load_checkpoint_model<F: Family>(
    family: &F,
    checkpoint: &Checkpoint,
    device: &Device,
) -> Result<F::Model> {
    let _rng = qean_models::backend::rng_guard();
    let model = family.init(&checkpoint.config, device)?;
    qean_checkpoint::weights::load_weights(model, &checkpoint.weights_file())
}
