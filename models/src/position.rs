//! Learned absolute position embedding (mint base_models.py `PositionEmbedding`): a trainable
//! [len, hidden] table added to the token embeddings, initialised truncated-normal σ 0.02.

use burn::config::Config;
use burn::module::{Module, Param};
use burn::tensor::{Device, Tensor};

use crate::init::truncated_normal;

/// Configuration of [`PositionEmbedding`].
#[derive(Config, Debug)]
pub struct PositionEmbeddingConfig {
    /// Sequence length (120 motion, 240 audio).
    pub len: usize,
    /// Model width.
    pub hidden: usize,
    /// Initialiser standard deviation (mint's `initializer_range`).
    #[config(default = 0.02)]
    pub std: f64,
}

/// Learned absolute position embedding.
#[derive(Module, Debug)]
pub struct PositionEmbedding {
    /// The [len, hidden] table.
    pub embedding: Param<Tensor<2>>,
}

impl PositionEmbeddingConfig {
    /// Builds the (lazily initialised) table.
    pub fn init(&self, device: &Device) -> PositionEmbedding {
        PositionEmbedding {
            embedding: truncated_normal([self.len, self.hidden], self.std, device),
        }
    }
}

impl PositionEmbedding {
    /// x [B, len, hidden] → x + P.
    pub fn forward(&self, x: Tensor<3>) -> Tensor<3> {
        x + self.embedding.val().unsqueeze::<3>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adds_the_same_table_to_every_batch_item() {
        let device = Device::flex();
        let pe = PositionEmbeddingConfig::new(5, 3).init(&device);
        let x = Tensor::<3>::zeros([2, 5, 3], &device);
        let y = pe.forward(x);
        let table: Vec<f32> = pe.embedding.val().into_data().try_to_vec().unwrap();
        let out: Vec<f32> = y.into_data().try_to_vec().unwrap();
        assert_eq!(&out[..15], &table[..]);
        assert_eq!(&out[15..], &table[..]);
        assert!(table.iter().any(|v| *v != 0.0));
    }
}
