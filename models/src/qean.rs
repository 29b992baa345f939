//! QEAN, "Quaternion-Enhanced Attention Network for Visual Dance Generation" (Zhou et al.;
//! official repo MarasyZZ/QEAN holds only a README): FACT plus switches (SPEC §4.3–4.7).
//!
//! - `position = rotary`: SPE (RoPE on per-head q/k) in every attention of all three
//!   transformers; the learned absolute embeddings are removed unless `keep_abs_pos`.
//!   Cross-modal positions are per-modality (motion i → i, audio j → j) or concatenated.
//! - `attention = qra`: QRA in the chosen cross-modal layers (`qra_layers`), or one
//!   motion-queries-audio block before the stack (`qra_topology = cross_prefix`).
//! - `input_fusion = quaternion_254`: the literal joint-frame quaternion embedding.
//! - `dropout`: probabilities, branch outputs and embeddings (QEAN Fig. 4).
//!
//! With every switch at its FACT value the parameters have FACT's names and shapes, and the
//! forward pass is FACT's (tested by loading FACT weights).

use burn::module::Module;
use burn::nn::{Dropout, DropoutConfig, Linear};
use burn::tensor::{Device, Tensor};

use crate::cross_prefix::{CrossPrefix, CrossPrefixConfig};
use crate::init::{glorot_dense, truncated_normal_dense};
use crate::input_fusion::{QuaternionFusion, QuaternionFusionConfig};
use crate::position::{PositionEmbedding, PositionEmbeddingConfig};
use crate::qra::{QraConfig, QraPenalty};
use crate::spe::{RotaryTables, Spe, SpeConfig};
use crate::transformer::{BlockConfig, StackContext, Transformer, TransformerConfig};
use qean_config::model::{
    AttentionKind, CrossPositions, DropoutSite, InputFusion, ModelConfig, PositionKind,
    QraPositions, QraTopology,
};

/// Configuration of [`Qean`]: the whole `[model]` table.
#[derive(Clone, Debug, PartialEq)]
pub struct QeanConfig {
    /// The model options.
    pub model: ModelConfig,
}

/// Prediction and (when QRA penalties are weighted) the weighted penalty to add to the loss.
#[derive(Clone, Debug)]
pub struct ModelOutput {
    /// [B, N_motion + N_audio, D].
    pub prediction: Tensor<3>,
    /// λ_ω·mean smoothness + λ_θ·mean θ² over the QRA layers; None when both weights are 0.
    pub penalty: Option<Tensor<1>>,
}

/// QEAN (and FACT-architecture baselines).
#[derive(Module, Debug)]
pub struct Qean {
    /// Dense(motion_dim → C).
    pub motion_embed: Linear,
    /// Learned P_m (absent with SPE unless `keep_abs_pos`).
    pub motion_pos: Option<PositionEmbedding>,
    /// Motion encoder.
    pub motion_transformer: Transformer,
    /// Dense(audio_dim → C) (`input_fusion = dense`).
    pub audio_embed: Option<Linear>,
    /// Literal quaternion fusion (`input_fusion = quaternion_254`).
    pub audio_fusion: Option<QuaternionFusion>,
    /// Learned P_a.
    pub audio_pos: Option<PositionEmbedding>,
    /// Audio encoder.
    pub audio_transformer: Transformer,
    /// Motion-queries-audio QRA block (`qra_topology = cross_prefix`).
    pub cross_prefix: Option<CrossPrefix>,
    /// Cross-modal transformer.
    pub cross_transformer: Transformer,
    /// Dense(C → motion_dim), truncated-normal kernel.
    pub output: Linear,
    /// Dropout after embedding + position.
    pub embed_dropout: Dropout,
    /// Rotary encoder at the head width (SPE on).
    pub spe: Option<Spe>,
    /// Rotary encoder at QRA's q/k head width (SPE and QRA on).
    pub qra_spe: Option<Spe>,
    #[module(skip)]
    options: QeanOptions,
}

/// The switches the forward pass reads.
#[derive(Clone, Debug)]
struct QeanOptions {
    cross_positions: CrossPositions,
    qra_positions: QraPositions,
    lambda_omega: f64,
    lambda_theta: f64,
}

impl From<&ModelConfig> for QeanConfig {
    fn from(c: &ModelConfig) -> Self {
        QeanConfig { model: c.clone() }
    }
}

impl QeanConfig {
    /// Wraps a model config.
    pub fn new(model: ModelConfig) -> Self {
        Self { model }
    }

    fn qra_config(&self) -> QraConfig {
        let c = &self.model;
        QraConfig::new(c.hidden, c.heads)
            .with_periods(c.qra.periods)
            .with_kernel(c.qra.kernel)
            .with_scale(c.attn_scale)
            .with_two_pi(c.qra.two_pi)
            .with_dk(c.qra.dk)
            .with_conv_input(c.qra.conv_input)
            .with_qk_proj(c.qra.qk_proj)
            .with_dropout(c.dropout_at(DropoutSite::Attention))
            .with_init(c.qra.init)
    }

