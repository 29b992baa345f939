//! FACT, the Full-Attention Cross-modal Transformer of "AI Choreographer" (Li et al., ICCV 2021),
//! exactly as google-research/mint builds it (mint/core/fact_model.py, base_models.py,
//! configs/fact_v5_deeper_t10_cm12.config; SPEC §4.1–4.2):
//!
//! - motion [B, 120, 225] → Dense(225 → 800) → + learned P_m → 2-layer transformer;
//! - audio [B, 240, 35] → Dense(35 → 800) → + learned P_a → 2-layer transformer;
//! - concatenate along time, motion first → 12-layer transformer → Dense(800 → 225);
//! - output [B, 360, 225]; tokens 0..20 are supervised.
//!
//! No dropout, no mask, no final LayerNorm. 120,406,977 parameters at mint's size.

use burn::config::Config;
use burn::module::Module;
use burn::nn::Linear;
use burn::tensor::{Device, Tensor};

use crate::init::{glorot_dense, truncated_normal_dense};
use crate::position::{PositionEmbedding, PositionEmbeddingConfig};
use crate::transformer::{BlockConfig, StackContext, Transformer, TransformerConfig};
use qean_config::model::{AttnScale, ModelConfig};

/// mint's FACT hyperparameters (defaults: the fact_v5_deeper_t10_cm12 config).
#[derive(Config, Debug)]
pub struct FactConfig {
    /// Width of all three transformers.
    #[config(default = 800)]
    pub hidden: usize,
    /// Heads.
    #[config(default = 10)]
    pub heads: usize,
    /// MLP inner width.
    #[config(default = 3072)]
    pub ffn: usize,
    /// Motion encoder layers.
    #[config(default = 2)]
    pub motion_layers: usize,
    /// Audio encoder layers.
    #[config(default = 2)]
    pub audio_layers: usize,
    /// Cross-modal layers.
    #[config(default = 12)]
    pub cross_layers: usize,
    /// Motion features (225 or 219).
    #[config(default = 225)]
    pub motion_dim: usize,
    /// Audio features.
    #[config(default = 35)]
    pub audio_dim: usize,
    /// Motion frames.
    #[config(default = 120)]
    pub motion_len: usize,
    /// Audio frames.
    #[config(default = 240)]
    pub audio_len: usize,
    /// Score scale.
    #[config(default = "AttnScale::Hidden")]
    pub scale: AttnScale,
}

impl From<&ModelConfig> for FactConfig {
    fn from(c: &ModelConfig) -> Self {
        FactConfig::new()
            .with_hidden(c.hidden)
            .with_heads(c.heads)
            .with_ffn(c.ffn)
            .with_motion_layers(c.motion_layers)
            .with_audio_layers(c.audio_layers)
            .with_cross_layers(c.cross_layers)
            .with_motion_dim(c.motion_dim())
            .with_audio_dim(c.audio_dim)
            .with_motion_len(c.motion_len)
            .with_audio_len(c.audio_len)
            .with_scale(c.attn_scale)
    }
}

/// mint's FACT.
#[derive(Module, Debug)]
pub struct Fact {
    /// Dense(motion_dim → C) (mint `LinearEmbedding`).
    pub motion_embed: Linear,
    /// Learned P_m [120, C].
    pub motion_pos: PositionEmbedding,
    /// Motion encoder.
    pub motion_transformer: Transformer,
    /// Dense(audio_dim → C).
    pub audio_embed: Linear,
    /// Learned P_a [240, C].
    pub audio_pos: PositionEmbedding,
    /// Audio encoder.
    pub audio_transformer: Transformer,
    /// Cross-modal transformer over the 360 concatenated tokens.
    pub cross_transformer: Transformer,
    /// Dense(C → motion_dim), truncated-normal kernel (mint `CrossModalLayer` output).
    pub output: Linear,
}

impl FactConfig {
    /// Builds FACT with mint's initialisers.
    pub fn init(&self, device: &Device) -> Fact {
        let block = BlockConfig::new(self.hidden, self.heads, self.ffn).with_scale(self.scale);
        let stack = |layers| TransformerConfig::uniform(layers, block.clone()).init(device);
        Fact {
            motion_embed: glorot_dense(self.motion_dim, self.hidden, true, device),
            motion_pos: PositionEmbeddingConfig::new(self.motion_len, self.hidden).init(device),
            motion_transformer: stack(self.motion_layers),
            audio_embed: glorot_dense(self.audio_dim, self.hidden, true, device),
            audio_pos: PositionEmbeddingConfig::new(self.audio_len, self.hidden).init(device),
            audio_transformer: stack(self.audio_layers),
            cross_transformer: stack(self.cross_layers),
            output: truncated_normal_dense(self.hidden, self.motion_dim, 0.02, device),
        }
    }
}

impl Fact {
    /// motion [B, 120, D], audio [B, 240, 35] → [B, 360, D] (tokens 0..120 motion, 120..360 audio).
    pub fn forward(&self, motion: Tensor<3>, audio: Tensor<3>) -> Tensor<3> {
        let (x, _) = self
            .cross_transformer
            .forward(self.encode(motion, audio), StackContext::default());
        self.output.forward(x)
    }

    /// Token 0 of [`Fact::forward`], [B, 1, D]: the prediction of frame 120, all the sampler needs.
    pub fn forward_first(&self, motion: Tensor<3>, audio: Tensor<3>) -> Tensor<3> {
        let x = self
            .cross_transformer
            .forward_first(self.encode(motion, audio), StackContext::default());
        self.output.forward(x)
    }

    /// Both encoders, concatenated motion first: the cross-modal stack's input [B, 360, C].
    fn encode(&self, motion: Tensor<3>, audio: Tensor<3>) -> Tensor<3> {
        let ctx = StackContext::default();
        let m = self.motion_pos.forward(self.motion_embed.forward(motion));
        let (m, _) = self.motion_transformer.forward(m, ctx);
        let a = self.audio_pos.forward(self.audio_embed.forward(audio));
        let (a, _) = self.audio_transformer.forward(a, ctx);
        Tensor::cat(vec![m, a], 1)
    }
}
