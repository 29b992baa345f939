//! The motion VQ-VAE as a trainer [`Family`] (SPEC §13.2.4–13.2.5): windows of pos72 frames (computed per
//! whole sequence from FK joints, then cut), the Bailando loss L1 + velocity + acceleration + β·commitment
//! (or T2M-GPT's smooth-L1), and the EMA codebook update after each optimiser step. The codebook and its
//! statistics are module state, so checkpoints carry them and resume is exact.

use std::sync::Mutex;

use burn::tensor::{Device, Tensor, TensorData};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::feature_cache;
use qean_aistpp::windows::{Batch, Sequence, SequenceSet, WindowSpec};
use qean_config::run::RunConfig;
use qean_config::vqvae::{Quantizer, ResetSource, TextBalance, VqConfig, VqLoss, VqNormalise};
use qean_io::error::{Error, Result};
use qean_models::vqvae::quantize::{assign, ChaChaEma, EmaCodebook, EmaOptions};
use qean_models::vqvae::VqVae;
use qean_motion::motion::Layout;
use qean_motion::pos72::{joints_to_pos72_f32, POS72};
use rand::{Rng, SeedableRng};

use crate::family::{Family, StepContext};
use qean_checkpoint::checkpoint::Checkpoint;
use qean_checkpoint::vqvae::{motion_pos72, normalise};

/// The VQ-VAE family. Holds the EMA state of the last update until the trainer hands the model back.
#[derive(Debug, Default)]
pub struct VqFamily {
    pending: Mutex<Option<EmaCodebook>>,
    /// The training split (set by `prepare`): the one a text set joins.
    train: Option<Split>,
    /// The text set's motions when `prepare` read them for the statistics, kept for the training windows
    /// (a text set is read once).
    text: Mutex<Option<Vec<TextMotion>>>,
}

/// A text-set motion's id and pos72 rows.
type TextMotion = (String, Vec<f32>);

/// A batch as the model reads it.
pub struct VqInputs {
    /// [B, T, 72] (normalised when `normalise = "zscore"`).
    pub x: Tensor<3>,
    /// The seed of this update's quantiser randomness (reset noise, permutations).
    pub seed: u64,
}

/// The `[vq]` table of a VQ-VAE run.
pub fn vq_of(config: &RunConfig) -> &VqConfig {
    config.vq_table()
}

/// Per-channel mean and SD (ddof 0) of the training split's pos72 frames and the text set's motions.
fn pos72_stats(
    ds: &Dataset,
    split: Split,
    c: &VqConfig,
    text: &[TextMotion],
) -> Result<(Vec<f64>, Vec<f64>)> {
    let mut stats = crate::data::ColumnStats::new(POS72);
    for name in ds.split(split) {
        let rows = motion_pos72(&ds.read_motion(&name)?, c);
        rows.chunks_exact(POS72).for_each(|r| stats.add(r));
    }
    for (_, rows) in text {
        rows.chunks_exact(POS72).for_each(|r| stats.add(r));
    }
    Ok(stats.mean_std())
}

/// The pos72 rows of every motion of `vq.text_set`'s `text_split` (none without a text set), by id.
fn text_motions(c: &VqConfig) -> Result<Vec<TextMotion>> {
    let Some(root) = &c.text_set else {
        return Ok(Vec::new());
    };
    let set = qean_aistpp::text_set::TextSet::open(root, &c.text_split)?;
    let opts = qean_checkpoint::vqvae::pos72_options(c);
    set.ids
        .iter()
        .map(|id| {
            let joints = set.joints(id, c.text_fps)?;
            Ok((id.clone(), joints_to_pos72_f32(&joints, &opts)))
        })
        .collect()
}

/// `set` (AIST++ training windows) joined by the text set's motions (`text`), each a sequence without
/// music, balanced by `vq.text_balance` (SPEC §13.2.5).
fn with_text_set(mut set: SequenceSet, c: &VqConfig, text: Vec<TextMotion>) -> Result<SequenceSet> {
    let music = set.sequences.len();
    let silent = std::sync::Arc::new(Vec::new());
    let mut short = 0;
    for (id, rows) in text {
        let frames = rows.len() / POS72;
        if set.spec.starts(frames) == 0 {
            short += 1;
            continue;
        }
        set.sequences.push(Sequence {
            name: format!("text:{id}"),
            motion: rows,
            motion_frames: frames,
            audio: silent.clone(),
            audio_frames: frames,
        });
    }
    let text = set.sequences.len() - music;
    if text == 0 {
        return Err(Error::at(
            c.text_set.as_deref().unwrap_or(std::path::Path::new("")),
            format!(
                "no motion of the text set is as long as a {}-frame window",
                set.spec.span()
            ),
        ));
    }
    let (m, t) = match c.text_balance {
        TextBalance::Proportional => (1, 1),
        TextBalance::Equal if text > music => ((text as f64 / music as f64).round() as usize, 1),
        TextBalance::Equal => (1, (music as f64 / text as f64).round() as usize),
    };
    set.visits = (0..set.sequences.len())
        .map(|i| if i < music { m } else { t })
        .collect();
    tracing::info!(
        "text set: {text} motions join {music} AIST++ sequences ({short} shorter than a window left out); each epoch visits them {t}× and {m}×"
    );
    Ok(set)
}

