//! Lin's transformer in-betweeners (SPEC §12.4c, thesis §3.5.3 and App. A). Each variant predicts the
//! residual over the interpolated keyframes: Ŷ = B + f(·), with B the SLERP base in the 225-D layout.
//!
//! - `motion`: Dense(225 → d) + positions, a self-attention stack, Dense(d → 225).
//! - `genre`: the same on [B_t | one-hot genre] (234-D).
//! - `cross_*`: a music encoder (Dense(22 → d) + positions + layers) as memory; a decoder on B whose layers
//!   self-attend, cross-attend to the memory and run the MLP.
//! - `merged_*`: the music encoder, then Dense([B_t | enc_t] (225 + d) → d) + positions, self-attention.
//!
//! Layers are §4.1 pre-LN (tanh-GELU MLP, fused bias-free q/k/v, output projection with bias, LayerNorm
//! ε 1e-5); scores 1/√d_head (or 1/√d); dropout on the probabilities and the branch outputs; a key-padding
//! bias (0 or −1e9) is the only mask, so batches may hold segments of unequal length. `inbetween.taper =
//! "sin2"` (ours) weighs the residual by sin² of the position between keys, so it vanishes at every key.

use burn::module::{Module, Param};
use burn::nn::{Dropout, DropoutConfig, LayerNorm, LayerNormConfig, Linear};
use burn::tensor::{Device, Tensor, TensorData};

use crate::attention::{
    attend_biased, merge_heads, score_scale, split_heads, Attention, AttentionConfig,
};
use crate::feed_forward::{FeedForward, FeedForwardConfig};
use crate::init::{glorot_dense, truncated_normal, truncated_normal_dense};
use qean_config::inbetween::{Decoder, InbetweenConfig, MergeAxis, Taper, Variant};

/// Motion vector width (the 225-D layout of §1.4).
pub const MOTION_DIM: usize = 225;
/// Music feature width: MFCC 1..20, envelope, onset peaks (columns [1..20, 0, 33] of the 35-D feature).
pub const MUSIC_DIM: usize = 22;
/// Genres in §1.1 order BR, PO, LO, MH, LH, HO, WA, KR, JS, JB; Lin's one-hot drops the last.
pub const GENRES: [&str; 10] = ["BR", "PO", "LO", "MH", "LH", "HO", "WA", "KR", "JS", "JB"];

/// The genres of the one-hot: nine, or ten with `include_jb`.
pub fn genres(c: &InbetweenConfig) -> &'static [&'static str] {
    if c.include_jb {
        &GENRES
    } else {
        &GENRES[..9]
    }
}

/// [rows, 9 | 10] genre one-hots of the genre variant, one row per index (`None`: all zeros).
pub fn genre_one_hot(c: &InbetweenConfig, rows: &[Option<usize>], device: &Device) -> Tensor<2> {
    let width = genres(c).len();
    let mut v = vec![0f32; rows.len() * width];
    for (i, g) in rows.iter().enumerate() {
        if let Some(k) = g {
            v[i * width + k] = 1.0;
        }
    }
    Tensor::from_data(TensorData::new(v, [rows.len(), width]), device)
}

/// The one-hot index of a genre code (`None` for unknown codes, and JB unless `include_jb`).
pub fn genre_index(c: &InbetweenConfig, code: &str) -> Option<usize> {
    genres(c).iter().position(|g| *g == code)
}

/// The 22 music columns of a 35-D feature row: MFCC 1..20 (columns 1..=20), envelope (0), onset peaks (33).
pub fn music_columns(row: &[f32]) -> [f32; MUSIC_DIM] {
    let mut out = [0.0; MUSIC_DIM];
    out[..20].copy_from_slice(&row[1..21]);
    out[20] = row[0];
    out[21] = row[33];
    out
}

/// Cross-attention: separate bias-free W_q (d × d) and W_kv (d × 2d); no LayerNorm on the memory.
#[derive(Module, Debug)]
pub struct CrossAttention {
    pub query: Linear,
    pub key_value: Linear,
    pub output: Linear,
    pub dropout: Dropout,
    heads: usize,
    scale: f64,
}

