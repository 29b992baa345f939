//! The genre classifier as a trainer [`Family`] (SPEC §13.10): random pos72 windows of the training split,
//! each labelled with its sequence's genre (AIST++: the name's gXX code; FineDance: its label), cross-entropy.

use burn::tensor::{Device, Int, Tensor, TensorData};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::feature_cache;
use qean_aistpp::windows::{Batch, SequenceSet, WindowSpec};
use qean_config::genre_clf::GenreClfConfig;
use qean_config::run::RunConfig;
use qean_io::error::{Error, Result};
use qean_models::control::genre_clf::GenreClassifier;
use qean_models::tsmt::loss::masked_cross_entropy;
use qean_motion::motion::Layout;
use qean_motion::pos72::POS72;
use rand::{Rng, SeedableRng};

use std::collections::HashMap;

use crate::family::{Family, StepContext};
use qean_checkpoint::checkpoint::Checkpoint;
use qean_checkpoint::genre_clf::pos72_rows;

/// The classifier family: the genre index of every sequence of its dataset, found by `prepare`.
#[derive(Debug, Default)]
pub struct GenreClfFamily {
    genres: HashMap<String, usize>,
}

/// The `[genre_clf]` table of a classifier run.
pub fn clf_of(config: &RunConfig) -> &GenreClfConfig {
    config.genre_clf_table()
}

/// Mean cross-entropy of logits [B, 10] against labels.
pub fn clf_loss(logits: Tensor<2>, labels: &[usize], device: &Device) -> Tensor<1> {
    let [b, k] = logits.dims();
    let targets: Vec<i64> = labels.iter().map(|&l| l as i64).collect();
    masked_cross_entropy(
        logits.reshape([b, 1, 1, k]),
        Tensor::<3, Int>::from_data(TensorData::new(targets, [b, 1, 1]), device),
        &vec![1; b],
    )
}

/// A batch as (windows [B, genre_clf.window, 72], labels). With an update's `seed`, each window is played at
/// a random tempo (`tempo_augment`) from a random start and turned about y (`yaw_augment`); without one
/// (validation), each drawn window's first frames as they are.
fn tensors(
    batch: Batch,
    device: &Device,
    (c, genres): (&GenreClfConfig, &HashMap<String, usize>),
    seed: Option<u64>,
) -> (Tensor<3>, Vec<usize>) {
    let (b, drawn, t) = (batch.len(), batch.spec.motion_len, c.window);
    let labels = batch
        .names
        .iter()
        .map(|n| genres.get(n).copied().unwrap_or(0))
        .collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed.unwrap_or(0) ^ 0x7E4B_0A11);
    let mut rows = Vec::with_capacity(b * t * POS72);
    let tempo = c.tempo_augment;
    for w in batch.motion.chunks_exact(drawn * POS72) {
        let rate = match seed {
            Some(_) if tempo > 1.0 => rng.random_range(-tempo.ln()..=tempo.ln()).exp(),
            _ => 1.0,
        };
        let span = (t - 1) as f64 * rate;
        let start = match seed {
            Some(_) => rng.random_range(0.0..=((drawn - 1) as f64 - span).max(0.0)),
            None => 0.0,
        };
        resample(w, start, rate, t, &mut rows);
    }
    if let (true, Some(seed)) = (c.yaw_augment, seed) {
        crate::vqvae::yaw(&mut rows, t, seed);
    }
    (
        Tensor::from_data(TensorData::new(rows, [b, t, POS72]), device),
        labels,
    )
}

/// `t` pos72 frames of `w` at positions start + k·rate (linear interpolation), appended to `out`; the root's
/// per-frame velocity (channels 0–2) scales with the rate.
fn resample(w: &[f32], start: f64, rate: f64, t: usize, out: &mut Vec<f32>) {
    let last = w.len() / POS72 - 1;
    for k in 0..t {
        let p = (start + k as f64 * rate).min(last as f64);
        let (i, f) = (p.floor() as usize, (p - p.floor()) as f32);
        let (a, b) = (
            &w[i * POS72..(i + 1) * POS72],
            &w[(i + 1).min(last) * POS72..],
        );
        out.extend((0..POS72).map(|c| {
            let v = a[c] + f * (b[c] - a[c]);
            if c < 3 {
                v * rate as f32
            } else {
                v
            }
        }));
    }
}

impl Family for GenreClfFamily {
    type Model = GenreClassifier;
    type Inputs = (Tensor<3>, Vec<usize>);

