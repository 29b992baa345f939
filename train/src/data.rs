//! The splits a run trains and validates on: motions in the model's layout and the 35-D music
//! features from the dataset's feature cache (`DIR/features/`), computed on first use.

use qean_data::audio::{self, FeatureOptions};
use qean_data::dataset::{Dataset, Split};
use qean_data::error::Result;
use qean_data::feature_cache;
use qean_data::motion::Layout;
use qean_data::windows::{SequenceSet, WindowSpec};

/// Makes sure every music ID of `names` has cached features (the default options of
/// `qean features --dataset`), computing the missing ones.
pub fn ensure_features(ds: &Dataset, names: &[String]) -> Result<usize> {
    let ids = Dataset::music_ids(names);
    let computed = feature_cache::ensure(
        ds,
        &ids,
        |id| FeatureOptions::for_name(id).cache_key(),
        |path, id| {
            tracing::info!("computing music features of {id} ({})", path.display());
            let f = audio::features_for_file(path, &FeatureOptions::for_name(id))?;
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

/// One split, ready for windowing.
pub fn load_split(
    ds: &Dataset,
    split: Split,
    layout: Layout,
    spec: WindowSpec,
) -> Result<SequenceSet> {
    ensure_features(ds, &ds.split(split))?;
    SequenceSet::load(ds, split, layout, spec, |id| feature_cache::load(ds, id))
}
