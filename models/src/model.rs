//! The model the trainer and the sampler hold: FACT or QEAN behind one enum, built from a
//! [`ModelConfig`], with weight files in Burn's burnpack format (BURN_NOTES "records").

use std::path::{Path, PathBuf};

use burn::module::Module;
use burn::tensor::{Device, Tensor};

use crate::error::Error;
use crate::fact::{Fact, FactConfig};
use crate::qean::{ModelOutput, Qean, QeanConfig};
use qean_config::model::{Arch, ModelConfig};

/// What the sampler needs from a model: one window in, every output token out.
pub trait DanceGenerator {
    /// motion [B, Lm, D], audio [B, La, A] → the prediction of frame Lm, [B, 1, D] (token 0 of
    /// the forward pass; implementations skip what only the other tokens need).
    fn generate(&self, motion: Tensor<3>, audio: Tensor<3>) -> Tensor<3>;

    /// The first `tokens` output tokens, [B, tokens, D] (temporal ensembling).
    fn generate_tokens(&self, motion: Tensor<3>, audio: Tensor<3>, tokens: usize) -> Tensor<3>;
}

/// FACT or QEAN.
// One value per run: the size gap between the variants costs nothing worth boxing for.
#[allow(clippy::large_enum_variant)]
#[derive(Module, Debug)]
pub enum DanceModel {
    /// mint's FACT.
    Fact(Fact),
    /// QEAN or a QEAN ablation.
    Qean(Qean),
}

impl DanceModel {
    /// Builds the model a config describes (parameters initialise lazily from the device
    /// RNG: seed with `device.seed(..)` first for a reproducible init). A config of another family is an
    /// error that names the module that builds it.
    pub fn new(config: &ModelConfig, device: &Device) -> Result<DanceModel, Error> {
        let builder = match config.arch {
            Arch::Fact => return Ok(DanceModel::Fact(FactConfig::from(config).init(device))),
            Arch::Qean => return Ok(DanceModel::Qean(QeanConfig::from(config).init(device))),
            Arch::Tsmt => "qean_models::tsmt::Tsmt from its [tsmt] table",
            Arch::Inbetween => "qean_models::inbetween::Inbetweener from its [inbetween] table",
            Arch::GenreClf => "qean_models::control::genre_clf::GenreClassifier",
            Arch::GptGenre => "qean_models::control::genre::GenreGpt",
            Arch::GptKeyframe => "qean_models::control::keyframe::KeyframeGpt",
            Arch::Gpt => "qean_models::control::gpt::Gpt from its [gpt] table",
            Arch::Vqvae => "qean_models::vqvae::VqVae from its [vq] table",
        };
        Err(Error::Family(format!(
            "model.arch = {:?} is not FACT or QEAN: it is built by {builder}",
            config.arch
        )))
    }

    /// motion [B, Lm, D], audio [B, La, A] → [B, Lm + La, D].
    pub fn forward(&self, motion: Tensor<3>, audio: Tensor<3>) -> Tensor<3> {
        match self {
            DanceModel::Fact(m) => m.forward(motion, audio),
            DanceModel::Qean(m) => m.forward(motion, audio),
        }
    }

    /// The prediction and the weighted QRA penalty to add to the loss (None for FACT and when
    /// the penalty weights are zero).
    pub fn forward_with_penalty(&self, motion: Tensor<3>, audio: Tensor<3>) -> ModelOutput {
        match self {
            DanceModel::Fact(m) => ModelOutput {
                prediction: m.forward(motion, audio),
                penalty: None,
            },
            DanceModel::Qean(m) => m.forward_with_penalty(motion, audio),
        }
    }

    /// Writes the weights to a burnpack file ([`save_weights`]).
    pub fn save_weights(&self, path: &Path) -> Result<PathBuf, Error> {
        save_weights(self, path)
    }

    /// Loads weights saved by [`save_weights`] from a model of the same config ([`load_weights`]).
    pub fn load_weights(self, path: &Path) -> Result<Self, Error> {
        load_weights(self, path)
    }
}

/// Writes any module's weights to a burnpack file (atomically: a scratch file renamed into place).
/// A path without extension gets `.bpk`; the path written is returned.
pub fn save_weights<M: Module>(model: &M, path: &Path) -> Result<PathBuf, Error> {
    let path = weights_path(path);
    model.clone().save_file(&path).map_err(|e| Error::Weights {
        path: path.clone(),
        message: format!("cannot save weights: {e}"),
    })?;
    Ok(path)
}