    /// Builds the model (mint's initialisers for the FACT parts).
    pub fn init(&self, device: &Device) -> Qean {
        let c = &self.model;
        let block = BlockConfig::new(c.hidden, c.heads, c.ffn)
            .with_scale(c.attn_scale)
            .with_attention_dropout(c.dropout_at(DropoutSite::Attention))
            .with_residual_dropout(c.dropout_at(DropoutSite::Residual));
        let stack = |layers| TransformerConfig::uniform(layers, block.clone()).init(device);
        let cross_blocks = (0..c.cross_layers)
            .map(|l| {
                let qra = c.layer_uses_qra(l).then(|| self.qra_config());
                block.clone().with_qra(qra)
            })
            .collect();
        let learned = c.learned_positions();
        let rotary = c.position == PositionKind::Rotary;
        let uses_qra = c.attention == AttentionKind::Qra;
        Qean {
            motion_embed: glorot_dense(c.motion_dim(), c.hidden, true, device),
            motion_pos: learned
                .then(|| PositionEmbeddingConfig::new(c.motion_len, c.hidden).init(device)),
            motion_transformer: stack(c.motion_layers),
            audio_embed: (c.input_fusion == InputFusion::Dense)
                .then(|| glorot_dense(c.audio_dim, c.hidden, true, device)),
            audio_fusion: (c.input_fusion == InputFusion::Quaternion254)
                .then(|| QuaternionFusionConfig::new(c.audio_dim, c.hidden).init(device)),
            audio_pos: learned
                .then(|| PositionEmbeddingConfig::new(c.audio_len, c.hidden).init(device)),
            audio_transformer: stack(c.audio_layers),
            cross_prefix: (uses_qra && c.qra.topology == QraTopology::CrossPrefix).then(|| {
                CrossPrefixConfig::new(self.qra_config())
                    .with_residual_dropout(c.dropout_at(DropoutSite::Residual))
                    .init(device)
            }),
            cross_transformer: TransformerConfig::new(cross_blocks).init(device),
            output: truncated_normal_dense(c.hidden, c.motion_dim(), 0.02, device),
            embed_dropout: DropoutConfig::new(c.dropout_at(DropoutSite::Embedding)).init(),
            spe: rotary.then(|| rope(c, c.head_dim())),
            qra_spe: (rotary && uses_qra).then(|| rope(c, c.qra_qk_head_dim())),
            options: QeanOptions {
                cross_positions: c.rope.cross_positions,
                qra_positions: c.qra.positions,
                lambda_omega: c.qra.lambda_omega,
                lambda_theta: c.qra.lambda_theta,
            },
        }
    }
}

fn rope(c: &ModelConfig, head_dim: usize) -> Spe {
    SpeConfig::new(head_dim)
        .with_base(c.rope.base)
        .with_pairing(c.rope.pairing)
        .init()
}

/// Rotary tables at the head width and at QRA's q/k width for one token sequence.
struct Tables {
    head: Option<RotaryTables>,
    qra: Option<RotaryTables>,
}

impl Tables {
    /// Context of the motion and audio encoders (softmax attention only).
    fn encoder_context(&self) -> StackContext<'_> {
        StackContext {
            rope: self.head.as_ref(),
            qra_rope: None,
            qra_positions: &[],
        }
    }
}

impl Qean {
    fn tables(&self, positions: &[f64], like: &Tensor<3>) -> Tables {
        let (device, dtype) = (like.device(), like.dtype());
        Tables {
            head: self
                .spe
                .as_ref()
                .map(|s| s.tables(positions, &device, dtype)),
            qra: self
                .qra_spe
                .as_ref()
                .map(|s| s.tables(positions, &device, dtype)),
        }
    }

    /// motion [B, Lm, D], audio [B, La, A] → [B, Lm + La, D].
    pub fn forward(&self, motion: Tensor<3>, audio: Tensor<3>) -> Tensor<3> {
        self.forward_with_penalty(motion, audio).prediction
    }

    /// The prediction and the weighted QRA penalty (for training).
    pub fn forward_with_penalty(&self, motion: Tensor<3>, audio: Tensor<3>) -> ModelOutput {
        self.run(motion, audio, false)
    }

    /// Token 0 of [`Qean::forward`], [B, 1, D]: the prediction of the next frame, all the sampler
    /// needs (the last cross-modal block computes only that token where it can).
    pub fn forward_first(&self, motion: Tensor<3>, audio: Tensor<3>) -> Tensor<3> {
        self.run(motion, audio, true).prediction
    }

