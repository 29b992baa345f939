//! QRA, quaternion rotary attention (QEAN §3.4 eq. 25–28; the same layer as Quatformer's
//! Learning-to-Rotate Attention, DAMO-DI-ML/KDD2022-Quatformer
//! `layers/Learning_to_Rotate_Attention.py`), multi-head as in SPEC §4.5.
//!
//! 1. Four convs (ω_Q, θ_Q, ω_K, θ_K) map the layer input (or the projected q/k) to H·P
//!    channels, channel h·P + p = head h, period p; ω = ReLU(·) ≥ 0, θ = π·tanh(·) ∈ (−π, π).
//! 2. q, k, v from FACT's bias-free fused projection (or quaternion q/k projections); with SPE
//!    on, q and k are rotated (RoPE) before the quaternion view.
//! 3. Per head, m = floor(d/4) quaternions in contiguous blocks [real | i | j | k]; the
//!    d − 4m remainder dims enter the score unrotated.
//! 4. α = 2π·ω_Q·pos_n + θ_Q (eq. 26; `two_pi = false` drops the 2π like the reference code);
//!    q ⊗ e^{iα}, k ⊗ e^{jβ} (right multiplication).
//! 5. score = s·[(1/P)·Σ_p ⟨Φ_p, Ψ_p⟩ + ⟨q_rem, k_rem⟩] (eq. 27), one matmul over the
//!    concatenated copies; softmax over keys; S·V, heads concatenated, Dense(C → C) (eq. 28).

use std::f64::consts::PI;

use burn::config::Config;
use burn::module::Module;
use burn::nn::conv::{Conv1d, Conv1dConfig};
use burn::nn::{Dropout, DropoutConfig, Initializer, Linear, PaddingConfig1d};
use burn::tensor::activation::{relu, softmax};
use burn::tensor::{Device, Tensor, TensorCreationOptions, TensorData};

use crate::attention::{merge_heads, score_scale, split_heads};
use crate::init::glorot_dense;
use crate::quaternion_linear::{QuaternionLinear, QuaternionLinearConfig};
use crate::spe::RotaryTables;
use qean_config::model::{AttnScale, QraConvInput, QraDk, QraInit, QraQkProj};

/// Configuration of [`Qra`].
#[derive(Config, Debug)]
pub struct QraConfig {
    /// Model width C.
    pub hidden: usize,
    /// Heads H.
    pub heads: usize,
    /// Periods P (2, the reference default).
    #[config(default = 2)]
    pub periods: usize,
    /// Conv kernel (1, the reference; or 3 with zero "same" padding).
    #[config(default = 1)]
    pub kernel: usize,
    /// Backbone score scale (stands in for the paper's 1/sqrt(d)).
    #[config(default = "AttnScale::Hidden")]
    pub scale: AttnScale,
    /// Multiply ω by 2π (eq. 26).
    #[config(default = true)]
    pub two_pi: bool,
    /// q/k width per head.
    #[config(default = "QraDk::Floor")]
    pub dk: QraDk,
    /// What the ω/θ convs read.
    #[config(default = "QraConvInput::Normed")]
    pub conv_input: QraConvInput,
    /// q/k projection.
    #[config(default = "QraQkProj::Dense")]
    pub qk_proj: QraQkProj,
    /// Dropout on the attention probabilities.
    #[config(default = 0.0)]
    pub dropout: f64,
    /// Initialisation of the ω/θ convs.
    #[config(default = "QraInit::Default")]
    pub init: QraInit,
}

/// Quaternion rotary attention.
#[derive(Module, Debug)]
pub struct Qra {
    /// Fused bias-free projection C → 2·H·d_k + C (q | k | v), as FACT's (`qk_proj = dense`).
    pub qkv: Option<Linear>,
    /// Quaternion q projection (`qk_proj = quaternion`).
    pub q_proj: Option<QuaternionLinear>,
    /// Quaternion k projection (`qk_proj = quaternion`).
    pub k_proj: Option<QuaternionLinear>,
    /// Bias-free v projection (`qk_proj = quaternion`).
    pub v_proj: Option<Linear>,
    /// ω_Q conv.
    pub omega_q: Conv1d,
    /// θ_Q conv.
    pub theta_q: Conv1d,
    /// ω_K conv.
    pub omega_k: Conv1d,
    /// θ_K conv.
    pub theta_k: Conv1d,
    /// Dense(C → C) with bias.
    pub output: Linear,
    /// Dropout on the probabilities.
    pub dropout: Dropout,
    heads: usize,
    periods: usize,
    qk_head_dim: usize,
    scale: f64,
    two_pi: bool,
    conv_reads_projection: bool,
}

