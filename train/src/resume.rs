//! Where a run starts: what `qean train --config C | --resume R [--run-dir D]` means ([`plan`]), and the
//! checkpoint a `train` call continues from, checked against the config ([`resume_point`]).

use std::path::{Path, PathBuf};

use qean_io::error::{Error, Result};

use qean_checkpoint::checkpoint::{self, Checkpoint};
use qean_checkpoint::run_dir;
use qean_config::run::RunConfig;

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

/// What the user asked for.
#[derive(Debug, Clone, Default)]
pub struct RunRequest {
    /// The run config (optional with `resume`: the run's own config.toml).
    pub config: Option<PathBuf>,
    /// A run directory or checkpoint to continue.
    pub resume: Option<PathBuf>,
    /// Where the run lives (default `runs/<config stem>`; with `resume`, must be the checkpoint's run).
    pub run_dir: Option<PathBuf>,
    /// `--set key=value` overrides, applied to the config.
    pub overrides: Vec<String>,
}

/// A run ready to train: its config, its directory and where it starts.
#[derive(Debug, Clone)]
pub struct RunPlan {
    pub config: RunConfig,
    pub run_dir: PathBuf,
    pub start: Start,
}

fn load(path: &Path, overrides: &[String]) -> Result<RunConfig> {
    RunConfig::load(path, overrides).map_err(|e| Error::msg(e.to_string()))
}

/// A run directory that has its resolved config.toml but no checkpoint yet.
fn fresh_run_without_checkpoint(path: &Path) -> bool {
    path.join("config.toml").is_file()
        && run_dir::list_checkpoints(path).is_ok_and(|c| c.is_empty())
}

/// Resolves a request: a new run from a config, or the continuation of a checkpoint (a run stopped before
/// its first checkpoint starts again from its own config).
pub fn plan(req: &RunRequest) -> Result<RunPlan> {
    let Some(path) = &req.resume else {
        let config_path = req
            .config
            .clone()
            .ok_or_else(|| Error::msg("give --config FILE or --resume RUN"))?;
        let config = load(&config_path, &req.overrides)?;
        let run_dir = req.run_dir.clone().unwrap_or_else(|| {
            let stem = config_path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "run".into());
            Path::new("runs").join(stem)
        });
        return Ok(RunPlan {
            config,
            run_dir,
            start: Start::Fresh,
        });
    };
    if fresh_run_without_checkpoint(path) {
        let config_path = req
            .config
            .clone()
            .unwrap_or_else(|| path.join("config.toml"));
        tracing::warn!(
            "{}: no checkpoint yet: training again from step 0",
            path.display()
        );
        return Ok(RunPlan {
            config: load(&config_path, &req.overrides)?,
            run_dir: path.clone(),
            start: Start::Auto,
        });
    }
    let ck = checkpoint::resolve(path)?;
    let run_dir = ck
        .run_dir()
        .ok_or_else(|| Error::at(&ck.dir, "not inside a run directory (R/checkpoints/step-N)"))?;
    if let Some(r) = &req.run_dir {
        if std::fs::canonicalize(r).ok() != std::fs::canonicalize(&run_dir).ok() {
            return Err(Error::msg(format!(
                "--run-dir {} does not hold the checkpoint {} (omit --run-dir with --resume)",
                r.display(),
                ck.dir.display()
            )));
        }
    }
    let config_path = req
        .config
        .clone()
        .unwrap_or_else(|| run_dir.join("config.toml"));
    Ok(RunPlan {
        config: load(&config_path, &req.overrides)?,
        run_dir,
        start: Start::From(ck.dir),
    })
}

/// The checkpoint a `train` call continues from (None: a fresh start), checked against `config`: same
/// model, not past `train.steps`. Resuming an older checkpoint discards the later ones (their history is
/// being rewritten).
pub fn resume_point(
    run_dir: &Path,
    start: &Start,
    config: &RunConfig,
) -> Result<Option<Checkpoint>> {
    let existing = run_dir::list_checkpoints(run_dir)?;
    let ck = match start {
        Start::Fresh => {
            if let Some((step, _)) = existing.last() {
                return Err(Error::at(
                    run_dir,
                    format!("already holds a run (checkpoint step-{step}): continue it with --resume, or pick another --run-dir"),
                ));
            }
            return Ok(None);
        }
        Start::From(dir) => Checkpoint::read(dir)?,
        Start::Auto if existing.is_empty() => return Ok(None),
        Start::Auto => checkpoint::resolve(run_dir)?,
    };
    ck.check_config(config)?;
    if ck.state.step > config.train.steps {
        return Err(Error::at(
            &ck.dir,
            format!(
                "checkpoint is at step {} but train.steps is {}",
                ck.state.step, config.train.steps
            ),
        ));
    }
    if ck.state.sampler.seed != config.train.seed {
        return Err(Error::at(
            &ck.dir,
            format!(
                "checkpoint was trained with train.seed = {}, the config says {}",
                ck.state.sampler.seed, config.train.seed
            ),
        ));
    }
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
    Ok(Some(ck))
}
