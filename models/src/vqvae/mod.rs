//! The motion VQ-VAE of the multi-modal control system (SPEC §13.2): pos72 windows [B, T, 72] → conv
//! encoder → z [B, T/8, C] → nearest code of a K × C codebook → conv decoder → [B, T, 72].
//!
//! - `encdec.rs`: the encoder and decoder (T2M-GPT's, with §13.9's parameter counts);
//! - `quantize.rs`: assignment and the EMA codebook update with dead-code reset, in plain Rust.
//!
//! The codebook and its EMA statistics are module state (`codebook`, `code_sum`, `code_count`,
//! `initialised`), so checkpoints carry them and resume exactly; with `quantizer = "ema_reset"` they never
//! receive gradients (the trainer's family writes them after each update). With `"st"` the codebook is a
//! learned parameter.

pub mod encdec;
pub mod quantize;

use burn::module::{Module, Param};
use burn::tensor::{Device, Int, Tensor, TensorData};
use qean_config::vqvae::{Quantizer, VqConfig};

use encdec::{Decoder, Encoder};
use quantize::{assign, EmaCodebook};

/// The motion VQ-VAE.
#[derive(Module, Debug)]
pub struct VqVae {
    pub encoder: Encoder,
    pub decoder: Decoder,
    /// e: [K, C].
    pub codebook: Param<Tensor<2>>,
    /// EMA Σz per code [K, C] and count [K]; `initialised` [1] is 1 once the first batch filled the codebook.
    pub code_sum: Param<Tensor<2>>,
    pub code_count: Param<Tensor<1>>,
    pub initialised: Param<Tensor<1>>,
}

/// One batch through the straight-through quantiser.
pub struct Quantized {
    /// z + sg(e[idx] − z): the decoder's input, with the encoder's gradient.
    pub z_q: Tensor<3>,
    /// The quantiser's loss before its weight (commitment for EMA; codebook + β·commitment for st).
    pub loss: Tensor<1>,
    pub indices: Vec<usize>,
}

impl VqVae {
    /// A fresh VQ-VAE; the codebook starts at zeros (EMA: the first batch fills it) or U(±1/K) (st).
    pub fn new(c: &VqConfig, device: &Device) -> VqVae {
        let (k, d) = (c.codes, c.code_dim);
        let codebook = match c.quantizer {
            Quantizer::EmaReset => Tensor::zeros([k, d], device),
            Quantizer::St => {
                let b = 1.0 / k as f64;
                Tensor::random([k, d], burn::tensor::Distribution::Uniform(-b, b), device)
            }
        };
        VqVae {
            encoder: Encoder::new(c, device),
            decoder: Decoder::new(c, device),
            codebook: Param::from_tensor(codebook),
            code_sum: Param::from_tensor(Tensor::zeros([k, d], device)),
            code_count: Param::from_tensor(Tensor::zeros([k], device)),
            initialised: Param::from_tensor(Tensor::zeros([1], device)),
        }
    }

    /// Codebook size K and code dimension C.
    pub fn codes(&self) -> (usize, usize) {
        let [k, d] = self.codebook.dims();
        (k, d)
    }

    /// The codebook and EMA statistics on the host.
    pub fn ema_state(&self) -> EmaCodebook {
        let (k, d) = self.codes();
        let host = |t: Tensor<2>| {
            t.into_data()
                .convert::<f32>()
                .try_to_vec::<f32>()
                .expect("f32")
        };
        EmaCodebook {
            codes: k,
            dim: d,
            codebook: host(self.codebook.val()),
            code_sum: host(self.code_sum.val()),
            code_count: self
                .code_count
                .val()
                .into_data()
                .convert::<f32>()
                .try_to_vec::<f32>()
                .expect("f32"),
            initialised: self.initialised.val().into_scalar::<f32>() != 0.0,
        }
    }

