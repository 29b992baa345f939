//! The training loop (SPEC §5): random windows from the train split, the L2 loss on the first
//! 20 output tokens (plus QRA's penalty when configured), Adam with the configured schedule,
//! validation, metrics, checkpoints, exact resume, Ctrl-C and NaN handling.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use burn::module::Module;
use burn::optim::decay::WeightDecayConfig;
use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};
use indicatif::{ProgressBar, ProgressStyle};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::windows::{Batch, SequenceSet, WindowSampler};
use qean_config::recipe::Predict;
use qean_io::error::{Error, Result};
use qean_models::loss::{difference_loss, motion_loss};
use qean_models::DanceModel;

use crate::checkpoint::{self, Best, Checkpoint, TrainerState};
use crate::data;
use crate::metrics_log::{self, MetricsLog, Row};
use crate::run_config::RunConfig;
use crate::run_dir::{self, RunLock};

/// How progress is shown.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ProgressMode {
    /// A bar on a terminal, plain lines otherwise.
    Auto,
    /// Plain periodic lines on stderr.
    Lines,
    /// Nothing (logs still go to train.log).
    Quiet,
}

/// Where a run starts.
#[derive(Debug, Clone, PartialEq)]
pub enum Start {
    /// A new run; the run directory must hold no checkpoint.
    Fresh,
    /// Continue from this checkpoint directory.
    From(PathBuf),
    /// Continue from the newest checkpoint if there is one, else start fresh (sweeps).
    Auto,
}

/// Options of one `train` call.
#[derive(Debug, Clone)]
pub struct TrainOptions {
    pub run_dir: PathBuf,
    pub start: Start,
    pub progress: ProgressMode,
    /// Set (e.g. by a Ctrl-C handler) to stop after the current update with a checkpoint.
    pub stop: Arc<AtomicBool>,
    /// A label for progress lines (sweeps name the run).
    pub label: String,
}

impl TrainOptions {
    pub fn new(run_dir: &Path) -> Self {
        TrainOptions {
            run_dir: run_dir.to_path_buf(),
            start: Start::Fresh,
            progress: ProgressMode::Auto,
            stop: Arc::new(AtomicBool::new(false)),
            label: String::new(),
        }
    }
}

/// How a `train` call ended.
#[derive(Debug, Clone, PartialEq)]
pub struct TrainOutcome {
    /// Updates applied.
    pub step: u64,
    pub total_steps: u64,
    /// Stopped by the stop flag (a checkpoint was written).
    pub interrupted: bool,
    /// Nothing to do: the run had already reached its step count.
    pub already_done: bool,
    pub last_loss: Option<f64>,
    pub val_loss: Option<f64>,
    pub best: Option<Best>,
    /// Training seconds over all sessions.
    pub seconds: f64,
    /// The newest checkpoint.
    pub checkpoint: PathBuf,
}

/// The run's optimiser: Adam with its betas, epsilon, weight decay and gradient clipping.
pub fn adam(config: &RunConfig) -> ModuleOptimizer {
    let o = &config.optim;
    let mut adam = AdamConfig::new()
        .with_beta_1(o.beta1 as f32)
        .with_beta_2(o.beta2 as f32)
        .with_epsilon(o.epsilon as f32);
    if o.weight_decay > 0.0 {
        adam = adam.with_weight_decay(Some(WeightDecayConfig::new(o.weight_decay as f32)));
    }
    if o.grad_clip_norm > 0.0 {
        adam = adam.with_grad_clipping(Some(
            burn::optim::grad_clipping::GradientClippingConfig::Norm(o.grad_clip_norm as f32),
        ));
    }
    adam.init()
}

/// Weights of the loss terms beyond SPEC §5.3's L2 (`[recipe]`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LossWeights {
    pub velocity: f64,
    pub accel: f64,
}

