//! Lin's transformer in-betweeners as a trainer [`Family`] (SPEC §12.4c "Training"): every sequence is cut
//! into its measures (the §12.2 grid at the music ID's tempo, shared boundaries), each measure a window of
//! its own, so an epoch visits every measure once. A window's keyframes are even keys (`train_keys` per
//! measure, or N ∈ {3, 5, 9} per draw with `mixed_keys`; at random frames with `random_keys`); the base B interpolates them (SLERP, or an
//! element-wise lerp of the 225-D vectors); the loss is the MSE between the predicted and the true
//! residual Y − B over the valid frames × 225 values (pad values and keyframes included: their target is
//! 0 or near it). Windows are padded to `max_len` and each batch is trimmed to its longest measure; the
//! model masks the padding.

use std::sync::Arc;

use burn::tensor::{Device, Tensor, TensorData};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::windows::{Batch, Sequence, SequenceSet, WindowSpec};
use qean_config::inbetween::{InbetweenConfig, Taper, Variant};
use qean_config::run::RunConfig;
use qean_io::error::{Error, Result};
use qean_keyframes::even::even_keys;
use qean_keyframes::measure::{segments, Boundary, Rounding};
use qean_models::inbetween::{
    genre_index, genre_one_hot, music_columns, taper_weights, Conditioning, Inbetweener,
    MOTION_DIM, MUSIC_DIM,
};
use rand::{Rng, SeedableRng};

use crate::family::{Family, StepContext};
use qean_checkpoint::inbetween::{base_225, drums_features};

/// Every sequence's music replaced by its drums stem's features (computed once per music ID).
fn with_drums(mut set: SequenceSet, dataset: &Dataset, c: &InbetweenConfig) -> Result<SequenceSet> {
    let mut done: std::collections::HashMap<String, Arc<Vec<f32>>> = Default::default();
    for seq in &mut set.sequences {
        let id = dataset
            .music_id(&seq.name)
            .ok_or_else(|| Error::msg(format!("{}: no AIST++ music ID in the name", seq.name)))?;
        if !done.contains_key(&id) {
            let music = dataset.audio_path(&id);
            let stems = dataset.root.join("stems").join(&id);
            let bpm = qean_aistpp::names::start_bpm(&id);
            tracing::info!("drums stem features of {id} ({:?})", c.drums);
            done.insert(
                id.clone(),
                Arc::new(drums_features(
                    music.as_deref(),
                    Some(&stems),
                    c.drums,
                    bpm,
                )?),
            );
        }
        let rows = done[&id].clone();
        seq.audio_frames = rows.len() / 35;
        seq.audio = rows;
    }
    Ok(set)
}

/// The in-betweener family (no state beyond the run config).
#[derive(Debug, Clone, Default)]
pub struct InbetweenFamily;

fn config_of(config: &RunConfig) -> &InbetweenConfig {
    config.inbetween_table()
}

/// The window of one measure, padded to `max_len` frames.
pub fn segment_spec(max_len: usize) -> WindowSpec {
    WindowSpec {
        motion_len: max_len,
        target_len: max_len,
        target_shift: 0,
        audio_len: max_len,
    }
}

/// A measure window's name: `<sequence>#<first frame>+<frames>`.
fn segment_name(sequence: &str, start: usize, len: usize) -> String {
    format!("{sequence}#{start}+{len}")
}

/// (sequence name, first frame, frames) of a measure window's name.
pub fn parse_segment_name(name: &str) -> Option<(&str, usize, usize)> {
    let (seq, rest) = name.rsplit_once('#')?;
    let (start, len) = rest.split_once('+')?;
    Some((seq, start.parse().ok()?, len.parse().ok()?))
}

/// Rows `a..a + len` of a row-major matrix of width `w`, padded to `total` rows with the last row.
fn padded_rows(data: &[f32], w: usize, a: usize, len: usize, total: usize) -> Vec<f32> {
    let mut out = Vec::with_capacity(total * w);
    out.extend_from_slice(&data[a * w..(a + len) * w]);
    let last = data[(a + len - 1) * w..(a + len) * w].to_vec();
    for _ in len..total {
        out.extend_from_slice(&last);
    }
    out
}