impl CrossAttention {
    fn new(c: &InbetweenConfig, device: &Device) -> Self {
        CrossAttention {
            query: glorot_dense(c.hidden, c.hidden, false, device),
            key_value: glorot_dense(c.hidden, 2 * c.hidden, false, device),
            output: glorot_dense(c.hidden, c.hidden, true, device),
            dropout: DropoutConfig::new(c.dropout).init(),
            heads: c.heads,
            scale: score_scale(c.scale, c.hidden, c.heads),
        }
    }

    fn forward(&self, x: Tensor<3>, memory: Tensor<3>, bias: Option<Tensor<4>>) -> Tensor<3> {
        let [_, _, d] = x.dims();
        let q = split_heads(self.query.forward(x), self.heads);
        let kv = self.key_value.forward(memory);
        let k = split_heads(kv.clone().narrow(2, 0, d), self.heads);
        let v = split_heads(kv.narrow(2, d, d), self.heads);
        self.output.forward(merge_heads(attend_biased(
            q,
            k,
            v,
            bias,
            self.scale,
            &self.dropout,
        )))
    }
}

/// One pre-LN layer: [self-attention] [cross-attention] MLP, each as x += Dropout(branch(LN(x))).
#[derive(Module, Debug)]
pub struct Layer {
    pub attention_norm: Option<LayerNorm>,
    pub attention: Option<Attention>,
    pub cross_norm: Option<LayerNorm>,
    pub cross: Option<CrossAttention>,
    pub mlp_norm: LayerNorm,
    pub mlp: FeedForward,
    pub dropout: Dropout,
}

fn layer_norm(d: usize, device: &Device) -> LayerNorm {
    LayerNormConfig::new(d).with_epsilon(1e-5).init(device)
}

impl Layer {
    fn new(c: &InbetweenConfig, self_attention: bool, cross: bool, device: &Device) -> Self {
        Layer {
            attention_norm: self_attention.then(|| layer_norm(c.hidden, device)),
            attention: self_attention.then(|| {
                AttentionConfig::new(c.hidden, c.heads)
                    .with_scale(c.scale)
                    .with_dropout(c.dropout)
                    .init(device)
            }),
            cross_norm: cross.then(|| layer_norm(c.hidden, device)),
            cross: cross.then(|| CrossAttention::new(c, device)),
            mlp_norm: layer_norm(c.hidden, device),
            mlp: FeedForwardConfig::new(c.hidden, c.ffn)
                .with_relu(c.mlp_act == qean_config::inbetween::MlpAct::Relu)
                .init(device),
            dropout: DropoutConfig::new(c.dropout).init(),
        }
    }

    fn forward(
        &self,
        mut x: Tensor<3>,
        bias: Option<Tensor<4>>,
        memory: Option<(Tensor<3>, Option<Tensor<4>>)>,
    ) -> Tensor<3> {
        if let (Some(norm), Some(attn)) = (&self.attention_norm, &self.attention) {
            x = x.clone()
                + self
                    .dropout
                    .forward(attn.forward_masked(norm.forward(x), bias));
        }
        if let (Some(norm), Some(cross), Some((m, mbias))) = (&self.cross_norm, &self.cross, memory)
        {
            x = x.clone()
                + self
                    .dropout
                    .forward(cross.forward(norm.forward(x), m, mbias));
        }
        x.clone()
            + self
                .dropout
                .forward(self.mlp.forward(self.mlp_norm.forward(x)))
    }
}

/// The music encoder of the cross and merged variants.
#[derive(Module, Debug)]
pub struct MusicEncoder {
    /// Dense(22 → d).
    pub input: Linear,
    /// [max_len, d], truncated normal σ 0.02.
    pub positions: Param<Tensor<2>>,
    pub layers: Vec<Layer>,
    pub dropout: Dropout,
}

impl MusicEncoder {
    fn forward(&self, music: Tensor<3>, bias: Option<Tensor<4>>) -> Tensor<3> {
        let n = music.dims()[1];
        let mut x =
            self.input.forward(music) + self.positions.val().narrow(0, 0, n).unsqueeze::<3>();
        x = self.dropout.forward(x);
        for layer in &self.layers {
            x = layer.forward(x, bias.clone(), None);
        }
        x
    }
}

