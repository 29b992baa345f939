//! The splits a run trains and validates on: motions in the model's layout and the 35-D music
//! features from the dataset's feature cache (`DIR/features/`), computed on first use.

use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::feature_cache;
use qean_aistpp::windows::{SequenceSet, WindowSpec, AUDIO_DIM};
use qean_checkpoint::features::ensure_features;
use qean_config::recipe::RecipeConfig;
use qean_io::error::Result;
use qean_motion::motion::Layout;

/// One split, ready for windowing, its music features as the recipe feeds them to the model.
pub fn load_split(
    ds: &Dataset,
    split: Split,
    layout: Layout,
    spec: WindowSpec,
    recipe: &RecipeConfig,
) -> Result<SequenceSet> {
    ensure_features(ds, &ds.split(split))?;
    SequenceSet::load(ds, split, layout, spec, |id| {
        let (data, frames) = feature_cache::load(ds, id)?;
        Ok((recipe.model_audio(data, AUDIO_DIM), frames))
    })
}

/// Per-column mean and SD of the music features of a split (every frame of each music ID once;
/// a constant column gets SD 1), for `recipe.audio_norm = "standardize"`.
pub fn audio_stats(ds: &Dataset, split: Split) -> Result<(Vec<f64>, Vec<f64>)> {
    let names = ds.split(split);
    ensure_features(ds, &names)?;
    let mut stats = ColumnStats::new(AUDIO_DIM);
    for id in ds.music_ids(&names) {
        let (data, _) = feature_cache::load(ds, &id)?;
        data.chunks_exact(AUDIO_DIM).for_each(|row| stats.add(row));
    }
    Ok(stats.mean_std())
}

/// Running per-column sums of rows, for a mean and SD over every row added.
pub struct ColumnStats {
    sum: Vec<f64>,
    sq: Vec<f64>,
    n: usize,
}

impl ColumnStats {
    pub fn new(width: usize) -> Self {
        ColumnStats {
            sum: vec![0.0; width],
            sq: vec![0.0; width],
            n: 0,
        }
    }

    pub fn add(&mut self, row: &[f32]) {
        for (k, &x) in row.iter().enumerate() {
            self.sum[k] += x as f64;
            self.sq[k] += (x as f64) * (x as f64);
        }
        self.n += 1;
    }

    /// Per-column mean and SD; a constant column (SD ≤ 1e-8) gets SD 1.
    pub fn mean_std(&self) -> (Vec<f64>, Vec<f64>) {
        let n = self.n.max(1) as f64;
        let mean: Vec<f64> = self.sum.iter().map(|s| s / n).collect();
        let std = self
            .sq
            .iter()
            .zip(&mean)
            .map(|(q, m)| (q / n - m * m).max(0.0).sqrt())
            .map(|v| if v > 1e-8 { v } else { 1.0 })
            .collect();
        (mean, std)
    }
}
