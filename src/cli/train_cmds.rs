//! `qean train`, `qean sweep`, `qean export`, and `qean inspect` of runs and checkpoints.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use clap::Args;
use qean_checkpoint::checkpoint;
use qean_checkpoint::ProgressMode;
use qean_config::run::string_override;
use qean_pipeline::evaluate::SweepScoring;
use qean_train::{sweep, TrainOptions};

/// Train a model from a TOML run config (SPEC §5): FACT and QEAN (random 240-frame windows of the
/// train split, L2 loss on the first 20 output tokens), TSMT, the in-betweeners, the motion
/// VQ-VAE, the GPT over its tokens, genre control over a GPT and the genre classifier (the
/// config's model.arch), each with Adam and the configured step schedule (the genre stage: one
/// Adam per optimiser group). Writes R/config.toml (resolved), R/metrics.csv (step, lr, loss,
/// val_loss, seconds), R/train.log, R/loss.png and R/checkpoints/step-N/ (model, optimiser,
/// trainer state, and the weights' moving average with train.ema_decay > 0; the last
/// train.keep_last plus the best by validation loss). Ctrl-C writes a checkpoint and stops;
/// `--resume R` continues exactly.
///
/// Examples:
///   qean train --config configs/tiny/full.toml --data synth --run-dir runs/full
///   qean train --resume runs/full --set train.steps=4000
///   qean train --config configs/control/vqvae_tiny.toml --data synth --run-dir runs/vq
///   qean train --config configs/control/gpt_tiny.toml --data synth --set gpt.vqvae_run=runs/vq
#[derive(Args, Debug)]
#[command(verbatim_doc_comment)]
#[command(about = "Train a model of any family from a TOML run config, or resume a run")]
pub struct TrainArgs {
    /// Run config (TOML; see configs/README.md). Optional with --resume (R/config.toml is used).
    #[arg(long, required_unless_present = "resume")]
    pub config: Option<PathBuf>,
    /// Run directory (default: runs/<config name>).
    #[arg(long)]
    pub run_dir: Option<PathBuf>,
    /// Continue a run: a run directory (its newest checkpoint) or R/checkpoints/step-N.
    #[arg(long)]
    pub resume: Option<PathBuf>,
    /// Dataset directory (AIST++, FineDance or a folder of dances: the layout is detected); the same as
    /// --set data.dir=DIR.
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Backend: flex (CPU, default), ndarray (CPU, to cross-check flex), wgpu (GPU); the last two
    /// need a build with --features ndarray or --features wgpu.
    #[arg(long, value_enum)]
    pub backend: Option<qean_models::backend::Backend>,
    /// Override any config field: --set train.steps=100 --set model.dropout=0.2 (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Plain progress lines instead of a bar.
    #[arg(long)]
    pub plain: bool,
}

/// A stop flag set by Ctrl-C (SIGINT) or SIGTERM: the trainer checkpoints and stops.
pub(crate) fn stop_flag() -> Arc<AtomicBool> {
    let flag = Arc::new(AtomicBool::new(false));
    let f = flag.clone();
    let installed = ctrlc::set_handler(move || {
        if f.swap(true, Ordering::SeqCst) {
            // Second Ctrl-C: give up at once (the newest checkpoint stays valid).
            eprintln!("interrupted again: exiting without a checkpoint");
            std::process::exit(130);
        }
        eprintln!("interrupt: finishing the current update and writing a checkpoint (Ctrl-C again to abort)");
    });
    if let Err(e) = installed {
        tracing::warn!("Ctrl-C handler not installed: {e}");
    }
    flag
}

fn overrides(
    set: &[String],
    data: &Option<PathBuf>,
    backend: &Option<qean_models::backend::Backend>,
) -> Vec<String> {
    let mut o = set.to_vec();
    if let Some(d) = data {
        o.push(string_override("data.dir", &d.to_string_lossy()));
    }
    if let Some(b) = backend {
        o.push(string_override("train.backend", b.name()));
    }
    o
}

fn progress(plain: bool) -> ProgressMode {
    if plain {
        ProgressMode::Lines
    } else {
        ProgressMode::Auto
    }
}

