//! Keras-default initialisers used by mint (SPEC §4.1 "Initialisation", Appendix A).
//!
//! Burn's `Linear` defaults to Kaiming-uniform with a Kaiming bias; mint's `Dense` layers use
//! Glorot-uniform kernels and zero biases, and its position embeddings and output kernel a
//! truncated normal (σ 0.02, resampled outside ±2σ). Parameters stay lazy: they are drawn from
//! the device RNG (`device.seed`) on first use, so building a model to count its parameters
//! allocates nothing.

use burn::module::{Param, ParamId};
use burn::nn::{Initializer, Linear};
use burn::tensor::{Device, Distribution, Shape, Tensor};

/// Keras `Dense(d_out)` on `d_in` inputs: Glorot-uniform kernel U(±sqrt(6/(d_in + d_out))),
/// zero bias (mint base_model_util.py / Keras defaults).
pub fn glorot_dense(d_in: usize, d_out: usize, bias: bool, device: &Device) -> Linear {
    let weight = Initializer::XavierUniform { gain: 1.0 }.init_with(
        [d_in, d_out],
        Some(d_in),
        Some(d_out),
        device,
    );
    let bias = bias.then(|| Initializer::Zeros.init([d_out], device));
    Linear { weight, bias }
}

/// A dense layer with a truncated-normal kernel (σ = `std`) and zero bias: mint's output layer.
pub fn truncated_normal_dense(d_in: usize, d_out: usize, std: f64, device: &Device) -> Linear {
    Linear {
        weight: truncated_normal([d_in, d_out], std, device),
        bias: Some(Initializer::Zeros.init([d_out], device)),
    }
}

/// A lazy parameter drawn from N(0, std²) truncated to ±2·std by resampling (Keras
/// `TruncatedNormal`, which redraws values outside two standard deviations).
pub fn truncated_normal<const D: usize>(
    shape: [usize; D],
    std: f64,
    device: &Device,
) -> Param<Tensor<D>> {
    Param::uninitialized(
        ParamId::new(),
        move |device, require_grad| {
            let t = sample_truncated_normal(shape, std, device);
            if require_grad {
                t.require_grad()
            } else {
                t
            }
        },
        device.clone(),
        true,
        Shape::from(shape),
    )
}

/// Draws N(0, std²) values and redraws those outside ±2·std until none are left.
pub fn sample_truncated_normal<const D: usize>(
    shape: [usize; D],
    std: f64,
    device: &Device,
) -> Tensor<D> {
    let mut t = Tensor::<D>::random(shape, Distribution::Normal(0.0, std), device);
    loop {
        let outside = t.clone().abs().greater_elem(2.0 * std);
        if !outside.clone().any().into_scalar::<bool>() {
            return t;
        }
        let redraw = Tensor::<D>::random(shape, Distribution::Normal(0.0, std), device);
        t = t.mask_where(outside, redraw);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truncated_normal_stays_within_two_sigma_and_has_the_truncated_variance() {
        let device = Device::flex();
        let t = sample_truncated_normal([200, 200], 0.02, &device);
        let v: Vec<f32> = t.into_data().try_to_vec().unwrap();
        assert!(v.iter().all(|x| x.abs() <= 0.04 + 1e-7));
        let var = v.iter().map(|x| (*x as f64).powi(2)).sum::<f64>() / v.len() as f64;
        // Variance of N(0,1) truncated to ±2: 0.7737.
        let expected = 0.7737 * 0.02f64.powi(2);
        assert!(
            (var / expected - 1.0).abs() < 0.02,
            "var {var} vs {expected}"
        );
    }

    #[test]
    fn glorot_dense_limits_and_zero_bias() {
        let device = Device::flex();
        let d = glorot_dense(800, 2400, true, &device);
        let limit = (6.0f64 / 3200.0).sqrt() as f32;
        let w: Vec<f32> = d.weight.val().into_data().try_to_vec().unwrap();
        assert!(w.iter().all(|x| x.abs() <= limit));
        // Uniform on ±limit has max close to the limit.
        assert!(w.iter().fold(0f32, |m, x| m.max(x.abs())) > 0.99 * limit);
        let b: Vec<f32> = d.bias.unwrap().val().into_data().try_to_vec().unwrap();
        assert!(b.iter().all(|x| *x == 0.0));
    }
}
