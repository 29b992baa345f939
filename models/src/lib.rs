//! Burn modules for music-conditioned dance generation: FACT ("AI Choreographer", Li et al.,
//! ICCV 2021; google-research/mint) and QEAN ("Quaternion-Enhanced Attention Network", Zhou
//! et al.), with QEAN's SPE (rotary positions) and QRA (quaternion rotary attention); Li et al.'s
//! two-stream motion transformer ([`tsmt`], SPEC §11); Lin's in-betweener ([`inbetween`], §12);
//! the motion VQ-VAE ([`vqvae`]) and the GPT over its codes with genre control and the genre
//! classifier ([`control`], §13).
//!
//! Entry points:
//! - the `[model]` table of a run config lives in qean-config (`qean_config::model`, no Burn);
//! - [`DanceModel::new`]: the model (FACT or QEAN) a `ModelConfig` describes; `forward(motion, audio)`;
//! - [`loss::motion_loss`]: L2 on the first 20 output tokens;
//! - [`DanceModel::save_weights`] / [`DanceModel::load_weights`]: burnpack files;
//! - [`inspect::inspect`]: summary and exact parameter count for `qean inspect`;
//! - [`backend::device`]: the device of a `Backend` (`flex | ndarray | wgpu`);
//! - [`sampler::sample`] over [`autoregress::autoregress`]: the autoregressive sampler.

pub mod attention;
pub mod autoregress;
pub mod backend;
pub mod control;
pub mod cross_prefix;
pub mod error;
pub mod fact;
pub mod feed_forward;
pub mod inbetween;
pub mod init;
pub mod input_fusion;
pub mod inspect;
pub mod loss;
pub mod model;
pub mod params;
pub mod position;
pub mod qean;
pub mod qra;
pub mod quaternion;
pub mod quaternion_linear;
pub mod sampler;
pub mod spe;
pub mod transformer;
pub mod tsmt;
pub mod vqvae;

#[cfg(test)]
pub(crate) mod testing;

pub use error::Error;
pub use fact::{Fact, FactConfig};
pub use model::{DanceGenerator, DanceModel};
pub use qean::{ModelOutput, Qean, QeanConfig};