/// Loads weights saved by [`save_weights`] into a module of the same shape; a missing file or a
/// mismatched parameter set is an error naming the file.
pub fn load_weights<M: Module>(model: M, path: &Path) -> Result<M, Error> {
    let path = weights_path(path);
    if !path.is_file() {
        return Err(Error::Weights {
            path,
            message: "no such weights file".into(),
        });
    }
    model.try_load_file(&path).map_err(|e| {
        let e = e.to_string();
        let first = shorten_lists(e.lines().next().unwrap_or(""), 3);
        Error::Weights {
            path: path.clone(),
            message: format!("cannot load weights (written by another model or config?): {first}"),
        }
    })
}

/// Shortens every `[a, b, c, ...]` list in `text` to its first `keep` items and a count, so that an
/// error naming hundreds of tensors stays one readable line.
pub fn shorten_lists(text: &str, keep: usize) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some(open) = rest.find('[') {
        let Some(len) = rest[open..].find(']') else {
            break;
        };
        let items: Vec<&str> = rest[open + 1..open + len].split(", ").collect();
        out.push_str(&rest[..open]);
        if items.len() > keep {
            out.push_str(&format!(
                "[{}, ... {} in all]",
                items[..keep].join(", "),
                items.len()
            ));
        } else {
            out.push_str(&rest[open..=open + len]);
        }
        rest = &rest[open + len + 1..];
    }
    out.push_str(rest);
    out
}

impl DanceGenerator for DanceModel {
    fn generate(&self, motion: Tensor<3>, audio: Tensor<3>) -> Tensor<3> {
        match self {
            DanceModel::Fact(m) => m.forward_first(motion, audio),
            DanceModel::Qean(m) => m.forward_first(motion, audio),
        }
    }

    fn generate_tokens(&self, motion: Tensor<3>, audio: Tensor<3>, tokens: usize) -> Tensor<3> {
        self.forward(motion, audio).narrow(1, 0, tokens)
    }
}

impl DanceGenerator for Fact {
    fn generate(&self, motion: Tensor<3>, audio: Tensor<3>) -> Tensor<3> {
        self.forward_first(motion, audio)
    }

    fn generate_tokens(&self, motion: Tensor<3>, audio: Tensor<3>, tokens: usize) -> Tensor<3> {
        self.forward(motion, audio).narrow(1, 0, tokens)
    }
}

impl DanceGenerator for Qean {
    fn generate(&self, motion: Tensor<3>, audio: Tensor<3>) -> Tensor<3> {
        self.forward_first(motion, audio)
    }

    fn generate_tokens(&self, motion: Tensor<3>, audio: Tensor<3>, tokens: usize) -> Tensor<3> {
        self.forward(motion, audio).narrow(1, 0, tokens)
    }
}

