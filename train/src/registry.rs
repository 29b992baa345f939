//! The one place in qean-train that knows every family: training dispatches here on the run's
//! [`ModelSpec`], and so does loading a checkpoint's model. The loop (`trainer.rs`), checkpoints
//! (`checkpoint.rs`) and the families themselves never name another family, so no module imports back.

use burn::tensor::Device;
use qean_config::run::RunConfig;
use qean_config::ModelSpec;
use qean_io::error::{Error, Result};
use qean_models::DanceModel;

use crate::checkpoint::Checkpoint;
use crate::trainer::{train_family, TrainOptions, TrainOutcome};

/// Trains (or continues) the run in `opts.run_dir` with `config`, whatever its family.
pub fn train(config: RunConfig, opts: &TrainOptions) -> Result<TrainOutcome> {
    match config.spec() {
        ModelSpec::FactQean(_) => train_family(&mut crate::fact_qean::FactQean, config, opts),
        ModelSpec::Tsmt(_) => train_family(&mut crate::tsmt::TsmtFamily::default(), config, opts),
        ModelSpec::Inbetween(_) => {
            train_family(&mut crate::inbetween::InbetweenFamily, config, opts)
        }
        ModelSpec::GenreClf(_) => train_family(&mut crate::genre_clf::GenreClfFamily, config, opts),
        ModelSpec::GptGenre(..) => {
            train_family(&mut crate::genre::GenreFamily::default(), config, opts)
        }
        ModelSpec::Gpt(_) => train_family(&mut crate::gpt::GptFamily::default(), config, opts),
        ModelSpec::Vqvae(_) => train_family(&mut crate::vqvae::VqFamily::default(), config, opts),
    }
}

impl Checkpoint {
    /// The FACT or QEAN model with this checkpoint's weights, on `device` (another family's checkpoint is
    /// an error that says what takes it).
    pub fn load_model(&self, device: &Device) -> Result<DanceModel> {
        let other = match self.config.spec() {
            ModelSpec::FactQean(_) => {
                return crate::family::load_checkpoint_model(&crate::fact_qean::FactQean, self, device)
            }
            ModelSpec::Tsmt(_) => {
                "a TSMT checkpoint, not FACT or QEAN: this command does not take TSMT runs"
            }
            ModelSpec::Inbetween(_) => {
                "an in-betweener checkpoint, not FACT or QEAN: it does not generate dances from music"
            }
            ModelSpec::GenreClf(_) => {
                "a genre classifier checkpoint, not FACT or QEAN: `qean eval --run` scores it"
            }
            ModelSpec::Gpt(_) | ModelSpec::GptGenre(..) => {
                "a music-to-dance GPT checkpoint, not FACT or QEAN: `qean sample` and `qean eval` take it"
            }
            ModelSpec::Vqvae(_) => {
                "a motion VQ-VAE checkpoint, not FACT or QEAN: it encodes and decodes dances, it does not generate them"
            }
        };
        Err(Error::at(&self.dir, other))
    }

    /// Every parameter of the checkpoint's model, whatever its family (inspection, export).
    pub fn named_parameters(
        &self,
        device: &Device,
    ) -> Result<Vec<qean_models::params::NamedParam>> {
        use crate::family::load_checkpoint_model as load;
        use qean_models::params::named_parameters as named;
        Ok(match self.config.spec() {
            ModelSpec::FactQean(_) => named(&load(&crate::fact_qean::FactQean, self, device)?),
            ModelSpec::Tsmt(_) => named(&load(&crate::tsmt::TsmtFamily::default(), self, device)?),
            ModelSpec::Inbetween(_) => {
                named(&load(&crate::inbetween::InbetweenFamily, self, device)?)
            }
            ModelSpec::GenreClf(_) => {
                named(&load(&crate::genre_clf::GenreClfFamily, self, device)?)
            }
            ModelSpec::GptGenre(..) => {
                named(&load(&crate::genre::GenreFamily::default(), self, device)?)
            }
            ModelSpec::Gpt(_) => named(&load(&crate::gpt::GptFamily::default(), self, device)?),
            ModelSpec::Vqvae(_) => named(&load(&crate::vqvae::VqFamily::default(), self, device)?),
        })
    }
}