/// The tempo (BPM) of a music without AIST++'s tempo prior (FineDance, a user's folder): the median interval
/// between the beats of its 35-D features (column 34, 60 frames a second; raw or standardised, a beat is
/// above the column's mid-range).
fn beat_tempo(audio: &[f32], dim: usize) -> Option<f64> {
    let column: Vec<f32> = audio
        .chunks_exact(dim)
        .map(|r| r[qean_audio::features::COL_BEAT])
        .collect();
    let (lo, hi) = column
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let beats: Vec<usize> = (0..column.len())
        .filter(|&t| column[t] > (lo + hi) / 2.0)
        .collect();
    let mut gaps: Vec<usize> = beats.windows(2).map(|w| w[1] - w[0]).collect();
    gaps.sort_unstable();
    let median = *gaps.get(gaps.len() / 2)?;
    Some(60.0 * qean_motion::motion::FPS / median as f64)
}

/// Every sequence of a whole-sequence set cut into its measures (each padded to `max_len`); music rows become
/// the 22 columns of §12.4c. A measure longer than `max_len` is an error naming the sequence.
pub fn measure_windows(whole: SequenceSet, c: &InbetweenConfig) -> Result<SequenceSet> {
    let mut sequences = Vec::new();
    let (d, ad) = (whole.dim, whole.audio_dim);
    for seq in &whole.sequences {
        if !c.include_jb && seq.name.starts_with("gJB") {
            continue;
        }
        let bpm = qean_aistpp::names::music_id_of(&seq.name)
            .and_then(|m| qean_aistpp::names::tempo_prior(&m))
            .or_else(|| beat_tempo(&seq.audio, ad))
            .ok_or_else(|| {
                Error::msg(format!(
                    "{}: no AIST++ music ID in the name and fewer than two beats in its music, so no measure grid",
                    seq.name
                ))
            })?;
        let music: Vec<f32> = seq
            .audio
            .chunks_exact(ad)
            .flat_map(|r| {
                let mut m = music_columns(r);
                c.normalise_music(&mut m);
                m
            })
            .collect();
        for (a, b) in segments(seq.frames(), bpm, Rounding::Cumulative, Boundary::Shared, 0) {
            let len = b - a + 1;
            if len < 2 {
                continue;
            }
            if len > c.max_len {
                return Err(Error::msg(format!(
                    "{}: a measure of {len} frames at {bpm} BPM is longer than inbetween.max_len ({})",
                    seq.name, c.max_len
                )));
            }
            sequences.push(Sequence {
                name: segment_name(&seq.name, a, len),
                motion: padded_rows(&seq.motion, d, a, len, c.max_len),
                motion_frames: c.max_len,
                audio: Arc::new(padded_rows(&music, MUSIC_DIM, a, len, c.max_len)),
                audio_frames: c.max_len,
            });
        }
    }
    Ok(SequenceSet {
        dim: MOTION_DIM,
        audio_dim: MUSIC_DIM,
        spec: segment_spec(c.max_len),
        sequences,
        visits: Vec::new(),
        ..whole
    })
}

/// A batch as the model takes it, with its targets and valid-frame mask.
pub struct IbInputs {
    pub base: Tensor<3>,
    pub target: Tensor<3>,
    /// [B, T, 1]: 1 on valid frames.
    pub mask: Tensor<3>,
    pub cond: Conditioning,
    pub valid_frames: usize,
}

