//! The music-to-dance GPT (SPEC §13.3, after Bailando `cross_cond_gpt2.py` and T2M-GPT `t2m_trans.py`): a
//! music base (M-Base: music MLP on 8-frame × 35 music tokens beside the motion tokens, block-causal over the
//! two streams), a text base (T-Base: CLIP embedding then motion tokens, causal, sinusoidal positions) and one
//! shared head (causal blocks, final LN, Linear(D → K+1)). Tokens: codes 0..K−1; the head's extra output is
//! End = K; input tables have K+2 rows (M-Base: Start = K, Mask = K+1; T-Base: End = K, Pad = K+1).

use burn::module::{Module, Param};
use burn::nn::{
    Dropout, DropoutConfig, Embedding, Initializer, LayerNorm, LayerNormConfig, Linear,
};
use burn::tensor::activation::softmax;
use burn::tensor::{Device, Int, Tensor, TensorData};
use qean_config::gpt::{GptConfig, MLayout};

use crate::attention::{merge_heads, split_heads};
use crate::control::genre::GenreModule;
use crate::feed_forward::gelu_tanh;

/// Values per music token: `rate` frames × 35 features, frame-major.
pub fn music_token_dim(c: &GptConfig) -> usize {
    c.rate * 35
}

/// N(0, 0.02) weights and zero biases (Bailando/T2M-GPT `_init_weights`).
/// (Parameters stay lazy, as `crate::init`'s: building a model to count it allocates nothing.)
fn linear(d_in: usize, d_out: usize, bias: bool, device: &Device) -> Linear {
    Linear {
        weight: NORMAL.init_with([d_in, d_out], Some(d_in), Some(d_out), device),
        bias: bias.then(|| Initializer::Zeros.init([d_out], device)),
    }
}

const NORMAL: Initializer = Initializer::Normal {
    mean: 0.0,
    std: 0.02,
};

fn embedding(rows: usize, d: usize, device: &Device) -> Embedding {
    Embedding {
        weight: NORMAL.init([rows, d], device),
    }
}

fn layer_norm(d: usize, device: &Device) -> LayerNorm {
    LayerNormConfig::new(d).with_epsilon(1e-5).init(device)
}

/// Pre-LN block: x += Attn(LN x); x += MLP(LN x). Separate q/k/v with bias, 1/√d_h, dropout on the
/// probabilities and the projection; MLP D → 4D (GELU) → D then dropout. 12D² + 13D parameters.
#[derive(Module, Debug)]
pub struct Block {
    pub ln1: LayerNorm,
    pub query: Linear,
    pub key: Linear,
    pub value: Linear,
    pub proj: Linear,
    pub ln2: LayerNorm,
    pub fc: Linear,
    pub fc_out: Linear,
    pub dropout: Dropout,
    heads: usize,
}

impl Block {
    pub fn new(d: usize, heads: usize, dropout: f64, device: &Device) -> Block {
        Block {
            ln1: layer_norm(d, device),
            query: linear(d, d, true, device),
            key: linear(d, d, true, device),
            value: linear(d, d, true, device),
            proj: linear(d, d, true, device),
            ln2: layer_norm(d, device),
            fc: linear(d, 4 * d, true, device),
            fc_out: linear(4 * d, d, true, device),
            dropout: DropoutConfig::new(dropout).init(),
            heads,
        }
    }

    /// x [B, N, D] under `bias` [1, 1, N, N] (0 allowed, −1e9 masked).
    pub fn forward(&self, x: Tensor<3>, bias: Tensor<4>) -> Tensor<3> {
        self.feed_forward(self.attend(x, bias))
    }

    /// The self-attention half: x + Attn(LN x).
    pub fn attend(&self, x: Tensor<3>, bias: Tensor<4>) -> Tensor<3> {
        self.attend_through(x, bias, [&self.query, &self.key, &self.value, &self.proj])
    }

