//! Quaternion dense layer (Parcollet et al.; Orkis-Research `core_qnn/quaternion_ops.py`
//! `quaternion_linear`, speechbrain `q_linear.py`), SPEC §4.6.
//!
//! Input 4·C_in and output 4·C_out features in contiguous component blocks [r | i | j | k].
//! Four component matrices W_r, W_i, W_j, W_k [C_in, C_out] assemble the Hamilton block weight
//! (block rows = input component, block columns = output component):
//!
//! ```text
//! r: ( W_r,  W_i,  W_j,  W_k)
//! i: (−W_i,  W_r,  W_k, −W_j)
//! j: (−W_j, −W_k,  W_r,  W_i)
//! k: (−W_k,  W_j, −W_i,  W_r)
//! ```
//!
//! so y_o = Σ_c w_{c,o} ⊗ x_c + b_o with the weight on the left. Initialisation: Parcollet's
//! `quaternion_init` — modulus ρ ~ s·χ₄, axis u = v/(|v| + 1e-4) with v ~ U(−1, 1)³, phase
//! φ ~ U(−π, π), w = ρ(cos φ, u sin φ); s = 1/sqrt(2(C_in + C_out)) (Glorot) or 1/sqrt(2·C_in)
//! (He). The bias starts at zero.

use std::f64::consts::PI;

use burn::config::Config;
use burn::module::{Module, Param};
use burn::nn::Initializer;
use burn::tensor::module::linear;
use burn::tensor::{Device, Distribution, Tensor};
use serde::{Deserialize, Serialize};

/// Scale criterion of the quaternion initialiser.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum QuaternionInit {
    /// s = 1/sqrt(2(C_in + C_out)) (`QuaternionLinearAutograd`'s default).
    Glorot,
    /// s = 1/sqrt(2·C_in).
    He,
}

/// Configuration of [`QuaternionLinear`]; sizes count quaternions.
#[derive(Config, Debug)]
pub struct QuaternionLinearConfig {
    /// Input quaternions C_in (4·C_in features).
    pub in_quaternions: usize,
    /// Output quaternions C_out (4·C_out features).
    pub out_quaternions: usize,
    /// Whether to add a (zero-initialised) bias.
    #[config(default = true)]
    pub bias: bool,
    /// Initialiser scale criterion.
    #[config(default = "QuaternionInit::Glorot")]
    pub init: QuaternionInit,
}

/// Quaternion dense layer: four [C_in, C_out] component matrices and a [4·C_out] bias.
#[derive(Module, Debug)]
pub struct QuaternionLinear {
    /// Real component.
    pub w_r: Param<Tensor<2>>,
    /// i component.
    pub w_i: Param<Tensor<2>>,
    /// j component.
    pub w_j: Param<Tensor<2>>,
    /// k component.
    pub w_k: Param<Tensor<2>>,
    /// Bias over the 4·C_out output features.
    pub bias: Option<Param<Tensor<1>>>,
}

impl QuaternionLinearConfig {
    /// The initialiser scale s.
    pub fn scale(&self) -> f64 {
        let (i, o) = (self.in_quaternions as f64, self.out_quaternions as f64);
        match self.init {
            QuaternionInit::Glorot => 1.0 / (2.0 * (i + o)).sqrt(),
            QuaternionInit::He => 1.0 / (2.0 * i).sqrt(),
        }
    }

    /// Builds the layer, drawing the weights from the device RNG now (the four components share
    /// one draw of modulus, axis and phase, so they cannot be initialised separately).
    pub fn init(&self, device: &Device) -> QuaternionLinear {
        let shape = [self.in_quaternions, self.out_quaternions];
        let [ci, co] = shape;
        let s = self.scale();
        let normal = Tensor::<3>::random([4, ci, co], Distribution::Normal(0.0, 1.0), device);
        let rho = normal
            .square()
            .sum_dim(0)
            .sqrt()
            .reshape(shape)
            .mul_scalar(s);
        let v = Tensor::<3>::random([3, ci, co], Distribution::Uniform(-1.0, 1.0), device);
        let v_norm = v.clone().square().sum_dim(0).sqrt();
        let u = v / v_norm.add_scalar(1e-4);
        let phase = Tensor::<2>::random(shape, Distribution::Uniform(-PI, PI), device);
        let modulus_sin = rho.clone() * phase.clone().sin();
        let axis = |c: usize| u.clone().narrow(0, c, 1).reshape(shape) * modulus_sin.clone();
        QuaternionLinear {
            w_r: Param::from_tensor(rho * phase.cos()),
            w_i: Param::from_tensor(axis(0)),
            w_j: Param::from_tensor(axis(1)),
            w_k: Param::from_tensor(axis(2)),
            bias: self
                .bias
                .then(|| Initializer::Zeros.init([4 * self.out_quaternions], device)),
        }
    }
}