impl LossWeights {
    pub fn of(config: &RunConfig) -> Self {
        LossWeights {
            velocity: config.recipe.velocity_loss,
            accel: config.recipe.accel_loss,
        }
    }
}

/// One optimiser update on one batch (motion, audio, target on an autodiff device): forward with
/// the QRA penalty, the loss of SPEC §5.3 (plus the recipe's difference terms), backward, Adam
/// step at `lr`. Returns the updated model and the loss before the update; a non-finite loss
/// returns the model unchanged.
pub fn update(
    model: DanceModel,
    optim: &mut ModuleOptimizer,
    (motion, audio, target): (Tensor<3>, Tensor<3>, Tensor<3>),
    weights: LossWeights,
    lr: f64,
) -> (DanceModel, f64) {
    let out = model.forward_with_penalty(motion, audio);
    let mut loss = motion_loss(out.prediction.clone(), target.clone());
    if weights.velocity > 0.0 {
        loss = loss
            + difference_loss(out.prediction.clone(), target.clone(), 1)
                .mul_scalar(weights.velocity);
    }
    if weights.accel > 0.0 {
        loss = loss + difference_loss(out.prediction, target, 2).mul_scalar(weights.accel);
    }
    if let Some(p) = out.penalty {
        loss = loss + p;
    }
    let value = loss.clone().into_scalar::<f32>() as f64;
    if !value.is_finite() {
        return (model, value);
    }
    let grads = GradientsParams::from_grads(loss.backward(), &model);
    (optim.step(lr, model, grads), value)
}

