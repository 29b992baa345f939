//! What a model family brings to the trainer. The loop (`trainer.rs`), the LR schedule, Adam, atomic
//! checkpoints, exact resume, the NaN stop, sweeps, logs and plots are the same for every family; a family
//! says what its model is, how a drawn batch of windows becomes its inputs, its loss and validation loss,
//! and what extra state its checkpoints carry. FACT and QEAN are one family ([`crate::fact_qean`]).
//!
//! The batch source is shared: windows of the dataset's sequences ([`SequenceSet`], drawn by the
//! resumable `WindowSampler`). A family that needs another representation (joint coordinates, tokens)
//! builds it from the windows in [`Family::inputs`].

use std::path::{Path, PathBuf};

use std::collections::HashSet;

use burn::module::{Module, ModuleVisitor, Param, ParamId};
use burn::tensor::{Device, Tensor};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::windows::{Batch, SequenceSet, WindowSpec};
use qean_io::error::{Error, Result};

use crate::checkpoint::Checkpoint;
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

/// The file a family's extra checkpoint state is written to, beside the weights.
pub const FAMILY_STATE_FILE: &str = "family.json";

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

/// The family state of a checkpoint (`family.json`), if it has one.
pub fn read_family_state(checkpoint: &Checkpoint) -> Result<Option<serde_json::Value>> {
    let path = checkpoint.dir.join(FAMILY_STATE_FILE);
    if !path.is_file() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|e| Error::at(&path, format!("malformed family state: {e}")))
}

/// A resumed stage must find the frozen run it was trained on: the weights hash saved under `key` in the
/// resume checkpoint's family state equals `frozen`'s (`what`: "the VQ-VAE this GPT", …). No saved hash: fine.
pub fn check_frozen_hash(
    resume: Option<&Checkpoint>,
    key: &str,
    frozen: &Checkpoint,
    what: &str,
) -> Result<()> {
    let Some(ck) = resume else {
        return Ok(());
    };
    let saved = read_family_state(ck)?;
    let hash = saved.as_ref().and_then(|s| s[key].as_str());
    match hash.filter(|h| *h != frozen.state.params_hash) {
        Some(h) => Err(Error::at(
            &frozen.dir,
            format!(
                "not {what} was trained on (weights hash {} there, {h} when training began)",
                frozen.state.params_hash
            ),
        )),
        None => Ok(()),
    }
}

/// The trainer's error for a weights file.
fn weights_error(e: qean_models::Error) -> Error {
    match e {
        qean_models::Error::Weights { path, message } => Error::at(path, message),
        other => Error::msg(other.to_string()),
    }
}

/// Writes any model's weights to a burnpack file; returns the path written.
pub fn save_weights<M: Module>(model: &M, path: &Path) -> Result<PathBuf> {
    qean_models::model::save_weights(model, path).map_err(weights_error)
}

/// Loads weights saved by [`save_weights`] into a model of the same shape.
pub fn load_weights<M: Module>(model: M, path: &Path) -> Result<M> {
    qean_models::model::load_weights(model, path).map_err(weights_error)
}

/// A checkpoint's model for `family`, on `device` (sampling, evaluation).
pub fn load_checkpoint_model<F: Family>(
    family: &F,
    checkpoint: &Checkpoint,
    device: &Device,
) -> Result<F::Model> {
    let model = family.init(&checkpoint.config, device)?;
    load_weights(model, &checkpoint.dir.join(crate::checkpoint::MODEL_FILE))
}