    /// [`Block::attend`] with other q, k, v and output projections (the keyframe module's, §13.3.5
    /// `mask`), this block's LN and dropout.
    pub fn attend_through(
        &self,
        x: Tensor<3>,
        bias: Tensor<4>,
        [query, key, value, proj]: [&Linear; 4],
    ) -> Tensor<3> {
        let h = self.ln1.forward(x.clone());
        let (q, k, v) = (
            split_heads(query.forward(h.clone()), self.heads),
            split_heads(key.forward(h.clone()), self.heads),
            split_heads(value.forward(h), self.heads),
        );
        let d_h = q.dims()[3];
        let scores = q
            .mul_scalar(1.0 / (d_h as f64).sqrt())
            .matmul(k.swap_dims(2, 3))
            + bias;
        let att = self.dropout.forward(softmax(scores, 3)).matmul(v);
        x + self.dropout.forward(proj.forward(merge_heads(att)))
    }

    /// The MLP half: x + MLP(LN x).
    pub fn feed_forward(&self, x: Tensor<3>) -> Tensor<3> {
        let h = gelu_tanh(self.fc.forward(self.ln2.forward(x.clone())));
        x.clone() + self.dropout.forward(self.fc_out.forward(h))
    }
}

/// 0 where `allowed(q, k)`, −1e9 elsewhere: [1, 1, N, N].
pub fn mask_bias(n: usize, allowed: impl Fn(usize, usize) -> bool, device: &Device) -> Tensor<4> {
    let v: Vec<f32> = (0..n * n)
        .map(|i| if allowed(i / n, i % n) { 0.0 } else { -1e9 })
        .collect();
    Tensor::from_data(TensorData::new(v, [1, 1, n, n]), device)
}

/// SPEC §13.3.5 `causal`: k ≤ q over one stream of n; over two streams of n, pos(k) ≤ pos(q) with
/// pos = index mod n.
pub fn causal_bias(len: usize, streams: usize, device: &Device) -> Tensor<4> {
    let n = len / streams;
    mask_bias(len, |q, k| k % n <= q % n, device)
}

/// Music base: music MLP on music tokens (stream m), token embeddings (stream t), learned zero-initialised
/// positions per stream, L_b blocks; h^M_j is the output at the t_j slot.
#[derive(Module, Debug)]
pub struct MBase {
    /// K + 2 rows: codes, Start, Mask.
    pub tokens: Embedding,
    pub music_in: Linear,
    pub music_out: Linear,
    /// [n, D] each.
    pub pos_music: Param<Tensor<2>>,
    pub pos_tokens: Param<Tensor<2>>,
    pub blocks: Vec<Block>,
    pub dropout: Dropout,
    two_stream: bool,
}

impl MBase {
    pub fn new(c: &GptConfig, device: &Device) -> MBase {
        let d = c.hidden;
        MBase {
            tokens: embedding(c.codes + 2, d, device),
            music_in: linear(music_token_dim(c), d, true, device),
            music_out: linear(d, d, true, device),
            pos_music: Initializer::Zeros.init([c.window, d], device),
            pos_tokens: Initializer::Zeros.init([c.window, d], device),
            blocks: (0..c.base_layers)
                .map(|_| Block::new(d, c.heads, c.dropout, device))
                .collect(),
            dropout: DropoutConfig::new(c.dropout).init(),
            two_stream: c.m_layout == MLayout::TwoStream,
        }
    }

    /// Whether the music and the motion tokens are two streams (`m_layout = two_stream`).
    pub fn two_stream(&self) -> bool {
        self.two_stream
    }

    /// The music MLP: Linear(280 → D) → GELU → Linear(D → D).
    pub fn music(&self, a: Tensor<3>) -> Tensor<3> {
        self.music_out.forward(gelu_tanh(self.music_in.forward(a)))
    }

    /// h^M [B, n, D] from input tokens [B, n] (c_{s+j−1}, Start at the sequence start) and music tokens
    /// [B, n, 280] (a_{s+j}).
    pub fn forward(&self, tokens: Tensor<2, Int>, music: Tensor<3>) -> Tensor<3> {
        self.forward_genre(tokens, music, None)
    }