pub fn train(a: TrainArgs) -> anyhow::Result<i32> {
    let overrides = overrides(&a.set, &a.data, &a.backend);
    let plan = qean_train::resume::plan(&qean_train::resume::RunRequest {
        config: a.config.clone(),
        resume: a.resume.clone(),
        run_dir: a.run_dir.clone(),
        overrides,
    })?;
    let (config, run_dir, start) = (plan.config, plan.run_dir, plan.start);
    let opts = TrainOptions {
        run_dir: run_dir.clone(),
        start,
        progress: progress(a.plain),
        stop: stop_flag(),
        label: String::new(),
    };
    let out = qean_train::train(config, &opts)?;
    let best = out
        .best
        .map(|b| format!(", best val_loss {:.4e} at step {}", b.val_loss, b.step))
        .unwrap_or_default();
    if out.interrupted {
        println!(
            "interrupted at step {}/{}: checkpoint {}\ncontinue with: qean train --resume {}",
            out.step,
            out.total_steps,
            out.checkpoint.display(),
            run_dir.display()
        );
        return Ok(130);
    }
    if out.already_done {
        println!(
            "{}: already trained to step {} (raise train.steps with --set to continue)",
            run_dir.display(),
            out.step
        );
        return Ok(0);
    }
    println!(
        "trained {} steps in {:.1} s: loss {}, val_loss {}{best}\ncheckpoint: {}\nmetrics: {}  plot: {}",
        out.step,
        out.seconds,
        out.last_loss.map(|v| format!("{v:.4e}")).unwrap_or_else(|| "-".into()),
        out.val_loss.map(|v| format!("{v:.4e}")).unwrap_or_else(|| "-".into()),
        out.checkpoint.display(),
        run_dir.join("metrics.csv").display(),
        run_dir.join("loss.png").display()
    );
    Ok(0)
}

/// Run a sweep: every variant × seed × grid combination of a sweep file is one training run in
/// S-runs/<name>/ (finished runs are skipped, interrupted ones resumed), then S-runs/summary.md,
/// summary.csv and summary.json: every run (variant, seed, steps, final train/val loss, time,
/// metrics when evaluated), each variant over its seeds as mean ± 95 % confidence interval
/// (Student's t), and, with `baseline = "NAME"` in the sweep file, each variant's paired
/// differences against it (seed by seed; * where the interval excludes 0). A variant with
/// `evaluate = false` is a stage others build on; in a string value `{seed}` is the run's seed
/// and `{runs}` the output directory (e.g. "gpt.vqvae_run" = "{runs}/vqvae-seed{seed}"). With
/// `table = "table1"` (or "table2") the sweep is also laid out as that QEAN paper table:
/// S-runs/table1.md, table1.json and the chart table1.png.
///
/// Examples:
///   qean sweep --config configs/sweeps/table1-tiny.toml --data qean-demo/data
///   qean sweep --config configs/sweeps/tiny-ablation.toml --data synth --seeds 0,1
#[derive(Args, Debug)]
#[command(verbatim_doc_comment)]
#[command(about = "Run a sweep of training runs (variants × seeds × grid) and summarise it")]
pub struct SweepArgs {
    /// Sweep file (see configs/sweeps/).
    #[arg(long)]
    pub config: PathBuf,
    /// Output directory (default: S-runs beside the sweep file).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Dataset directory for every run (same as --set data.dir=DIR).
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Backend for every run.
    #[arg(long, value_enum)]
    pub backend: Option<qean_models::backend::Backend>,
    /// Override a field in every run (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Train only these variants (comma-separated names; e.g. to split a sweep over machines or
    /// cores: the summary then lists these runs only).
    #[arg(long, value_delimiter = ',')]
    pub only: Vec<String>,
    /// Train these seeds instead of the sweep file's `seeds` (comma-separated, e.g. 0,1,2).
    #[arg(long, value_delimiter = ',')]
    pub seeds: Vec<u64>,
    /// Generated frames per sequence when evaluating, instead of the sweep file's `eval_frames`.
    #[arg(long)]
    pub eval_frames: Option<usize>,
    /// Score every evaluated run under a named protocol (bailando, edge, lodge: docs/protocols.md),
    /// instead of the sweep file's `protocol_preset`; the summary and paper table name it.
    #[arg(long, value_enum)]
    pub protocol_preset: Option<qean_eval::preset::ProtocolPreset>,
    /// Print the planned runs and exit.
    #[arg(long)]
    pub dry_run: bool,
    /// Plain progress lines instead of bars.
    #[arg(long)]
    pub plain: bool,
}