/// A rotation about y by a random angle of every window's positions and velocities (`yaw_augment`).
pub(crate) fn yaw(rows: &mut [f32], window: usize, seed: u64) {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x05EE_D7A3_u64);
    for w in rows.chunks_exact_mut(window * POS72) {
        let a: f64 = rng.random_range(0.0..std::f64::consts::TAU);
        let (s, c) = (a.sin() as f32, a.cos() as f32);
        for row in w.chunks_exact_mut(POS72) {
            for p in row.chunks_exact_mut(3) {
                let (x, z) = (p[0], p[2]);
                p[0] = c * x + s * z;
                p[2] = -s * x + c * z;
            }
        }
    }
}

fn l1(a: Tensor<3>, b: Tensor<3>) -> Tensor<1> {
    (a - b).abs().mean()
}

/// Smooth-L1 (Huber, δ = 1), mean.
fn smooth_l1(a: Tensor<3>, b: Tensor<3>) -> Tensor<1> {
    let d = (a - b).abs();
    let small = d.clone().lower_elem(1.0);
    let quad = d.clone().powi_scalar(2) * 0.5;
    let lin = d - 0.5;
    lin.mask_where(small, quad).mean()
}

fn diff(x: Tensor<3>) -> Tensor<3> {
    let t = x.dims()[1];
    x.clone().narrow(1, 1, t - 1) - x.narrow(1, 0, t - 1)
}

/// The reconstruction loss of SPEC §13.2.4 (without the quantiser term).
pub fn reconstruction_loss(recon: Tensor<3>, x: Tensor<3>, c: &VqConfig) -> Tensor<1> {
    match c.loss {
        VqLoss::Bailando => {
            let (dr, dx) = (diff(recon.clone()), diff(x.clone()));
            l1(recon, x)
                + l1(dr.clone(), dx.clone()) * c.lambda_vel
                + l1(diff(dr), diff(dx)) * c.lambda_acc
        }
        VqLoss::T2m => {
            let joints = |v: Tensor<3>| v.narrow(2, 3, POS72 - 3);
            smooth_l1(recon.clone(), x.clone()) + smooth_l1(joints(recon), joints(x)) * 0.5
        }
    }
}

/// The EMA options of a `[vq]` table.
pub fn ema_options(c: &VqConfig) -> EmaOptions {
    EmaOptions {
        mu: c.mu as f32,
        randperm: c.reset_source == ResetSource::Randperm,
        reset_stats: c.reset_stats,
    }
}

/// The whole loss of one batch without updating anything: reconstruction with the current codes + β·L_q.
pub fn eval_loss(model: &VqVae, x: Tensor<3>, c: &VqConfig) -> Tensor<1> {
    let z = model
        .encode(x.clone())
        .expect("windows are multiples of the rate");
    let (_, d) = model.codes();
    let indices = assign(&VqVae::host_rows(&z), &model.ema_state().codebook, d);
    let q = model.quantize_with(z, indices, c);
    reconstruction_loss(model.decode(q.z_q), x, c) + q.loss * c.commit
}

impl Family for VqFamily {
    type Model = VqVae;
    type Inputs = VqInputs;

    fn init(&self, config: &RunConfig, device: &Device) -> Result<VqVae> {
        Ok(VqVae::new(vq_of(config), device))
    }

    /// `normalise = "zscore"`: statistics fitted once on the training split (kept by resume).
    fn prepare(
        &mut self,
        config: &mut RunConfig,
        dataset: &Dataset,
        train: Split,
        resume: Option<&Checkpoint>,
    ) -> Result<()> {
        let c = config
            .vq
            .as_mut()
            .ok_or_else(|| Error::msg("model.arch = \"vqvae\" needs a [vq] table"))?;
        self.train = Some(train);
        if c.normalise == VqNormalise::Zscore {
            if let Some(saved) = resume.and_then(|ck| ck.config.vq.clone()) {
                c.mean = saved.mean;
                c.std = saved.std;
            } else if c.mean.is_empty() {
                let text = text_motions(c)?;
                let (mean, std) = pos72_stats(dataset, train, c, &text)?;
                *self.text.lock().unwrap_or_else(|e| e.into_inner()) = Some(text);
                tracing::info!("pos72 statistics fitted on the {} split", train.name());
                c.mean = mean;
                c.std = std;
            }
        }
        c.validate().map_err(Error::msg)
    }

