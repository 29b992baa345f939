//! Li et al.'s Two-Stream Motion Transformer (SPEC §11.5; the authors' `two_stream_transformer_discrete.py`):
//! a causal pose stream over binned joint coordinates and a causal audio stream over MFCCs and beat
//! tokens, fused per frame into one categorical distribution per coordinate (a classifier shared
//! over coordinates).
//!
//! Blocks are post-LN with a kernel-1 convolutional feed-forward whose hidden width is the model
//! width; q/k/v heads have their own width d_k (not D/H). Positions are a frozen sinusoid table
//! with row 0 for padding; valid tokens sit at positions 1.. .

use burn::module::{Module, Param};
use burn::nn::{Dropout, DropoutConfig, Initializer, LayerNorm, LayerNormConfig, Linear};
use burn::tensor::activation::{relu, softmax, tanh};
use burn::tensor::{Device, Int, Tensor, TensorData};

use crate::attention::{merge_heads, split_heads};
use qean_config::tsmt::{AudioStreams, TsmtConfig};

/// MFCC c0..c12 and their deltas (SPEC §11.4).
pub const MFCC_DIM: usize = 26;
/// Width of the MFCC and beat embeddings before the audio stream's input conv.
const AUDIO_EMBED: usize = 30;
/// Beat tokens: 0 no beat, 1 beat, 2 padding.
pub const BEAT_PAD: i64 = 2;

/// PyTorch's default Linear / kernel-1 Conv1d initialiser: U(±1/√fan_in).
fn torch_uniform(d_in: usize) -> Initializer {
    let bound = 1.0 / (d_in as f64).sqrt();
    Initializer::Uniform {
        min: -bound,
        max: bound,
    }
}

/// PyTorch's default Linear / kernel-1 Conv1d: weight and bias U(±1/√fan_in).
fn torch_linear(d_in: usize, d_out: usize, device: &Device) -> Linear {
    linear_with(torch_uniform(d_in), d_in, d_out, device)
}

/// A Linear with the given weight initialiser and PyTorch's default bias.
fn linear_with(weight: Initializer, d_in: usize, d_out: usize, device: &Device) -> Linear {
    Linear {
        weight: weight.init_with([d_in, d_out], Some(d_in), Some(d_out), device),
        bias: Some(torch_uniform(d_in).init([d_out], device)),
    }
}

/// An embedding table whose last row is padding: always zero, never trained (PyTorch's `padding_idx`).
#[derive(Module, Debug)]
pub struct PaddedEmbedding {
    /// [rows, width], N(0, 1); the last row is masked out on use.
    pub table: Param<Tensor<2>>,
}

impl PaddedEmbedding {
    fn new(rows: usize, width: usize, device: &Device) -> Self {
        Self {
            table: Initializer::Normal {
                mean: 0.0,
                std: 1.0,
            }
            .init([rows, width], device),
        }
    }

    /// Rows of `ids` (any shape, flattened) → [ids, width]; the padding row reads as zeros.
    fn lookup(&self, ids: Tensor<1, Int>) -> Tensor<2> {
        let table = self.table.val();
        let [rows, _] = table.dims();
        let keep: Vec<f32> = (0..rows).map(|r| (r + 1 < rows) as u8 as f32).collect();
        let keep = Tensor::<2>::from_data(TensorData::new(keep, [rows, 1]), &table.device());
        (table * keep).select(0, ids)
    }
}

/// The frozen sinusoid table's rows for `positions` ([B, N] → [B, N, width]); position 0 is zeros.
fn sinusoid(positions: &[usize], batch: usize, width: usize, device: &Device) -> Tensor<3> {
    let n = positions.len() / batch;
    let mut v = Vec::with_capacity(positions.len() * width);
    for &p in positions {
        for c in 0..width {
            let value = if p == 0 {
                0.0
            } else {
                let angle = p as f64 / 10000f64.powf((2 * (c / 2)) as f64 / width as f64);
                if c % 2 == 0 {
                    angle.sin()
                } else {
                    angle.cos()
                }
            };
            v.push(value as f32);
        }
    }
    Tensor::from_data(TensorData::new(v, [batch, n, width]), device)
}

/// Sizes of one block.
#[derive(Clone, Copy, Debug)]
struct BlockSize {
    width: usize,
    heads: usize,
    head_dim: usize,
}