/// What a forward pass reads besides the base.
pub struct Conditioning {
    /// [B, T, 22] music rows aligned with the frames (cross and merged variants).
    pub music: Option<Tensor<3>>,
    /// [B, 9 | 10] genre one-hots (genre variant).
    pub genre: Option<Tensor<2>>,
    /// Valid frames per row (the rest is padding); `None`: every frame is valid.
    pub lengths: Option<Vec<usize>>,
    /// [B, T, 1] weights of the residual (`inbetween.taper`, from [`taper_weights`]); `None`: 1.
    pub taper: Option<Tensor<3>>,
}

/// The residual's weight on each of `len` frames (a segment and its padding) for sorted segment-relative
/// `keys` (`inbetween.taper`): 1 everywhere for `none`; for `sin2`, sin²(π(t − t1)/(t2 − t1)) between
/// consecutive keys t1 < t2, so 0 at every key and outside the first and last key (the padding).
pub fn taper_weights(keys: &[usize], len: usize, taper: Taper) -> Vec<f32> {
    if taper == Taper::None {
        return vec![1.0; len];
    }
    let mut w = vec![0.0f32; len];
    for k in keys.windows(2) {
        let span = (k[1] - k[0]) as f64;
        for (t, v) in w.iter_mut().enumerate().take(k[1].min(len)).skip(k[0] + 1) {
            *v = (std::f64::consts::PI * (t - k[0]) as f64 / span)
                .sin()
                .powi(2) as f32;
        }
    }
    w
}

/// One in-betweener.
#[derive(Module, Debug)]
pub struct Inbetweener {
    /// Dense(225 | 234 | 225 + d → d).
    pub motion_in: Linear,
    /// [max_len, d] positions of the motion stream.
    pub positions: Param<Tensor<2>>,
    pub music: Option<MusicEncoder>,
    /// The self-attention stack, or the decoder of the cross variants.
    pub layers: Vec<Layer>,
    /// Dense(d → 225): §4.1's output init (truncated normal σ 0.02, zero bias), so f starts small and Ŷ ≈ B.
    pub output: Linear,
    pub dropout: Dropout,
    genre: bool,
    /// Width of the genre one-hot (9, or 10 with `include_jb`).
    genres: usize,
    merged: bool,
    /// `merge_axis = time`: motion and music tokens side by side in time.
    merge_time: bool,
    cross: bool,
    max_len: usize,
}

impl Inbetweener {
    /// Builds the variant `c.variant` (parameters initialise lazily from the device RNG).
    pub fn new(c: &InbetweenConfig, device: &Device) -> Inbetweener {
        let v = c.variant;
        let merged = matches!(v, Variant::MergedFull | Variant::MergedDrum);
        let merge_time = merged && c.merge_axis == MergeAxis::Time;
        let input = match v {
            Variant::Genre => MOTION_DIM + genres(c).len(),
            _ if merged && !merge_time => MOTION_DIM + c.hidden,
            _ => MOTION_DIM,
        };
        let music = v.has_audio().then(|| MusicEncoder {
            input: glorot_dense(MUSIC_DIM, c.hidden, true, device),
            positions: truncated_normal([c.max_len, c.hidden], 0.02, device),
            layers: (0..c.audio_layers)
                .map(|_| Layer::new(c, true, false, device))
                .collect(),
            dropout: DropoutConfig::new(c.dropout).init(),
        });
        let self_attention = !(v.is_cross() && c.decoder == Decoder::CrossOnly);
        Inbetweener {
            motion_in: glorot_dense(input, c.hidden, true, device),
            positions: truncated_normal([c.max_len, c.hidden], 0.02, device),
            music,
            layers: (0..c.layers)
                .map(|_| Layer::new(c, self_attention, v.is_cross(), device))
                .collect(),
            output: truncated_normal_dense(c.hidden, MOTION_DIM, 0.02, device),
            dropout: DropoutConfig::new(c.dropout).init(),
            genre: v == Variant::Genre,
            genres: genres(c).len(),
            merged,
            merge_time,
            cross: v.is_cross(),
            max_len: c.max_len,
        }
    }

