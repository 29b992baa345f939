//! Running a sweep planned by [`qean_config::sweep::plan`]: every run trained in order (finished
//! runs skipped, interrupted ones resumed), then `S-runs/summary.md` and `summary.csv`.

use std::path::Path;

use qean_io::error::{Error, Result};

pub use qean_config::sweep::{plan, PlannedRun, SweepConfig, Variant};

use crate::trainer::{Start, TrainOptions};

/// How a sweep's run ended this time.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RunStatus {
    Finished,
    /// It had reached its step count in an earlier sweep.
    FinishedEarlier,
    /// Stopped (Ctrl-C) with a checkpoint; the next sweep resumes it.
    Interrupted,
}

impl std::fmt::Display for RunStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            RunStatus::Finished => "finished",
            RunStatus::FinishedEarlier => "finished earlier",
            RunStatus::Interrupted => "interrupted",
        })
    }
}

/// One row of the summary.
#[derive(Debug, Clone)]
pub struct RunResult {
    pub run: PlannedRun,
    pub steps: u64,
    pub train_loss: Option<f64>,
    pub val_loss: Option<f64>,
    pub seconds: f64,
    pub status: RunStatus,
    /// Metric name → value (when evaluation ran).
    pub metrics: Vec<(String, f64)>,
}

/// Per-run evaluation hook: run directory → metrics (name, value).
pub type Evaluator<'a> = dyn Fn(&Path) -> Result<Vec<(String, f64)>> + 'a;

/// Trains every planned run in order and writes the summary after each.
pub fn run(
    out_dir: &Path,
    runs: &[PlannedRun],
    options: &TrainOptions,
    evaluator: Option<&Evaluator>,
) -> Result<Vec<RunResult>> {
    std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
    let mut results = Vec::new();
    for (k, run) in runs.iter().enumerate() {
        let opts = TrainOptions {
            run_dir: run.run_dir.clone(),
            start: Start::Auto,
            label: format!("[{}/{}] {}", k + 1, runs.len(), run.name),
            ..options.clone()
        };
        let outcome = crate::registry::train(run.config.clone(), &opts)?;
        let status = if outcome.interrupted {
            RunStatus::Interrupted
        } else if outcome.already_done {
            RunStatus::FinishedEarlier
        } else {
            RunStatus::Finished
        };
        let rows = crate::metrics_log::read(&run.run_dir.join("metrics.csv")).unwrap_or_default();
        let train_loss = rows.iter().rev().find_map(|r| r.loss);
        let val_loss = rows.iter().rev().find_map(|r| r.val_loss);
        let metrics = match (evaluator, outcome.interrupted) {
            (Some(eval), false) => eval(&run.run_dir)?,
            _ => vec![],
        };
        results.push(RunResult {
            run: run.clone(),
            steps: outcome.step,
            train_loss,
            val_loss,
            seconds: outcome.seconds,
            status,
            metrics,
        });
        write_summary(out_dir, &results)?;
        if outcome.interrupted {
            break;
        }
    }
    Ok(results)
}

fn fmt_opt(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.4e}")).unwrap_or_else(|| "-".into())
}

/// Writes `summary.csv` and `summary.md` (atomically).
pub fn write_summary(out_dir: &Path, results: &[RunResult]) -> Result<()> {
    let metric_names: Vec<String> = {
        let mut names: Vec<String> = Vec::new();
        for r in results {
            for (n, _) in &r.metrics {
                if !names.contains(n) {
                    names.push(n.clone());
                }
            }
        }
        names
    };
    let grid_keys: Vec<String> = {
        let mut keys: Vec<String> = Vec::new();
        for r in results {
            for (k, _) in &r.run.grid {
                if !keys.contains(k) {
                    keys.push(k.clone());
                }
            }
        }
        keys
    };
    let mut csv = String::from("run,variant,seed");
    let mut md_head = String::from("| run | variant | seed");
    for k in &grid_keys {
        csv.push_str(&format!(",{k}"));
        md_head.push_str(&format!(" | {k}"));
    }
    csv.push_str(",steps,train_loss,val_loss,seconds,status");
    md_head.push_str(" | steps | train loss | val loss | seconds | status");
    for m in &metric_names {
        csv.push_str(&format!(",{m}"));
        md_head.push_str(&format!(" | {m}"));
    }
    csv.push('\n');
    md_head.push_str(" |\n");
    let columns = md_head.matches(" | ").count() + 1;
    let mut md = String::from("# Sweep summary\n\n");
    md.push_str(&md_head);
    md.push_str(&"|---".repeat(columns));
    md.push_str("|\n");
    for r in results {
        let grid_value = |k: &String| {
            r.run
                .grid
                .iter()
                .find(|(g, _)| g == k)
                .map(|(_, v)| v.clone())
                .unwrap_or_default()
        };
        csv.push_str(&format!("{},{},{}", r.run.name, r.run.variant, r.run.seed));
        md.push_str(&format!(
            "| {} | {} | {}",
            r.run.name, r.run.variant, r.run.seed
        ));
        for k in &grid_keys {
            csv.push_str(&format!(",{}", grid_value(k)));
            md.push_str(&format!(" | {}", grid_value(k)));
        }
        let opt_csv = |x: Option<f64>| x.map(|v| format!("{v:e}")).unwrap_or_default();
        csv.push_str(&format!(
            ",{},{},{},{:.1},{}",
            r.steps,
            opt_csv(r.train_loss),
            opt_csv(r.val_loss),
            r.seconds,
            r.status
        ));
        md.push_str(&format!(
            " | {} | {} | {} | {:.1} | {}",
            r.steps,
            fmt_opt(r.train_loss),
            fmt_opt(r.val_loss),
            r.seconds,
            r.status
        ));
        for m in &metric_names {
            let v = r.metrics.iter().find(|(n, _)| n == m).map(|(_, v)| *v);
            csv.push_str(&format!(",{}", opt_csv(v)));
            md.push_str(&format!(
                " | {}",
                v.map(|v| format!("{v:.4}")).unwrap_or_else(|| "-".into())
            ));
        }
        csv.push('\n');
        md.push_str(" |\n");
    }
    qean_io::fsutil::atomic_write(&out_dir.join("summary.csv"), csv.as_bytes())?;
    qean_io::fsutil::atomic_write(&out_dir.join("summary.md"), md.as_bytes())?;
    Ok(())
}