/// One post-LN block (SPEC §11.5 step 2).
#[derive(Module, Debug)]
pub struct TsmtBlock {
    pub query: Linear,
    pub key: Linear,
    pub value: Linear,
    pub output: Linear,
    pub attention_norm: LayerNorm,
    /// Kernel-1 Conv1d(D → D), ReLU, Conv1d(D → D).
    pub conv1: Linear,
    pub conv2: Linear,
    pub ffn_norm: LayerNorm,
    pub attention_dropout: Dropout,
    pub residual_dropout: Dropout,
    heads: usize,
    head_dim: usize,
}

impl TsmtBlock {
    fn new(s: BlockSize, dropout: f64, device: &Device) -> Self {
        let hd = s.heads * s.head_dim;
        // W_q, W_k, W_v ~ N(0, 2/(D + d_k)) (the reference's init).
        let qkv_std = (2.0 / (s.width + s.head_dim) as f64).sqrt();
        let normal = || Initializer::Normal {
            mean: 0.0,
            std: qkv_std,
        };
        Self {
            query: linear_with(normal(), s.width, hd, device),
            key: linear_with(normal(), s.width, hd, device),
            value: linear_with(normal(), s.width, hd, device),
            output: linear_with(Initializer::XavierNormal { gain: 1.0 }, hd, s.width, device),
            attention_norm: LayerNormConfig::new(s.width)
                .with_epsilon(1e-5)
                .init(device),
            conv1: torch_linear(s.width, s.width, device),
            conv2: torch_linear(s.width, s.width, device),
            ffn_norm: LayerNormConfig::new(s.width)
                .with_epsilon(1e-5)
                .init(device),
            attention_dropout: DropoutConfig::new(dropout).init(),
            residual_dropout: DropoutConfig::new(dropout).init(),
            heads: s.heads,
            head_dim: s.head_dim,
        }
    }

    /// x [B, N, D] → [B, N, D] under the causal `bias` ([N, N]: 0 or −1e9); `mask` [B, N, 1] zeroes
    /// padding tokens after each sub-layer.
    fn forward(&self, x: Tensor<3>, bias: Tensor<4>, mask: Tensor<3>) -> Tensor<3> {
        self.forward_with(x, bias, Some(mask), None)
    }

    /// The block over new tokens x [B, s, D] that attend to the `cache`d keys and values of the
    /// tokens before them (appended to it); `bias` is [s, t + s]. Without a mask every token is valid.
    fn forward_with(
        &self,
        x: Tensor<3>,
        bias: Tensor<4>,
        mask: Option<Tensor<3>>,
        cache: Option<&mut Option<(Tensor<4>, Tensor<4>)>>,
    ) -> Tensor<3> {
        let q = split_heads(self.query.forward(x.clone()), self.heads);
        let mut k = split_heads(self.key.forward(x.clone()), self.heads);
        let mut v = split_heads(self.value.forward(x.clone()), self.heads);
        if let Some(cache) = cache {
            if let Some((k0, v0)) = cache.take() {
                k = Tensor::cat(vec![k0, k], 2);
                v = Tensor::cat(vec![v0, v], 2);
            }
            *cache = Some((k.clone(), v.clone()));
        }
        let scores = q
            .mul_scalar(1.0 / (self.head_dim as f64).sqrt())
            .matmul(k.swap_dims(2, 3))
            + bias;
        let probs = self.attention_dropout.forward(softmax(scores, 3));
        let z = self.output.forward(merge_heads(probs.matmul(v)));
        let masked = |y: Tensor<3>| match &mask {
            Some(m) => y * m.clone(),
            None => y,
        };
        let x = masked(
            self.attention_norm
                .forward(x + self.residual_dropout.forward(z)),
        );
        let h = self.conv2.forward(relu(self.conv1.forward(x.clone())));
        masked(self.ffn_norm.forward(x + self.residual_dropout.forward(h)))
    }
}

/// A stack of blocks over an embedded input.
#[derive(Module, Debug)]
pub struct Stream {
    /// Kernel-1 Conv1d from the embedded input to the stream width.
    pub input: Linear,
    pub blocks: Vec<TsmtBlock>,
    pub embed_dropout: Dropout,
    width: usize,
}