/// The device-RNG seed of update `step` (dropout masks are a function of (seed, step)).
fn update_seed(seed: u64, step: u64) -> u64 {
    let mut z = seed ^ step.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Model inputs and the training target of a batch: the future frames, or (`predict =
/// "offset"`) the future frames minus each window's last input frame.
fn tensors(batch: &Batch, device: &Device, predict: Predict) -> (Tensor<3>, Tensor<3>, Tensor<3>) {
    let b = batch.len();
    let sp = batch.spec;
    let d = batch.dim;
    let mut target = batch.target.clone();
    if predict == Predict::Offset {
        for i in 0..b {
            let last = &batch.motion[(i * sp.motion_len + sp.motion_len - 1) * d..][..d];
            for row in
                target[i * sp.target_len * d..(i + 1) * sp.target_len * d].chunks_exact_mut(d)
            {
                for (x, l) in row.iter_mut().zip(last) {
                    *x -= l;
                }
            }
        }
    }
    (
        Tensor::from_data(
            TensorData::new(batch.motion.clone(), [b, sp.motion_len, d]),
            device,
        ),
        Tensor::from_data(
            TensorData::new(
                batch.audio.clone(),
                [b, sp.audio_len, qean_aistpp::windows::AUDIO_DIM],
            ),
            device,
        ),
        Tensor::from_data(TensorData::new(target, [b, sp.target_len, d]), device),
    )
}

/// Teacher-forced validation loss (SPEC §5.6): the s = 0 window of every sequence of the split,
/// no dropout, the mean squared error of the predicted poses over all of them.
pub fn validation_loss(
    model: &DanceModel,
    set: &SequenceSet,
    batch_size: usize,
    device: &Device,
    predict: Predict,
) -> f64 {
    let all = set.first_windows();
    let n = all.len();
    let (sp, d) = (all.spec, all.dim);
    let per_m = sp.motion_len * d;
    let per_a = sp.audio_len * qean_aistpp::windows::AUDIO_DIM;
    let per_t = sp.target_len * d;
    let mut sum = 0.0;
    let mut start = 0;
    while start < n {
        let end = (start + batch_size).min(n);
        let chunk = Batch {
            motion: all.motion[start * per_m..end * per_m].to_vec(),
            audio: all.audio[start * per_a..end * per_a].to_vec(),
            target: all.target[start * per_t..end * per_t].to_vec(),
            names: all.names[start..end].to_vec(),
            starts: all.starts[start..end].to_vec(),
            dim: d,
            spec: sp,
        };
        let (m, a, t) = tensors(&chunk, device, predict);
        let loss = motion_loss(model.forward(m, a), t).into_scalar::<f32>() as f64;
        sum += loss * (end - start) as f64;
        start = end;
    }
    sum / n as f64
}

struct Reporter {
    mode: ProgressMode,
    bar: Option<ProgressBar>,
    last_line: Instant,
    label: String,
}

impl Reporter {
    fn new(mode: ProgressMode, total: u64, done: u64, label: &str) -> Self {
        let mode = match mode {
            ProgressMode::Auto if std::io::stderr().is_terminal() => ProgressMode::Auto,
            ProgressMode::Auto => ProgressMode::Lines,
            m => m,
        };
        let bar = (mode == ProgressMode::Auto).then(|| {
            let pb = ProgressBar::new(total);
            pb.set_style(
                ProgressStyle::with_template(
                    "{prefix}{bar:30} {pos}/{len} {msg} {per_sec} [{elapsed_precise} eta {eta}]",
                )
                .expect("valid template"),
            );
            pb.set_prefix(if label.is_empty() {
                String::new()
            } else {
                format!("{label} ")
            });
            pb.set_position(done);
            pb.reset_eta();
            pb
        });
        Reporter {
            mode,
            bar,
            last_line: Instant::now(),
            label: label.to_string(),
        }
    }

    fn update(&mut self, step: u64, total: u64, loss: f64, lr: f64, rate: f64, force: bool) {
        let msg = format!("loss {loss:.4e} lr {lr:.1e}");
        match self.mode {
            ProgressMode::Auto => {
                if let Some(pb) = &self.bar {
                    pb.set_position(step);
                    pb.set_message(msg);
                }
            }
            ProgressMode::Lines => {
                if force || self.last_line.elapsed().as_secs_f64() >= 10.0 {
                    let eta = if rate > 0.0 {
                        (total - step) as f64 / rate
                    } else {
                        0.0
                    };
                    let label = if self.label.is_empty() {
                        String::new()
                    } else {
                        format!("{}: ", self.label)
                    };
                    eprintln!("{label}step {step}/{total} {msg} {rate:.2} steps/s eta {eta:.0} s");
                    self.last_line = Instant::now();
                }
            }
            ProgressMode::Quiet => {}
        }
    }

    fn println(&self, line: &str) {
        match (&self.bar, self.mode) {
            (Some(pb), _) => pb.println(line),
            (None, ProgressMode::Quiet) => {}
            (None, _) => eprintln!("{line}"),
        }
    }

    fn finish(&self) {
        if let Some(pb) = &self.bar {
            pb.finish_and_clear();
        }
    }
}

/// Everything the loop carries between updates.
struct Session {
    config: RunConfig,
    run_dir: PathBuf,
    device: Device,
    plain: Device,
    model: DanceModel,
    optim: ModuleOptimizer,
    sampler: WindowSampler,
    train_set: SequenceSet,
    val_set: Option<SequenceSet>,
    step: u64,
    last_loss: Option<f64>,
    val_loss: Option<f64>,
    val_step: Option<u64>,
    best: Option<Best>,
    elapsed_before: f64,
    started: Instant,
    metrics: MetricsLog,
}

impl Session {
    fn elapsed(&self) -> f64 {
        self.elapsed_before + self.started.elapsed().as_secs_f64()
    }

    fn validate(&mut self) -> Option<f64> {
        let set = self.val_set.as_ref()?;
        let model = self.model.valid();
        let v = validation_loss(
            &model,
            set,
            self.config.train.batch_size,
            &self.plain,
            self.config.recipe.predict,
        );
        self.val_loss = Some(v);
        self.val_step = Some(self.step);
        if v.is_finite() && self.best.is_none_or(|b| v < b.val_loss) {
            self.best = Some(Best {
                step: self.step,
                val_loss: v,
            });
        }
        Some(v)
    }

    fn state(&self, params_hash: String) -> TrainerState {
        let total = self.config.train.steps;
        TrainerState {
            format: checkpoint::FORMAT,
            step: self.step,
            total_steps: total,
            seed: self.config.train.seed,
            sampler: self.sampler.state(),
            next_lr: self.config.schedule.lr(self.step, total),
            last_loss: self.last_loss,
            val_loss: (self.val_step == Some(self.step))
                .then_some(self.val_loss)
                .flatten(),
            best: self.best,
            elapsed_seconds: self.elapsed(),
            params_hash,
            backend: self.config.train.backend.clone(),
        }
    }

    /// The error that ends a diverged run, naming the last good checkpoint (also logged to train.log).
    fn diverged(&self, what: String) -> Error {
        let last_good = run_dir::list_checkpoints(&self.run_dir)
            .ok()
            .and_then(|l| l.last().map(|(_, d)| d.display().to_string()))
            .unwrap_or_else(|| "none".into());
        let msg = format!(
            "training diverged: {what}; stopped (last good checkpoint: {last_good}). Lower \
             schedule.initial or set optim.grad_clip_norm"
        );
        tracing::error!(target: crate::logging::FILE_ONLY, "{msg}");
        Error::at(&self.run_dir, msg)
    }

    /// Writes `step-N` atomically, prunes old checkpoints, redraws loss.png.
    fn checkpoint(&mut self) -> Result<PathBuf> {
        let dir = self
            .run_dir
            .join(run_dir::CHECKPOINTS)
            .join(run_dir::checkpoint_name(self.step));
        if dir.exists() {
            return Ok(dir);
        }
        let parent = self.run_dir.join(run_dir::CHECKPOINTS);
        std::fs::create_dir_all(&parent).map_err(|e| Error::io(&parent, e))?;
        if let Some(v) = self
            .val_loss
            .filter(|v| !v.is_finite() && self.val_step == Some(self.step))
        {
            return Err(self.diverged(format!(
                "the validation loss after update {} is {v}; no checkpoint written",
                self.step
            )));
        }
        let params = qean_models::params::named_parameters(&self.model);
        if let Some(p) = params
            .iter()
            .find(|p| p.values.iter().any(|v| !v.is_finite()))
        {
            return Err(self.diverged(format!(
                "parameter {} is not finite after update {}; no checkpoint written",
                p.name, self.step
            )));
        }
        let state = self.state(qean_models::params::params_hash(&params));
        let config_text = self.config.to_toml().map_err(Error::msg)?;
        qean_io::fsutil::atomic_dir(&dir, |tmp| {
            self.model
                .save_weights(&tmp.join(checkpoint::MODEL_FILE))
                .map_err(Error::msg)?;
            let opt_path = tmp.join(checkpoint::OPTIMIZER_FILE);
            self.optim
                .save(&opt_path)
                .map_err(|e| Error::at(&opt_path, format!("cannot save optimiser state: {e}")))?;
            let state_path = tmp.join(checkpoint::STATE_FILE);
            let json = serde_json::to_string_pretty(&state).expect("state serialises");
            std::fs::write(&state_path, json).map_err(|e| Error::io(&state_path, e))?;
            let cfg = tmp.join(checkpoint::CONFIG_FILE);
            std::fs::write(&cfg, &config_text).map_err(|e| Error::io(&cfg, e))?;
            Ok(())
        })?;
        tracing::info!(
            "checkpoint {} (params_hash {})",
            dir.display(),
            state.params_hash
        );
        self.prune()?;
        self.plot();
        Ok(dir)
    }

    fn prune(&self) -> Result<()> {
        let list = run_dir::list_checkpoints(&self.run_dir)?;
        let with_val: Vec<(u64, Option<f64>)> = list
            .iter()
            .map(|(s, dir)| {
                let v = Checkpoint::read(dir).ok().and_then(|c| c.state.val_loss);
                (*s, v)
            })
            .collect();
        for step in run_dir::to_prune(&with_val, self.config.train.keep_last) {
            if let Some((_, dir)) = list.iter().find(|(s, _)| *s == step) {
                // Renamed away first: a kill mid-deletion must not leave a half checkpoint.
                qean_io::fsutil::atomic_remove_dir(dir)?;
                tracing::info!("pruned {}", dir.display());
            }
        }
        Ok(())
    }

    fn plot(&self) {
        let path = self.run_dir.join("loss.png");
        let result = metrics_log::read(self.metrics.path()).and_then(|rows| {
            let title = format!("{} LOSS", self.config.summary().to_uppercase());
            let png = crate::plot::loss_plot(&rows, &title).to_png();
            qean_io::fsutil::atomic_write(&path, &png)
        });
        if let Err(e) = result {
            tracing::warn!("loss plot not updated: {e}");
        }
    }
}

/// Trains (or continues) the run in `opts.run_dir` with `config`.
pub fn train(config: RunConfig, opts: &TrainOptions) -> Result<TrainOutcome> {
    let run_dir = &opts.run_dir;
    let created = !run_dir.exists();
    std::fs::create_dir_all(run_dir).map_err(|e| Error::io(run_dir, e))?;
    let result = (|| {
        let _lock = RunLock::acquire(run_dir)?;
        let log_path = run_dir.join("train.log");
        let file = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&log_path)
            .map_err(|e| Error::io(&log_path, e))?;
        let subscriber = crate::logging::subscriber(file);
        tracing::subscriber::with_default(subscriber, || train_locked(config, opts))
    })();
    // A fresh run that failed before its first checkpoint leaves nothing behind (the error was printed).
    if result.is_err() && created && run_dir::list_checkpoints(run_dir).is_ok_and(|c| c.is_empty())
    {
        let _ = std::fs::remove_dir_all(run_dir);
    }
    result
}