/// Keys per measure of row `i` of a draw: `train_keys`, or one of 3, 5, 9 (`mixed_keys`).
fn keys_for(c: &InbetweenConfig, seed: u64, i: usize) -> usize {
    if c.mixed_keys {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(
            seed ^ (i as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
        );
        [3, 5, 9][rng.random_range(0..3)]
    } else {
        c.train_keys
    }
}

/// The keys of row `i` of a draw in a measure of `len` frames: even, or (`random_keys`) its two ends and
/// n − 2 distinct interior frames drawn uniformly.
fn window_keys(c: &InbetweenConfig, seed: u64, i: usize, len: usize) -> Vec<usize> {
    let n = keys_for(c, seed, i);
    if !c.random_keys || len < 3 {
        return even_keys(0, len - 1, n);
    }
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(
        seed ^ (i as u64).wrapping_mul(0xD1B5_4A32_D192_ED03),
    );
    let interior = rand::seq::index::sample(&mut rng, len - 2, (n - 2).min(len - 2));
    let mut keys: Vec<usize> = interior.into_iter().map(|k| k + 1).collect();
    keys.extend([0, len - 1]);
    keys.sort_unstable();
    keys
}

/// Tensors of a batch of measure windows, trimmed to its longest measure.
pub fn tensors(batch: &Batch, c: &InbetweenConfig, seed: u64, device: &Device) -> IbInputs {
    let b = batch.len();
    let lens: Vec<usize> = batch
        .names
        .iter()
        .map(|n| {
            parse_segment_name(n)
                .expect("measure windows are named by measure_windows")
                .2
        })
        .collect();
    let t = lens.iter().copied().max().unwrap_or(1);
    let (w, span) = (MOTION_DIM, batch.spec.motion_len);
    let (mut base, mut target, mut music, mut mask) = (vec![], vec![], vec![], vec![]);
    let mut taper = vec![];
    for (i, &len) in lens.iter().enumerate() {
        let rows = &batch.motion[i * span * w..(i + 1) * span * w];
        let keys = window_keys(c, seed, i, len);
        taper.extend(taper_weights(&keys, t, c.taper));
        let mut bi = base_225(rows, len, &keys, c.base);
        bi.extend_from_slice(&rows[len * w..t * w]);
        base.extend(bi);
        target.extend_from_slice(&rows[..t * w]);
        music.extend_from_slice(&batch.audio[i * span * MUSIC_DIM..(i * span + t) * MUSIC_DIM]);
        mask.extend((0..t).map(|f| if f < len { 1.0f32 } else { 0.0 }));
    }
    let genre = (c.variant == Variant::Genre).then(|| {
        let rows: Vec<Option<usize>> = batch
            .names
            .iter()
            .map(|n| n.get(1..3).and_then(|code| genre_index(c, code)))
            .collect();
        genre_one_hot(c, &rows, device)
    });
    let tensor = |v: Vec<f32>, width: usize| {
        Tensor::<3>::from_data(TensorData::new(v, [b, t, width]), device)
    };
    IbInputs {
        base: tensor(base, w),
        target: tensor(target, w),
        mask: tensor(mask, 1),
        cond: Conditioning {
            music: c.variant.has_audio().then(|| tensor(music, MUSIC_DIM)),
            genre,
            lengths: Some(lens.clone()),
            taper: (c.taper != Taper::None).then(|| tensor(taper, 1)),
        },
        valid_frames: lens.iter().sum(),
    }
}

/// The MSE of the residual over valid frames × 225 values: ((Ŷ − B) − (Y − B))² = (Ŷ − Y)²; plus, with
/// `lambda_vel` > 0, λ times the MSE of its frame-to-frame differences over consecutive valid frames (a
/// jitter penalty of ours; Lin's loss is the first term).
pub fn residual_loss(model: &Inbetweener, inputs: IbInputs, lambda_vel: f64) -> Tensor<1> {
    let pred = model.forward(inputs.base, &inputs.cond);
    let diff = (pred - inputs.target) * inputs.mask.clone();
    let mse = (diff.clone() * diff.clone())
        .sum()
        .div_scalar((inputs.valid_frames * MOTION_DIM) as f64);
    let [b, t, _] = diff.dims();
    if lambda_vel == 0.0 || t < 2 {
        return mse;
    }
    let pairs = inputs.mask.clone().narrow(1, 1, t - 1) * inputs.mask.narrow(1, 0, t - 1);
    let step = (diff.clone().narrow(1, 1, t - 1) - diff.narrow(1, 0, t - 1)) * pairs;
    let count = (inputs.valid_frames.saturating_sub(b)).max(1) * MOTION_DIM;
    mse + (step.clone() * step)
        .sum()
        .div_scalar(count as f64)
        .mul_scalar(lambda_vel)
}

/// Mean and SD of the 22 music columns over every frame of the training split's music (each music ID once;
/// the drums stem's for the drums variants). A constant column gets SD 1.
fn music_stats(
    dataset: &Dataset,
    split: Split,
    c: &InbetweenConfig,
) -> Result<(Vec<f64>, Vec<f64>)> {
    let names = dataset.split(split);
    qean_checkpoint::features::ensure_features(dataset, &names)?;
    let mut stats = crate::data::ColumnStats::new(MUSIC_DIM);
    for id in dataset.music_ids(&names) {
        let data = if c.variant.drums() {
            let stems = dataset.root.join("stems").join(&id);
            let bpm = qean_aistpp::names::start_bpm(&id);
            drums_features(
                dataset.audio_path(&id).as_deref(),
                Some(&stems),
                c.drums,
                bpm,
            )?
        } else {
            qean_aistpp::feature_cache::load(dataset, &id)?.0
        };
        data.chunks_exact(35)
            .for_each(|row| stats.add(&music_columns(row)));
    }
    Ok(stats.mean_std())
}

impl Family for InbetweenFamily {
    type Model = Inbetweener;
    type Inputs = IbInputs;

    /// The music statistics of `music_norm = "standardize"`: a resumed run's from its checkpoint, a
    /// config's own when it names them, else fitted on the training split; written into the run config.
    fn prepare(
        &mut self,
        config: &mut RunConfig,
        dataset: &Dataset,
        train: Split,
        resume: Option<&qean_checkpoint::checkpoint::Checkpoint>,
    ) -> Result<()> {
        let c = config
            .inbetween
            .as_mut()
            .ok_or_else(|| Error::msg("model.arch = \"inbetween\" needs an [inbetween] table"))?;
        if !c.variant.has_audio() || c.music_norm != qean_config::inbetween::MusicNorm::Standardize
        {
            return Ok(());
        }
        if let Some(ck) = resume {
            let saved = ck.config.inbetween();
            c.music_mean = saved.music_mean;
            c.music_std = saved.music_std;
        } else if c.music_mean.is_empty() {
            let (mean, std) = music_stats(dataset, train, c)?;
            tracing::info!(
                "music statistics fitted on the {} split (22 columns)",
                train.name()
            );
            c.music_mean = mean;
            c.music_std = std;
        }
        c.validate().map_err(Error::msg)
    }

    fn init(&self, config: &RunConfig, device: &Device) -> Result<Inbetweener> {
        Ok(Inbetweener::new(config_of(config), device))
    }

    fn draw_spec(&self, config: &RunConfig) -> WindowSpec {
        segment_spec(config_of(config).max_len)
    }

    /// Whole sequences (any length), cut into measure windows.
    fn load_set(
        &self,
        dataset: &Dataset,
        split: Split,
        _spec: WindowSpec,
        config: &RunConfig,
    ) -> Result<SequenceSet> {
        let c = config_of(config);
        let one = WindowSpec {
            motion_len: 1,
            target_len: 1,
            target_shift: 0,
            audio_len: 1,
        };
        let mut whole =
            crate::data::load_split(dataset, split, config.layout(), one, &config.recipe)?;
        if c.variant.drums() {
            whole = with_drums(whole, dataset, c)?;
        }
        measure_windows(whole, c)
    }

    fn inputs(
        &self,
        drawn: Batch,
        _model: &Inbetweener,
        device: &Device,
        ctx: &StepContext,
    ) -> IbInputs {
        tensors(&drawn, config_of(ctx.config), ctx.rng_seed, device)
    }

    fn loss(&self, model: &Inbetweener, inputs: IbInputs, config: &RunConfig) -> Tensor<1> {
        residual_loss(model, inputs, config_of(config).lambda_vel)
    }

    /// Every validation measure once, `train_keys` keys, no dropout: the mean squared error per valid value
    /// (without the velocity term, so runs with other `lambda_vel` compare).
    fn validation_loss(
        &self,
        model: &Inbetweener,
        set: &SequenceSet,
        config: &RunConfig,
        device: &Device,
    ) -> f64 {
        let c = InbetweenConfig {
            mixed_keys: false,
            random_keys: false,
            ..config_of(config).clone()
        };
        let all = set.first_windows();
        let (mut sum, mut count) = (0.0, 0usize);
        let mut start = 0;
        while start < all.len() {
            let end = (start + config.train.batch_size.max(1)).min(all.len());
            let inputs = tensors(&all.slice(start, end), &c, 0, device);
            let values = inputs.valid_frames * MOTION_DIM;
            sum += residual_loss(model, inputs, 0.0).into_scalar::<f32>() as f64 * values as f64;
            count += values;
            start = end;
        }
        sum / count.max(1) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_names_round_trip() {
        let n = segment_name("gBR_sBM_cAll_d04_mBR0_ch01", 180, 181);
        assert_eq!(
            parse_segment_name(&n),
            Some(("gBR_sBM_cAll_d04_mBR0_ch01", 180, 181))
        );
    }

    #[test]
    fn window_keys_are_even_or_random_with_the_ends_kept() {
        let mut c = InbetweenConfig::tiny();
        assert_eq!(window_keys(&c, 7, 0, 181), vec![0, 45, 90, 135, 180]);
        c.random_keys = true;
        let mut differ = false;
        for i in 0..20 {
            let k = window_keys(&c, 7, i, 181);
            assert_eq!(k.len(), 5);
            assert_eq!((k[0], k[4]), (0, 180));
            assert!(k.windows(2).all(|w| w[0] < w[1]), "{k:?}");
            assert_eq!(k, window_keys(&c, 7, i, 181), "seeded");
            differ |= k != [0, 45, 90, 135, 180];
        }
        assert!(differ);
        // More keys than frames: every frame is a key.
        assert_eq!(window_keys(&c, 7, 0, 4), vec![0, 1, 2, 3]);
    }

    /// With the output layer zeroed Ŷ = B, so the loss is a closed form of B − Y: the plain MSE over valid
    /// values, plus λ times the MSE of consecutive valid differences (padding ignored).
    #[test]
    fn velocity_term_is_the_mse_of_consecutive_differences() {
        let device = Device::flex();
        device.seed(1);
        let c = InbetweenConfig {
            dropout: 0.0,
            ..InbetweenConfig::tiny()
        };
        let mut model = Inbetweener::new(&c, &device);
        model.output.weight = model.output.weight.map(|w| w.zeros_like());
        model.output.bias = model.output.bias.map(|p| p.map(|b| b.zeros_like()));
        // Two rows of 4 frames; the second has 3 valid frames.
        let (b, t, w) = (2, 4, MOTION_DIM);
        let e = |i: usize, f: usize, d: usize| ((i * 7 + f * 3 + d) % 5) as f64 * 0.1 - 0.2;
        let lens = [4usize, 3];
        let (mut base, mut target, mut mask) = (vec![], vec![], vec![]);
        for (i, &len) in lens.iter().enumerate() {
            for f in 0..t {
                for d in 0..w {
                    base.push(0.5f32);
                    target.push((0.5 - e(i, f, d)) as f32);
                }
                mask.push(if f < len { 1.0f32 } else { 0.0 });
            }
        }
        let tensor = |v: Vec<f32>, width: usize| {
            Tensor::<3>::from_data(TensorData::new(v, [b, t, width]), &device)
        };
        let inputs = || IbInputs {
            base: tensor(base.clone(), w),
            target: tensor(target.clone(), w),
            mask: tensor(mask.clone(), 1),
            cond: Conditioning {
                music: None,
                genre: None,
                lengths: Some(lens.to_vec()),
                taper: None,
            },
            valid_frames: 7,
        };
        let (mut sq, mut vel) = (0.0, 0.0);
        for (i, &len) in lens.iter().enumerate() {
            for d in 0..w {
                for f in 0..len {
                    sq += e(i, f, d).powi(2);
                }
                for f in 1..len {
                    vel += (e(i, f, d) - e(i, f - 1, d)).powi(2);
                }
            }
        }
        let (mse, vmse) = (sq / (7 * w) as f64, vel / (5 * w) as f64);
        let got = |l: f64| residual_loss(&model, inputs(), l).into_scalar::<f32>() as f64;
        assert!((got(0.0) - mse).abs() < 1e-6, "{} vs {mse}", got(0.0));
        assert!(
            (got(2.5) - (mse + 2.5 * vmse)).abs() < 1e-5,
            "{} vs {}",
            got(2.5),
            mse + 2.5 * vmse
        );
    }
}
