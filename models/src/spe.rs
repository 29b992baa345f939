//! SPE: rotary position encoding of per-head queries and keys (QEAN eq. 12–24; RoFormer).
//!
//! Head dim d, pairs t = 0..d/2, φ_t = base^(−2t/d). At position s the pair is rotated by s·φ_t:
//! (x, y) → (x cos − y sin, y cos + x sin). Interleaved pairs (x_{2t}, x_{2t+1}) by default,
//! half-split (x_t, x_{t+d/2}) as an option (SPEC §4.4). Positions are an explicit list, so the
//! cross-modal stack can number motion and audio tokens from 0 each (per-modality positions).
//! No parameters: the tables are computed per call from the positions.

use burn::config::Config;
use burn::module::Module;
use burn::tensor::{DType, Device, Tensor, TensorCreationOptions, TensorData};

use qean_config::model::RopePairing;

/// Configuration of [`Spe`].
#[derive(Config, Debug)]
pub struct SpeConfig {
    /// Width of one head (even).
    pub head_dim: usize,
    /// Frequency base (10000).
    #[config(default = 10000.0)]
    pub base: f64,
    /// Pair convention.
    #[config(default = "RopePairing::Interleaved")]
    pub pairing: RopePairing,
}

/// Rotary encoder of q/k heads.
#[derive(Module, Debug)]
pub struct Spe {
    head_dim: usize,
    base: f64,
    #[module(skip)]
    pairing: RopePairing,
}

/// cos and sin of every (position, dim) angle, [N, head_dim], ready to broadcast over [B, H].
#[derive(Clone, Debug)]
pub struct RotaryTables {
    cos: Tensor<2>,
    sin: Tensor<2>,
    pairing: RopePairing,
}

impl SpeConfig {
    /// Builds the encoder.
    pub fn init(&self) -> Spe {
        assert!(
            self.head_dim.is_multiple_of(2),
            "rotary head dim must be even"
        );
        Spe {
            head_dim: self.head_dim,
            base: self.base,
            pairing: self.pairing,
        }
    }
}

impl Spe {
    /// The rotation angle s·φ_t of every dim of a head at position `s`, in dim order.
    pub fn angles(&self, s: f64) -> Vec<f64> {
        let d = self.head_dim;
        let half = d / 2;
        let phi = |t: usize| self.base.powf(-2.0 * t as f64 / d as f64);
        (0..d)
            .map(|i| {
                let t = match self.pairing {
                    RopePairing::Interleaved => i / 2,
                    RopePairing::HalfSplit => i % half,
                };
                s * phi(t)
            })
            .collect()
    }

    /// Tables for the given token positions, computed in f64 and stored in `dtype`.
    pub fn tables(&self, positions: &[f64], device: &Device, dtype: DType) -> RotaryTables {
        let n = positions.len();
        let angles: Vec<f64> = positions.iter().flat_map(|&s| self.angles(s)).collect();
        let make = |f: fn(f64) -> f64| {
            let data = TensorData::new(angles.iter().map(|a| f(*a)).collect(), [n, self.head_dim]);
            Tensor::<2>::from_data(
                data,
                TensorCreationOptions::new(device.clone()).with_dtype(dtype),
            )
        };
        RotaryTables {
            cos: make(f64::cos),
            sin: make(f64::sin),
            pairing: self.pairing,
        }
    }

    /// Rotates x [B, H, N, head_dim] by the tables of its N positions.
    pub fn rotate(&self, x: Tensor<4>, tables: &RotaryTables) -> Tensor<4> {
        tables.rotate(x)
    }

    /// Positions 0..len.
    pub fn range(len: usize) -> Vec<f64> {
        (0..len).map(|i| i as f64).collect()
    }
}

impl RotaryTables {
    /// Number of positions.
    pub fn len(&self) -> usize {
        self.cos.dims()[0]
    }

    /// Whether the tables cover no position.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The tables of positions `start..start + len`.
    pub fn narrow(&self, start: usize, len: usize) -> Self {
        Self {
            cos: self.cos.clone().narrow(0, start, len),
            sin: self.sin.clone().narrow(0, start, len),
            pairing: self.pairing,
        }
    }