fn train_locked(mut config: RunConfig, opts: &TrainOptions) -> Result<TrainOutcome> {
    let run_dir = opts.run_dir.clone();
    run_dir::clean_temporaries(&run_dir)?;
    let existing = run_dir::list_checkpoints(&run_dir)?;
    let resume_from: Option<Checkpoint> = match &opts.start {
        Start::Fresh => {
            if let Some((step, _)) = existing.last() {
                return Err(Error::at(
                    &run_dir,
                    format!("already holds a run (checkpoint step-{step}): continue it with --resume, or pick another --run-dir"),
                ));
            }
            None
        }
        Start::From(dir) => Some(Checkpoint::read(dir)?),
        Start::Auto => {
            if existing.is_empty() {
                None
            } else {
                Some(checkpoint::resolve(&run_dir)?)
            }
        }
    };

    // Data: absolute path, so the resolved config works from any directory.
    let data_dir = config.data.dir.clone().ok_or_else(|| {
        Error::msg("data.dir is not set: pass --data DIR (or --set data.dir=DIR)".to_string())
    })?;
    let data_dir = std::fs::canonicalize(&data_dir)
        .map_err(|_| Error::at(&data_dir, "dataset directory does not exist"))?;
    config.data.dir = Some(data_dir.clone());

    if let Some(ck) = &resume_from {
        ck.check_model(&config.model)?;
        if ck.state.step > config.train.steps {
            return Err(Error::at(
                &ck.dir,
                format!(
                    "checkpoint is at step {} but train.steps is {}",
                    ck.state.step, config.train.steps
                ),
            ));
        }
        // Resuming an older checkpoint discards the later ones (their history is being rewritten).
        for (step, dir) in &existing {
            if *step > ck.state.step {
                tracing::warn!(
                    "discarding {} (resuming from step {})",
                    dir.display(),
                    ck.state.step
                );
                qean_io::fsutil::atomic_remove_dir(dir)?;
            }
        }
    }

    let ds = Dataset::open(&data_dir)?;
    let spec = config.window_spec();
    let layout = config.layout();
    let train_split: Split = config.data.train_split.parse().map_err(Error::msg)?;
    if let Some(ck) = resume_from
        .as_ref()
        .filter(|_| config.recipe.needs_audio_stats())
    {
        // A resumed run keeps the statistics its model was trained with.
        config.recipe.audio_mean = ck.config.recipe.audio_mean.clone();
        config.recipe.audio_std = ck.config.recipe.audio_std.clone();
    }
    if config.recipe.needs_audio_stats() {
        let (mean, std) = data::audio_stats(&ds, train_split)?;
        config.recipe.audio_mean = mean;
        config.recipe.audio_std = std;
    }
    let train_set = data::load_split(
        &ds,
        train_split,
        layout,
        crate::recipe::draw_spec(&config),
        &config.recipe,
    )?;
    let val_set = if config.data.val_split.is_empty() {
        None
    } else {
        let split: Split = config.data.val_split.parse().map_err(Error::msg)?;
        if ds.split(split).is_empty() {
            tracing::warn!("the {} split is empty: no validation", split.name());
            None
        } else {
            Some(data::load_split(&ds, split, layout, spec, &config.recipe)?)
        }
    };

    let plain = qean_models::backend::device(&config.train.backend).map_err(Error::msg)?;
    let device = plain.clone().autodiff();
    let total = config.train.steps;
    let seed = config.train.seed;

    // Model, optimiser and stream: fresh, or exactly as the checkpoint left them.
    device.seed(seed);
    let mut model = DanceModel::new(&config.model, &device);
    let mut optim = adam(&config);
    let (step, sampler, last_loss, best, elapsed_before) = match &resume_from {
        None => (0, WindowSampler::new(seed, &train_set), None, None, 0.0),
        Some(ck) => {
            model = model
                .load_weights(&ck.dir.join(checkpoint::MODEL_FILE))
                .map_err(Error::msg)?;
            let opt_path = ck.dir.join(checkpoint::OPTIMIZER_FILE);
            optim = optim
                .load(&opt_path)
                .map_err(|e| Error::at(&opt_path, format!("cannot load optimiser state: {e}")))?;
            if ck.state.sampler.seed != seed {
                return Err(Error::at(
                    &ck.dir,
                    format!(
                        "checkpoint was trained with train.seed = {}, the config says {seed}",
                        ck.state.sampler.seed
                    ),
                ));
            }
            (
                ck.state.step,
                WindowSampler::resume(ck.state.sampler, &train_set),
                ck.state.last_loss,
                ck.state.best,
                ck.state.elapsed_seconds,
            )
        }
    };

    // The resolved config, for people and for `--resume R`.
    let config_text = config.to_toml().map_err(Error::msg)?;
    qean_io::fsutil::atomic_write(&run_dir.join("config.toml"), config_text.as_bytes())?;
    let metrics = MetricsLog::open(&run_dir.join("metrics.csv"), step)?;
    tracing::info!(
        "{} run {} at step {step}/{total}: {} ({} train sequences, {} val, backend {})",
        if resume_from.is_some() {
            "resuming"
        } else {
            "starting"
        },
        run_dir.display(),
        config.summary(),
        train_set.sequences.len(),
        val_set.as_ref().map_or(0, |v| v.sequences.len()),
        config.train.backend
    );
    let mut s = Session {
        config,
        run_dir: run_dir.clone(),
        device,
        plain,
        model,
        optim,
        sampler,
        train_set,
        val_set,
        step,
        last_loss,
        val_loss: None,
        val_step: None,
        best,
        elapsed_before,
        started: Instant::now(),
        metrics,
    };
    if s.step >= total {
        let dir = checkpoint::resolve(&run_dir)?.dir;
        return Ok(outcome(&s, false, true, dir));
    }
    run_loop(&mut s, opts)
}

