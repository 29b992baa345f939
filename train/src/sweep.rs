//! Running a sweep planned by [`qean_config::sweep::plan`]: every run trained in order (finished
//! runs skipped, interrupted ones resumed), then `S-runs/summary.md`, `summary.csv` and `summary.json`: every
//! run, then each variant over its seeds (mean ± 95 % confidence interval, Student's t) and its paired
//! differences against the sweep's baseline variant (the same seeds).

use std::path::Path;

use qean_eval::preset::ProtocolPreset;
use qean_eval::stats::{paired_difference, Interval};
use qean_io::error::{Error, Result};

pub use qean_config::sweep::{plan, plan_seeds, PaperTable, PlannedRun, SweepConfig, Variant};

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

/// Keeps the runs of the variants in `only` (all when it is empty); a name the sweep file `file` does not
/// have is an error.
pub fn keep_only(
    runs: &mut Vec<PlannedRun>,
    config: &SweepConfig,
    only: &[String],
    file: &Path,
) -> Result<()> {
    if let Some(unknown) = only
        .iter()
        .find(|v| !config.variant.iter().any(|c| &c.name == *v))
    {
        return Err(Error::at(
            file,
            format!("--only names variant `{unknown}`, which the sweep does not have"),
        ));
    }
    if !only.is_empty() {
        runs.retain(|r| only.contains(&r.variant));
    }
    Ok(())
}

/// The sweep file's `protocol_preset` (`file` names it in the error): a name `qean eval --protocol-preset`
/// takes, or an error listing them.
pub fn protocol_preset(config: &SweepConfig, file: &Path) -> Result<Option<ProtocolPreset>> {
    config
        .protocol_preset
        .as_deref()
        .map(|name| {
            name.parse::<ProtocolPreset>()
                .map_err(|e| Error::at(file, format!("protocol_preset: {e}")))
        })
        .transpose()
}

/// Per-run evaluation hook: run directory → metrics (name, value).
pub type Evaluator<'a> = dyn Fn(&Path) -> Result<Vec<(String, f64)>> + 'a;

/// How the summary is laid out beyond its per-run table.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct SummaryLayout {
    /// Paired differences against this variant.
    pub baseline: Option<String>,
    /// Also a QEAN paper table (`table1.md`/`.json`, `table2.…`).
    pub table: Option<PaperTable>,
    /// The named protocol the runs were scored under (`None`: our defaults, Bailando's settings).
    #[serde(default)]
    pub protocol: Option<ProtocolPreset>,
}

impl SummaryLayout {
    /// The sweep file's choices, scored under `protocol` ([`protocol_preset`]).
    pub fn of(config: &SweepConfig, protocol: Option<ProtocolPreset>) -> Self {
        SummaryLayout {
            baseline: config.baseline.clone(),
            table: config.table,
            protocol,
        }
    }
}

/// Per-run evaluation hook: run directory → metrics (name, value), and a key naming what it computes
/// (e.g. the frames scored): a run's recorded metrics are reused only under the same key.
pub struct SweepEvaluator<'a> {
    pub key: String,
    pub eval: &'a Evaluator<'a>,
}

/// What a sweep records in each run directory (`R/sweep.json`): the run's place in the sweep and its
/// metrics, so that a rerun does not evaluate it again and `qean report` rebuilds the summary.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RunRecord {
    /// Position in the sweep's plan.
    pub index: usize,
    pub name: String,
    pub variant: String,
    pub seed: u64,
    pub grid: Vec<(String, String)>,
    pub evaluate: bool,
    /// The checkpoint step the metrics are of.
    pub step: u64,
    /// The hash of the weights scored (the sampled ones; empty when not evaluated).
    #[serde(default)]
    pub weights: String,
    /// The evaluator's key and the data scored (empty when not evaluated).
    pub eval_key: String,
    /// Metric name → value (`None`: not finite).
    pub metrics: Vec<(String, Option<f64>)>,
}

/// A run's metrics (name, value).
pub type Metrics = Vec<(String, f64)>;

/// A run's metrics: those recorded for the same step, weights, data and evaluator, else computed now;
/// with the key and weights hash to record.
fn evaluate_or_reuse(
    run: &PlannedRun,
    step: u64,
    e: &SweepEvaluator,
) -> Result<(Metrics, String, String)> {
    let weights = qean_checkpoint::checkpoint::resolve(&run.run_dir)?
        .sampled_hash()
        .to_string();
    let data = run.config.data.dir.as_deref().unwrap_or(Path::new("-"));
    let key = format!("{}; data {}", e.key, data.display());
    let recorded = read_record(&run.run_dir)
        .filter(|r| r.evaluate && r.step == step && r.eval_key == key && r.weights == weights);
    let metrics = match recorded {
        Some(r) => finite(&r.metrics),
        None => (e.eval)(&run.run_dir)?,
    };
    Ok((metrics, key, weights))
}