/// ω and θ of one side (Q or K), [B, H, P, N].
#[derive(Clone, Debug)]
pub struct FrequencyPhase {
    /// Frequencies ω ≥ 0.
    pub omega: Tensor<4>,
    /// Phases θ ∈ (−π, π).
    pub theta: Tensor<4>,
}

/// Quatformer's regularisers for one QRA layer: mean((ω_{n+1} − ω_n)²) and mean(θ²), each
/// averaged over the Q and K sides.
#[derive(Clone, Debug)]
pub struct QraPenalty {
    /// Smoothness of ω along positions.
    pub omega_smoothness: Tensor<1>,
    /// Mean squared phase.
    pub theta_square: Tensor<1>,
}

/// Token-side inputs of one QRA call: the normalised tokens, their normalised positions
/// (pos_n of eq. 26) and, with SPE, their rotary tables.
pub struct QraSide<'a> {
    /// Tokens [B, N, C].
    pub x: Tensor<3>,
    /// Normalised position of every token.
    pub positions: &'a [f64],
    /// Rotary tables for the q/k head width, when SPE is on.
    pub rope: Option<&'a RotaryTables>,
}

/// What [`Qra::probabilities`] computes for one query/key pair.
pub struct QraAttention {
    /// Attention probabilities [B, H, N, M], after dropout.
    pub probs: Tensor<4>,
    /// Values [B, H, M, d_v].
    pub values: Tensor<4>,
    /// Frequencies and phases of the query side.
    pub query: FrequencyPhase,
    /// Frequencies and phases of the key side.
    pub key: FrequencyPhase,
}

impl QraConfig {
    /// q/k width per head.
    pub fn qk_head_dim(&self) -> usize {
        let d = self.hidden / self.heads;
        match (self.dk, self.qk_proj) {
            (QraDk::Floor, QraQkProj::Dense) => d,
            _ => d.div_ceil(4) * 4,
        }
    }

    /// Builds the layer: Glorot projections (as FACT), convs U(±1/sqrt(C_in·kernel)).
    pub fn init(&self, device: &Device) -> Qra {
        assert!(
            self.hidden.is_multiple_of(self.heads),
            "heads must divide hidden"
        );
        assert!(
            self.kernel == 1 || self.kernel == 3,
            "QRA kernel must be 1 or 3"
        );
        let c = self.hidden;
        let dq = self.heads * self.qk_head_dim();
        let (qkv, q_proj, k_proj, v_proj) = match self.qk_proj {
            QraQkProj::Dense => (
                Some(glorot_dense(c, 2 * dq + c, false, device)),
                None,
                None,
                None,
            ),
            QraQkProj::Quaternion => {
                assert!(
                    c.is_multiple_of(4),
                    "quaternion q/k projection needs hidden % 4 == 0"
                );
                let q = QuaternionLinearConfig::new(c / 4, dq / 4).init(device);
                let k = QuaternionLinearConfig::new(c / 4, dq / 4).init(device);
                let v = glorot_dense(c, c, false, device);
                (None, Some(q), Some(k), Some(v))
            }
        };
        let conv_in = match self.conv_input {
            QraConvInput::Normed => c,
            QraConvInput::Projected => dq,
        };
        let bound = 1.0 / ((conv_in * self.kernel) as f64).sqrt();
        let initializer = match self.init {
            QraInit::Default => Initializer::Uniform {
                min: -bound,
                max: bound,
            },
            QraInit::Small => Initializer::Uniform {
                min: -0.1 * bound,
                max: 0.1 * bound,
            },
            QraInit::Zero => Initializer::Zeros,
        };
        let conv = || {
            Conv1dConfig::new(conv_in, self.heads * self.periods, self.kernel)
                .with_padding(PaddingConfig1d::Explicit(self.kernel / 2, self.kernel / 2))
                .with_initializer(initializer.clone())
                .init(device)
        };
        Qra {
            qkv,
            q_proj,
            k_proj,
            v_proj,
            omega_q: conv(),
            theta_q: conv(),
            omega_k: conv(),
            theta_k: conv(),
            output: glorot_dense(c, c, true, device),
            dropout: DropoutConfig::new(self.dropout).init(),
            heads: self.heads,
            periods: self.periods,
            qk_head_dim: self.qk_head_dim(),
            scale: score_scale(self.scale, self.hidden, self.heads),
            two_pi: self.two_pi,
            conv_reads_projection: self.conv_input == QraConvInput::Projected,
        }
    }
}

