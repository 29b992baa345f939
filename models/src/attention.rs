//! FACT's multi-head self-attention (mint base_models.py `Attention`, SPEC §4.1).
//!
//! - One fused, bias-free q/k/v projection Dense(C → 3C); column = part·C + head·d_h + e,
//!   part (q, k, v) outermost.
//! - Scores q·kᵀ·s with s = C^(−1/2) (mint scales by the hidden size, not the head size; option
//!   `attn_scale = head` gives 1/sqrt(d_h)).
//! - Softmax over keys, no mask; heads concatenated; Dense(C → C) with bias.
//! - Optional rotary q/k (SPE, SPEC §4.4) after the projection, per head; v is never rotated.
//! - Optional dropout on the probabilities (QEAN, SPEC §4.7); mint applies none.

use burn::config::Config;
use burn::module::Module;
use burn::nn::{Dropout, DropoutConfig, Linear};
use burn::tensor::activation::softmax;
use burn::tensor::module::attention;
use burn::tensor::ops::AttentionModuleOptions;
use burn::tensor::{Device, Tensor};

use crate::init::glorot_dense;
use crate::spe::RotaryTables;
use qean_config::model::AttnScale;

/// Configuration of [`Attention`].
#[derive(Config, Debug)]
pub struct AttentionConfig {
    /// Model width C.
    pub hidden: usize,
    /// Number of heads H (C divisible by H).
    pub heads: usize,
    /// Score scale.
    #[config(default = "AttnScale::Hidden")]
    pub scale: AttnScale,
    /// Dropout on the attention probabilities.
    #[config(default = 0.0)]
    pub dropout: f64,
}

/// Multi-head self-attention with a fused bias-free q/k/v projection.
#[derive(Module, Debug)]
pub struct Attention {
    /// Dense(C → 3C), no bias, Glorot over fan_out 3C.
    pub qkv: Linear,
    /// Dense(C → C) with bias.
    pub output: Linear,
    /// Dropout on the probabilities.
    pub dropout: Dropout,
    heads: usize,
    scale: f64,
}

/// The score scale s for a width and head count.
pub fn score_scale(scale: AttnScale, hidden: usize, heads: usize) -> f64 {
    match scale {
        AttnScale::Hidden => 1.0 / (hidden as f64).sqrt(),
        AttnScale::Head => 1.0 / ((hidden / heads) as f64).sqrt(),
    }
}

impl AttentionConfig {
    /// Builds the layer (Keras initialisers: Glorot kernels, zero bias).
    pub fn init(&self, device: &Device) -> Attention {
        assert!(
            self.hidden.is_multiple_of(self.heads),
            "heads must divide hidden"
        );
        Attention {
            qkv: glorot_dense(self.hidden, 3 * self.hidden, false, device),
            output: glorot_dense(self.hidden, self.hidden, true, device),
            dropout: DropoutConfig::new(self.dropout).init(),
            heads: self.heads,
            scale: score_scale(self.scale, self.hidden, self.heads),
        }
    }
}

/// [B, N, H·d] → [B, H, N, d].
pub fn split_heads(x: Tensor<3>, heads: usize) -> Tensor<4> {
    let [b, n, c] = x.dims();
    x.reshape([b, n, heads, c / heads]).swap_dims(1, 2)
}

/// [B, H, N, d] → [B, N, H·d].
pub fn merge_heads(x: Tensor<4>) -> Tensor<3> {
    let [b, h, n, d] = x.dims();
    x.swap_dims(1, 2).reshape([b, n, h * d])
}

/// softmax(q·kᵀ·scale)·v per head, with dropout on the probabilities. On a plain flex device
/// (inference: sampling, validation) this is flex's fused attention, which never materialises the
/// score matrix; under autodiff, and on other backends (which the wgpu parity test covers), the
/// explicit ops below.
pub fn attend(
    q: Tensor<4>,
    k: Tensor<4>,
    v: Tensor<4>,
    scale: f64,
    dropout: &Dropout,
) -> Tensor<4> {
    let device = q.device();
    if !device.is_autodiff() && device == Device::flex() {
        let options = AttentionModuleOptions {
            scale: Some(scale),
            softcap: None,
            is_causal: false,
        };
        return attention(q, k, v, None, None, options);
    }
    // Training: batch items in chunks whose [H, N, N] score blocks (f32) total at most 8 MiB, so the
    // softmax passes run in cache and their temporaries stay small (tiny FACT step ≈3 % faster, peak
    // memory 1146 → 832 MiB). Every item is attended on its own either way.
    let [b, h, n, _] = q.dims();
    let per_item = h * n * k.dims()[2] * 4;
    let chunk = (8 << 20) / per_item.max(1);
    if chunk >= 1 && chunk < b {
        let mut outs = Vec::new();
        let mut start = 0;
        while start < b {
            let len = chunk.min(b - start);
            outs.push(attend_block(
                q.clone().narrow(0, start, len),
                k.clone().narrow(0, start, len),
                v.clone().narrow(0, start, len),
                scale,
                dropout,
            ));
            start += len;
        }
        return Tensor::cat(outs, 0);
    }
    attend_block(q, k, v, scale, dropout)
}