impl Stream {
    fn new(d_in: usize, s: BlockSize, layers: usize, dropout: f64, device: &Device) -> Self {
        Self {
            input: torch_linear(d_in, s.width, device),
            blocks: (0..layers)
                .map(|_| TsmtBlock::new(s, dropout, device))
                .collect(),
            embed_dropout: DropoutConfig::new(dropout).init(),
            width: s.width,
        }
    }

    fn forward(&self, x: Tensor<3>, ctx: &Context) -> Tensor<3> {
        self.forward_with(x, ctx, None)
    }

    /// The stream over `ctx`'s tokens; with `cache`, over new tokens after the cached ones.
    fn forward_with(&self, x: Tensor<3>, ctx: &Context, cache: Option<&mut KvCache>) -> Tensor<3> {
        let [b, _, _] = x.dims();
        let pe = sinusoid(&ctx.positions, b, self.width, &x.device());
        let mut h = self.embed_dropout.forward(self.input.forward(x) + pe);
        match cache {
            None => {
                for block in &self.blocks {
                    h = block.forward(h, ctx.bias.clone(), ctx.mask.clone());
                }
            }
            Some(cache) => {
                cache.layers.resize(self.blocks.len(), None);
                for (block, kv) in self.blocks.iter().zip(&mut cache.layers) {
                    h = block.forward_with(h, ctx.bias.clone(), None, Some(kv));
                }
            }
        }
        h
    }
}

/// Keys and values of the tokens a stream has seen, per block: [B, H, t, d_k] each (SPEC §11.8
/// step 4).
#[derive(Clone, Debug, Default)]
pub struct KvCache {
    layers: Vec<Option<(Tensor<4>, Tensor<4>)>>,
}

/// The caches of every stream and how many tokens they hold (positions continue from there).
#[derive(Clone, Debug, Default)]
pub struct TsmtCache {
    pose: KvCache,
    audio: KvCache,
    beat: KvCache,
    len: usize,
}

impl TsmtCache {
    /// Tokens cached so far.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// Positions, causal bias and padding mask shared by both streams.
struct Context {
    positions: Vec<usize>,
    bias: Tensor<4>,
    mask: Tensor<3>,
}

impl Context {
    fn new(lengths: &[usize], n: usize, device: &Device) -> Self {
        let b = lengths.len();
        let positions: Vec<usize> = lengths
            .iter()
            .flat_map(|&len| (0..n).map(move |t| if t < len { t + 1 } else { 0 }))
            .collect();
        let mask: Vec<f32> = positions.iter().map(|&p| (p > 0) as u8 as f32).collect();
        let bias: Vec<f32> = (0..n * n)
            .map(|i| if i % n > i / n { -1e9 } else { 0.0 })
            .collect();
        Self {
            positions,
            bias: Tensor::from_data(TensorData::new(bias, [1, 1, n, n]), device),
            mask: Tensor::from_data(TensorData::new(mask, [b, n, 1]), device),
        }
    }