/// The finite values of recorded metrics.
fn finite(metrics: &[(String, Option<f64>)]) -> Vec<(String, f64)> {
    metrics
        .iter()
        .filter_map(|(n, v)| v.map(|v| (n.clone(), v)))
        .collect()
}

/// The record's file name in a run directory.
pub const RECORD_FILE: &str = "sweep.json";
/// The summary layout's file in the sweep's output directory.
pub const LAYOUT_FILE: &str = "sweep-layout.json";

fn read_record(run_dir: &Path) -> Option<RunRecord> {
    let text = std::fs::read_to_string(run_dir.join(RECORD_FILE)).ok()?;
    serde_json::from_str(&text).ok()
}

fn write_json<T: serde::Serialize>(path: &Path, value: &T) -> Result<()> {
    let json = serde_json::to_string_pretty(value).expect("records serialise");
    qean_io::fsutil::atomic_write(path, json.as_bytes())
}

/// Trains every planned run in order (evaluating those with `evaluate`, or reusing the metrics recorded
/// for the same checkpoint and evaluator) and writes the summary after each, laid out as `layout` says.
pub fn run(
    out_dir: &Path,
    runs: &[PlannedRun],
    options: &TrainOptions,
    evaluator: Option<&SweepEvaluator>,
    layout: &SummaryLayout,
) -> Result<Vec<RunResult>> {
    std::fs::create_dir_all(out_dir).map_err(|e| Error::io(out_dir, e))?;
    write_json(&out_dir.join(LAYOUT_FILE), layout)?;
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
        let (metrics, eval_key, weights) =
            match evaluator.filter(|_| run.evaluate && !outcome.interrupted) {
                Some(e) => evaluate_or_reuse(run, outcome.step, e)?,
                None => (Vec::new(), String::new(), String::new()),
            };
        if !outcome.interrupted {
            let record = RunRecord {
                index: run.index,
                name: run.name.clone(),
                variant: run.variant.clone(),
                seed: run.seed,
                grid: run.grid.clone(),
                evaluate: !eval_key.is_empty(),
                step: outcome.step,
                weights,
                eval_key,
                metrics: metrics
                    .iter()
                    .map(|(n, v)| (n.clone(), v.is_finite().then_some(*v)))
                    .collect(),
            };
            write_json(&run.run_dir.join(RECORD_FILE), &record)?;
        }
        results.push(RunResult {
            run: run.clone(),
            steps: outcome.step,
            train_loss,
            val_loss,
            seconds: outcome.seconds,
            status,
            metrics,
        });
        write_summary(out_dir, &results, layout)?;
        if outcome.interrupted {
            break;
        }
    }
    Ok(results)
}

/// The layout a sweep saved in its output directory (the default when it saved none).
pub fn saved_layout(out_dir: &Path) -> Result<SummaryLayout> {
    let path = out_dir.join(LAYOUT_FILE);
    match std::fs::read_to_string(&path) {
        Ok(text) => serde_json::from_str(&text)
            .map_err(|e| Error::at(&path, format!("malformed sweep layout: {e}"))),
        Err(_) => Ok(SummaryLayout::default()),
    }
}

/// `qean report SWEEP_DIR`: the summary, paper table and chart rebuilt from the finished runs ([`collect`]),
/// laid out as the sweep saved it with `table` and `baseline` over it; returns the layout used and the
/// number of runs. Nothing is written when the baseline names no run here.
pub fn report(
    out_dir: &Path,
    table: Option<PaperTable>,
    baseline: Option<String>,
) -> Result<(SummaryLayout, usize)> {
    let saved = saved_layout(out_dir)?;
    let layout = SummaryLayout {
        baseline: baseline.or(saved.baseline),
        table: table.or(saved.table),
        protocol: saved.protocol,
    };
    let results = collect(out_dir)?;
    if let Some(b) = &layout.baseline {
        if !results.iter().any(|r| &r.run.variant == b) {
            return Err(Error::at(
                out_dir,
                format!("baseline `{b}`: no run of that variant here"),
            ));
        }
    }
    write_summary(out_dir, &results, &layout)?;
    Ok((layout, results.len()))
}

