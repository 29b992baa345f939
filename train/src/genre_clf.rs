//! The genre classifier as a trainer [`Family`] (SPEC §13.10): random pos72 windows of the training split,
//! each labelled with its sequence's genre (the name's gXX code), cross-entropy.

use burn::tensor::{Device, Int, Tensor, TensorData};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::feature_cache;
use qean_aistpp::windows::{Batch, SequenceSet, WindowSpec};
use qean_config::genre_clf::GenreClfConfig;
use qean_config::run::RunConfig;
use qean_io::error::{Error, Result};
use qean_models::control::genre_clf::GenreClassifier;
use qean_models::tsmt::loss::masked_cross_entropy;
use qean_motion::motion::{Layout, Motion};
use qean_motion::pos72::POS72;

use crate::family::{Family, StepContext};
use qean_aistpp::names::genre_of;
use qean_checkpoint::genre_clf::pos72_rows;

/// The classifier family.
#[derive(Debug, Default)]
pub struct GenreClfFamily;

/// The `[genre_clf]` table of a classifier run.
pub fn clf_of(config: &RunConfig) -> &GenreClfConfig {
    config.genre_clf_table()
}

/// Mean cross-entropy of logits [B, 10] against labels.
pub fn clf_loss(logits: Tensor<2>, labels: &[usize], device: &Device) -> Tensor<1> {
    let [b, k] = logits.dims();
    let targets: Vec<i64> = labels.iter().map(|&l| l as i64).collect();
    masked_cross_entropy(
        logits.reshape([b, 1, 1, k]),
        Tensor::<3, Int>::from_data(TensorData::new(targets, [b, 1, 1]), device),
        &vec![1; b],
    )
}

/// A batch as (windows [B, T, 72], labels).
fn tensors(batch: &Batch, device: &Device) -> (Tensor<3>, Vec<usize>) {
    let (b, t) = (batch.len(), batch.spec.motion_len);
    let labels = batch
        .names
        .iter()
        .map(|n| genre_of(n).unwrap_or(0))
        .collect();
    (
        Tensor::from_data(TensorData::new(batch.motion.clone(), [b, t, POS72]), device),
        labels,
    )
}

impl Family for GenreClfFamily {
    type Model = GenreClassifier;
    type Inputs = (Tensor<3>, Vec<usize>);

    fn init(&self, config: &RunConfig, device: &Device) -> Result<GenreClassifier> {
        Ok(GenreClassifier::new(clf_of(config), device))
    }

    /// Windows of pos72 rows; sequences without a genre code are left out.
    fn load_set(
        &self,
        dataset: &Dataset,
        split: Split,
        spec: WindowSpec,
        _config: &RunConfig,
    ) -> Result<SequenceSet> {
        qean_checkpoint::features::ensure_features(dataset, &dataset.split(split))?;
        let set = SequenceSet::load(dataset, split, Layout::L219, spec, |id| {
            feature_cache::load(dataset, id)
        })?;
        let mut set = set.remap(
            POS72,
            0,
            |seq| {
                let mut rows = pos72_rows(&Motion::read_pkl(&dataset.motion_path(&seq.name))?);
                rows.truncate(seq.motion_frames * POS72);
                Ok(rows)
            },
            |_, _| Vec::new(),
        )?;
        set.sequences.retain(|s| genre_of(&s.name).is_some());
        if set.sequences.is_empty() {
            return Err(Error::at(
                &dataset.root,
                format!("no {} sequence carries a genre code (gBR_…)", split.name()),
            ));
        }
        Ok(set)
    }

    fn inputs(
        &self,
        drawn: Batch,
        _model: &GenreClassifier,
        device: &Device,
        _ctx: &StepContext,
    ) -> Self::Inputs {
        tensors(&drawn, device)
    }

    fn loss(
        &self,
        model: &GenreClassifier,
        (x, labels): Self::Inputs,
        _config: &RunConfig,
    ) -> Tensor<1> {
        let device = x.device();
        clf_loss(model.forward(x), &labels, &device)
    }

    fn validation_loss(
        &self,
        model: &GenreClassifier,
        set: &SequenceSet,
        config: &RunConfig,
        device: &Device,
    ) -> f64 {
        crate::family::mean_over_first_windows(set, config.train.batch_size, |batch| {
            let (x, labels) = tensors(&batch, device);
            clf_loss(model.forward(x), &labels, device)
        })
    }
}