    /// `s` new valid tokens after `t` cached ones in each of `b` rows: positions t+1..t+s, and a
    /// bias [s, t + s] hiding keys after each query.
    fn after(b: usize, t: usize, s: usize, device: &Device) -> Self {
        let positions = (0..b).flat_map(|_| t + 1..=t + s).collect();
        let keys = t + s;
        let bias: Vec<f32> = (0..s * keys)
            .map(|i| if i % keys > t + i / keys { -1e9 } else { 0.0 })
            .collect();
        Self {
            positions,
            bias: Tensor::from_data(TensorData::new(bias, [1, 1, s, keys]), device),
            mask: Tensor::ones([b, s, 1], device),
        }
    }
}

/// The audio branch: one stream over [MFCC ; beat] (`single`) or a beat and an MFCC stream (`split`).
#[derive(Module, Debug)]
pub struct AudioBranch {
    /// Linear(26 → 30) then tanh: the MFCC embedding.
    pub mfcc: Linear,
    /// [3, 30], row 2 = padding.
    pub beat: PaddedEmbedding,
    /// `single`: the joint stream; `split`: the MFCC stream.
    pub stream: Stream,
    /// `split` only: the beat stream.
    pub beat_stream: Option<Stream>,
}

/// One batch: pose tokens, audio, and how many tokens of each row are valid (the rest is padding).
#[derive(Debug, Clone)]
pub struct TsmtInput {
    /// [B, N, n] bins, padding = C.
    pub tokens: Tensor<3, Int>,
    /// [B, N, 26] MFCC c0..c12 and deltas of the frame each token predicts.
    pub mfcc: Tensor<3>,
    /// [B, N] beat tokens of the same frames (padding = 2).
    pub beat: Tensor<2, Int>,
    /// Valid tokens per row (padding follows them).
    pub lengths: Vec<usize>,
}

/// The whole model.
#[derive(Module, Debug)]
pub struct Tsmt {
    /// [C + 1, D_E], row C = padding.
    pub pose_embed: PaddedEmbedding,
    /// The pose stream (its input is the temporal-wise FC, n·D_E → D).
    pub pose: Stream,
    pub audio: AudioBranch,
    /// Linear(D + D_a(·2) → n·d_out).
    pub fuse: Linear,
    /// Linear(d_out → C), shared over coordinates.
    pub classifier: Linear,
    coords: usize,
    d_out: usize,
}

impl Tsmt {
    /// Builds the model a `[tsmt]` table describes (PyTorch's initialisers, SPEC §11.5 step 5).
    pub fn new(c: &TsmtConfig, device: &Device) -> Self {
        let n = c.coords();
        let pose = BlockSize {
            width: c.hidden,
            heads: c.heads,
            head_dim: c.head_dim,
        };
        let audio = BlockSize {
            width: c.audio_hidden,
            heads: c.audio_heads,
            head_dim: c.audio_head_dim,
        };
        let split = c.audio_streams == AudioStreams::Split;
        let stream_in = if split { AUDIO_EMBED } else { 2 * AUDIO_EMBED };
        let audio_width = if split { 2 } else { 1 } * c.audio_hidden;
        Self {
            pose_embed: PaddedEmbedding::new(c.n_bins + 1, c.embed, device),
            pose: Stream::new(n * c.embed, pose, c.layers, c.dropout, device),
            audio: AudioBranch {
                mfcc: torch_linear(MFCC_DIM, AUDIO_EMBED, device),
                beat: PaddedEmbedding::new(3, AUDIO_EMBED, device),
                stream: Stream::new(stream_in, audio, c.audio_layers, c.dropout, device),
                beat_stream: split
                    .then(|| Stream::new(AUDIO_EMBED, audio, c.audio_layers, c.dropout, device)),
            },
            fuse: torch_linear(c.hidden + audio_width, n * c.d_out, device),
            classifier: torch_linear(c.d_out, c.n_bins, device),
            coords: n,
            d_out: c.d_out,
        }
    }

    /// Logits [B, N, n, C]: the distribution of each coordinate of the frame after each token.
    pub fn forward(&self, input: TsmtInput) -> Tensor<4> {
        let [_, t, _] = input.tokens.dims();
        let ctx = Context::new(&input.lengths, t, &input.mfcc.device());
        self.forward_with(input.tokens, input.mfcc, input.beat, &ctx, None)
    }

    /// Logits [B, s, n, C] of `s` new valid tokens (all rows alike) after the ones `cache` holds,
    /// whose keys and values it keeps: running a sequence in pieces gives the logits of
    /// [`Tsmt::forward`] on the whole (attention is causal, the rest per token).
    pub fn forward_cached(
        &self,
        tokens: Tensor<3, Int>,
        mfcc: Tensor<3>,
        beat: Tensor<2, Int>,
        cache: &mut TsmtCache,
    ) -> Tensor<4> {
        let [b, s, _] = tokens.dims();
        let ctx = Context::after(b, cache.len, s, &mfcc.device());
        let logits = self.forward_with(tokens, mfcc, beat, &ctx, Some(cache));
        cache.len += s;
        logits
    }