    /// This model with the codebook and EMA statistics of `s` (parameter ids kept).
    pub fn with_ema_state(mut self, s: &EmaCodebook) -> VqVae {
        let device = self.codebook.val().device();
        let (k, d) = (s.codes, s.dim);
        let t2 = |v: &[f32]| Tensor::<2>::from_data(TensorData::new(v.to_vec(), [k, d]), &device);
        let t1 =
            |v: Vec<f32>| Tensor::<1>::from_data(TensorData::new(v.clone(), [v.len()]), &device);
        self.codebook = self.codebook.map(|_| t2(&s.codebook));
        self.code_sum = self.code_sum.map(|_| t2(&s.code_sum));
        self.code_count = self.code_count.map(|_| t1(s.code_count.clone()));
        self.initialised = self
            .initialised
            .map(|_| t1(vec![if s.initialised { 1.0 } else { 0.0 }]));
        self
    }

    /// Frames per token, 2^down_t.
    pub fn rate(&self) -> usize {
        1 << self.encoder.down.len()
    }

    /// z [B, n, C] of pos72 windows [B, T, 72]; T must be a multiple of 2^down_t.
    pub fn encode(&self, x: Tensor<3>) -> Result<Tensor<3>, String> {
        let [_, t, w] = x.dims();
        if w != qean_motion::pos72::POS72 {
            return Err(format!("the VQ-VAE reads 72 values per frame, got {w}"));
        }
        if t == 0 || !t.is_multiple_of(self.rate()) {
            return Err(format!(
                "the VQ-VAE encodes lengths that are multiples of {} frames, got {t} (crop to {})",
                self.rate(),
                t / self.rate() * self.rate()
            ));
        }
        Ok(self.encoder.forward(x))
    }

    /// [B, n·2^down_t, 72] from (quantised) latents [B, n, C].
    pub fn decode(&self, z: Tensor<3>) -> Tensor<3> {
        self.decoder.forward(z)
    }

    /// z rows on the host, batch-major (row = b·n + t).
    pub fn host_rows(z: &Tensor<3>) -> Vec<f32> {
        z.clone()
            .into_data()
            .convert::<f32>()
            .try_to_vec::<f32>()
            .expect("f32")
    }

    /// Codebook rows `indices` as a [B, n, C] tensor (differentiable with respect to the codebook).
    pub fn lookup(&self, indices: &[usize], b: usize, n: usize) -> Tensor<3> {
        let (_, d) = self.codes();
        let device = self.codebook.val().device();
        let idx: Vec<i64> = indices.iter().map(|&i| i as i64).collect();
        let idx = Tensor::<1, Int>::from_data(TensorData::new(idx, [indices.len()]), &device);
        self.codebook.val().select(0, idx).reshape([b, n, d])
    }

    /// The straight-through quantiser on z with codes `indices` (assigned by the caller: the EMA
    /// family assigns on the host before its update). EMA: L = mean((z − sg e)²). st: L = mean((e − sg z)²)
    /// + β_st·mean((sg e − z)²).
    pub fn quantize_with(&self, z: Tensor<3>, indices: Vec<usize>, c: &VqConfig) -> Quantized {
        let [b, n, _] = z.dims();
        let e = self.lookup(&indices, b, n);
        let loss = match c.quantizer {
            Quantizer::EmaReset => (z.clone() - e.clone().detach()).powi_scalar(2).mean(),
            Quantizer::St => {
                (e.clone() - z.clone().detach()).powi_scalar(2).mean()
                    + (e.clone().detach() - z.clone()).powi_scalar(2).mean() * c.beta_st
            }
        };
        let z_q = z.clone() + (e - z).detach();
        Quantized { z_q, loss, indices }
    }

    /// The EMA quantiser's straight-through with codebook rows `e` [B, n, C] the caller looked up on the
    /// host (before its update): z_q = z + sg(e − z), L = mean((z − sg e)²).
    pub fn quantize_rows(&self, z: Tensor<3>, e: Tensor<3>, indices: Vec<usize>) -> Quantized {
        let e = e.detach();
        let loss = (z.clone() - e.clone()).powi_scalar(2).mean();
        Quantized {
            z_q: z.clone() + (e - z).detach(),
            loss,
            indices,
        }
    }