    fn init(&self, config: &RunConfig, device: &Device) -> Result<GenreClassifier> {
        Ok(GenreClassifier::new(clf_of(config), device))
    }

    /// The genre vocabulary is the data's (written into the run's config); every sequence's genre looked up
    /// once (FineDance's label files).
    fn prepare(
        &mut self,
        config: &mut RunConfig,
        dataset: &Dataset,
        _train: Split,
        _resume: Option<&Checkpoint>,
    ) -> Result<()> {
        let (set, genres) = dataset.genres("the genre classifier")?;
        let mut c = config.genre_clf_table().clone();
        c.genres = set;
        config.genre_clf = Some(c);
        self.genres = genres;
        Ok(())
    }

    /// Windows of pos72 rows; sequences without a genre code are left out.
    fn load_set(
        &self,
        dataset: &Dataset,
        split: Split,
        spec: WindowSpec,
        _config: &RunConfig,
    ) -> Result<SequenceSet> {
        qean_checkpoint::features::ensure_features(dataset, &dataset.split(split))?;
        let set = SequenceSet::load(dataset, split, Layout::L219, spec, |id| {
            feature_cache::load(dataset, id)
        })?;
        let mut set = set.remap(
            POS72,
            0,
            |seq| {
                let mut rows = pos72_rows(&dataset.read_motion(&seq.name)?);
                rows.truncate(seq.motion_frames * POS72);
                Ok(rows)
            },
            |_, _| Vec::new(),
        )?;
        set.sequences.retain(|s| self.genres.contains_key(&s.name));
        if set.sequences.is_empty() {
            return Err(Error::at(
                &dataset.root,
                format!(
                    "no {} sequence has a genre (an AIST++ name's gBR_… code, a FineDance label_json/ file)",
                    split.name()
                ),
            ));
        }
        Ok(set)
    }

    fn inputs(
        &self,
        drawn: Batch,
        _model: &GenreClassifier,
        device: &Device,
        ctx: &StepContext,
    ) -> Self::Inputs {
        tensors(
            drawn,
            device,
            (clf_of(ctx.config), &self.genres),
            Some(ctx.rng_seed),
        )
    }

    fn loss(
        &self,
        model: &GenreClassifier,
        (x, labels): Self::Inputs,
        _config: &RunConfig,
    ) -> Tensor<1> {
        let device = x.device();
        clf_loss(model.forward(x), &labels, &device)
    }

    fn validation_loss(
        &self,
        model: &GenreClassifier,
        set: &SequenceSet,
        config: &RunConfig,
        device: &Device,
    ) -> f64 {
        crate::family::mean_over_first_windows(set, config.train.batch_size, |batch| {
            let (x, labels) = tensors(batch, device, (clf_of(config), &self.genres), None);
            clf_loss(model.forward(x), &labels, device)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rows(frames: usize) -> Vec<f32> {
        (0..frames * POS72).map(|v| v as f32).collect()
    }

    #[test]
    fn resampling_at_rate_one_keeps_the_frames() {
        let w = rows(12);
        let mut out = Vec::new();
        resample(&w, 0.0, 1.0, 10, &mut out);
        assert_eq!(out, w[..10 * POS72]);
    }

    /// At rate 2 every other frame is taken and the root's per-frame velocity doubles; half-way positions
    /// interpolate; the last frame repeats past the end.
    #[test]
    fn resampling_plays_faster_and_slower() {
        let w = rows(12);
        let mut out = Vec::new();
        resample(&w, 1.0, 2.0, 5, &mut out);
        for k in 0..5 {
            let src = &w[(1 + 2 * k) * POS72..(2 + 2 * k) * POS72];
            let got = &out[k * POS72..(k + 1) * POS72];
            assert_eq!(
                got[..3],
                src[..3].iter().map(|v| v * 2.0).collect::<Vec<_>>()[..]
            );
            assert_eq!(got[3..], src[3..]);
        }
        let mut slow = Vec::new();
        resample(&w, 0.0, 0.5, 3, &mut slow);
        assert_eq!(slow[POS72 + 5], 0.5 * (w[5] + w[POS72 + 5]));
        assert_eq!(slow[POS72], 0.5 * 0.5 * (w[0] + w[POS72]));
        let mut past = Vec::new();
        resample(&w, 10.0, 1.5, 3, &mut past);
        assert_eq!(past[2 * POS72 + 7], w[11 * POS72 + 7]);
    }
}