    fn forward_with(
        &self,
        tokens: Tensor<3, Int>,
        mfcc: Tensor<3>,
        beat: Tensor<2, Int>,
        ctx: &Context,
        cache: Option<&mut TsmtCache>,
    ) -> Tensor<4> {
        let [b, t, n] = tokens.dims();
        let e = self
            .pose_embed
            .lookup(tokens.reshape([b * t * n]))
            .reshape([b, t, n * self.pose_embed.table.dims()[1]]);
        let (zx, za) = match cache {
            None => (
                self.pose.forward(e, ctx),
                self.audio_forward(mfcc, beat, ctx, None),
            ),
            Some(c) => (
                self.pose.forward_with(e, ctx, Some(&mut c.pose)),
                self.audio_forward(mfcc, beat, ctx, Some((&mut c.audio, &mut c.beat))),
            ),
        };
        let u = self.fuse.forward(Tensor::cat(vec![zx, za], 2)).reshape([
            b,
            t,
            self.coords,
            self.d_out,
        ]);
        self.classifier.forward(u)
    }

    fn audio_forward(
        &self,
        mfcc: Tensor<3>,
        beat: Tensor<2, Int>,
        ctx: &Context,
        cache: Option<(&mut KvCache, &mut KvCache)>,
    ) -> Tensor<3> {
        let [b, t] = beat.dims();
        let m = tanh(self.audio.mfcc.forward(mfcc));
        let bt = self
            .audio
            .beat
            .lookup(beat.reshape([b * t]))
            .reshape([b, t, AUDIO_EMBED]);
        let (audio_cache, beat_cache) = match cache {
            Some((a, b)) => (Some(a), Some(b)),
            None => (None, None),
        };
        match &self.audio.beat_stream {
            None => self
                .audio
                .stream
                .forward_with(Tensor::cat(vec![m, bt], 2), ctx, audio_cache),
            Some(beats) => Tensor::cat(
                vec![
                    beats.forward_with(bt, ctx, beat_cache),
                    self.audio.stream.forward_with(m, ctx, audio_cache),
                ],
                2,
            ),
        }
    }

    /// Coordinates per frame, n.
    pub fn coords(&self) -> usize {
        self.coords
    }
}

/// SPEC §11.6's closed-form parameter count (`tsmt_params`): trainable tensors, padding rows
/// included, the frozen sinusoid tables not.
pub fn tsmt_params(c: &TsmtConfig) -> usize {
    tsmt_params_for(c, c.coords())
}

/// [`tsmt_params`] for `n` coordinates per frame (48: the reference's 16 H36M joints).
pub fn tsmt_params_for(c: &TsmtConfig, n: usize) -> usize {
    let blk = |d: usize, h: usize, dk: usize| {
        2 * h * dk * (d + 1) + h * dk * (2 * d + 1) + 2 * d * d + 7 * d
    };
    let (cc, de, d, da) = (c.n_bins, c.embed, c.hidden, c.audio_hidden);
    let pose = (cc + 1) * de + n * de * d + d + c.layers * blk(d, c.heads, c.head_dim);
    let a_blk = c.audio_layers * blk(da, c.audio_heads, c.audio_head_dim);
    let (audio, fused) = match c.audio_streams {
        AudioStreams::Single => (900 + 61 * da + a_blk, d + da),
        AudioStreams::Split => (900 + 2 * (31 * da + a_blk), d + 2 * da),
    };
    pose + audio + fused * n * c.d_out + n * c.d_out + c.d_out * cc + cc
}

#[cfg(test)]
mod tests {
    use super::*;
    use qean_config::tsmt::RootMode;

    fn count(c: &TsmtConfig) -> usize {
        Tsmt::new(c, &Device::flex()).num_params()
    }

    /// A deterministic batch: tokens, MFCCs and beats as functions of (row, frame, coordinate).
    fn batch(
        c: &TsmtConfig,
        rows: usize,
        frames: usize,
        lengths: &[usize],
        salt: i64,
    ) -> TsmtInput {
        let n = c.coords();
        let device = Device::flex();
        let mut tokens = Vec::new();
        let mut mfcc = Vec::new();
        let mut beat = Vec::new();
        for (r, &len) in lengths.iter().enumerate().take(rows) {
            for t in 0..frames {
                let valid = t < len;
                for d in 0..n {
                    let k = (r as i64 * 31 + t as i64 * 17 + d as i64 * 7 + salt) % c.n_bins as i64;
                    tokens.push(if valid { k } else { c.n_bins as i64 });
                }
                for m in 0..MFCC_DIM {
                    let x = ((r * 13 + t * 5 + m) as f32 * 0.37).sin() * 30.0;
                    mfcc.push(if valid { x } else { 0.0 });
                }
                beat.push(if valid {
                    ((t + r) % 4 == 0) as i64
                } else {
                    BEAT_PAD
                });
            }
        }
        TsmtInput {
            tokens: Tensor::from_data(TensorData::new(tokens, [rows, frames, n]), &device),
            mfcc: Tensor::from_data(TensorData::new(mfcc, [rows, frames, MFCC_DIM]), &device),
            beat: Tensor::from_data(TensorData::new(beat, [rows, frames]), &device),
            lengths: lengths.to_vec(),
        }
    }