/// q ⊗ e^{iα} in closed form: (a cos − b sin, b cos + a sin, c cos + d sin, d cos − c sin).
pub fn rotate_about_i(q: [Tensor<5>; 4], cos: Tensor<5>, sin: Tensor<5>) -> [Tensor<5>; 4] {
    let [a, b, c, d] = q;
    [
        a.clone() * cos.clone() - b.clone() * sin.clone(),
        b * cos.clone() + a * sin.clone(),
        c.clone() * cos.clone() + d.clone() * sin.clone(),
        d * cos - c * sin,
    ]
}

/// k ⊗ e^{jβ} in closed form: (a cos − c sin, b cos − d sin, c cos + a sin, d cos + b sin).
pub fn rotate_about_j(k: [Tensor<5>; 4], cos: Tensor<5>, sin: Tensor<5>) -> [Tensor<5>; 4] {
    let [a, b, c, d] = k;
    [
        a.clone() * cos.clone() - c.clone() * sin.clone(),
        b.clone() * cos.clone() - d.clone() * sin.clone(),
        c * cos.clone() + a * sin.clone(),
        d * cos + b * sin,
    ]
}

/// Rotates every quaternion of x [B, H, N, d] by the per-(head, period, token) angles
/// [B, H, P, N] and lays the P rotated copies side by side, scaled by `copy_scale`, followed by
/// the unrotated remainder dims: [B, H, N, P·4m + (d − 4m)].
fn quaternion_copies(x: Tensor<4>, angles: Tensor<4>, about_i: bool, copy_scale: f64) -> Tensor<4> {
    let [b, h, n, d] = x.dims();
    let p = angles.dims()[2];
    let m = d / 4;
    let part = |i: usize| x.clone().narrow(3, i * m, m).unsqueeze_dim::<5>(2);
    let parts = [part(0), part(1), part(2), part(3)];
    let angles = angles.unsqueeze_dim::<5>(4);
    let (cos, sin) = (angles.clone().cos(), angles.sin());
    let rotated = if about_i {
        rotate_about_i(parts, cos, sin)
    } else {
        rotate_about_j(parts, cos, sin)
    };
    // [B, H, P, N, 4m] → [B, H, N, P·4m]
    let copies = Tensor::cat(rotated.to_vec(), 4)
        .swap_dims(2, 3)
        .reshape([b, h, n, p * 4 * m])
        .mul_scalar(copy_scale);
    if d > 4 * m {
        Tensor::cat(vec![copies, x.narrow(3, 4 * m, d - 4 * m)], 3)
    } else {
        copies
    }
}

impl Qra {
    /// Self-attention: queries and keys are the same tokens.
    pub fn forward(
        &self,
        x: Tensor<3>,
        positions: &[f64],
        rope: Option<&RotaryTables>,
    ) -> (Tensor<3>, QraPenalty) {
        let side = || QraSide {
            x: x.clone(),
            positions,
            rope,
        };
        self.forward_cross(side(), side())
    }

    /// Queries from `query` tokens attend to `key` tokens (N ≠ M allowed).
    pub fn forward_cross(&self, query: QraSide, key: QraSide) -> (Tensor<3>, QraPenalty) {
        let a = self.probabilities(query, key);
        let heads = a.probs.matmul(a.values);
        let penalty = penalty(&a.query, &a.key);
        (self.output.forward(merge_heads(heads)), penalty)
    }

