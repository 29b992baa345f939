//! The one place in qean-train that knows every family: training dispatches here on the run's
//! [`ModelSpec`] (loading a checkpoint's model dispatches in qean-checkpoint's registry). The loop
//! (`trainer.rs`) and the families never name another family, so no module imports back.

use qean_config::run::RunConfig;
use qean_config::ModelSpec;
use qean_io::error::Result;

use crate::trainer::{train_family, TrainOptions, TrainOutcome};

/// Trains (or continues) the run in `opts.run_dir` with `config`, whatever its family.
pub fn train(config: RunConfig, opts: &TrainOptions) -> Result<TrainOutcome> {
    match config.spec() {
        ModelSpec::FactQean(_) => train_family(&mut crate::fact_qean::FactQean, config, opts),
        ModelSpec::Tsmt(_) => train_family(&mut crate::tsmt::TsmtFamily::default(), config, opts),
        ModelSpec::Inbetween(_) => {
            train_family(&mut crate::inbetween::InbetweenFamily, config, opts)
        }
        ModelSpec::GenreClf(_) => train_family(
            &mut crate::genre_clf::GenreClfFamily::default(),
            config,
            opts,
        ),
        ModelSpec::GptGenre(..) => {
            train_family(&mut crate::genre::GenreFamily::default(), config, opts)
        }
        ModelSpec::GptKeyframe(..) => train_family(
            &mut crate::keyframe::KeyframeFamily::default(),
            config,
            opts,
        ),
        ModelSpec::Gpt(_) => train_family(&mut crate::gpt::GptFamily::default(), config, opts),
        ModelSpec::Vqvae(_) => train_family(&mut crate::vqvae::VqFamily::default(), config, opts),
    }
}
