//! The transformer MLP (mint base_models.py `MLP`, SPEC §4.1): Dense(C → F) + tanh-GELU →
//! Dense(F → C), F = 3072 (the `Transformer.intermediate_size` proto default).

use burn::config::Config;
use burn::module::Module;
use burn::nn::Linear;
use burn::tensor::activation::sigmoid;
use burn::tensor::{Device, Tensor};

use crate::init::glorot_dense;

/// Configuration of [`FeedForward`].
#[derive(Config, Debug)]
pub struct FeedForwardConfig {
    /// Model width C.
    pub hidden: usize,
    /// Inner width F.
    pub inner: usize,
    /// ReLU instead of the tanh-GELU (the in-betweeners' `mlp_act = "relu"`).
    #[config(default = false)]
    pub relu: bool,
}

/// Two dense layers with a tanh-approximated GELU between them.
#[derive(Module, Debug)]
pub struct FeedForward {
    /// Dense(C → F).
    pub expand: Linear,
    /// Dense(F → C).
    pub contract: Linear,
    relu: bool,
}

impl FeedForwardConfig {
    /// Builds the MLP (Glorot kernels, zero biases).
    pub fn init(&self, device: &Device) -> FeedForward {
        FeedForward {
            expand: glorot_dense(self.hidden, self.inner, true, device),
            contract: glorot_dense(self.inner, self.hidden, true, device),
            relu: self.relu,
        }
    }
}

impl FeedForward {
    /// x [B, N, C] → [B, N, C].
    pub fn forward(&self, x: Tensor<3>) -> Tensor<3> {
        let h = self.expand.forward(x);
        let h = if self.relu {
            burn::tensor::activation::relu(h)
        } else {
            gelu_tanh(h)
        };
        self.contract.forward(h)
    }
}

/// GELU with the tanh approximation, 0.5x(1 + tanh(sqrt(2/π)(x + 0.044715x³))), as mint's (TF 2.3
/// era) gelu; computed as x·σ(2u) (the same function: 0.5(1 + tanh u) = σ(2u)) with x³ from
/// products, so one exp per element and no powf or tanh (which cost a quarter of a CPU step).
pub fn gelu_tanh<const D: usize>(x: Tensor<D>) -> Tensor<D> {
    let a = 2.0 * (2.0 / std::f64::consts::PI).sqrt();
    let b = a * 0.044715;
    // 2u = x·(a + b·x²)
    let two_u = x.clone() * (x.clone() * x.clone()).mul_scalar(b).add_scalar(a);
    x * sigmoid(two_u)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{f64_tensor, to_vec};

    #[test]
    fn gelu_is_the_tanh_approximation() {
        let device = Device::flex();
        let xs = vec![-30.0, -3.0, -1.0, -0.1, 0.0, 0.5, 2.0, 30.0];
        let y = to_vec(gelu_tanh(f64_tensor(xs.clone(), [8], &device)));
        for (x, g) in xs.iter().zip(y) {
            let inner = (2.0 / std::f64::consts::PI).sqrt() * (x + 0.044715 * x.powi(3));
            let want = 0.5 * x * (1.0 + inner.tanh());
            assert!((g - want).abs() < 1e-14, "{x}: {g} vs {want}");
        }
        // Not the erf GELU: they differ by ~1e-4 near x = -1... measurable in f64.
        let erf_like = -0.15865525393145707; // x·Φ(x) at x = −1
        let tanh_value = to_vec(gelu_tanh(f64_tensor(vec![-1.0], [1], &device)))[0];
        assert!((tanh_value - erf_like).abs() > 1e-5);
        // Burn's own tanh-GELU agrees (it computes the same function the slow way).
        let burn = to_vec(burn::tensor::activation::gelu_approximate(f64_tensor(
            xs.clone(),
            [8],
            &device,
        )));
        let ours = to_vec(gelu_tanh(f64_tensor(xs, [8], &device)));
        for (a, b) in burn.iter().zip(&ours) {
            assert!((a - b).abs() < 1e-13, "{a} vs {b}");
        }
    }

    #[test]
    fn gelu_gradient_matches_the_derivative() {
        // d/dx of 0.5x(1 + tanh u): 0.5(1 + tanh u) + 0.5x(1 − tanh²u)·u'.
        let device = Device::flex().autodiff();
        let xs = vec![-2.5, -0.7, 0.0, 0.3, 1.9];
        let x = f64_tensor(xs.clone(), [5], &device).require_grad();
        let grads = gelu_tanh(x.clone()).sum().backward();
        let g = to_vec(x.grad(&grads).unwrap());
        let c = (2.0 / std::f64::consts::PI).sqrt();
        for (x, g) in xs.iter().zip(g) {
            let u = c * (x + 0.044715 * x.powi(3));
            let du = c * (1.0 + 3.0 * 0.044715 * x * x);
            let want = 0.5 * (1.0 + u.tanh()) + 0.5 * x * (1.0 - u.tanh().powi(2)) * du;
            assert!((g - want).abs() < 1e-12, "{x}: {g} vs {want}");
        }
    }
}