    fn values(x: Tensor<4>) -> Vec<f32> {
        x.into_data().try_to_vec::<f32>().unwrap()
    }

    #[test]
    fn logits_are_causal_and_padding_changes_no_valid_logit() {
        for streams in [AudioStreams::Single, AudioStreams::Split] {
            let c = TsmtConfig {
                audio_streams: streams,
                ..TsmtConfig::tiny()
            };
            let device = Device::flex();
            device.seed(7);
            let model = Tsmt::new(&c, &device);
            let (t, n, cc) = (12, c.coords(), c.n_bins);
            let base = model.forward(batch(&c, 2, t, &[t, t], 0));
            assert_eq!(base.dims(), [2, t, n, cc]);
            let base = values(base);
            // Change every input of frame j (tokens, MFCCs, beats) by rebuilding the batch with
            // another salt there: logits before j must not move.
            let j = 7;
            let mut other = batch(&c, 2, t, &[t, t], 0);
            let changed = batch(&c, 2, t, &[t, t], 5);
            other.tokens = other.tokens.slice_assign(
                [0..2, j..j + 1, 0..n],
                changed.tokens.clone().slice([0..2, j..j + 1, 0..n]),
            );
            other.mfcc = other.mfcc.clone().slice_assign(
                [0..2, j..j + 1, 0..MFCC_DIM],
                other
                    .mfcc
                    .slice([0..2, j..j + 1, 0..MFCC_DIM])
                    .add_scalar(3.0),
            );
            let moved = values(model.forward(other));
            let per_frame = n * cc;
            for row in 0..2 {
                let at = |v: &[f32], f: usize| {
                    v[(row * t + f) * per_frame..(row * t + f + 1) * per_frame].to_vec()
                };
                for f in 0..j {
                    assert_eq!(at(&base, f), at(&moved, f), "{streams:?} frame {f}");
                }
                assert_ne!(
                    at(&base, j),
                    at(&moved, j),
                    "{streams:?}: frame {j} must see its input"
                );
            }
            // A row padded after 5 tokens gives the logits of the same 5 tokens alone.
            let padded = values(model.forward(batch(&c, 1, t, &[5], 0)));
            let alone = values(model.forward(batch(&c, 1, 5, &[5], 0)));
            let diff = padded[..5 * per_frame]
                .iter()
                .zip(&alone)
                .map(|(a, b)| (a - b).abs())
                .fold(0f32, f32::max);
            assert!(
                diff < 1e-5,
                "{streams:?}: padding moved a valid logit by {diff}"
            );
        }
    }

    #[test]
    fn parameter_counts_match_spec() {
        let paper = TsmtConfig::paper();
        assert_eq!(count(&paper), 1_419_388);
        assert_eq!(count(&TsmtConfig::tiny()), 37_524);
        let delta = TsmtConfig {
            root_mode: RootMode::Delta,
            ..paper.clone()
        };
        assert_eq!(count(&delta), 1_428_058);
        for c in [
            paper.clone(),
            TsmtConfig::tiny(),
            delta,
            TsmtConfig {
                audio_streams: AudioStreams::Split,
                ..TsmtConfig::tiny()
            },
        ] {
            assert_eq!(count(&c), tsmt_params_for(&c, c.coords()), "{c:?}");
        }
        // The reference as released has n = 48 (16 H36M joints): 1,358,698, `split` 1,395,402.
        let split = TsmtConfig {
            audio_streams: AudioStreams::Split,
            ..paper.clone()
        };
        assert_eq!(tsmt_params_for(&paper, 48), 1_358_698);
        assert_eq!(tsmt_params_for(&split, 48), 1_395_402);
    }
}