impl QuaternionLinear {
    /// The [4·C_in, 4·C_out] Hamilton block weight.
    pub fn weight(&self) -> Tensor<2> {
        let (r, i, j, k) = (
            self.w_r.val(),
            self.w_i.val(),
            self.w_j.val(),
            self.w_k.val(),
        );
        let row = |blocks: [Tensor<2>; 4]| Tensor::cat(blocks.to_vec(), 1);
        Tensor::cat(
            vec![
                row([r.clone(), i.clone(), j.clone(), k.clone()]),
                row([i.clone().neg(), r.clone(), k.clone(), j.clone().neg()]),
                row([j.clone().neg(), k.clone().neg(), r.clone(), i.clone()]),
                row([k.neg(), j, i.neg(), r]),
            ],
            0,
        )
    }

    /// x [..., 4·C_in] → [..., 4·C_out].
    pub fn forward<const D: usize>(&self, x: Tensor<D>) -> Tensor<D> {
        linear(x, self.weight(), self.bias.as_ref().map(|b| b.val()))
    }

    /// Input quaternions C_in.
    pub fn in_quaternions(&self) -> usize {
        self.w_r.dims()[0]
    }

    /// Output quaternions C_out.
    pub fn out_quaternions(&self) -> usize {
        self.w_r.dims()[1]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::quaternion::{hamilton, norm_sq};
    use crate::testing::{f64_normal, to_f64, to_vec};

    #[test]
    fn block_matrix_equals_per_quaternion_hamilton_products() {
        // QL-1 (SPEC §4.6): y_o = Σ_c w_{c,o} ⊗ x_c + b_o.
        let device = Device::flex();
        let (ci, co, n) = (3, 2, 4);
        let mut layer = to_f64(QuaternionLinearConfig::new(ci, co).init(&device));
        layer.bias = layer.bias.map(|b| b.map(|_| f64_normal([4 * co], &device)));
        let x = f64_normal([n, 4 * ci], &device);
        let y = to_vec(layer.forward(x.clone()));
        let xs = to_vec(x);
        let comps = [&layer.w_r, &layer.w_i, &layer.w_j, &layer.w_k].map(|w| to_vec(w.val()));
        let bias = to_vec(layer.bias.as_ref().unwrap().val());
        let mut worst = 0f64;
        for t in 0..n {
            for o in 0..co {
                let mut acc = [0.0; 4];
                for c in 0..ci {
                    let w = [0, 1, 2, 3].map(|p| comps[p][c * co + o]);
                    let xq = [0, 1, 2, 3].map(|p| xs[t * 4 * ci + p * ci + c]);
                    let prod = hamilton(w, xq);
                    (0..4).for_each(|p| acc[p] += prod[p]);
                }
                for p in 0..4 {
                    let got = y[t * 4 * co + p * co + o];
                    worst = worst.max((got - acc[p] - bias[p * co + o]).abs());
                }
            }
        }
        assert!(worst < 1e-12, "{worst}");
    }

    #[test]
    fn weight_on_the_right_would_differ() {
        // The layer is not x_c ⊗ w_{c,o}: the test above can tell the two orders apart.
        let w = [0.3, -1.2, 0.7, 2.0];
        let x = [-0.5, 0.1, 1.4, -0.9];
        let gap: f64 = (0..4)
            .map(|p| (hamilton(w, x)[p] - hamilton(x, w)[p]).abs())
            .sum();
        assert!(gap > 0.1);
    }

    #[test]
    fn init_has_expected_energy_and_zero_bias() {
        // QL-2: E|w|² ≈ 4s² (ρ ~ s·χ₄, so E ρ² = 4s²; |u| ≈ 1).
        let device = Device::flex();
        for init in [QuaternionInit::Glorot, QuaternionInit::He] {
            let config = QuaternionLinearConfig::new(100, 150).with_init(init);
            let layer = config.init(&device);
            let comps = [&layer.w_r, &layer.w_i, &layer.w_j, &layer.w_k].map(|w| to_vec(w.val()));
            let count = 100 * 150;
            let energy = (0..count)
                .map(|q| norm_sq([0, 1, 2, 3].map(|p| comps[p][q])))
                .sum::<f64>()
                / count as f64;
            let s = config.scale();
            assert!(
                (energy / (4.0 * s * s) - 1.0).abs() < 0.03,
                "{init:?}: {energy}"
            );
            // Phases spread: the real part is not always the largest component.
            let real_share = (0..count).map(|q| comps[0][q].powi(2)).sum::<f64>() / count as f64;
            assert!((real_share / energy - 0.5).abs() < 0.05, "{real_share}");
            let bias = to_vec(layer.bias.unwrap().val());
            assert!(bias.iter().all(|b| *b == 0.0));
        }
    }
}
