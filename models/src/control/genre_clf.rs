//! The genre classifier of SPEC §13.10: pos72 windows [B, T, 72] → Conv1d(72 → W, k3) ReLU → 3 × [Conv1d(W → W,
//! k4, s2, p1) ReLU] → mean over time → Linear(W → genres: AIST++'s 10, FineDance's 16). PyTorch's default init (U(±1/√fan_in)), set explicitly.

use burn::module::Module;
use burn::nn::conv::Conv1d;
use burn::nn::{Initializer, Linear, LinearConfig};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor};
use qean_config::genre_clf::GenreClfConfig;
use qean_motion::pos72::POS72;

use crate::vqvae::encdec::conv;

#[derive(Module, Debug)]
pub struct GenreClassifier {
    pub input: Conv1d,
    pub down: Vec<Conv1d>,
    pub output: Linear,
}

impl GenreClassifier {
    pub fn new(c: &GenreClfConfig, device: &Device) -> GenreClassifier {
        let w = c.width;
        let bound = 1.0 / (w as f64).sqrt();
        GenreClassifier {
            input: conv(POS72, w, 3, 1, 1, 1, device),
            down: (0..3).map(|_| conv(w, w, 4, 2, 1, 1, device)).collect(),
            output: LinearConfig::new(w, c.genres.count())
                .with_initializer(Initializer::Uniform {
                    min: -bound,
                    max: bound,
                })
                .init(device),
        }
    }

    /// Logits [B, genres] of windows [B, T, 72].
    pub fn forward(&self, x: Tensor<3>) -> Tensor<2> {
        let mut h = relu(self.input.forward(x.swap_dims(1, 2)));
        for d in &self.down {
            h = relu(d.forward(h));
        }
        let [b, w, _] = h.dims();
        self.output.forward(h.mean_dim(2).reshape([b, w]))
    }
}

/// SPEC §13.9: 3·72·W + W + 3(4W² + W) + 10W + 10, with G genres in place of AIST++'s 10.
pub fn genre_clf_params(c: &GenreClfConfig) -> usize {
    let (w, g) = (c.width, c.genres.count());
    3 * POS72 * w + w + 3 * (4 * w * w + w) + g * w + g
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_shapes() {
        let device = Device::flex();
        for (w, want) in [(64, 63_882), (256, 845_322)] {
            let c = GenreClfConfig {
                width: w,
                ..GenreClfConfig::default()
            };
            assert_eq!(GenreClassifier::new(&c, &device).num_params(), want);
            assert_eq!(genre_clf_params(&c), want);
        }
        let c = GenreClfConfig {
            width: 64,
            genres: qean_aistpp::layout::GenreSet::FineDance,
            ..GenreClfConfig::default()
        };
        let n = GenreClassifier::new(&c, &device).num_params();
        assert_eq!(
            (n, genre_clf_params(&c)),
            (63_882 + 6 * 65, 63_882 + 6 * 65)
        );
        let c = GenreClfConfig {
            width: 8,
            ..GenreClfConfig::default()
        };
        let m = GenreClassifier::new(&c, &device);
        assert_eq!(
            m.forward(Tensor::zeros([3, 240, 72], &device)).dims(),
            [3, 10]
        );
    }
}