pub fn sweep(a: SweepArgs) -> anyhow::Result<i32> {
    let overrides = overrides(&a.set, &a.data, &a.backend);
    let seeds = (!a.seeds.is_empty()).then_some(a.seeds.as_slice());
    let (config, out_dir, mut runs) =
        sweep::plan_seeds(&a.config, a.out.as_deref(), &overrides, seeds)?;
    sweep::keep_only(&mut runs, &config, &a.only, &a.config)?;
    let protocol = match a.protocol_preset {
        Some(p) => Some(p),
        None => sweep::protocol_preset(&config, &a.config)?,
    };
    println!("{} runs in {}:", runs.len(), out_dir.display());
    for r in &runs {
        println!("  {}  ({})", r.name, r.config.summary());
    }
    if a.dry_run {
        return Ok(0);
    }
    let options = TrainOptions {
        progress: progress(a.plain),
        stop: stop_flag(),
        ..TrainOptions::new(&out_dir)
    };
    let scoring = SweepScoring::new(
        a.eval_frames
            .or(config.eval_frames.filter(|_| protocol.is_none())),
        protocol,
    );
    let evaluator = |run_dir: &Path| scoring.metrics(run_dir);
    let evaluator = sweep::SweepEvaluator {
        key: scoring.key(),
        eval: &evaluator,
    };
    let evaluator_ref = runs.iter().any(|r| r.evaluate).then_some(&evaluator);
    let results = sweep::run(
        &out_dir,
        &runs,
        &options,
        evaluator_ref,
        &sweep::SummaryLayout::of(&config, protocol),
    )?;
    if results
        .iter()
        .any(|r| r.status == sweep::RunStatus::Interrupted)
    {
        println!("interrupted: run the same command again to continue");
        return Ok(130);
    }
    let md = std::fs::read_to_string(out_dir.join("summary.md"))?;
    print!("{md}");
    println!("summary: {}", out_dir.join("summary.csv").display());
    print_table_paths(&out_dir, config.table);
    Ok(0)
}

/// Where a sweep's paper table and its chart are, if it has one.
fn print_table_paths(dir: &Path, table: Option<sweep::PaperTable>) {
    if let Some(t) = table {
        let path = |ext: &str| {
            dir.join(format!("{}.{ext}", t.name()))
                .display()
                .to_string()
        };
        println!("{}: {} (chart {})", t.name(), path("md"), path("png"));
    }
}

/// Rebuild a sweep's summary, paper table and chart from its finished runs, without training or
/// evaluating: reads each run's R/sweep.json (its variant, seed and metrics, written by `qean
/// sweep`), R/metrics.csv and newest checkpoint, and writes S-runs/summary.{md,csv,json} and, for
/// a sweep with a `table`, tableN.{md,json,png}. Use it after copying runs from several machines
/// into one directory (`qean sweep --only` splits a sweep), or to lay the same runs out as
/// another table.
///
/// Examples:
///   qean report configs/sweeps/table1-tiny-runs
///   qean report ablation-runs --table table2 --baseline baseline
#[derive(Args, Debug)]
#[command(verbatim_doc_comment)]
#[command(about = "Rebuild a sweep's summary, tables and charts from its finished runs")]
pub struct ReportArgs {
    /// The sweep's output directory (S-runs).
    pub dir: PathBuf,
    /// Lay the runs out as this QEAN paper table (default: the sweep file's `table`).
    #[arg(long, value_enum)]
    pub table: Option<sweep::PaperTable>,
    /// Paired differences against this variant (default: the sweep file's `baseline`).
    #[arg(long)]
    pub baseline: Option<String>,
}

pub fn report(a: ReportArgs) -> anyhow::Result<i32> {
    let (layout, runs) = sweep::report(&a.dir, a.table, a.baseline.clone())?;
    print!("{}", std::fs::read_to_string(a.dir.join("summary.md"))?);
    println!(
        "{runs} runs; summary: {}",
        a.dir.join("summary.md").display()
    );
    print_table_paths(&a.dir, layout.table);
    Ok(0)
}

/// Export a checkpoint's weights as one safetensors file: every parameter as f32 under a stable
/// dotted name (docs/weights.md lists them with shapes, layouts and roles; Burn's Linear weight is
/// [in, out]). The header holds the model config, the step and the params_hash.
#[derive(Args, Debug)]
#[command(about = "Export a checkpoint's weights as one safetensors file")]
pub struct ExportArgs {
    /// A run directory (its newest checkpoint) or R/checkpoints/step-N.
    pub checkpoint: PathBuf,
    /// Output file (.safetensors).
    #[arg(long)]
    pub out: PathBuf,
}

pub fn export(a: ExportArgs) -> anyhow::Result<i32> {
    let ck = checkpoint::resolve(&a.checkpoint)?;
    let s = qean_train::export::export_safetensors(&ck, &a.out)?;
    println!(
        "{}: {} tensors, {} values (step {}), params_hash: {}",
        a.out.display(),
        s.tensors,
        s.values,
        ck.state.step,
        s.params_hash
    );
    Ok(0)
}

/// `qean inspect` of a checkpoint directory ([`qean_train::inspect::checkpoint`]).
pub fn inspect_checkpoint(dir: &Path) -> anyhow::Result<()> {
    print!("{}", qean_train::inspect::checkpoint(dir)?);
    Ok(())
}

/// `qean inspect` of a run directory ([`qean_train::inspect::run`]).
pub fn inspect_run(dir: &Path) -> anyhow::Result<()> {
    print!("{}", qean_train::inspect::run(dir)?);
    Ok(())
}