/// The finished runs of a sweep's output directory, rebuilt from their records
/// (`R/sweep.json`, `R/metrics.csv`, the newest checkpoint) without training or evaluating, in the
/// sweep's order ([`write_summary`] then lays them out).
pub fn collect(out_dir: &Path) -> Result<Vec<RunResult>> {
    let entries = std::fs::read_dir(out_dir).map_err(|e| Error::io(out_dir, e))?;
    let mut records: Vec<(RunRecord, std::path::PathBuf)> = Vec::new();
    for entry in entries {
        let dir = entry.map_err(|e| Error::io(out_dir, e))?.path();
        if !dir.join(RECORD_FILE).is_file() {
            continue;
        }
        let path = dir.join(RECORD_FILE);
        let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
        let record: RunRecord = serde_json::from_str(&text)
            .map_err(|e| Error::at(&path, format!("malformed sweep record: {e}")))?;
        records.push((record, dir));
    }
    if records.is_empty() {
        return Err(Error::at(
            out_dir,
            "no finished sweep runs here (no */sweep.json): run `qean sweep` first",
        ));
    }
    records.sort_by(|(a, da), (b, db)| (a.index, da).cmp(&(b.index, db)));
    // One summary, one way of scoring: runs scored under two protocols (or lengths) are not mixed.
    let mut scored = records
        .iter()
        .filter(|(r, _)| r.evaluate && !r.eval_key.is_empty());
    if let Some((first, a)) = scored.next() {
        if let Some((other, b)) = scored.find(|(r, _)| r.eval_key != first.eval_key) {
            return Err(Error::at(
                out_dir,
                format!(
                    "runs scored differently: {} ({}) and {} ({}); score them again the same way (qean sweep with one --eval-frames and --protocol-preset)",
                    a.display(),
                    first.eval_key,
                    b.display(),
                    other.eval_key
                ),
            ));
        }
    }
    let mut results = Vec::new();
    for (r, dir) in records {
        let rows = crate::metrics_log::read(&dir.join("metrics.csv")).unwrap_or_default();
        let ck = qean_checkpoint::checkpoint::resolve(&dir)?;
        if r.step != ck.state.step {
            tracing::warn!(
                "{}: its record is of step {}, its newest checkpoint is step {}: left out (run the sweep again)",
                dir.display(),
                r.step,
                ck.state.step
            );
            continue;
        }
        results.push(RunResult {
            run: PlannedRun {
                name: r.name,
                variant: r.variant,
                seed: r.seed,
                grid: r.grid,
                config: ck.config.clone(),
                run_dir: dir,
                evaluate: r.evaluate,
                index: r.index,
            },
            steps: ck.state.step,
            train_loss: rows.iter().rev().find_map(|x| x.loss),
            val_loss: rows.iter().rev().find_map(|x| x.val_loss),
            seconds: ck.state.elapsed_seconds,
            status: RunStatus::FinishedEarlier,
            metrics: finite(&r.metrics),
        });
    }
    Ok(results)
}

fn fmt_opt(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.4e}")).unwrap_or_else(|| "-".into())
}

/// Each distinct name once, in the order first seen.
fn first_seen<'a>(names: impl Iterator<Item = &'a String>) -> Vec<String> {
    let mut out: Vec<String> = Vec::new();
    for n in names {
        if !out.contains(n) {
            out.push(n.clone());
        }
    }
    out
}

/// Writes `summary.csv`, `summary.md` and `summary.json` (atomically): every run, then each variant over
/// its seeds, and its paired differences against the layout's baseline; and the layout's paper table.
pub fn write_summary(out_dir: &Path, results: &[RunResult], layout: &SummaryLayout) -> Result<()> {
    let metric_names = first_seen(results.iter().flat_map(|r| r.metrics.iter().map(|m| &m.0)));
    let grid_keys = first_seen(results.iter().flat_map(|r| r.run.grid.iter().map(|g| &g.0)));
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
    let mut md = format!(
        "# Sweep summary\n\n{}\n\n",
        crate::paper_table::protocol_line(layout.protocol)
    );
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
    let groups = seed_groups(results, &metric_names, layout.baseline.as_deref());
    md.push_str(&seed_tables(&groups));
    let json = serde_json::to_string_pretty(&groups).expect("summary serialises");
    qean_io::fsutil::atomic_write(&out_dir.join("summary.csv"), csv.as_bytes())?;
    qean_io::fsutil::atomic_write(&out_dir.join("summary.md"), md.as_bytes())?;
    qean_io::fsutil::atomic_write(&out_dir.join("summary.json"), json.as_bytes())?;
    if let Some(kind) = layout.table {
        crate::paper_table::write(out_dir, kind, &groups, layout.protocol)?;
    }
    Ok(())
}