    /// Attention probabilities, values and the frequencies/phases of both sides.
    pub fn probabilities(&self, query: QraSide, key: QraSide) -> QraAttention {
        let [_, n, c] = query.x.dims();
        let m_keys = key.x.dims()[1];
        assert_eq!(
            query.positions.len(),
            n,
            "QRA: one position per query token"
        );
        assert_eq!(
            key.positions.len(),
            m_keys,
            "QRA: one position per key token"
        );
        let (q, k, v) = self.project(query.x.clone(), key.x.clone(), c);
        let (conv_q_in, conv_k_in) = if self.conv_reads_projection {
            (q.clone(), k.clone())
        } else {
            (query.x.clone(), key.x.clone())
        };
        let fq = self.frequency_phase(&self.omega_q, &self.theta_q, conv_q_in);
        let fk = self.frequency_phase(&self.omega_k, &self.theta_k, conv_k_in);
        let mut q = split_heads(q, self.heads);
        let mut k = split_heads(k, self.heads);
        let v = split_heads(v, self.heads);
        if let Some(t) = query.rope {
            q = t.rotate(q);
        }
        if let Some(t) = key.rope {
            k = t.rotate(k);
        }
        let alpha = self.angles(&fq, query.positions);
        let beta = self.angles(&fk, key.positions);
        let qc = quaternion_copies(q, alpha, true, 1.0 / self.periods as f64);
        let kc = quaternion_copies(k, beta, false, 1.0);
        let scores = qc.matmul(kc.swap_dims(2, 3)).mul_scalar(self.scale);
        QraAttention {
            probs: self.dropout.forward(softmax(scores, 3)),
            values: v,
            query: fq,
            key: fk,
        }
    }

    /// q [B, N, H·d_k], k [B, M, H·d_k], v [B, M, C]; per-head layout of q/k is
    /// [real | i | j | k | remainder].
    fn project(&self, xq: Tensor<3>, xk: Tensor<3>, c: usize) -> (Tensor<3>, Tensor<3>, Tensor<3>) {
        let dq = self.heads * self.qk_head_dim;
        match (&self.qkv, &self.q_proj, &self.k_proj, &self.v_proj) {
            (Some(qkv), _, _, _) => {
                let w = qkv.weight.val();
                let q = burn::tensor::module::linear(xq, w.clone().narrow(1, 0, dq), None);
                let k = burn::tensor::module::linear(xk.clone(), w.clone().narrow(1, dq, dq), None);
                let v = burn::tensor::module::linear(xk, w.narrow(1, 2 * dq, c), None);
                (q, k, v)
            }
            (None, Some(qp), Some(kp), Some(vp)) => {
                let q = self.quaternions_to_heads(qp.forward(xq));
                let k = self.quaternions_to_heads(kp.forward(xk.clone()));
                (q, k, vp.forward(xk))
            }
            _ => unreachable!("QraConfig::init sets either qkv or the three projections"),
        }
    }

    /// QuaternionLinear output [r | i | j | k] (each H·d_k/4 wide) → head-major [B, N, H·d_k]:
    /// output quaternion o = (d_k/4)·h + c becomes quaternion c of head h (SPEC §4.6).
    fn quaternions_to_heads(&self, y: Tensor<3>) -> Tensor<3> {
        let [b, n, _] = y.dims();
        let m = self.qk_head_dim / 4;
        y.reshape([b * n, 4, self.heads, m])
            .swap_dims(1, 2)
            .reshape([b, n, self.heads * self.qk_head_dim])
    }

    fn frequency_phase(&self, omega: &Conv1d, theta: &Conv1d, x: Tensor<3>) -> FrequencyPhase {
        let [b, n, _] = x.dims();
        let x = x.swap_dims(1, 2);
        let shape = [b, self.heads, self.periods, n];
        FrequencyPhase {
            omega: relu(omega.forward(x.clone())).reshape(shape),
            theta: theta.forward(x).tanh().mul_scalar(PI).reshape(shape),
        }
    }