    /// [`MBase::forward`] with the genre module's eq. 3 sub-layer after every block's self-attention,
    /// attending to the genre tokens G [B, n_g, D] (SPEC §13.5).
    pub fn forward_genre(
        &self,
        tokens: Tensor<2, Int>,
        music: Tensor<3>,
        genre: Option<(&GenreModule, Tensor<3>)>,
    ) -> Tensor<3> {
        let [_, n] = tokens.dims();
        let device = music.device();
        let m = self.music(music) + self.pos_music.val().narrow(0, 0, n).unsqueeze::<3>();
        let t =
            self.tokens.forward(tokens) + self.pos_tokens.val().narrow(0, 0, n).unsqueeze::<3>();
        let streams = if self.two_stream { 2 } else { 1 };
        let (mut x, bias) = if self.two_stream {
            (Tensor::cat(vec![m, t], 1), causal_bias(2 * n, 2, &device))
        } else {
            (m + t, causal_bias(n, 1, &device))
        };
        x = self.dropout.forward(x);
        for (l, b) in self.blocks.iter().enumerate() {
            x = b.attend(x, bias.clone());
            if let Some((module, g)) = &genre {
                let xa = &module.xattn[l];
                x = if streams == 1 || module.all_positions() {
                    x.clone() + xa.forward(x, g.clone(), streams)
                } else {
                    // Only the music stream queries G: x_m += W_o·eq. 3, the token stream unchanged.
                    let music = x.clone().narrow(1, 0, n);
                    let update = xa.forward(music.clone(), g.clone(), 1);
                    Tensor::cat(vec![music + update, x.narrow(1, n, n)], 1)
                };
            }
            x = b.feed_forward(x);
        }
        if self.two_stream {
            x.narrow(1, n, n)
        } else {
            x
        }
    }
}

/// Fixed sinusoidal positions (T2M-GPT PE1d_sincos): even dims sin, odd dims cos, 10000^(2i/D).
pub fn sincos_positions(n: usize, d: usize, device: &Device) -> Tensor<2> {
    let mut v = vec![0f32; n * d];
    for p in 0..n {
        for i in 0..d / 2 {
            let angle = p as f64 / 10000f64.powf(2.0 * i as f64 / d as f64);
            v[p * d + 2 * i] = angle.sin() as f32;
            v[p * d + 2 * i + 1] = angle.cos() as f32;
        }
    }
    Tensor::from_data(TensorData::new(v, [n, d]), device)
}

/// Text base: [Linear(512 → D)(CLIP), E(c_0), …, E(c_{n−2})] + sincos positions, L_b causal blocks.
#[derive(Module, Debug)]
pub struct TBase {
    /// K + 2 rows: codes, End, Pad.
    pub tokens: Embedding,
    pub text_in: Linear,
    pub blocks: Vec<Block>,
}

impl TBase {
    pub fn new(c: &GptConfig, device: &Device) -> TBase {
        TBase {
            tokens: embedding(c.codes + 2, c.hidden, device),
            text_in: linear(c.text_dim, c.hidden, true, device),
            blocks: (0..c.base_layers)
                .map(|_| Block::new(c.hidden, c.heads, c.dropout, device))
                .collect(),
        }
    }

    /// h^T [B, n, D] from the text embedding [B, 512] and input tokens [B, n − 1].
    pub fn forward(&self, text: Tensor<2>, tokens: Tensor<2, Int>) -> Tensor<3> {
        let e = self.text_in.forward(text).unsqueeze_dim::<3>(1);
        self.blocks_over(Tensor::cat(vec![e, self.tokens.forward(tokens)], 1))
    }

    /// h^T [1, 1 + len, D] of one embedding [1, 512] and a context of `tokens` (none at an interval's first
    /// token: the embedding alone predicts it).
    pub fn forward_context(&self, text: Tensor<2>, tokens: &[usize]) -> Tensor<3> {
        let device = text.device();
        let e = self.text_in.forward(text).unsqueeze_dim::<3>(1);
        if tokens.is_empty() {
            return self.blocks_over(e);
        }
        let ids: Vec<i64> = tokens.iter().map(|&t| t as i64).collect();
        let ids = Tensor::<2, Int>::from_data(TensorData::new(ids, [1, tokens.len()]), &device);
        self.blocks_over(Tensor::cat(vec![e, self.tokens.forward(ids)], 1))
    }

