//! The one place that builds a checkpoint's model for each family: one `match` on the run's [`ModelSpec`]
//! gives a [`FamilyModel`], and the sampler, the evaluation and `inspect` take the variant they handle. The
//! weights are the checkpoint's `model.bpk` (its `ema.bpk` when the run averaged them); a model is built from the checkpoint's own config, so a
//! checkpoint never loads into another family's shape.

use burn::tensor::Device;
use qean_config::ModelSpec;
use qean_io::error::{Error, Result};
use qean_models::control::genre::GenreGpt;
use qean_models::control::genre_clf::GenreClassifier;
use qean_models::control::gpt::Gpt;
use qean_models::control::keyframe::KeyframeGpt;
use qean_models::inbetween::Inbetweener;
use qean_models::params::{named_parameters, NamedParam};
use qean_models::tsmt::Tsmt;
use qean_models::vqvae::VqVae;
use qean_models::DanceModel;

use crate::checkpoint::{Checkpoint, EMA_FILE, MODEL_FILE};
use crate::weights::load_weights;

/// A checkpoint's model, by family.
// Built once per load and taken apart at once: the variants' sizes do not matter.
#[allow(clippy::large_enum_variant)]
pub enum FamilyModel {
    FactQean(DanceModel),
    Tsmt(Tsmt),
    Inbetween(Inbetweener),
    Vqvae(VqVae),
    Gpt(Gpt),
    GptGenre(GenreGpt),
    GenreClf(GenreClassifier),
    GptKeyframe(KeyframeGpt),
}

impl FamilyModel {
    /// Every parameter, whatever the family (inspection, export).
    pub fn named_parameters(&self) -> Vec<NamedParam> {
        match self {
            FamilyModel::FactQean(m) => named_parameters(m),
            FamilyModel::Tsmt(m) => named_parameters(m),
            FamilyModel::Inbetween(m) => named_parameters(m),
            FamilyModel::Vqvae(m) => named_parameters(m),
            FamilyModel::Gpt(m) => named_parameters(m),
            FamilyModel::GptGenre(m) => named_parameters(m),
            FamilyModel::GenreClf(m) => named_parameters(m),
            FamilyModel::GptKeyframe(m) => named_parameters(m),
        }
    }
}

/// Which of a checkpoint's weights to load.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Weights {
    /// What samplers and evaluations use: the moving average of a run trained with `train.ema_decay` > 0,
    /// else the trained weights.
    Sampled,
    /// The weights training continues from (`model.bpk`, whose hash the trainer state records).
    Trained,
}

impl Checkpoint {
    /// The weights a sampler or evaluation loads: the moving average of a run trained with
    /// `train.ema_decay` > 0, else the trained weights.
    pub fn weights_file(&self) -> std::path::PathBuf {
        self.file_of(Weights::Sampled)
    }

    /// The file holding `which` weights.
    pub fn file_of(&self, which: Weights) -> std::path::PathBuf {
        match which {
            Weights::Sampled if self.config.train.ema_decay > 0.0 => self.dir.join(EMA_FILE),
            _ => self.dir.join(MODEL_FILE),
        }
    }

    /// The checkpoint's model with the weights samplers use ([`Checkpoint::weights_file`]), on `device`.
    pub fn load_family(&self, device: &Device) -> Result<FamilyModel> {
        self.load_family_weights(device, Weights::Sampled)
    }

    /// The checkpoint's model with `which` weights, on `device`.
    pub fn load_family_weights(&self, device: &Device, which: Weights) -> Result<FamilyModel> {
        let path = self.file_of(which);
        // Initialisation draws from the process's random stream before the weights replace it.
        let _rng = qean_models::backend::rng_guard();
        Ok(match self.config.spec() {
            ModelSpec::FactQean(m) => FamilyModel::FactQean(load_weights(
                DanceModel::new(m, device).map_err(|e| Error::at(&self.dir, e.to_string()))?,
                &path,
            )?),
            ModelSpec::Tsmt(t) => FamilyModel::Tsmt(load_weights(Tsmt::new(t, device), &path)?),
            ModelSpec::Inbetween(c) => {
                FamilyModel::Inbetween(load_weights(Inbetweener::new(c, device), &path)?)
            }
            ModelSpec::Vqvae(v) => FamilyModel::Vqvae(load_weights(VqVae::new(v, device), &path)?),
            ModelSpec::Gpt(g) => FamilyModel::Gpt(load_weights(Gpt::new(g, device), &path)?),
            ModelSpec::GptGenre(g, c) => FamilyModel::GptGenre(load_weights(
                GenreGpt::new(g, c, c.code_dim, device),
                &path,
            )?),
            ModelSpec::GenreClf(c) => {
                FamilyModel::GenreClf(load_weights(GenreClassifier::new(c, device), &path)?)
            }
            ModelSpec::GptKeyframe(g, k) => FamilyModel::GptKeyframe(load_weights(
                KeyframeGpt::new(g, k.weights, device),
                &path,
            )?),
        })
    }

    /// The FACT or QEAN model with this checkpoint's weights, on `device` (another family's checkpoint is
    /// an error that says what takes it, before any weights are read).
    pub fn load_model(&self, device: &Device) -> Result<DanceModel> {
        let other = match self.config.spec() {
            ModelSpec::FactQean(_) => match self.load_family(device)? {
                FamilyModel::FactQean(m) => return Ok(m),
                _ => unreachable!("a FACT/QEAN spec loads a FACT/QEAN model"),
            },
            ModelSpec::Tsmt(_) => {
                "a TSMT checkpoint, not FACT or QEAN: this command does not take TSMT runs"
            }
            ModelSpec::Inbetween(_) => {
                "an in-betweener checkpoint, not FACT or QEAN: it does not generate dances from music"
            }
            ModelSpec::GenreClf(_) => {
                "a genre classifier checkpoint, not FACT or QEAN: `qean eval --run` scores it"
            }
            ModelSpec::Gpt(_) | ModelSpec::GptGenre(..) | ModelSpec::GptKeyframe(..) => {
                "a music-to-dance GPT checkpoint, not FACT or QEAN: `qean sample` and `qean eval` take it"
            }
            ModelSpec::Vqvae(_) => {
                "a motion VQ-VAE checkpoint, not FACT or QEAN: it encodes and decodes dances, it does not generate them"
            }
        };
        Err(Error::at(&self.dir, other))
    }

    /// Every trained parameter of the checkpoint's model, whatever its family (inspection; their hash
    /// is the recorded `params_hash`).
    pub fn named_parameters(&self, device: &Device) -> Result<Vec<NamedParam>> {
        self.named_parameters_of(device, Weights::Trained)
    }

    /// Every parameter of `which` weights (export writes the sampled ones).
    pub fn named_parameters_of(&self, device: &Device, which: Weights) -> Result<Vec<NamedParam>> {
        Ok(self.load_family_weights(device, which)?.named_parameters())
    }

    /// The error for a checkpoint of another family than the command takes (`what`: "a TSMT", …).
    pub fn not_family(&self, what: &str) -> Error {
        Error::at(
            &self.dir,
            format!("not {what} run (model.arch = {:?})", self.config.model.arch),
        )
    }
}