    /// Rotates x [B, H, N, head_dim] by these tables (N positions).
    pub fn rotate(&self, x: Tensor<4>) -> Tensor<4> {
        let [b, h, n, d] = x.dims();
        assert_eq!(
            [n, d],
            self.cos.dims(),
            "rotary: x does not match the tables"
        );
        let tables = self;
        let partner = match self.pairing {
            // (x_{2t}, x_{2t+1}) → (−x_{2t+1}, x_{2t}).
            RopePairing::Interleaved => {
                let pairs = x.clone().reshape([b, h, n, d / 2, 2]);
                let even = pairs.clone().narrow(4, 0, 1);
                let odd = pairs.narrow(4, 1, 1);
                Tensor::cat(vec![odd.neg(), even], 4).reshape([b, h, n, d])
            }
            // (x_t, x_{t+d/2}) → (−x_{t+d/2}, x_t).
            RopePairing::HalfSplit => {
                let first = x.clone().narrow(3, 0, d / 2);
                let second = x.clone().narrow(3, d / 2, d / 2);
                Tensor::cat(vec![second.neg(), first], 3)
            }
        };
        x * tables.cos.clone().unsqueeze::<4>() + partner * tables.sin.clone().unsqueeze::<4>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{f64_normal, f64_tensor, max_abs_diff, to_vec};

    fn dot_scores(q: Tensor<4>, k: Tensor<4>) -> Vec<f64> {
        to_vec(q.matmul(k.swap_dims(2, 3)))
    }

    fn both() -> [Spe; 2] {
        [
            SpeConfig::new(8).init(),
            SpeConfig::new(8)
                .with_pairing(RopePairing::HalfSplit)
                .init(),
        ]
    }

    #[test]
    fn scores_depend_only_on_the_offset() {
        // SPEC §4.4 (a): <R_s q, R_t k> is unchanged under (s, t) → (s + Δ, t + Δ) and equals
        // <q, R_{t−s} k>.
        let device = Device::flex();
        for spe in both() {
            let q = f64_normal([1, 1, 1, 8], &device);
            let k = f64_normal([1, 1, 1, 8], &device);
            let rot = |x: &Tensor<4>, s: f64| {
                spe.rotate(x.clone(), &spe.tables(&[s], &device, DType::F64))
            };
            let base = dot_scores(rot(&q, 3.0), rot(&k, 10.0))[0];
            for delta in [1.0, 17.0, 200.0] {
                let shifted = dot_scores(rot(&q, 3.0 + delta), rot(&k, 10.0 + delta))[0];
                assert!((shifted - base).abs() < 1e-10, "{shifted} vs {base}");
            }
            let relative = dot_scores(q.clone(), rot(&k, 7.0))[0];
            assert!((relative - base).abs() < 1e-10);
            // And it does depend on the offset.
            let other = dot_scores(rot(&q, 3.0), rot(&k, 11.0))[0];
            assert!((other - base).abs() > 1e-6);
        }
    }

    #[test]
    fn identity_at_zero_and_norms_preserved() {
        // SPEC §4.4 (b), (c).
        let device = Device::flex();
        for spe in both() {
            let x = f64_normal([2, 3, 5, 8], &device);
            let t0 = spe.tables(&[0.0; 5], &device, DType::F64);
            assert!(max_abs_diff(spe.rotate(x.clone(), &t0), x.clone()) < 1e-15);
            let pos = [0.0, 1.0, 7.0, 119.0, 239.0];
            let y = spe.rotate(x.clone(), &spe.tables(&pos, &device, DType::F64));
            let norms = |t: Tensor<4>| to_vec(t.square().sum_dim(3));
            for (a, b) in norms(x).iter().zip(norms(y)) {
                assert!((a - b).abs() < 1e-12 * a.max(1.0));
            }
        }
    }

    #[test]
    fn interleaved_rotates_adjacent_pairs_by_s_phi() {
        // x = e_2 (pair t = 1), d = 4: φ_1 = 10000^(−1/2) = 0.01; at s = 50 the angle is 0.5.
        let device = Device::flex();
        let spe = SpeConfig::new(4).init();
        let x = f64_tensor(vec![0.0, 0.0, 1.0, 0.0], [1, 1, 1, 4], &device);
        let y = to_vec(spe.rotate(x, &spe.tables(&[50.0], &device, DType::F64)));
        let expected = [0.0, 0.0, 0.5f64.cos(), 0.5f64.sin()];
        for (a, b) in y.iter().zip(expected) {
            assert!((a - b).abs() < 1e-14, "{y:?}");
        }
    }

    #[test]
    fn matches_burn_rotary_encoding_on_contiguous_positions() {
        // Burn's nn::RotaryEncoding uses the same interleaved convention (SPEC §4.4).
        let device = Device::flex();
        let burn_rope = burn::nn::RotaryEncodingConfig::new(16, 8).init(&device);
        let spe = SpeConfig::new(8).init();
        let x = Tensor::<4>::random([1, 2, 16, 8], burn::tensor::Distribution::Default, &device);
        let ours = spe.rotate(x.clone(), &spe.tables(&Spe::range(16), &device, x.dtype()));
        let theirs = burn_rope.forward(x);
        assert!(max_abs_diff(ours, theirs) < 1e-4);
    }
}