    /// α = (2π)·ω·pos + θ, [B, H, P, N].
    fn angles(&self, f: &FrequencyPhase, positions: &[f64]) -> Tensor<4> {
        let n = positions.len();
        let pos = Tensor::<1>::from_data(
            TensorData::new(positions.to_vec(), [n]),
            TensorCreationOptions::new(f.omega.device()).with_dtype(f.omega.dtype()),
        )
        .reshape([1, 1, 1, n]);
        let omega = if self.two_pi {
            f.omega.clone().mul_scalar(2.0 * PI)
        } else {
            f.omega.clone()
        };
        omega * pos + f.theta.clone()
    }

    /// Heads H.
    pub fn heads(&self) -> usize {
        self.heads
    }

    /// Periods P.
    pub fn periods(&self) -> usize {
        self.periods
    }
}

fn penalty(fq: &FrequencyPhase, fk: &FrequencyPhase) -> QraPenalty {
    let smooth = |omega: &Tensor<4>| {
        let n = omega.dims()[3];
        if n < 2 {
            return omega.clone().sum().mul_scalar(0.0);
        }
        let diff = omega.clone().narrow(3, 1, n - 1) - omega.clone().narrow(3, 0, n - 1);
        diff.square().mean()
    };
    QraPenalty {
        omega_smoothness: (smooth(&fq.omega) + smooth(&fk.omega)).mul_scalar(0.5),
        theta_square: (fq.theta.clone().square().mean() + fk.theta.clone().square().mean())
            .mul_scalar(0.5),
    }
}