    /// The longest segment the position tables cover.
    pub fn max_len(&self) -> usize {
        self.max_len
    }

    /// Ŷ = B + f(B, conditioning): base [B, T, 225] → [B, T, 225].
    pub fn forward(&self, base: Tensor<3>, cond: &Conditioning) -> Tensor<3> {
        let [b, t, _] = base.dims();
        assert!(
            t <= self.max_len,
            "segment of {t} frames is longer than the position table ({})",
            self.max_len
        );
        let device = base.device();
        let bias = cond.lengths.as_ref().map(|lens| key_bias(lens, t, &device));
        let memory = match (&self.music, &cond.music) {
            (Some(enc), Some(m)) => Some(enc.forward(m.clone(), bias.clone())),
            (Some(_), None) => panic!("this in-betweener needs music"),
            _ => None,
        };
        let input = if self.genre {
            let g = cond
                .genre
                .clone()
                .expect("the genre in-betweener needs a genre");
            let g = g.unsqueeze_dim::<3>(1).expand([b, t, self.genres]);
            Tensor::cat(vec![base.clone(), g], 2)
        } else if self.merged && !self.merge_time {
            Tensor::cat(vec![base.clone(), memory.clone().expect("music")], 2)
        } else {
            base.clone()
        };
        let mut x =
            self.motion_in.forward(input) + self.positions.val().narrow(0, 0, t).unsqueeze::<3>();
        x = self.dropout.forward(x);
        // merge_axis = time: [motion tokens; music tokens], each half masked like its segment.
        let bias = if self.merge_time {
            x = Tensor::cat(vec![x, memory.clone().expect("music")], 1);
            bias.map(|b| Tensor::cat(vec![b.clone(), b], 3))
        } else {
            bias
        };
        for layer in &self.layers {
            let mem = if self.cross {
                memory.clone().map(|m| (m, bias.clone()))
            } else {
                None
            };
            x = layer.forward(x, bias.clone(), mem);
        }
        if self.merge_time {
            x = x.narrow(1, 0, t);
        }
        let residual = self.output.forward(x);
        match &cond.taper {
            Some(w) => base + residual * w.clone(),
            None => base + residual,
        }
    }
}

/// [B, 1, 1, T]: 0 for valid keys, −1e9 for padding.
fn key_bias(lengths: &[usize], t: usize, device: &Device) -> Tensor<4> {
    let values: Vec<f32> = lengths
        .iter()
        .flat_map(|&len| (0..t).map(move |i| if i < len { 0.0 } else { -1e9 }))
        .collect();
    Tensor::from_data(TensorData::new(values, [lengths.len(), 1, 1, t]), device)
}

