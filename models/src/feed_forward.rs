//! The transformer MLP (mint base_models.py `MLP`, SPEC §4.1): Dense(C → F) + tanh-GELU →
//! Dense(F → C), F = 3072 (the `Transformer.intermediate_size` proto default).

use burn::config::Config;
use burn::module::Module;
use burn::nn::Linear;
use burn::tensor::activation::gelu_approximate;
use burn::tensor::{Device, Tensor};

use crate::init::glorot_dense;

/// Configuration of [`FeedForward`].
#[derive(Config, Debug)]
pub struct FeedForwardConfig {
    /// Model width C.
    pub hidden: usize,
    /// Inner width F.
    pub inner: usize,
}

/// Two dense layers with a tanh-approximated GELU between them.
#[derive(Module, Debug)]
pub struct FeedForward {
    /// Dense(C → F).
    pub expand: Linear,
    /// Dense(F → C).
    pub contract: Linear,
}

impl FeedForwardConfig {
    /// Builds the MLP (Glorot kernels, zero biases).
    pub fn init(&self, device: &Device) -> FeedForward {
        FeedForward {
            expand: glorot_dense(self.hidden, self.inner, true, device),
            contract: glorot_dense(self.inner, self.hidden, true, device),
        }
    }
}

impl FeedForward {
    /// x [B, N, C] → [B, N, C].
    pub fn forward(&self, x: Tensor<3>) -> Tensor<3> {
        // GELU with the tanh approximation, 0.5x(1 + tanh(sqrt(2/π)(x + 0.044715x³))), as mint's
        // (TF 2.3 era) gelu.
        self.contract
            .forward(gelu_approximate(self.expand.forward(x)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{f64_tensor, to_vec};

    #[test]
    fn gelu_is_the_tanh_approximation() {
        let device = Device::flex();
        let xs = vec![-3.0, -1.0, -0.1, 0.0, 0.5, 2.0];
        let y = to_vec(gelu_approximate(f64_tensor(xs.clone(), [6], &device)));
        for (x, g) in xs.iter().zip(y) {
            let inner = (2.0 / std::f64::consts::PI).sqrt() * (x + 0.044715 * x.powi(3));
            let want = 0.5 * x * (1.0 + inner.tanh());
            assert!((g - want).abs() < 1e-14, "{x}: {g} vs {want}");
        }
        // Not the erf GELU: they differ by ~1e-4 near x = -1... measurable in f64.
        let erf_like = -0.15865525393145707; // x·Φ(x) at x = −1
        let tanh_value = to_vec(gelu_approximate(f64_tensor(vec![-1.0], [1], &device)))[0];
        assert!((tanh_value - erf_like).abs() > 1e-5);
    }
}