    /// Sinusoidal positions and the causal blocks over the embedded inputs.
    fn blocks_over(&self, x: Tensor<3>) -> Tensor<3> {
        let device = x.device();
        let [_, n, d] = x.dims();
        let mut x = x + sincos_positions(n, d, &device).unsqueeze::<3>();
        let bias = causal_bias(n, 1, &device);
        for b in &self.blocks {
            x = b.forward(x, bias.clone());
        }
        x
    }
}

/// The shared head: L_h causal blocks, final LN, Linear(D → K+1, no bias).
#[derive(Module, Debug)]
pub struct Head {
    pub blocks: Vec<Block>,
    pub ln: LayerNorm,
    pub logits: Linear,
}

impl Head {
    pub fn new(c: &GptConfig, device: &Device) -> Head {
        Head {
            blocks: (0..c.head_layers)
                .map(|_| Block::new(c.hidden, c.heads, c.dropout, device))
                .collect(),
            ln: layer_norm(c.hidden, device),
            logits: linear(c.hidden, c.codes + 1, false, device),
        }
    }

    /// Logits [B, n, K+1] of h [B, n, D].
    pub fn forward(&self, h: Tensor<3>) -> Tensor<3> {
        let n = h.dims()[1];
        let bias = causal_bias(n, 1, &h.device());
        let mut x = h;
        for b in &self.blocks {
            x = b.forward(x, bias.clone());
        }
        self.logits.forward(self.ln.forward(x))
    }
}

/// The whole GPT.
#[derive(Module, Debug)]
pub struct Gpt {
    pub m_base: MBase,
    pub t_base: TBase,
    pub head: Head,
}

impl Gpt {
    pub fn new(c: &GptConfig, device: &Device) -> Gpt {
        Gpt {
            m_base: MBase::new(c, device),
            t_base: TBase::new(c, device),
            head: Head::new(c, device),
        }
    }

    /// Music mode: logits [B, n, K+1] of c_{s..s+n} from input tokens and music tokens.
    pub fn music_logits(&self, tokens: Tensor<2, Int>, music: Tensor<3>) -> Tensor<3> {
        self.head.forward(self.m_base.forward(tokens, music))
    }

    /// Music mode with genre control: the genre module's tokens G [B, n_g, D] steer every M-Base block.
    pub fn genre_logits(
        &self,
        tokens: Tensor<2, Int>,
        music: Tensor<3>,
        genre: &GenreModule,
        g: Tensor<3>,
    ) -> Tensor<3> {
        self.head
            .forward(self.m_base.forward_genre(tokens, music, Some((genre, g))))
    }

    /// Text mode: logits [B, n, K+1] from the text embedding and n − 1 input tokens.
    pub fn text_logits(&self, text: Tensor<2>, tokens: Tensor<2, Int>) -> Tensor<3> {
        self.head.forward(self.t_base.forward(text, tokens))
    }
}