    /// Tokens of pos72 windows [B, T, 72]: the nearest code of each latent, batch-major.
    pub fn tokens(&self, x: Tensor<3>) -> Result<Vec<usize>, String> {
        let z = self.encode(x)?;
        let (_, d) = self.codes();
        let codebook = self.ema_state().codebook;
        Ok(assign(&Self::host_rows(&z), &codebook, d))
    }

    /// pos72 [B, n·2^down_t, 72] of tokens [B × n].
    pub fn decode_tokens(&self, indices: &[usize], b: usize, n: usize) -> Tensor<3> {
        self.decode(self.lookup(indices, b, n))
    }
}

/// Encoder and decoder parameters (SPEC §13.9 counts them apart from the codebook and its statistics).
pub fn network_params(model: &VqVae) -> (usize, usize) {
    (model.encoder.num_params(), model.decoder.num_params())
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::tensor::Distribution;

    #[test]
    fn parameter_counts_equal_the_spec() {
        let device = Device::flex();
        for (c, enc, dec) in [
            (VqConfig::tiny(), 174_656, 174_728),
            (VqConfig::paper(), 13_491_712, 13_491_784),
        ] {
            let m = VqVae::new(&c, &device);
            assert_eq!(network_params(&m), (enc, dec));
            assert_eq!(encdec::encoder_params(&c), enc);
            assert_eq!(encdec::decoder_params(&c), dec);
        }
    }

    #[test]
    fn shapes_round_trip_and_codebook_state() {
        let device = Device::flex();
        let c = VqConfig::tiny();
        let m = VqVae::new(&c, &device);
        let x = Tensor::<3>::random([2, 64, 72], Distribution::Normal(0.0, 1.0), &device);
        let z = m.encode(x).unwrap();
        assert_eq!(z.dims(), [2, 8, 64]);
        let odd = Tensor::<3>::zeros([1, 60, 72], &device);
        assert!(m.encode(odd).unwrap_err().contains("multiples of 8"));
        assert_eq!(m.decode(z.clone()).dims(), [2, 64, 72]);
        // The EMA state survives a round trip through the module.
        let mut s = m.ema_state();
        assert!(!s.initialised);
        s.codebook[5] = 2.5;
        s.code_count[3] = 0.5;
        s.initialised = true;
        let m = m.with_ema_state(&s);
        assert_eq!(m.ema_state(), s);
        let q = m.quantize_with(z, vec![1; 16], &c);
        assert_eq!(q.z_q.dims(), [2, 8, 64]);
        assert_eq!(
            m.tokens(Tensor::zeros([1, 64, 72], &device)).unwrap().len(),
            8
        );
    }

    /// SPEC §13.11 test 6: the commitment loss value, and the straight-through gradient is the identity
    /// for the encoder output (the decoder's gradient reaches z unchanged).
    #[test]
    fn commitment_value_and_straight_through_gradient() {
        use crate::testing::{f64_normal, to_vec};
        let device = Device::flex().autodiff();
        let c = VqConfig {
            codes: 4,
            code_dim: 3,
            ..VqConfig::tiny()
        };
        let m = VqVae::new(&c, &device);
        let z = f64_normal([1, 2, 3], &device).require_grad();
        let e = f64_normal([1, 2, 3], &device);
        let q = m.quantize_rows(z.clone(), e.clone(), vec![0, 1]);
        let (zv, ev) = (to_vec(z.clone()), to_vec(e.clone()));
        let want: f64 = zv
            .iter()
            .zip(&ev)
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / 6.0;
        assert!((to_vec(q.loss.clone())[0] - want).abs() < 1e-12);
        // The forward value is e; the gradient of Σ w·z_q with respect to z is w.
        assert!(crate::testing::max_abs_diff(q.z_q.clone(), e) < 1e-12);
        let w = f64_normal([1, 2, 3], &device);
        let grads = (q.z_q * w.clone()).sum().backward();
        let g = to_vec(z.grad(&grads).unwrap());
        for (a, b) in g.iter().zip(to_vec(w)) {
            assert!((a - b).abs() < 1e-12, "{a} vs {b}");
        }
    }
}