/// One variant (at one grid point) over its seeds.
#[derive(Debug, Clone, serde::Serialize)]
pub struct SeedGroup {
    pub variant: String,
    pub grid: Vec<(String, String)>,
    pub seeds: Vec<u64>,
    /// Quantity ("train_loss", "val_loss", then the metrics) → its interval over the seeds.
    pub intervals: Vec<(String, Option<Interval>)>,
    /// The baseline variant at the same grid point it is compared with, over the seeds both ran (none
    /// for the baseline itself, or without one).
    pub against: Option<String>,
    pub paired: Vec<(String, Option<Interval>)>,
}

impl SeedGroup {
    /// Its variant and grid point, as a row label.
    pub fn label(&self) -> String {
        let grid: Vec<String> = self.grid.iter().map(|(k, v)| format!("{k}={v}")).collect();
        if grid.is_empty() {
            self.variant.clone()
        } else {
            format!("{} ({})", self.variant, grid.join(", "))
        }
    }
}

/// The markdown head of a table over seeds: `first`, the seed count, then `columns`.
pub(crate) fn seeds_table_head<'a>(
    first: &str,
    columns: impl ExactSizeIterator<Item = &'a str>,
) -> String {
    let n = columns.len();
    let mut h = format!("| {first} | seeds |");
    for c in columns {
        h.push_str(&format!(" {c} |"));
    }
    h.push('\n');
    h.push_str(&"|---".repeat(n + 2));
    h.push_str("|\n");
    h
}

/// Each quantity's values per seed, for one run.
fn quantities(r: &RunResult, metric_names: &[String]) -> Vec<(String, Option<f64>)> {
    let mut q = vec![
        ("train_loss".to_string(), r.train_loss),
        ("val_loss".to_string(), r.val_loss),
    ];
    for m in metric_names {
        let v = r.metrics.iter().find(|(n, _)| n == m).map(|(_, v)| *v);
        q.push((m.clone(), v));
    }
    q
}

