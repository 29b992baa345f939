//! The training loop (SPEC §5), the same for every model family ([`Family`]): random windows from the
//! train split, the family's loss, Adam with the configured schedule, validation, metrics, checkpoints,
//! exact resume, Ctrl-C and NaN handling.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

use std::collections::HashSet;

use burn::module::{Module, ModuleVisitor, Param, ParamId};
use burn::optim::decay::WeightDecayConfig;
use burn::optim::{AdamConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::windows::{SequenceSet, WindowSampler};
use qean_io::error::{Error, Result};

use crate::family::{Family, StepContext};
use crate::metrics_log::{self, MetricsLog, Row};
use crate::progress::Reporter;
pub use crate::resume::Start;
use qean_checkpoint::checkpoint::{self, Best, Checkpoint, TrainerState};
use qean_checkpoint::run_dir::{self, RunLock};
use qean_checkpoint::ProgressMode;
use qean_config::run::RunConfig;

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

/// The run's optimiser: Adam with its betas, epsilon and coupled weight decay (g ← g + λθ inside the
/// step, PyTorch's `Adam(weight_decay)`). Gradient clipping is global ([`apply_update`]), not Burn's
/// per-tensor clip.
pub fn adam(config: &RunConfig) -> ModuleOptimizer {
    let o = &config.optim;
    let mut adam = AdamConfig::new()
        .with_beta_1(o.beta1 as f32)
        .with_beta_2(o.beta2 as f32)
        .with_epsilon(o.epsilon as f32);
    if o.weight_decay > 0.0 {
        adam = adam.with_weight_decay(Some(WeightDecayConfig::new(o.weight_decay as f32)));
    }
    adam.init()
}

/// Sums the squares of every gradient of a module's float parameters.
struct GradNorm<'g> {
    grads: &'g GradientsParams,
    sum: f64,
}

impl ModuleVisitor for GradNorm<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        if let Some(g) = self.grads.get::<D>(param.id) {
            self.sum += g.powi_scalar(2).sum().into_scalar::<f32>() as f64;
        }
    }
}

/// Multiplies every gradient of a module's float parameters by one factor.
struct GradScale<'g> {
    grads: &'g mut GradientsParams,
    factor: f32,
}

impl ModuleVisitor for GradScale<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        if let Some(g) = self.grads.remove::<D>(param.id) {
            self.grads
                .register::<D>(param.id, g.mul_scalar(self.factor));
        }
    }
}

/// PyTorch's `clip_grad_norm_(parameters, max_norm)`: when the global L2 norm of all gradients
/// exceeds `max_norm`, every gradient is scaled by max_norm / (norm + 1e-6). Returns the norm.
pub fn clip_global_norm<M: Module>(model: &M, grads: &mut GradientsParams, max_norm: f64) -> f64 {
    let mut norm = GradNorm { grads, sum: 0.0 };
    model.visit(&mut norm);
    let total = norm.sum.sqrt();
    if total > max_norm {
        let factor = (max_norm / (total + 1e-6)) as f32;
        model.visit(&mut GradScale { grads, factor });
    }
    total
}

/// One optimiser update from a batch's loss: backward, global-norm clipping at `clip` (0 = none), Adam
/// step at `lr`. Returns the updated model and the loss before the update; a non-finite loss returns
/// the model unchanged.
pub fn apply_update<M: Module>(
    model: M,
    optim: &mut ModuleOptimizer,
    loss: Tensor<1>,
    lr: f64,
    clip: f64,
) -> (M, f64) {
    let value = loss.clone().into_scalar::<f32>() as f64;
    if !value.is_finite() {
        return (model, value);
    }
    let mut grads = GradientsParams::from_grads(loss.backward(), &model);
    if clip > 0.0 {
        clip_global_norm(&model, &mut grads, clip);
    }
    (optim.step(lr, model, grads), value)
}

/// Drops every gradient of a module's parameters outside `keep`.
struct GradKeep<'g> {
    grads: &'g mut GradientsParams,
    keep: &'g HashSet<ParamId>,
}

impl ModuleVisitor for GradKeep<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        if !self.keep.contains(&param.id) {
            self.grads.remove::<D>(param.id);
        }
    }
}

/// One optimiser update of one parameter group ([`Family::param_groups`]): like [`apply_update`], with
/// the gradients of every parameter outside `keep` dropped first.
pub fn apply_group_update<M: Module>(
    model: M,
    optim: &mut ModuleOptimizer,
    loss: Tensor<1>,
    keep: &HashSet<ParamId>,
    lr: f64,
    clip: f64,
) -> (M, f64) {
    let value = loss.clone().into_scalar::<f32>() as f64;
    if !value.is_finite() {
        return (model, value);
    }
    let mut grads = GradientsParams::from_grads(loss.backward(), &model);
    model.visit(&mut GradKeep {
        grads: &mut grads,
        keep,
    });
    if clip > 0.0 {
        clip_global_norm(&model, &mut grads, clip);
    }
    (optim.step(lr, model, grads), value)
}