/// softmax(q·kᵀ·scale + bias)·v per head, with dropout on the probabilities; `bias` broadcasts over the
/// scores (e.g. [B, 1, 1, M] to mask padded keys).
pub fn attend_biased(
    q: Tensor<4>,
    k: Tensor<4>,
    v: Tensor<4>,
    bias: Option<Tensor<4>>,
    scale: f64,
    dropout: &Dropout,
) -> Tensor<4> {
    let mut scores = q.mul_scalar(scale).matmul(k.swap_dims(2, 3));
    if let Some(b) = bias {
        scores = scores + b;
    }
    dropout.forward(softmax(scores, 3)).matmul(v)
}

/// The explicit softmax(q·kᵀ·scale)·v of one batch chunk.
fn attend_block(
    q: Tensor<4>,
    k: Tensor<4>,
    v: Tensor<4>,
    scale: f64,
    dropout: &Dropout,
) -> Tensor<4> {
    // The scale goes on q ([N, d] per head) rather than on the [N, N] scores.
    let scores = q.mul_scalar(scale).matmul(k.swap_dims(2, 3));
    let probs = dropout.forward(softmax(scores, 3));
    probs.matmul(v)
}

impl Attention {
    /// x [B, N, C] → [B, N, C]; `rope` (tables for the N positions) rotates q and k.
    pub fn forward(&self, x: Tensor<3>, rope: Option<&RotaryTables>) -> Tensor<3> {
        let [_, _, c] = x.dims();
        let qkv = self.qkv.forward(x);
        let mut q = split_heads(qkv.clone().narrow(2, 0, c), self.heads);
        let mut k = split_heads(qkv.clone().narrow(2, c, c), self.heads);
        let v = split_heads(qkv.narrow(2, 2 * c, c), self.heads);
        if let Some(tables) = rope {
            q = tables.rotate(q);
            k = tables.rotate(k);
        }
        let heads = attend(q, k, v, self.scale, &self.dropout);
        self.output.forward(merge_heads(heads))
    }

    /// [`Attention::forward`] without rotary positions and with an additive key bias [B, 1, 1, N] (0 for
    /// valid keys, −1e9 for padding), computed with explicit ops (the in-betweeners' batches of unequal
    /// segments).
    pub fn forward_masked(&self, x: Tensor<3>, key_bias: Option<Tensor<4>>) -> Tensor<3> {
        let [_, _, c] = x.dims();
        let qkv = self.qkv.forward(x);
        let q = split_heads(qkv.clone().narrow(2, 0, c), self.heads);
        let k = split_heads(qkv.clone().narrow(2, c, c), self.heads);
        let v = split_heads(qkv.narrow(2, 2 * c, c), self.heads);
        self.output.forward(merge_heads(attend_biased(
            q,
            k,
            v,
            key_bias,
            self.scale,
            &self.dropout,
        )))
    }

    /// Only the first query: x [B, N, C] → [B, 1, C], equal to `forward(x, rope)` at token 0 (keys
    /// and values still cover all N tokens). The sampler reads nothing else of the last layer.
    pub fn forward_first(&self, x: Tensor<3>, rope: Option<&RotaryTables>) -> Tensor<3> {
        let [_, _, c] = x.dims();
        let qkv = self.qkv.forward(x);
        let mut q = split_heads(qkv.clone().narrow(1, 0, 1).narrow(2, 0, c), self.heads);
        let mut k = split_heads(qkv.clone().narrow(2, c, c), self.heads);
        let v = split_heads(qkv.narrow(2, 2 * c, c), self.heads);
        if let Some(tables) = rope {
            q = tables.narrow(0, 1).rotate(q);
            k = tables.rotate(k);
        }
        let heads = attend(q, k, v, self.scale, &self.dropout);
        self.output.forward(merge_heads(heads))
    }

