//! The multi-modal control system's token models (SPEC §13.3–13.5): the music-to-dance GPT (`gpt.rs`). The
//! motion VQ-VAE whose tokens it predicts is `crate::vqvae`.

pub mod fusion;
pub mod genre;
pub mod genre_clf;
pub mod gpt;
pub mod keyframe;