fn weights_path(path: &Path) -> PathBuf {
    if path.extension().is_some() {
        path.to_path_buf()
    } else {
        path.with_extension("bpk")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::max_abs_diff;
    use burn::tensor::Distribution;
    use qean_config::model::{AttentionKind, PositionKind};

    #[test]
    fn long_lists_in_errors_are_shortened() {
        assert_eq!(
            shorten_lists("Missing tensors: [\"a\", \"b\", \"c\", \"d\"] and [x]", 2),
            "Missing tensors: [\"a\", \"b\", ... 4 in all] and [x]"
        );
        assert_eq!(shorten_lists("no list [", 2), "no list [");
    }

    use crate::testing::micro_config as tiny;

    fn inputs(c: &ModelConfig, device: &Device) -> (Tensor<3>, Tensor<3>) {
        (
            Tensor::random(
                [2, c.motion_len, c.motion_dim()],
                Distribution::Default,
                device,
            ),
            Tensor::random([2, c.audio_len, c.audio_dim], Distribution::Default, device),
        )
    }

    #[test]
    fn generate_is_token_zero_of_the_forward_pass() {
        // The sampler's shortcut (last layer for token 0 only) changes no number beyond f64
        // rounding, for FACT and for QEAN with rotary positions, QRA in the last layer or only in
        // the first, a cross-prefix block and per-modality or concatenated positions.
        use crate::testing::{f64_normal, to_f64};
        use qean_config::model::{CrossPositions, QraLayers, QraOptions, QraTopology, RopeOptions};
        let device = Device::flex();
        let qean = tiny(Arch::Qean);
        let configs = [
            tiny(Arch::Fact),
            qean.clone(),
            ModelConfig {
                position: PositionKind::Rotary,
                ..qean.clone()
            },
            ModelConfig {
                position: PositionKind::Rotary,
                rope: RopeOptions {
                    cross_positions: CrossPositions::Concatenated,
                    ..RopeOptions::default()
                },
                ..qean.clone()
            },
            ModelConfig {
                attention: AttentionKind::Qra,
                ..qean.clone()
            },
            ModelConfig {
                position: PositionKind::Rotary,
                attention: AttentionKind::Qra,
                qra: QraOptions {
                    layers: QraLayers::FirstK,
                    layers_k: 1,
                    ..QraOptions::default()
                },
                ..qean.clone()
            },
            ModelConfig {
                attention: AttentionKind::Qra,
                qra: QraOptions {
                    topology: QraTopology::CrossPrefix,
                    ..QraOptions::default()
                },
                ..qean.clone()
            },
        ];
        for config in configs {
            let model = to_f64(DanceModel::new(&config, &device).unwrap());
            let m = f64_normal([3, config.motion_len, config.motion_dim()], &device);
            let a = f64_normal([3, config.audio_len, config.audio_dim], &device);
            let full = model.forward(m.clone(), a.clone()).narrow(1, 0, 1);
            let first = model.generate(m, a);
            assert_eq!(first.dims(), [3, 1, 225]);
            let diff = max_abs_diff(first, full);
            assert!(diff < 1e-10, "{config:?}: {diff}");
        }
    }

    #[test]
    fn output_shape_and_save_load_round_trip() {
        let device = Device::flex();
        let dir = tempfile::tempdir().unwrap();
        for config in [
            tiny(Arch::Fact),
            ModelConfig {
                position: PositionKind::Rotary,
                attention: AttentionKind::Qra,
                dropout: 0.1,
                ..tiny(Arch::Qean)
            },
        ] {
            let model = DanceModel::new(&config, &device).unwrap();
            let (m, a) = inputs(&config, &device);
            let y = model.forward(m.clone(), a.clone());
            assert_eq!(y.dims(), [2, 16, 225]);
            let path = model.save_weights(&dir.path().join("w")).unwrap();
            assert_eq!(path.extension().unwrap(), "bpk");
            let fresh = DanceModel::new(&config, &device).unwrap();
            assert!(max_abs_diff(fresh.forward(m.clone(), a.clone()), y.clone()) > 1e-6);
            let loaded = fresh.load_weights(&path).unwrap();
            assert_eq!(max_abs_diff(loaded.forward(m, a), y), 0.0);
        }
    }

    #[test]
    fn loading_into_another_architecture_fails_with_the_file_named() {
        let device = Device::flex();
        let dir = tempfile::tempdir().unwrap();
        let path = DanceModel::new(&tiny(Arch::Fact), &device)
            .unwrap()
            .save_weights(&dir.path().join("fact.bpk"))
            .unwrap();
        let other = ModelConfig {
            hidden: 32,
            ..tiny(Arch::Fact)
        };
        let e = DanceModel::new(&other, &device)
            .unwrap()
            .load_weights(&path)
            .unwrap_err()
            .to_string();
        assert!(e.contains("fact.bpk") && !e.contains('\n'), "{e}");
        let e = DanceModel::new(&tiny(Arch::Fact), &device)
            .unwrap()
            .load_weights(&dir.path().join("missing.bpk"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing.bpk"), "{e}");
    }

    /// Another family's config is an error naming what builds it, not a panic.
    #[test]
    fn another_family_is_an_error() {
        let config = ModelConfig {
            arch: Arch::Tsmt,
            ..tiny(Arch::Fact)
        };
        let e = DanceModel::new(&config, &Device::flex())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("not FACT or QEAN") && e.contains("[tsmt]"),
            "{e}"
        );
    }

    #[test]
    fn qean_baseline_with_fact_weights_is_fact() {
        // QEAN = FACT + switches: with every switch off, the parameters have FACT's names and
        // shapes, and FACT's weights give FACT's output.
        let device = Device::flex();
        let dir = tempfile::tempdir().unwrap();
        let fact_config = tiny(Arch::Fact);
        let DanceModel::Fact(fact) = DanceModel::new(&fact_config, &device).unwrap() else {
            unreachable!()
        };
        let path = dir.path().join("fact.bpk");
        fact.clone().save_file(&path).unwrap();
        let DanceModel::Qean(qean) = DanceModel::new(&tiny(Arch::Qean), &device).unwrap() else {
            unreachable!()
        };
        let qean = qean.try_load_file(&path).unwrap();
        let (m, a) = inputs(&fact_config, &device);
        let err = max_abs_diff(fact.forward(m.clone(), a.clone()), qean.forward(m, a));
        assert_eq!(err, 0.0);
    }
}
