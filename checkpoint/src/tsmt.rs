//! TSMT's music as its model hears it (SPEC §11.4), one definition for the trainer and the sampler.

use qean_audio::delta::{tsmt_audio, TSMT_MFCC_DIM};
use qean_config::RecipeConfig;

/// The `frames × 26` MFCC + Δ rows and the beat flags of a 35-D feature matrix (frame-major), the rows as
/// the run's `recipe.audio_norm` says: the paper's raw values (`none`) or each column standardised over
/// the track (`per_track`).
pub fn heard_audio(features: &[f32], frames: usize, recipe: &RecipeConfig) -> (Vec<f32>, Vec<u8>) {
    let (rows, beats) = tsmt_audio(features, frames);
    (recipe.model_audio(rows, TSMT_MFCC_DIM), beats)
}