    /// The motion encoder (positions 0..Lm): embedding, positions, dropout, transformer.
    fn encode_motion(&self, motion: Tensor<3>) -> Tensor<3> {
        let lm = motion.dims()[1];
        let m = self.motion_embed.forward(motion);
        let m = self.embed_dropout.forward(match &self.motion_pos {
            Some(p) => p.forward(m),
            None => m,
        });
        let tables = self.tables(&Spe::range(lm), &m);
        self.motion_transformer
            .forward(m, tables.encoder_context())
            .0
    }

    /// The audio encoder (positions 0..La): dense embedding or the quaternion fusion of [audio | motion]
    /// frames (eq. 25), positions, dropout, transformer.
    fn encode_audio(&self, audio: Tensor<3>, motion: Tensor<3>) -> Tensor<3> {
        let la = audio.dims()[1];
        let a = match (&self.audio_embed, &self.audio_fusion) {
            (Some(dense), _) => dense.forward(audio),
            (None, Some(fusion)) => fusion.forward(audio, motion),
            (None, None) => unreachable!("QeanConfig::init sets one audio embedding"),
        };
        let a = self.embed_dropout.forward(match &self.audio_pos {
            Some(p) => p.forward(a),
            None => a,
        });
        let tables = self.tables(&Spe::range(la), &a);
        self.audio_transformer
            .forward(a, tables.encoder_context())
            .0
    }

    /// The optional motion-queries-audio QRA block before the cross-modal stack; its penalty is added
    /// to `penalties`.
    fn motion_queries_audio(
        &self,
        m: Tensor<3>,
        a: &Tensor<3>,
        penalties: &mut Vec<QraPenalty>,
    ) -> Tensor<3> {
        let Some(prefix) = &self.cross_prefix else {
            return m;
        };
        let (lm, la) = (m.dims()[1], a.dims()[1]);
        let (mq, ak) = match self.options.qra_positions {
            QraPositions::Concatenated => (fractions(lm, lm), fractions(la, la)),
            QraPositions::TimeAligned => (fractions(lm, la), fractions(la, la)),
        };
        let qm = self.tables(&Spe::range(lm), &m).qra;
        let qa = self.tables(&Spe::range(la), a).qra;
        let (m, p) = prefix.forward(m, a.clone(), (&mq, &ak), (qm.as_ref(), qa.as_ref()));
        penalties.push(p);
        m
    }

    /// Positions of the cross-modal stack's tokens [motion | audio]: for the rotary tables, and for QRA.
    fn cross_positions(&self, lm: usize, la: usize) -> (Vec<f64>, Vec<f64>) {
        let rope: Vec<f64> = match self.options.cross_positions {
            CrossPositions::PerModality => {
                Spe::range(lm).into_iter().chain(Spe::range(la)).collect()
            }
            CrossPositions::Concatenated => Spe::range(lm + la),
        };
        let qra: Vec<f64> = match self.options.qra_positions {
            QraPositions::Concatenated => fractions(lm + la, lm + la),
            QraPositions::TimeAligned => fractions(lm, la)
                .into_iter()
                .chain(fractions(la, la))
                .collect(),
        };
        (rope, qra)
    }

    fn run(&self, motion: Tensor<3>, audio: Tensor<3>, first_only: bool) -> ModelOutput {
        let [_, lm, _] = motion.dims();
        let [_, la, _] = audio.dims();
        let mut penalties: Vec<QraPenalty> = Vec::new();
        let m = self.encode_motion(motion.clone());
        let a = self.encode_audio(audio, motion);
        let m = self.motion_queries_audio(m, &a, &mut penalties);

        // Cross-modal stack over [motion | audio].
        let x = Tensor::cat(vec![m, a], 1);
        let (rope_positions, qra_positions) = self.cross_positions(lm, la);
        let x_tables = self.tables(&rope_positions, &x);
        let ctx = StackContext {
            rope: x_tables.head.as_ref(),
            qra_rope: x_tables.qra.as_ref(),
            qra_positions: &qra_positions,
        };
        let x = if first_only {
            self.cross_transformer.forward_first(x, ctx)
        } else {
            let (x, p) = self.cross_transformer.forward(x, ctx);
            penalties.extend(p);
            x
        };
        ModelOutput {
            prediction: self.output.forward(x),
            penalty: self.weighted_penalty(penalties),
        }
    }

    fn weighted_penalty(&self, penalties: Vec<QraPenalty>) -> Option<Tensor<1>> {
        let (lw, lt) = (self.options.lambda_omega, self.options.lambda_theta);
        if penalties.is_empty() || (lw == 0.0 && lt == 0.0) {
            return None;
        }
        let n = penalties.len() as f64;
        penalties
            .into_iter()
            .map(|p| p.omega_smoothness.mul_scalar(lw / n) + p.theta_square.mul_scalar(lt / n))
            .reduce(|a, b| a + b)
    }
}

/// i/denominator for i in 0..len (QRA's pos_n).
fn fractions(len: usize, denominator: usize) -> Vec<f64> {
    (0..len).map(|i| i as f64 / denominator as f64).collect()
}