    /// The score scale in use.
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// Number of heads.
    pub fn heads(&self) -> usize {
        self.heads
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{f64_normal, max_abs_diff, to_f64, to_vec};
    use burn::tensor::{DType, TensorData};

    #[test]
    fn chunked_training_attention_equals_one_block() {
        // [H, N, N] of 1 × 1100 × 1100 f32 is 4.6 MiB, so three items go one chunk at a time.
        let device = Device::flex().autodiff();
        let [b, h, n, d] = [3, 1, 1100, 4];
        let q = f64_normal([b, h, n, d], &device);
        let k = f64_normal([b, h, n, d], &device);
        let v = f64_normal([b, h, n, d], &device);
        let none = DropoutConfig::new(0.0).init();
        let chunked = attend(q.clone(), k.clone(), v.clone(), 0.3, &none);
        let whole = attend_block(q, k, v, 0.3, &none);
        assert_eq!(chunked.dims(), [b, h, n, d]);
        assert!(max_abs_diff(chunked, whole) < 1e-12);
    }

    #[allow(clippy::too_many_arguments)] // the weights of SPEC §4.1, spelled out
    /// Plain-loop attention in f64 from the weight matrices, following SPEC §4.1 literally.
    fn reference(
        x: &[f64],
        n: usize,
        c: usize,
        heads: usize,
        wqkv: &[f64],
        wo: &[f64],
        bo: &[f64],
        scale: f64,
    ) -> Vec<f64> {
        let d = c / heads;
        // proj[t][col] = Σ_i x[t][i]·W[i][col], W is [C, 3C] row-major.
        let proj = |t: usize, col: usize| {
            (0..c)
                .map(|i| x[t * c + i] * wqkv[i * 3 * c + col])
                .sum::<f64>()
        };
        let mut concat = vec![0.0; n * c];
        for h in 0..heads {
            for t in 0..n {
                let q: Vec<f64> = (0..d).map(|e| proj(t, h * d + e)).collect();
                let scores: Vec<f64> = (0..n)
                    .map(|u| (0..d).map(|e| q[e] * proj(u, c + h * d + e)).sum::<f64>() * scale)
                    .collect();
                let m = scores.iter().cloned().fold(f64::MIN, f64::max);
                let z: f64 = scores.iter().map(|s| (s - m).exp()).sum();
                for e in 0..d {
                    concat[t * c + h * d + e] = (0..n)
                        .map(|u| (scores[u] - m).exp() / z * proj(u, 2 * c + h * d + e))
                        .sum();
                }
            }
        }
        (0..n * c)
            .map(|idx| {
                let (t, o) = (idx / c, idx % c);
                (0..c)
                    .map(|i| concat[t * c + i] * wo[i * c + o])
                    .sum::<f64>()
                    + bo[o]
            })
            .collect()
    }

    #[test]
    fn hidden_scale_quirk_and_qkv_split_order() {
        // SPEC §9 item 8: s = 1/sqrt(C) (not 1/sqrt(d_h)); q/k/v columns part-outermost.
        let device = Device::flex();
        let (n, c, heads) = (5, 12, 3);
        for scale in [AttnScale::Hidden, AttnScale::Head] {
            let mut attn = to_f64(
                AttentionConfig::new(c, heads)
                    .with_scale(scale)
                    .init(&device),
            );
            // Larger weights than Glorot so the softmax is far from uniform and the scale matters.
            attn.qkv.weight = attn.qkv.weight.map(|w| w.mul_scalar(4.0));
            attn.output.bias = attn
                .output
                .bias
                .map(|b| b.map(|_| f64_normal([c], &device)));
            let x = f64_normal([1, n, c], &device);
            let got = to_vec(attn.forward(x.clone(), None));
            let s = match scale {
                AttnScale::Hidden => 1.0 / (c as f64).sqrt(),
                AttnScale::Head => 1.0 / ((c / heads) as f64).sqrt(),
            };
            let want = reference(
                &to_vec(x.clone()),
                n,
                c,
                heads,
                &to_vec(attn.qkv.weight.val()),
                &to_vec(attn.output.weight.val()),
                &to_vec(attn.output.bias.as_ref().unwrap().val()),
                s,
            );
            let err = got
                .iter()
                .zip(&want)
                .fold(0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(err < 1e-12, "{scale:?}: {err}");
            // The other scale gives a measurably different output.
            let wrong = reference(
                &to_vec(x),
                n,
                c,
                heads,
                &to_vec(attn.qkv.weight.val()),
                &to_vec(attn.output.weight.val()),
                &to_vec(attn.output.bias.as_ref().unwrap().val()),
                if s == 0.5 { 1.0 / 12f64.sqrt() } else { 0.5 },
            );
            let gap = got
                .iter()
                .zip(&wrong)
                .fold(0f64, |m, (a, b)| m.max((a - b).abs()));
            assert!(gap > 1e-3, "{scale:?}: scale does not matter? {gap}");
        }
    }

    #[test]
    fn default_scale_is_one_over_sqrt_hidden() {
        let device = Device::flex();
        let attn = AttentionConfig::new(800, 10).init(&device);
        assert!((attn.scale() - 1.0 / 800f64.sqrt()).abs() < 1e-15);
        assert!(attn.qkv.bias.is_none());
        assert!(attn.output.bias.is_some());
        let [i, o] = attn.qkv.weight.dims();
        assert_eq!((i, o), (800, 2400));
    }

    #[test]
    fn heads_split_and_merge_round_trip() {
        let device = Device::flex();
        let data: Vec<f64> = (0..2 * 3 * 12).map(|i| i as f64).collect();
        let x = Tensor::<3>::from_data(
            TensorData::new(data, [2, 3, 12]),
            crate::testing::f64_options(&device),
        );
        let h = split_heads(x.clone(), 4);
        assert_eq!(h.dims(), [2, 4, 3, 3]);
        // Head 1 of token 2 (batch 0) is columns 3..6 of that token.
        let v = to_vec(h.clone().narrow(0, 0, 1).narrow(1, 1, 1).narrow(2, 2, 1));
        assert_eq!(v, vec![27.0, 28.0, 29.0]);
        assert_eq!(max_abs_diff(merge_heads(h), x.clone()), 0.0);
        assert_eq!(x.dtype(), DType::F64);
    }
}