    /// Windows of pos72 rows; no music. The training split is joined by `vq.text_set`'s motions.
    fn load_set(
        &self,
        dataset: &Dataset,
        split: Split,
        spec: WindowSpec,
        config: &RunConfig,
    ) -> Result<SequenceSet> {
        let c = vq_of(config);
        qean_checkpoint::features::ensure_features(dataset, &dataset.split(split))?;
        let set = SequenceSet::load(dataset, split, Layout::L219, spec, |id| {
            feature_cache::load(dataset, id)
        })?;
        let set = set.remap(
            POS72,
            0,
            |seq| {
                let motion = dataset.read_motion(&seq.name)?;
                let mut rows = motion_pos72(&motion, c);
                rows.truncate(seq.motion_frames * POS72);
                Ok(rows)
            },
            |_, _| Vec::new(),
        )?;
        if c.text_set.is_some() && self.train == Some(split) {
            let read = self.text.lock().unwrap_or_else(|e| e.into_inner()).take();
            let text = match read {
                Some(text) => text,
                None => text_motions(c)?,
            };
            return with_text_set(set, c, text);
        }
        Ok(set)
    }

    fn inputs(&self, drawn: Batch, _model: &VqVae, device: &Device, ctx: &StepContext) -> VqInputs {
        let c = vq_of(ctx.config);
        let (b, t) = (drawn.len(), drawn.spec.motion_len);
        let mut rows = drawn.motion;
        if c.yaw() {
            yaw(&mut rows, t, ctx.rng_seed);
        }
        normalise(&mut rows, c);
        VqInputs {
            x: Tensor::from_data(TensorData::new(rows, [b, t, POS72]), device),
            seed: ctx.rng_seed,
        }
    }

    /// EMA: init (first batch), assign with the current codes, commitment, then the codebook update
    /// (kept until [`Family::after_update`] writes it into the model). st: the learned codebook's losses.
    fn loss(&self, model: &VqVae, inputs: VqInputs, config: &RunConfig) -> Tensor<1> {
        let c = vq_of(config);
        let z = model
            .encode(inputs.x.clone())
            .expect("windows are multiples of the rate");
        let [b, n, _] = z.dims();
        let q = match c.quantizer {
            Quantizer::St => {
                let (_, d) = model.codes();
                let indices = assign(&VqVae::host_rows(&z), &model.ema_state().codebook, d);
                model.quantize_with(z, indices, c)
            }
            Quantizer::EmaReset => {
                let rows = VqVae::host_rows(&z);
                let mut state = model.ema_state();
                let mut rng = ChaChaEma(rand_chacha::ChaCha8Rng::seed_from_u64(inputs.seed));
                let opts = ema_options(c);
                state.init_if_needed(&rows, &mut rng, &opts);
                let indices = assign(&rows, &state.codebook, state.dim);
                let e = state.rows(&indices);
                let device = z.device();
                let e = Tensor::<3>::from_data(TensorData::new(e, [b, n, state.dim]), &device);
                state.update(&rows, &indices, &mut rng, &opts);
                *self.pending.lock().expect("not poisoned") = Some(state);
                model.quantize_rows(z, e, indices)
            }
        };
        reconstruction_loss(model.decode(q.z_q), inputs.x, c) + q.loss * c.commit
    }

    fn after_update(&self, model: VqVae) -> VqVae {
        match self.pending.lock().expect("not poisoned").take() {
            Some(state) => model.with_ema_state(&state),
            None => model,
        }
    }

    /// The s = 0 window of every sequence, current codes, no update: the loss per window.
    fn validation_loss(
        &self,
        model: &VqVae,
        set: &SequenceSet,
        config: &RunConfig,
        device: &Device,
    ) -> f64 {
        let c = vq_of(config);
        let t = set.spec.motion_len;
        crate::family::mean_over_first_windows(set, config.train.batch_size, |batch| {
            let b = batch.len();
            let mut rows = batch.motion;
            normalise(&mut rows, c);
            eval_loss(
                model,
                Tensor::from_data(TensorData::new(rows, [b, t, POS72]), device),
                c,
            )
        })
    }
}