/// Normalised QRA positions n/N for N tokens.
pub fn fractional_positions(len: usize) -> Vec<f64> {
    (0..len).map(|i| i as f64 / len as f64).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attention::{Attention, AttentionConfig};
    use crate::quaternion::{hamilton, norm_sq};
    use crate::spe::SpeConfig;
    use crate::testing::{f64_normal, max_abs_diff, to_f64, to_vec};
    use burn::module::Param;
    use burn::tensor::DType;

    fn zero_convs(mut qra: Qra) -> Qra {
        let zero = |conv: Conv1d| Conv1d {
            weight: conv.weight.map(|w| w.zeros_like()),
            bias: conv.bias.map(|b| b.map(|t| t.zeros_like())),
            ..conv
        };
        qra.omega_q = zero(qra.omega_q);
        qra.theta_q = zero(qra.theta_q);
        qra.omega_k = zero(qra.omega_k);
        qra.theta_k = zero(qra.theta_k);
        qra
    }

    /// Pearson correlation of the row-centred log-probabilities (= row-centred scores) of two
    /// QRA layers that differ only in their convs.
    fn score_correlation(a: &Qra, b: &Qra, x: Tensor<3>, positions: &[f64]) -> f64 {
        let side = || QraSide {
            x: x.clone(),
            positions,
            rope: None,
        };
        let centred = |q: &Qra| {
            let l = q.probabilities(side(), side()).probs.log();
            let mean = l.clone().mean_dim(3);
            to_vec(l - mean)
        };
        let (u, v) = (centred(a), centred(b));
        let n = u.len() as f64;
        let (mu, mv) = (u.iter().sum::<f64>() / n, v.iter().sum::<f64>() / n);
        let (mut suv, mut suu, mut svv) = (0.0, 0.0, 0.0);
        for (x, y) in u.iter().zip(&v) {
            suv += (x - mu) * (y - mv);
            suu += (x - mu).powi(2);
            svv += (y - mv).powi(2);
        }
        suv / (suu * svv).sqrt()
    }

    /// `qra_init`: how close QRA's scores start to dot-product attention's (issue 17). Zero is
    /// attention exactly; small is close; the default initialisation is far (printed with
    /// --nocapture for docs/freezing.md).
    #[test]
    fn qra_init_sets_how_close_qra_starts_to_attention() {
        let device = Device::flex();
        for (hidden, heads, n) in [(80, 8, 180), (800, 16, 360)] {
            let mut corr = Vec::new();
            for init in [QraInit::Default, QraInit::Small, QraInit::Zero] {
                device.seed(5);
                let qra = to_f64(QraConfig::new(hidden, heads).with_init(init).init(&device));
                let plain = zero_convs(qra.clone());
                let x = f64_normal([1, n, hidden], &device);
                let positions: Vec<f64> = (0..n).map(|i| i as f64 / n as f64).collect();
                corr.push(score_correlation(&qra, &plain, x, &positions));
            }
            println!(
                "hidden {hidden}, {heads} heads, {n} tokens: score correlation with attention at init: \
                 default {:.3}, small {:.3}, zero {:.3}",
                corr[0], corr[1], corr[2]
            );
            assert!((corr[2] - 1.0).abs() < 1e-9, "{corr:?}");
            assert!(corr[1] > 0.9 && corr[0] < corr[1], "{corr:?}");
        }
    }

    fn pair(hidden: usize, heads: usize, periods: usize, device: &Device) -> (Attention, Qra) {
        let mut attn = to_f64(AttentionConfig::new(hidden, heads).init(device));
        // Sharper scores than Glorot, so a broken reduction could not hide in a flat softmax.
        attn.qkv.weight = attn.qkv.weight.map(|w| w.mul_scalar(3.0));
        let mut qra = to_f64(
            QraConfig::new(hidden, heads)
                .with_periods(periods)
                .init(device),
        );
        qra.qkv = Some(attn.qkv.clone());
        qra.output = attn.output.clone();
        (attn, zero_convs(qra))
    }

    #[test]
    fn zero_convs_reduce_to_canonical_attention() {
        // QRA-1: ω = θ = 0 gives FACT's attention with the same weights, for P = 1 and 2, with a
        // remainder (d_h = 10: 2 quaternions + 2 dims) and without (d_h = 8).
        let device = Device::flex();
        for (hidden, heads) in [(40, 4), (32, 4)] {
            for periods in [1, 2] {
                let (attn, qra) = pair(hidden, heads, periods, &device);
                let x = f64_normal([2, 7, hidden], &device);
                let pos = fractional_positions(7);
                let want = attn.forward(x.clone(), None);
                let (got, _) = qra.forward(x, &pos, None);
                let err = max_abs_diff(got, want);
                println!("QRA-1 C {hidden} P {periods}: max |QRA − attention| = {err:.2e}");
                assert!(err < 1e-10, "C {hidden} P {periods}: {err}");
            }
        }
    }

    #[test]
    fn zero_convs_with_spe_reduce_to_rotary_attention() {
        let device = Device::flex();
        let (attn, qra) = pair(40, 4, 2, &device);
        let spe = SpeConfig::new(10).init();
        let tables = spe.tables(&[0.0, 1.0, 2.0, 0.0, 1.0], &device, DType::F64);
        let x = f64_normal([1, 5, 40], &device);
        let want = attn.forward(x.clone(), Some(&tables));
        let (got, _) = qra.forward(x, &fractional_positions(5), Some(&tables));
        assert!(max_abs_diff(got, want) < 1e-10);
    }

    #[test]
    fn nonzero_phases_change_the_output() {
        let device = Device::flex();
        let (attn, mut qra) = pair(32, 4, 2, &device);
        qra.theta_q.bias = qra.theta_q.bias.map(|b| b.map(|t| t.ones_like()));
        let x = f64_normal([1, 6, 32], &device);
        let (got, _) = qra.forward(x.clone(), &fractional_positions(6), None);
        assert!(max_abs_diff(got, attn.forward(x, None)) > 1e-4);
    }

    fn random_angle_parts(device: &Device) -> ([Tensor<5>; 4], Tensor<5>) {
        let parts = [0, 1, 2, 3].map(|_| f64_normal([1, 1, 1, 5, 1], device));
        let angle = f64_normal([1, 1, 1, 5, 1], device).mul_scalar(2.0);
        (parts, angle)
    }

    #[test]
    fn closed_forms_are_right_hamilton_products_and_keep_norms() {
        // QRA-2 and QRA-3.
        let device = Device::flex();
        let (parts, angle) = random_angle_parts(&device);
        let (cos, sin) = (angle.clone().cos(), angle.clone().sin());
        let qi = rotate_about_i(parts.clone(), cos.clone(), sin.clone()).map(to_vec);
        let kj = rotate_about_j(parts.clone(), cos, sin).map(to_vec);
        let q = parts.map(to_vec);
        let a = to_vec(angle);
        for t in 0..5 {
            let x = [q[0][t], q[1][t], q[2][t], q[3][t]];
            let ei = [a[t].cos(), a[t].sin(), 0.0, 0.0];
            let ej = [a[t].cos(), 0.0, a[t].sin(), 0.0];
            let want_i = hamilton(x, ei);
            let want_j = hamilton(x, ej);
            for p in 0..4 {
                assert!((qi[p][t] - want_i[p]).abs() < 1e-14);
                assert!((kj[p][t] - want_j[p]).abs() < 1e-14);
            }
            let got_i = [qi[0][t], qi[1][t], qi[2][t], qi[3][t]];
            assert!((norm_sq(got_i) - norm_sq(x)).abs() < 1e-12);
            // Left multiplication would differ.
            let left = hamilton(ei, x);
            assert!((0..4).any(|p| (left[p] - want_i[p]).abs() > 1e-6) || a[t].sin().abs() < 1e-3);
        }
    }

    #[test]
    fn a_theta_q_bias_channel_moves_only_its_head() {
        // QRA-4: channel h·P + p belongs to head h.
        let device = Device::flex();
        let (heads, periods) = (4, 2);
        let (_, base) = pair(32, heads, periods, &device);
        let x = f64_normal([1, 6, 32], &device);
        let pos = fractional_positions(6);
        let side = || QraSide {
            x: x.clone(),
            positions: &pos,
            rope: None,
        };
        let p0 = base.probabilities(side(), side()).probs;
        let (h, p) = (2, 1);
        let mut moved = base.clone();
        let mut bias = vec![0.0; heads * periods];
        bias[h * periods + p] = 1.5;
        moved.theta_q.bias = Some(Param::from_tensor(crate::testing::f64_tensor(
            bias,
            [heads * periods],
            &device,
        )));
        let p1 = moved.probabilities(side(), side()).probs;
        for head in 0..heads {
            let diff = max_abs_diff(p0.clone().narrow(1, head, 1), p1.clone().narrow(1, head, 1));
            if head == h {
                assert!(diff > 1e-6, "head {head} should move: {diff}");
            } else {
                assert!(diff < 1e-15, "head {head} moved: {diff}");
            }
        }
    }

    #[test]
    fn round_up_and_quaternion_projection_shapes_and_counts() {
        let device = Device::flex();
        // d_h = 50 → 52 with round_up: q/k 832 wide, v 800.
        let qra = QraConfig::new(800, 16)
            .with_dk(QraDk::RoundUp)
            .init(&device);
        assert_eq!(
            qra.qkv.as_ref().unwrap().weight.dims(),
            [800, 2 * 832 + 800]
        );
        let qra = QraConfig::new(32, 4)
            .with_qk_proj(QraQkProj::Quaternion)
            .init(&device);
        assert_eq!(qra.q_proj.as_ref().unwrap().in_quaternions(), 8);
        assert_eq!(qra.q_proj.as_ref().unwrap().out_quaternions(), 8);
        let x = Tensor::<3>::random([2, 5, 32], burn::tensor::Distribution::Default, &device);
        let (y, pen) = qra.forward(x, &fractional_positions(5), None);
        assert_eq!(y.dims(), [2, 5, 32]);
        assert!(pen.theta_square.into_scalar::<f32>() >= 0.0);
        // Kernel 3 with projected conv input.
        let qra = QraConfig::new(32, 4)
            .with_kernel(3)
            .with_conv_input(QraConvInput::Projected)
            .init(&device);
        let x = Tensor::<3>::random([1, 5, 32], burn::tensor::Distribution::Default, &device);
        let (y, _) = qra.forward(x, &fractional_positions(5), None);
        assert_eq!(y.dims(), [1, 5, 32]);
    }

    #[test]
    fn penalty_is_zero_for_constant_omega_and_zero_theta() {
        let device = Device::flex();
        let (_, qra) = pair(32, 4, 2, &device);
        let x = f64_normal([1, 6, 32], &device);
        let (_, pen) = qra.forward(x, &fractional_positions(6), None);
        assert_eq!(to_vec(pen.omega_smoothness), vec![0.0]);
        assert_eq!(to_vec(pen.theta_square), vec![0.0]);
    }
}
