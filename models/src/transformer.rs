//! Pre-LN transformer (mint base_models.py `Transformer`, SPEC §4.1):
//! x += Attn(LN(x)); x += MLP(LN(x)); LayerNorm ε = 1e-5; no final LayerNorm after the stack.
//! The self-attention of a block is FACT's softmax attention or QRA (QEAN), chosen per block.
//! Optional dropout (QEAN, SPEC §4.7) on both branch outputs before the residual add.

use burn::config::Config;
use burn::module::Module;
use burn::nn::{Dropout, DropoutConfig, LayerNorm, LayerNormConfig};
use burn::tensor::{Device, Tensor};

use crate::attention::{Attention, AttentionConfig};
use crate::feed_forward::{FeedForward, FeedForwardConfig};
use crate::qra::{Qra, QraConfig, QraPenalty};
use crate::spe::RotaryTables;
use qean_config::model::AttnScale;

/// Configuration of one [`Block`].
#[derive(Config, Debug)]
pub struct BlockConfig {
    /// Model width C.
    pub hidden: usize,
    /// Heads.
    pub heads: usize,
    /// MLP inner width.
    pub ffn: usize,
    /// Score scale of the softmax attention.
    #[config(default = "AttnScale::Hidden")]
    pub scale: AttnScale,
    /// Dropout on attention probabilities.
    #[config(default = 0.0)]
    pub attention_dropout: f64,
    /// Dropout on the branch outputs.
    #[config(default = 0.0)]
    pub residual_dropout: f64,
    /// QRA instead of softmax attention.
    #[config(default = "None")]
    pub qra: Option<QraConfig>,
}

/// The token mixer of a block.
// A handful per model; boxing the QRA variant would only add an indirection.
#[allow(clippy::large_enum_variant)]
#[derive(Module, Debug)]
pub enum Mixer {
    /// FACT's softmax attention.
    Softmax(Attention),
    /// Quaternion rotary attention.
    Qra(Qra),
}

/// One pre-LN block.
#[derive(Module, Debug)]
pub struct Block {
    /// LayerNorm before the attention.
    pub attention_norm: LayerNorm,
    /// Self-attention.
    pub mixer: Mixer,
    /// LayerNorm before the MLP.
    pub mlp_norm: LayerNorm,
    /// MLP.
    pub mlp: FeedForward,
    /// Dropout on the branch outputs.
    pub residual_dropout: Dropout,
}

/// Per-token inputs every block of a stack shares.
#[derive(Clone, Copy, Default)]
pub struct StackContext<'a> {
    /// Rotary tables at the head width (SPE), for softmax blocks.
    pub rope: Option<&'a RotaryTables>,
    /// Rotary tables at QRA's q/k head width (equal to `rope` unless `qra_dk = round_up`).
    pub qra_rope: Option<&'a RotaryTables>,
    /// QRA's normalised token positions (pos_n of eq. 26); needed when a block uses QRA.
    pub qra_positions: &'a [f64],
}

impl BlockConfig {
    /// Builds the block.
    pub fn init(&self, device: &Device) -> Block {
        let mixer = match &self.qra {
            None => Mixer::Softmax(
                AttentionConfig::new(self.hidden, self.heads)
                    .with_scale(self.scale)
                    .with_dropout(self.attention_dropout)
                    .init(device),
            ),
            Some(qra) => Mixer::Qra(qra.init(device)),
        };
        Block {
            attention_norm: LayerNormConfig::new(self.hidden)
                .with_epsilon(1e-5)
                .init(device),
            mixer,
            mlp_norm: LayerNormConfig::new(self.hidden)
                .with_epsilon(1e-5)
                .init(device),
            mlp: FeedForwardConfig::new(self.hidden, self.ffn).init(device),
            residual_dropout: DropoutConfig::new(self.residual_dropout).init(),
        }
    }
}

impl Block {
    /// x [B, N, C] → [B, N, C], and the QRA penalty when the block uses QRA.
    pub fn forward(&self, x: Tensor<3>, ctx: StackContext) -> (Tensor<3>, Option<QraPenalty>) {
        let h = self.attention_norm.forward(x.clone());
        let (a, penalty) = match &self.mixer {
            Mixer::Softmax(attn) => (attn.forward(h, ctx.rope), None),
            Mixer::Qra(qra) => {
                let (a, p) = qra.forward(h, ctx.qra_positions, ctx.qra_rope);
                (a, Some(p))
            }
        };
        let x = x + self.residual_dropout.forward(a);
        let h = self.mlp_norm.forward(x.clone());
        let x = x.clone() + self.residual_dropout.forward(self.mlp.forward(h));
        (x, penalty)
    }