fn outcome(
    s: &Session,
    interrupted: bool,
    already_done: bool,
    checkpoint: PathBuf,
) -> TrainOutcome {
    TrainOutcome {
        step: s.step,
        total_steps: s.config.train.steps,
        interrupted,
        already_done,
        last_loss: s.last_loss,
        val_loss: s.val_loss,
        best: s.best,
        seconds: s.elapsed(),
        checkpoint,
    }
}

fn run_loop(s: &mut Session, opts: &TrainOptions) -> Result<TrainOutcome> {
    let total = s.config.train.steps;
    let t = s.config.train.clone();
    let mut reporter = Reporter::new(opts.progress, total, s.step, &opts.label);
    let session_start_step = s.step;
    let mut last_checkpoint: Option<PathBuf> = None;
    while s.step < total {
        if opts.stop.load(Ordering::SeqCst) {
            let dir = s.checkpoint()?;
            reporter.finish();
            tracing::warn!(
                "interrupted at step {}: checkpoint {}",
                s.step,
                dir.display()
            );
            return Ok(outcome(s, true, false, dir));
        }
        let drawn = s.sampler.next_batch(&s.train_set, t.batch_size);
        let rng_seed = update_seed(t.seed, s.step);
        let batch =
            crate::recipe::model_inputs(drawn, &s.config, &s.model, &s.plain, rng_seed, s.step);
        let inputs = tensors(&batch, &s.device, s.config.recipe.predict);
        s.device.seed(rng_seed);
        let lr = s.config.schedule.lr(s.step, total);
        let weights = LossWeights::of(&s.config);
        let (model, value) = update(s.model.clone(), &mut s.optim, inputs, weights, lr);
        if !value.is_finite() {
            reporter.finish();
            return Err(s.diverged(format!("the loss of update {} is {value}", s.step + 1)));
        }
        s.model = model;
        s.step += 1;
        s.last_loss = Some(value);

        let at_checkpoint = s.step.is_multiple_of(t.checkpoint_every) || s.step == total;
        let at_val = (t.val_every > 0 && s.step.is_multiple_of(t.val_every)) || at_checkpoint;
        let val = if at_val { s.validate() } else { None };
        if s.step.is_multiple_of(t.log_every) || val.is_some() || s.step == total {
            s.metrics.append(&Row {
                step: s.step,
                lr,
                loss: Some(value),
                val_loss: val,
                seconds: s.elapsed(),
            })?;
            tracing::info!(
                "step {} lr {lr:e} loss {value:.6e}{}",
                s.step,
                val.map(|v| format!(" val_loss {v:.6e}"))
                    .unwrap_or_default()
            );
        }
        let rate =
            (s.step - session_start_step) as f64 / s.started.elapsed().as_secs_f64().max(1e-9);
        reporter.update(s.step, total, value, lr, rate, false);
        if let Some(v) = val {
            reporter.println(&format!(
                "{}step {}: val_loss {v:.4e}",
                if opts.label.is_empty() {
                    String::new()
                } else {
                    format!("{}: ", opts.label)
                },
                s.step
            ));
        }
        if at_checkpoint {
            last_checkpoint = Some(s.checkpoint()?);
            reporter.update(s.step, total, value, lr, rate, true);
        }
    }
    reporter.finish();
    let dir = match last_checkpoint {
        Some(d) => d,
        None => s.checkpoint()?,
    };
    tracing::info!(
        "finished {} steps in {:.1} s: loss {:.6e}, val_loss {}",
        total,
        s.elapsed(),
        s.last_loss.unwrap_or(f64::NAN),
        s.val_loss
            .map(|v| format!("{v:.6e}"))
            .unwrap_or_else(|| "-".into())
    );
    Ok(outcome(s, false, false, dir))
}