/// The finished runs grouped by (variant, grid point), in order of first appearance; each compared with
/// the `baseline` variant at its grid point.
pub fn seed_groups(
    results: &[RunResult],
    metric_names: &[String],
    baseline: Option<&str>,
) -> Vec<SeedGroup> {
    let finished: Vec<&RunResult> = results
        .iter()
        .filter(|r| r.status != RunStatus::Interrupted)
        .collect();
    let mut keys: Vec<(String, Vec<(String, String)>)> = Vec::new();
    for r in &finished {
        let key = (r.run.variant.clone(), r.run.grid.clone());
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    // Per group: each quantity's (seed, value) pairs.
    let series = |key: &(String, Vec<(String, String)>)| -> Vec<(String, Vec<(u64, f64)>)> {
        let runs: Vec<&&RunResult> = finished
            .iter()
            .filter(|r| r.run.variant == key.0 && r.run.grid == key.1)
            .collect();
        let names: Vec<String> = runs
            .first()
            .map(|r| {
                quantities(r, metric_names)
                    .into_iter()
                    .map(|(n, _)| n)
                    .collect()
            })
            .unwrap_or_default();
        names
            .iter()
            .enumerate()
            .map(|(i, n)| {
                let vals = runs
                    .iter()
                    .filter_map(|r| quantities(r, metric_names)[i].1.map(|v| (r.run.seed, v)))
                    .collect();
                (n.clone(), vals)
            })
            .collect()
    };
    keys.iter()
        .map(|key| {
            let own = series(key);
            let first = baseline
                .and_then(|b| keys.iter().find(|k| k.0 == b && k.1 == key.1))
                .filter(|k| *k != key);
            let base = first.map(series);
            let values = |v: &[(u64, f64)]| v.iter().map(|(_, x)| *x).collect::<Vec<_>>();
            SeedGroup {
                variant: key.0.clone(),
                grid: key.1.clone(),
                seeds: finished
                    .iter()
                    .filter(|r| r.run.variant == key.0 && r.run.grid == key.1)
                    .map(|r| r.run.seed)
                    .collect(),
                intervals: own
                    .iter()
                    .map(|(n, v)| (n.clone(), Interval::of(&values(v))))
                    .collect(),
                against: first.map(|k| k.0.clone()),
                paired: match &base {
                    Some(b) => own
                        .iter()
                        .zip(b)
                        .map(|((n, v), (_, w))| (n.clone(), paired_difference(v, w)))
                        .collect(),
                    None => Vec::new(),
                },
            }
        })
        .collect()
}

/// A cell: "m ± h" (four significant digits), "m (1 seed)", or "-"; "(n of N)" where fewer than the
/// group's `seeds` gave a value.
fn interval_cell(i: &Option<Interval>, seeds: usize) -> String {
    let Some(i) = i else {
        return "-".into();
    };
    let scale = i.mean.abs().max(i.half_width.unwrap_or(0.0));
    let decimals = if scale == 0.0 {
        3
    } else {
        (3 - scale.log10().floor() as i64).clamp(0, 6) as usize
    };
    i.display_of(decimals, seeds)
}

/// The markdown of the seed statistics: one table of intervals, one of paired differences (when a
/// variant has a baseline), with how to read them.
fn seed_tables(groups: &[SeedGroup]) -> String {
    if groups.is_empty() {
        return String::new();
    }
    let names: Vec<&str> = groups[0]
        .intervals
        .iter()
        .map(|(n, _)| n.as_str())
        .collect();
    let head = |first: &str| seeds_table_head(first, names.iter().copied());
    let mut md = String::from(
        "\n## Over seeds\n\nMean ± the half-width of its 95 % confidence interval (Student's t, n − 1 \
         degrees of freedom, over the seeds each variant ran):\n\n",
    );
    md.push_str(&head("variant"));
    for g in groups {
        md.push_str(&format!("| {} | {} |", g.label(), g.seeds.len()));
        for (_, i) in &g.intervals {
            md.push_str(&format!(" {} |", interval_cell(i, g.seeds.len())));
        }
        md.push('\n');
    }
    if groups.iter().any(|g| g.against.is_some()) {
        md.push_str(
            "\n## Paired differences\n\nEach variant minus the baseline at the same grid point, seed by seed \
             (the seeds' shared part cancels), mean ± 95 % interval; * marks an interval that excludes 0 \
             (a difference the seeds do not explain):\n\n",
        );
        md.push_str(&head("variant − baseline"));
        for g in groups {
            let Some(base) = &g.against else { continue };
            md.push_str(&format!("| {} − {base} | {} |", g.label(), g.seeds.len()));
            for (_, i) in &g.paired {
                let star = if i.is_some_and(|i| i.excludes_zero()) {
                    " *"
                } else {
                    ""
                };
                md.push_str(&format!(" {}{star} |", interval_cell(i, g.seeds.len())));
            }
            md.push('\n');
        }
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    fn result(variant: &str, seed: u64, fid: f64) -> RunResult {
        RunResult {
            run: PlannedRun {
                name: format!("{variant}-seed{seed}"),
                variant: variant.into(),
                seed,
                grid: Vec::new(),
                config: Default::default(),
                run_dir: format!("/nowhere/{variant}-seed{seed}").into(),
                evaluate: true,
                index: 0,
            },
            steps: 10,
            train_loss: Some(1.0 + seed as f64),
            val_loss: None,
            seconds: 1.0,
            status: RunStatus::Finished,
            metrics: vec![("fid_k".into(), fid)],
        }
    }

    #[test]
    fn variants_over_seeds_with_paired_differences() {
        let results = [
            result("baseline", 0, 60.1),
            result("baseline", 1, 55.5),
            result("baseline", 2, 71.3),
            result("full", 0, 50.1),
            result("full", 1, 46.5),
            result("full", 2, 60.3),
        ];
        let groups = seed_groups(&results, &["fid_k".into()], Some("baseline"));
        assert!(seed_groups(&results, &["fid_k".into()], None)
            .iter()
            .all(|g| g.against.is_none()));
        assert_eq!(groups.len(), 2);
        let (base, full) = (&groups[0], &groups[1]);
        assert_eq!(
            (base.seeds.clone(), base.against.clone()),
            (vec![0, 1, 2], None)
        );
        let fid = base.intervals[2].1.unwrap();
        assert!((fid.mean - 62.3).abs() < 1e-9);
        assert!((fid.half_width.unwrap() - 20.18734477064501).abs() < 1e-9);
        assert_eq!(full.against.as_deref(), Some("baseline"));
        // Differences −10, −9, −11: mean −10, sd 1, t(2) = 4.3027 → ± 2.4841.
        let d = full.paired[2].1.unwrap();
        assert!((d.mean + 10.0).abs() < 1e-9);
        assert!((d.half_width.unwrap() - 4.302652729749462 / 3f64.sqrt()).abs() < 1e-9);
        assert!(d.excludes_zero());
        // No validation loss anywhere: no interval.
        assert_eq!(base.intervals[1], ("val_loss".into(), None));
        let md = seed_tables(&groups);
        assert!(
            md.contains("| baseline | 3 | 2.000 ± 2.484 | - | 62.30 ± 20.19 |"),
            "{md}"
        );
        assert!(
            md.contains("| full − baseline | 3 | 0.000 ± 0.000 | - | -10.00 ± 2.48 * |"),
            "{md}"
        );
    }
}