/// Parameters by the closed forms of §12.4c: encoder layer 4d² + 2df + 6d + f, decoder layer + 4d² + 3d,
/// Dense(a → b) = ab + b, positions max_len·d.
pub fn inbetween_params(c: &InbetweenConfig) -> usize {
    let (d, f) = (c.hidden, c.ffn);
    let dense = |a: usize, b: usize| a * b + b;
    let encoder = 4 * d * d + 2 * d * f + 6 * d + f;
    let positions = c.max_len * d;
    let v = c.variant;
    let audio = if v.has_audio() {
        dense(MUSIC_DIM, d) + positions + c.audio_layers * encoder
    } else {
        0
    };
    let input = match v {
        Variant::Genre => dense(MOTION_DIM + genres(c).len(), d),
        Variant::MergedFull | Variant::MergedDrum if c.merge_axis == MergeAxis::Features => {
            dense(MOTION_DIM + d, d)
        }
        _ => dense(MOTION_DIM, d),
    };
    let layer = if v.is_cross() {
        let cross = 4 * d * d + 3 * d;
        if c.decoder == Decoder::CrossOnly {
            encoder - (4 * d * d + 3 * d) + cross
        } else {
            encoder + cross
        }
    } else {
        encoder
    };
    audio + input + positions + c.layers * layer + dense(d, MOTION_DIM)
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::tensor::Distribution;

    fn count(c: &InbetweenConfig) -> usize {
        Inbetweener::new(c, &Device::flex()).num_params()
    }

    #[test]
    fn parameter_counts_equal_the_spec() {
        let want = [
            (Variant::Motion, 30_485_313, 111_009),
            (Variant::Genre, 30_492_513, 111_585),
            (Variant::CrossFull, 70_877_601, 227_553),
            (Variant::CrossDrum, 70_877_601, 227_553),
            (Variant::MergedFull, 61_268_001, 198_497),
            (Variant::MergedDrum, 61_268_001, 198_497),
        ];
        for (variant, paper, tiny) in want {
            let p = InbetweenConfig {
                variant,
                ..InbetweenConfig::paper()
            };
            let t = InbetweenConfig {
                variant,
                ..InbetweenConfig::tiny()
            };
            assert_eq!(count(&p), paper, "{variant:?} paper");
            assert_eq!(count(&t), tiny, "{variant:?} tiny");
            assert_eq!(inbetween_params(&p), paper);
            assert_eq!(inbetween_params(&t), tiny);
        }
        let relu = InbetweenConfig {
            mlp_act: qean_config::inbetween::MlpAct::Relu,
            ..InbetweenConfig::tiny()
        };
        assert_eq!(count(&relu), 111_009);
        let cross_only = InbetweenConfig {
            variant: Variant::CrossFull,
            decoder: Decoder::CrossOnly,
            ..InbetweenConfig::tiny()
        };
        assert_eq!(count(&cross_only), inbetween_params(&cross_only));
        // merge_axis = time: the merge Dense reads B alone (d fewer inputs).
        let time = InbetweenConfig {
            variant: Variant::MergedFull,
            merge_axis: MergeAxis::Time,
            ..InbetweenConfig::tiny()
        };
        assert_eq!(count(&time), 198_497 - 64 * 64);
        assert_eq!(inbetween_params(&time), count(&time));
        // include_jb: a tenth genre, one more input row of the merge Dense (d more weights).
        let jb = InbetweenConfig {
            variant: Variant::Genre,
            include_jb: true,
            ..InbetweenConfig::tiny()
        };
        assert_eq!(count(&jb), 111_585 + 64);
        assert_eq!(inbetween_params(&jb), count(&jb));
    }

    fn inputs(variant: Variant, b: usize, t: usize, device: &Device) -> (Tensor<3>, Conditioning) {
        let base = Tensor::<3>::random([b, t, MOTION_DIM], Distribution::Normal(0.0, 1.0), device);
        let music = variant.has_audio().then(|| {
            Tensor::<3>::random([b, t, MUSIC_DIM], Distribution::Normal(0.0, 1.0), device)
        });
        let genre = (variant == Variant::Genre).then(|| {
            let mut g = vec![0f32; b * 9];
            for i in 0..b {
                g[i * 9 + (i % 9)] = 1.0;
            }
            Tensor::from_data(TensorData::new(g, [b, 9]), device)
        });
        (
            base,
            Conditioning {
                music,
                genre,
                lengths: None,
                taper: None,
            },
        )
    }

    #[test]
    fn shapes_zero_output_and_padding() {
        let device = Device::flex();
        device.seed(3);
        let time = (Variant::MergedDrum, MergeAxis::Time);
        for (variant, merge_axis) in Variant::ALL
            .map(|v| (v, MergeAxis::Features))
            .into_iter()
            .chain([time])
        {
            let c = InbetweenConfig {
                variant,
                merge_axis,
                dropout: 0.0,
                ..InbetweenConfig::tiny()
            };
            let mut model = Inbetweener::new(&c, &device);
            let (base, cond) = inputs(variant, 2, 17, &device);
            let y = model.forward(base.clone(), &cond);
            assert_eq!(y.dims(), [2, 17, MOTION_DIM]);
            // Padding: 3 more frames of anything, masked, leave the first 17 outputs unchanged.
            let pad = |x: Tensor<3>| {
                let [b, _, w] = x.dims();
                Tensor::cat(
                    vec![
                        x,
                        Tensor::<3>::random([b, 3, w], Distribution::Normal(0.0, 5.0), &device),
                    ],
                    1,
                )
            };
            let padded = Conditioning {
                music: cond.music.clone().map(pad),
                genre: cond.genre.clone(),
                lengths: Some(vec![17, 17]),
                taper: None,
            };
            let yp = model.forward(pad(base.clone()), &padded).narrow(1, 0, 17);
            let diff: f32 = (yp - y.clone()).abs().max().into_scalar();
            assert!(
                diff < 1e-4,
                "{variant:?}: padding changed valid outputs by {diff}"
            );
            // Zeroed output layer: the base comes back.
            model.output.weight = model.output.weight.map(|w| w.zeros_like());
            model.output.bias = model.output.bias.map(|p| p.map(|b| b.zeros_like()));
            let y0 = model.forward(base.clone(), &cond);
            let diff: f32 = (y0 - base).abs().max().into_scalar();
            assert_eq!(diff, 0.0, "{variant:?}");
        }
    }

    #[test]
    fn a_tapered_residual_vanishes_at_the_keys() {
        let keys = [0, 4, 12];
        assert_eq!(taper_weights(&keys, 13, Taper::None), vec![1.0; 13]);
        let w = taper_weights(&keys, 13, Taper::Sin2);
        for k in keys {
            assert_eq!(w[k], 0.0);
        }
        assert_eq!((w[2], w[8]), (1.0, 1.0), "midpoints of the spans");
        assert!((w[1] - 0.5).abs() < 1e-6 && (w[3] - 0.5).abs() < 1e-6);
        assert!((w[7] - w[9]).abs() < 1e-7, "symmetric in its span");
        // Padding past the last key weighs 0.
        assert_eq!(taper_weights(&[0, 4], 7, Taper::Sin2)[5..], [0.0, 0.0]);
        // Through the model: keys return the base bit for bit, other frames B + w·f.
        let device = Device::flex();
        device.seed(5);
        let c = InbetweenConfig {
            dropout: 0.0,
            ..InbetweenConfig::tiny()
        };
        let model = Inbetweener::new(&c, &device);
        let (base, mut cond) = inputs(Variant::Motion, 1, 13, &device);
        let plain = model.forward(base.clone(), &cond);
        cond.taper = Some(Tensor::from_data(
            TensorData::new(w.clone(), [1, 13, 1]),
            &device,
        ));
        let tapered = model.forward(base.clone(), &cond);
        let rows = |x: Tensor<3>| x.into_data().try_to_vec::<f32>().unwrap();
        let (b, p, y) = (rows(base), rows(plain), rows(tapered));
        for (t, &wt) in w.iter().enumerate() {
            for d in 0..MOTION_DIM {
                let i = t * MOTION_DIM + d;
                if keys.contains(&t) {
                    assert_eq!(y[i], b[i], "frame {t}");
                } else {
                    assert!(
                        (y[i] - (b[i] + wt * (p[i] - b[i]))).abs() < 1e-5,
                        "frame {t}"
                    );
                }
            }
        }
    }

    #[test]
    fn genre_order_and_music_columns() {
        let lin = InbetweenConfig::tiny();
        assert_eq!(genre_index(&lin, "BR"), Some(0));
        assert_eq!(genre_index(&lin, "JS"), Some(8));
        assert_eq!(genre_index(&lin, "JB"), None);
        let ten = InbetweenConfig {
            include_jb: true,
            ..lin
        };
        assert_eq!(genre_index(&ten, "JS"), Some(8));
        assert_eq!(genre_index(&ten, "JB"), Some(9));
        assert_eq!(genre_index(&ten, "XX"), None);
        let row: Vec<f32> = (0..35).map(|i| i as f32).collect();
        let m = music_columns(&row);
        assert_eq!(m[0], 1.0);
        assert_eq!(m[19], 20.0);
        assert_eq!((m[20], m[21]), (0.0, 33.0));
    }
}
