//! `qra_topology = cross_prefix` (SPEC §4.5 "Plug-in", after QEAN Fig. 3's wording): one QRA block
//! in which the motion tokens query the audio tokens, added residually to the motion tokens
//! before the cross-modal stack: x_m ← x_m + QRA(LN(x_m), LN′(x_a)). Two fresh LayerNorms, no
//! MLP; q and the ω_Q/θ_Q convs read the motion tokens, k, v and the ω_K/θ_K convs the audio.

use burn::config::Config;
use burn::module::Module;
use burn::nn::{Dropout, DropoutConfig, LayerNorm, LayerNormConfig};
use burn::tensor::{Device, Tensor};

use crate::qra::{Qra, QraConfig, QraPenalty, QraSide};
use crate::spe::RotaryTables;

/// Configuration of [`CrossPrefix`].
#[derive(Config, Debug)]
pub struct CrossPrefixConfig {
    /// The QRA layer.
    pub qra: QraConfig,
    /// Dropout on the branch output (the residual site of SPEC §4.7).
    #[config(default = 0.0)]
    pub residual_dropout: f64,
}

/// Motion-queries-audio QRA block.
#[derive(Module, Debug)]
pub struct CrossPrefix {
    /// LN over the motion tokens.
    pub motion_norm: LayerNorm,
    /// LN′ over the audio tokens.
    pub audio_norm: LayerNorm,
    /// The QRA layer.
    pub qra: Qra,
    /// Dropout on the branch output.
    pub residual_dropout: Dropout,
}

impl CrossPrefixConfig {
    /// Builds the block.
    pub fn init(&self, device: &Device) -> CrossPrefix {
        CrossPrefix {
            motion_norm: LayerNormConfig::new(self.qra.hidden).init(device),
            audio_norm: LayerNormConfig::new(self.qra.hidden).init(device),
            qra: self.qra.init(device),
            residual_dropout: DropoutConfig::new(self.residual_dropout).init(),
        }
    }
}

impl CrossPrefix {
    /// Updated motion tokens [B, N, C] and the QRA penalty.
    pub fn forward(
        &self,
        motion: Tensor<3>,
        audio: Tensor<3>,
        positions: (&[f64], &[f64]),
        rope: (Option<&RotaryTables>, Option<&RotaryTables>),
    ) -> (Tensor<3>, QraPenalty) {
        let query = QraSide {
            x: self.motion_norm.forward(motion.clone()),
            positions: positions.0,
            rope: rope.0,
        };
        let key = QraSide {
            x: self.audio_norm.forward(audio),
            positions: positions.1,
            rope: rope.1,
        };
        let (y, penalty) = self.qra.forward_cross(query, key);
        (motion + self.residual_dropout.forward(y), penalty)
    }
}