/// The file of optimiser group `g`'s state (group 0: [`checkpoint::OPTIMIZER_FILE`]).
fn optimizer_file(g: usize) -> String {
    if g == 0 {
        checkpoint::OPTIMIZER_FILE.to_string()
    } else {
        format!("optimizer-{g}.bpk")
    }
}

/// The device-RNG seed of update `step` (dropout masks are a function of (seed, step)).
fn update_seed(seed: u64, step: u64) -> u64 {
    let mut z = seed ^ step.wrapping_add(1).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// Everything the loop carries between updates.
struct Session<'f, F: Family> {
    family: &'f F,
    config: RunConfig,
    run_dir: PathBuf,
    device: Device,
    plain: Device,
    model: F::Model,
    /// The moving average of the weights (`train.ema_decay` > 0), without autodiff ([`crate::ema`]).
    ema: Option<F::Model>,
    /// The family's parameter groups (empty: one group of every parameter) and one optimiser per group.
    groups: Vec<HashSet<ParamId>>,
    optims: Vec<ModuleOptimizer>,
    /// The last update's loss of every optimiser group (families with several).
    group_losses: Vec<f64>,
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

impl<F: Family> Session<'_, F> {
    fn elapsed(&self) -> f64 {
        self.elapsed_before + self.started.elapsed().as_secs_f64()
    }

    /// The moving average after an update (`train.ema_decay` > 0): it starts at the weights themselves.
    fn average(&mut self) {
        if self.config.train.ema_decay > 0.0 {
            let d = crate::ema::decay_at(self.config.train.ema_decay, self.step);
            // After the first update the average is the weights (also when resuming a checkpoint of
            // step 0, whose saved average is the initial weights).
            self.ema = Some(match self.ema.take() {
                Some(ema) if self.step > 1 => crate::ema::update(ema, &self.model, d),
                _ => self.model.valid(),
            });
        }
    }

    fn validate(&mut self) -> Option<f64> {
        let set = self.val_set.as_ref()?;
        let model = match &self.ema {
            Some(ema) => ema.clone(),
            None => self.model.valid(),
        };
        let v = self
            .family
            .validation_loss(&model, set, &self.config, &self.plain);
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
            next_lr: self.config.schedule.lr(self.step, total)
                * self.family.lr_factor(&self.config),
            last_loss: self.last_loss,
            val_loss: (self.val_step == Some(self.step))
                .then_some(self.val_loss)
                .flatten(),
            best: self.best,
            elapsed_seconds: self.elapsed(),
            params_hash,
            ema_params_hash: None,
            backend: self.config.train.backend.to_string(),
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
        // Before the first update of a session the average is the weights themselves.
        let ema = self
            .ema
            .clone()
            .or_else(|| (self.config.train.ema_decay > 0.0).then(|| self.model.valid()));
        let mut state = self.state(qean_models::params::params_hash(&params));
        state.ema_params_hash = ema
            .as_ref()
            .map(|m| qean_models::params::params_hash(&qean_models::params::named_parameters(m)));
        let config_text = self.config.to_toml().map_err(Error::msg)?;
        let family_state = self.family.checkpoint_state();
        qean_io::fsutil::atomic_dir(&dir, |tmp| {
            qean_checkpoint::weights::save_weights(&self.model, &tmp.join(checkpoint::MODEL_FILE))?;
            if let Some(ema) = &ema {
                qean_checkpoint::weights::save_weights(ema, &tmp.join(checkpoint::EMA_FILE))?;
            }
            if let Some(v) = &family_state {
                let p = tmp.join(qean_checkpoint::weights::FAMILY_STATE_FILE);
                let json = serde_json::to_string_pretty(v).expect("JSON value serialises");
                std::fs::write(&p, json).map_err(|e| Error::io(&p, e))?;
            }
            for (g, optim) in self.optims.iter().enumerate() {
                let opt_path = tmp.join(optimizer_file(g));
                optim.save(&opt_path).map_err(|e| {
                    Error::at(&opt_path, format!("cannot save optimiser state: {e}"))
                })?;
            }
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

/// Trains (or continues) a run of any model family: the run directory is locked, logs go to
/// `train.log`, and a fresh run that fails before its first checkpoint leaves nothing behind.
pub fn train_family<F: Family>(
    family: &mut F,
    config: RunConfig,
    opts: &TrainOptions,
) -> Result<TrainOutcome> {
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
        tracing::subscriber::with_default(subscriber, || train_locked(family, config, opts))
    })();
    if result.is_err() && created && run_dir::list_checkpoints(run_dir).is_ok_and(|c| c.is_empty())
    {
        let _ = std::fs::remove_dir_all(run_dir);
    }
    result
}

/// The run's dataset directory, made absolute so that the resolved config works from anywhere.
fn absolute_data_dir(config: &mut RunConfig) -> Result<PathBuf> {
    let dir = config.data.dir.clone().ok_or_else(|| {
        Error::msg("data.dir is not set: pass --data DIR (or --set data.dir=DIR)".to_string())
    })?;
    let dir = std::fs::canonicalize(&dir)
        .map_err(|_| Error::at(&dir, "dataset directory does not exist"))?;
    config.data.dir = Some(dir.clone());
    Ok(dir)
}

/// The training set and (when `data.val_split` names a non-empty split) the validation set.
fn load_sets<F: Family>(
    family: &F,
    ds: &Dataset,
    train_split: Split,
    config: &RunConfig,
) -> Result<(SequenceSet, Option<SequenceSet>)> {
    let train_set = family.load_set(ds, train_split, family.draw_spec(config), config)?;
    let Some(split) = config.data.val_split else {
        return Ok((train_set, None));
    };
    if ds.split(split).is_empty() {
        tracing::warn!("the {} split is empty: no validation", split.name());
        return Ok((train_set, None));
    }
    let val = family.load_set(ds, split, config.window_spec(), config)?;
    Ok((train_set, Some(val)))
}

fn train_locked<F: Family>(
    family: &mut F,
    mut config: RunConfig,
    opts: &TrainOptions,
) -> Result<TrainOutcome> {
    // Seeded draws from here to the last update: no other job of this process draws in between.
    let _rng = qean_models::backend::rng_guard();
    let run_dir = opts.run_dir.clone();
    run_dir::clean_temporaries(&run_dir)?;
    let resume = crate::resume::resume_point(&run_dir, &opts.start, &config)?;
    let data_dir = absolute_data_dir(&mut config)?;
    let ds = Dataset::open(&data_dir)?;
    let train_split = config.data.train_split;
    family.prepare(&mut config, &ds, train_split, resume.as_ref())?;
    let (train_set, val_set) = load_sets(family, &ds, train_split, &config)?;
    let mut s = Session::start(
        family,
        config,
        &run_dir,
        train_set,
        val_set,
        resume.as_ref(),
    )?;
    if s.step >= s.config.train.steps {
        let dir = checkpoint::resolve(&run_dir)?.dir;
        return Ok(outcome(&s, false, true, dir));
    }
    run_loop(&mut s, opts)
}

impl<'f, F: Family> Session<'f, F> {
    /// The session of a run: model, optimiser and window stream fresh, or exactly as `resume` left them;
    /// the resolved config written to `R/config.toml`.
    fn start(
        family: &'f F,
        config: RunConfig,
        run_dir: &Path,
        train_set: SequenceSet,
        val_set: Option<SequenceSet>,
        resume: Option<&Checkpoint>,
    ) -> Result<Self> {
        let run_dir = run_dir.to_path_buf();
        let plain = qean_models::backend::device(config.train.backend)
            .map_err(|e| Error::msg(e.to_string()))?;
        let device = plain.clone().autodiff();
        let total = config.train.steps;
        let seed = config.train.seed;

        // Model, optimiser and stream: fresh, or exactly as the checkpoint left them.
        device.seed(seed);
        let mut model = family.init(&config, &device)?;
        if let Some(ck) = resume {
            model = qean_checkpoint::weights::load_weights(
                model,
                &ck.dir.join(checkpoint::MODEL_FILE),
            )?;
        }
        // The average as saved; a fresh run's (or one whose checkpoint has none) starts at the weights
        // after the next update (built now, it would initialise the lazy parameters out of turn).
        let ema = match resume.map(|ck| ck.dir.join(checkpoint::EMA_FILE)) {
            Some(path) if config.train.ema_decay > 0.0 && path.is_file() => Some(
                qean_checkpoint::weights::load_weights(model.valid(), &path)?,
            ),
            _ => None,
        };
        // Parameter ids survive every update, so the groups are found once.
        let groups = family.param_groups(&model);
        let mut optims: Vec<ModuleOptimizer> =
            (0..groups.len().max(1)).map(|_| adam(&config)).collect();
        let (step, sampler, last_loss, best, elapsed_before) = match resume {
            None => (0, WindowSampler::new(seed, &train_set), None, None, 0.0),
            Some(ck) => {
                for (g, optim) in optims.iter_mut().enumerate() {
                    let opt_path = ck.dir.join(optimizer_file(g));
                    *optim = adam(&config).load(&opt_path).map_err(|e| {
                        Error::at(&opt_path, format!("cannot load optimiser state: {e}"))
                    })?;
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
            if resume.is_some() {
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
        Ok(Session {
            family,
            config,
            run_dir: run_dir.clone(),
            device,
            plain,
            model,
            ema,
            groups,
            optims,
            group_losses: Vec::new(),
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
        })
    }
}

fn outcome<F: Family>(
    s: &Session<F>,
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

/// One update: the family's loss and one Adam step, or one step per parameter group in order (returning
/// group 0's loss, or the first non-finite one).
fn update<F: Family>(s: &mut Session<F>, inputs: F::Inputs, lr: f64) -> (F::Model, f64) {
    let clip = s.config.optim.grad_clip_norm;
    if s.groups.is_empty() {
        let loss = s.family.loss(&s.model, inputs, &s.config);
        return apply_update(s.model.clone(), &mut s.optims[0], loss, lr, clip);
    }
    let mut model = s.model.clone();
    let mut values = Vec::with_capacity(s.groups.len());
    for (g, keep) in s.groups.iter().enumerate() {
        let loss = s.family.group_loss(&model, &inputs, g, &s.config);
        let (next, value) = apply_group_update(model, &mut s.optims[g], loss, keep, lr, clip);
        model = next;
        values.push(value);
        if !value.is_finite() {
            return (model, value);
        }
    }
    s.group_losses = values;
    (model, s.group_losses[0])
}

fn run_loop<F: Family>(s: &mut Session<F>, opts: &TrainOptions) -> Result<TrainOutcome> {
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
        let ctx = StepContext {
            config: &s.config,
            plain: &s.plain,
            rng_seed,
            step: s.step,
        };
        let inputs = s.family.inputs(drawn, &s.model, &s.device, &ctx);
        s.device.seed(rng_seed);
        let lr = s.config.schedule.lr(s.step, total) * s.family.lr_factor(&s.config);
        let (model, value) = update(s, inputs, lr);
        if !value.is_finite() {
            reporter.finish();
            return Err(s.diverged(format!("the loss of update {} is {value}", s.step + 1)));
        }
        s.model = s.family.after_update(model);
        s.step += 1;
        s.average();
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
            let groups = if s.group_losses.len() > 1 {
                let each: Vec<String> = s.group_losses.iter().map(|v| format!("{v:.4e}")).collect();
                format!(" (per optimiser group: {})", each.join(", "))
            } else {
                String::new()
            };
            tracing::info!(
                "step {} lr {lr:e} loss {value:.6e}{groups}{}",
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

#[cfg(test)]
mod tests {
    use super::*;
    use burn::nn::LinearConfig;
    use burn::tensor::TensorData;

    /// PyTorch's clip_grad_norm_: one factor for every gradient, from the norm over all of them.
    #[test]
    fn clipping_scales_all_gradients_by_the_global_norm() {
        let device = Device::flex().autodiff();
        device.seed(3);
        let model = LinearConfig::new(3, 2).init(&device);
        let x = Tensor::<2>::from_data(TensorData::new(vec![1.0f32, -2.0, 3.0], [1, 3]), &device);
        let loss = model.forward(x).sum().mul_scalar(5.0);
        let grads = GradientsParams::from_grads(loss.backward(), &model);
        let values = |g: &GradientsParams| {
            let w = g.get::<2>(model.weight.id).unwrap();
            let b = g.get::<1>(model.bias.as_ref().unwrap().id).unwrap();
            let mut v = w.into_data().try_to_vec::<f32>().unwrap();
            v.extend(b.into_data().try_to_vec::<f32>().unwrap());
            v
        };
        let before = values(&grads);
        let norm = before
            .iter()
            .map(|&g| (g as f64).powi(2))
            .sum::<f64>()
            .sqrt();
        // d(5·Σ(Wx + b))/dW = 5x per row, /db = 5: norm = 5·sqrt(2·14 + 2).
        assert!((norm - 5.0 * 30f64.sqrt()).abs() < 1e-4, "{norm}");
        let mut clipped = grads;
        let reported = clip_global_norm(&model, &mut clipped, 0.25);
        assert!((reported - norm).abs() < 1e-4);
        let after = values(&clipped);
        let factor = 0.25 / (norm + 1e-6);
        for (a, b) in after.iter().zip(&before) {
            assert!((*a as f64 - *b as f64 * factor).abs() < 1e-6, "{a} vs {b}");
        }
        // Below the limit nothing changes.
        let mut same = GradientsParams::from_grads(
            model
                .forward(Tensor::<2>::from_data(
                    TensorData::new(vec![1.0f32, -2.0, 3.0], [1, 3]),
                    &device,
                ))
                .sum()
                .mul_scalar(5.0)
                .backward(),
            &model,
        );
        clip_global_norm(&model, &mut same, 1e3);
        assert_eq!(values(&same), before);
    }
}