    /// Token 0 of [`Block::forward`], [B, 1, C], computing the attention query, the residuals and
    /// the MLP for that token alone (a QRA block runs whole: its rotations need every position).
    pub fn forward_first(&self, x: Tensor<3>, ctx: StackContext) -> Tensor<3> {
        let h = self.attention_norm.forward(x.clone());
        let a = match &self.mixer {
            Mixer::Softmax(attn) => attn.forward_first(h, ctx.rope),
            Mixer::Qra(qra) => qra
                .forward(h, ctx.qra_positions, ctx.qra_rope)
                .0
                .narrow(1, 0, 1),
        };
        let x = x.narrow(1, 0, 1) + self.residual_dropout.forward(a);
        let h = self.mlp_norm.forward(x.clone());
        x + self.residual_dropout.forward(self.mlp.forward(h))
    }
}

/// Configuration of a [`Transformer`]: one block config per layer.
#[derive(Config, Debug)]
pub struct TransformerConfig {
    /// The blocks, bottom first.
    pub blocks: Vec<BlockConfig>,
}

/// A stack of pre-LN blocks.
#[derive(Module, Debug)]
pub struct Transformer {
    /// The blocks, bottom first.
    pub blocks: Vec<Block>,
}

impl TransformerConfig {
    /// `layers` copies of `block`.
    pub fn uniform(layers: usize, block: BlockConfig) -> Self {
        Self::new(vec![block; layers])
    }

    /// Builds the stack.
    pub fn init(&self, device: &Device) -> Transformer {
        Transformer {
            blocks: self.blocks.iter().map(|b| b.init(device)).collect(),
        }
    }
}

impl Transformer {
    /// x [B, N, C] → [B, N, C], and the penalties of its QRA blocks.
    pub fn forward(&self, x: Tensor<3>, ctx: StackContext) -> (Tensor<3>, Vec<QraPenalty>) {
        let mut penalties = Vec::new();
        let mut x = x;
        for block in &self.blocks {
            let (y, p) = block.forward(x, ctx);
            x = y;
            penalties.extend(p);
        }
        (x, penalties)
    }

    /// Token 0 of [`Transformer::forward`], [B, 1, C]: every block but the last runs whole, the
    /// last only for token 0 (what autoregressive sampling reads).
    pub fn forward_first(&self, x: Tensor<3>, ctx: StackContext) -> Tensor<3> {
        let Some((last, below)) = self.blocks.split_last() else {
            return x.narrow(1, 0, 1);
        };
        let mut x = x;
        for block in below {
            x = block.forward(x, ctx).0;
        }
        last.forward_first(x, ctx)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{f64_normal, max_abs_diff, to_f64};

    #[test]
    fn block_is_pre_ln_residual() {
        // Rebuild the block by hand from its parts: x + A(LN1 x), then + M(LN2 ·).
        let device = Device::flex();
        let block = to_f64(BlockConfig::new(16, 4, 32).init(&device));
        let x = f64_normal([2, 5, 16], &device);
        let (y, penalty) = block.forward(x.clone(), StackContext::default());
        assert!(penalty.is_none());
        let Mixer::Softmax(attn) = &block.mixer else {
            panic!("softmax block expected")
        };
        let x1 = x.clone() + attn.forward(block.attention_norm.forward(x), None);
        let want = x1.clone() + block.mlp.forward(block.mlp_norm.forward(x1));
        assert!(max_abs_diff(y, want) < 1e-12);
    }

    #[test]
    fn stack_runs_blocks_in_order_without_final_norm() {
        let device = Device::flex();
        let stack = to_f64(TransformerConfig::uniform(2, BlockConfig::new(8, 2, 16)).init(&device));
        let x = f64_normal([1, 3, 8], &device);
        let (y, _) = stack.forward(x.clone(), StackContext::default());
        let (h, _) = stack.blocks[0].forward(x, StackContext::default());
        let (want, _) = stack.blocks[1].forward(h, StackContext::default());
        assert!(max_abs_diff(y, want) < 1e-15);
    }
}