/// Parameters by SPEC §13.9's closed forms: (M-Base, head, T-Base).
pub fn gpt_params(c: &GptConfig) -> (usize, usize, usize) {
    let (d, k, n) = (c.hidden, c.codes, c.window);
    let block = 12 * d * d + 13 * d;
    let a = music_token_dim(c);
    let m_base = c.base_layers * block + (k + 2) * d + (a * d + d) + (d * d + d) + 2 * n * d;
    let t_base = c.base_layers * block + (k + 2) * d + c.text_dim * d + d;
    let head = c.head_layers * block + 2 * d + d * (k + 1);
    (m_base, head, t_base)
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::tensor::Distribution;

    #[test]
    fn parameter_counts_equal_the_spec() {
        let device = Device::flex();
        for (c, m, h, t) in [
            (GptConfig::tiny(), 132_480, 108_352, 141_120),
            (GptConfig::paper(), 44_170_752, 43_315_968, 43_709_184),
        ] {
            let g = Gpt::new(&c, &device);
            assert_eq!(
                (
                    g.m_base.num_params(),
                    g.head.num_params(),
                    g.t_base.num_params()
                ),
                (m, h, t)
            );
            assert_eq!(gpt_params(&c), (m, h, t));
        }
        assert_eq!(132_480 + 108_352 + 141_120, 381_952);
    }

    fn random_inputs(c: &GptConfig, device: &Device) -> (Tensor<2, Int>, Tensor<3>) {
        let n = c.window;
        let tokens = Tensor::<2, Int>::from_data(
            TensorData::new(
                (0..n as i64).map(|i| (i * 7) % c.codes as i64).collect(),
                [1, n],
            ),
            device,
        );
        let music = Tensor::random(
            [1, n, music_token_dim(c)],
            Distribution::Normal(0.0, 1.0),
            device,
        );
        (tokens, music)
    }

    /// SPEC §13.11 test 7: in the two-stream causal mode, changing a_{i+1} or c_i (the input at j = i + 1)
    /// leaves h^M_{≤i} unchanged and changing a_i changes h^M_i.
    #[test]
    fn two_stream_mask_is_causal_per_position() {
        let device = Device::flex();
        let c = GptConfig {
            dropout: 0.0,
            ..GptConfig::tiny()
        };
        let g = Gpt::new(&c, &device);
        let (tokens, music) = random_inputs(&c, &device);
        let base = g.m_base.forward(tokens.clone(), music.clone());
        let i = 5;
        let n = c.window;
        let changed = |t: Tensor<3>, lo: usize| -> f32 {
            let d = (t.narrow(1, 0, lo) - base.clone().narrow(1, 0, lo))
                .abs()
                .max();
            d.into_scalar()
        };
        // a_{i+1}
        let mut m = music
            .clone()
            .into_data()
            .convert::<f32>()
            .try_to_vec::<f32>()
            .unwrap();
        let w = music_token_dim(&c);
        for v in &mut m[(i + 1) * w..(i + 2) * w] {
            *v += 3.0;
        }
        let m2 = Tensor::from_data(TensorData::new(m.clone(), [1, n, w]), &device);
        let out = g.m_base.forward(tokens.clone(), m2);
        assert_eq!(changed(out.clone(), i + 1), 0.0);
        // c_i is the input at slot i + 1.
        let mut t = tokens
            .clone()
            .into_data()
            .convert::<i64>()
            .try_to_vec::<i64>()
            .unwrap();
        t[i + 1] = (t[i + 1] + 1) % c.codes as i64;
        let t2 = Tensor::from_data(TensorData::new(t, [1, n]), &device);
        assert_eq!(changed(g.m_base.forward(t2, music.clone()), i + 1), 0.0);
        // a_i changes h^M_i.
        for v in &mut m[i * w..(i + 1) * w] {
            *v += 3.0;
        }
        let m3 = Tensor::from_data(TensorData::new(m, [1, n, w]), &device);
        let out = g.m_base.forward(tokens, m3);
        let d: f32 = (out.narrow(1, i, 1) - base.narrow(1, i, 1))
            .abs()
            .max()
            .into_scalar();
        assert!(d > 0.0);
    }

    #[test]
    fn text_base_and_head_are_causal() {
        let device = Device::flex();
        let c = GptConfig {
            dropout: 0.0,
            ..GptConfig::tiny()
        };
        let g = Gpt::new(&c, &device);
        let n = c.window;
        let text = Tensor::<2>::random([1, 512], Distribution::Normal(0.0, 1.0), &device);
        let t = |v: i64| {
            Tensor::<2, Int>::from_data(
                TensorData::new(
                    (0..(n - 1) as i64)
                        .map(|i| if i == 9 { v } else { i })
                        .collect(),
                    [1, n - 1],
                ),
                &device,
            )
        };
        let a = g.text_logits(text.clone(), t(3));
        let b = g.text_logits(text, t(4));
        // Token 9 is input slot 10: logits 0..=9 unchanged, 10 changed.
        let d: f32 = (a.clone().narrow(1, 0, 10) - b.clone().narrow(1, 0, 10))
            .abs()
            .max()
            .into_scalar();
        assert_eq!(d, 0.0);
        let d: f32 = (a.narrow(1, 10, 1) - b.narrow(1, 10, 1))
            .abs()
            .max()
            .into_scalar();
        assert!(d > 0.0);
        assert_eq!(
            g.music_logits(random_inputs(&c, &device).0, random_inputs(&c, &device).1)
                .dims(),
            [1, n, c.codes + 1]
        );
    }
}
