//! The dataset's 35-D music features, computed on first use into its feature cache (`DIR/features/`) with the
//! default options of `qean features --dataset`: what training, evaluation and the demo read.

use qean_aistpp::dataset::Dataset;
use qean_aistpp::feature_cache;
use qean_audio::{self as audio, FeatureOptions};
use qean_io::error::Result;

/// Makes sure every music ID of `names` has cached features (the default options of
/// `qean features --dataset`), computing the missing ones.
pub fn ensure_features(ds: &Dataset, names: &[String]) -> Result<usize> {
    let ids = ds.music_ids(names);
    let computed = feature_cache::ensure(
        ds,
        &ids,
        |id| FeatureOptions::with_start_bpm(qean_aistpp::names::start_bpm(id)).cache_key(),
        |path, id| {
            tracing::info!("computing music features of {id} ({})", path.display());
            let f = audio::features_for_file(
                path,
                &FeatureOptions::with_start_bpm(qean_aistpp::names::start_bpm(id)),
            )?;
            if f.is_silent() {
                tracing::warn!(
                    "{}: the audio is silent (no onsets, no beats)",
                    path.display()
                );
            }
            Ok((f.data, f.frames))
        },
        |_, _, _| {},
    )?;
    if computed > 0 {
        tracing::info!("computed and cached the features of {computed} music IDs");
    }
    Ok(computed)
}
