//! `qean sweep --config S.toml`: a base run config, a list of variants (each a config file
//! and/or overrides), seeds and a grid of any other fields; every combination is one run in
//! `S-runs/<variant>-seed<k>[-<key>=<value>…]/`, trained in order (finished runs are skipped,
//! interrupted ones resumed), then `S-runs/summary.md`, `summary.csv` and `summary.json` (and
//! `tableN.{md,json,png}` with `table`).
//!
//! ```toml
//! base = "../tiny/baseline.toml"        # relative to this file
//! seeds = [0, 1]
//! evaluate = false                      # also compute the AIST++ metrics per run
//! eval_frames = 1200                    # generated frames per sequence when evaluating
//! baseline = "baseline"                 # paired differences against this variant (same seeds)
//! table = "table2"                      # also laid out as the QEAN paper's Table 2
//! protocol_preset = "edge"              # score under a named protocol (bailando, edge, lodge)
//! [set]                                 # overrides shared by every run
//! "train.steps" = 200
//! [[variant]]
//! name = "baseline"
//! [[variant]]
//! name = "spe"
//! set = { "model.position" = "rotary" }
//! [grid]                                # every combination of these values
//! "schedule.initial" = [1e-4, 3e-4]
//! ```
//!
//! A variant can build on another's run of the same seed (`configs/sweeps/table1-tiny.toml`): in a
//! string value `{seed}` is the run's seed and `{runs}` the sweep's output directory, and a stage that is
//! only a base for others is not evaluated. (With a grid, run names carry the grid point too, so name
//! such a base run in full.)
//!
//! ```toml
//! [[variant]]
//! name = "vqvae"
//! config = "../control/vqvae_tiny.toml"
//! evaluate = false
//! [[variant]]
//! name = "gpt"
//! config = "../control/gpt_tiny.toml"
//! set = { "gpt.vqvae_run" = "{runs}/vqvae-seed{seed}" }
//! ```

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use qean_io::error::{Error, Result};
use serde::Deserialize;

use crate::run::RunConfig;
/// A QEAN paper table a sweep can be laid out as.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, serde::Serialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
#[value(rename_all = "lowercase")]
pub enum PaperTable {
    /// Table 1: every method's FID_k, FID_g, Dist_k, Dist_g and BeatAlign.
    Table1,
    /// Table 2: the ablation's FID_k, FID_g and BeatAlign, with paired differences to the baseline.
    Table2,
}

impl PaperTable {
    pub fn name(self) -> &'static str {
        match self {
            PaperTable::Table1 => "table1",
            PaperTable::Table2 => "table2",
        }
    }
}

/// One variant: a config file (default: the sweep's base) plus overrides.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Variant {
    pub name: String,
    pub config: Option<PathBuf>,
    #[serde(default)]
    pub set: BTreeMap<String, toml::Value>,
    /// Whether its runs are evaluated (default: the sweep's `evaluate`); e.g. false for a VQ-VAE stage.
    #[serde(default)]
    pub evaluate: Option<bool>,
}

/// The sweep file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SweepConfig {
    pub base: PathBuf,
    #[serde(default)]
    pub seeds: Vec<u64>,
    #[serde(default)]
    pub evaluate: bool,
    /// The variant every other one is compared with, seed by seed (paired differences in the summary).
    #[serde(default)]
    pub baseline: Option<String>,
    /// Also write the summary in a QEAN paper table's layout (`table1.md`/`.json` or `table2.…`).
    #[serde(default)]
    pub table: Option<PaperTable>,
    /// Generated frames per sequence when evaluating (default 1200, as the protocol; a preset's own).
    #[serde(default)]
    pub eval_frames: Option<usize>,
    /// A named evaluation protocol for every evaluated run: bailando, edge or lodge (docs/protocols.md).
    #[serde(default)]
    pub protocol_preset: Option<String>,
    #[serde(default)]
    pub set: BTreeMap<String, toml::Value>,
    #[serde(default)]
    pub variant: Vec<Variant>,
    #[serde(default)]
    pub grid: BTreeMap<String, Vec<toml::Value>>,
}

/// One planned run.
#[derive(Debug, Clone)]
pub struct PlannedRun {
    pub name: String,
    pub variant: String,
    pub seed: u64,
    /// Grid values of this run (key, value as TOML).
    pub grid: Vec<(String, String)>,
    pub config: RunConfig,
    pub run_dir: PathBuf,
    /// Whether the sweep evaluates this run (its variant's `evaluate`, else the sweep's).
    pub evaluate: bool,
    /// Position in the whole plan (kept when `--only` trains a part): the order of the summary.
    pub index: usize,
}

fn value_text(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// `key=value` for `--set`, with `{seed}` in a string value replaced by the run's seed and `{runs}` by
/// the sweep's output directory (absolute).
fn override_spec(key: &str, v: &toml::Value, seed: u64, runs: &Path) -> String {
    match v {
        toml::Value::String(s) if s.contains("{seed}") || s.contains("{runs}") => format!(
            "{key}={}",
            toml::Value::String(
                s.replace("{seed}", &seed.to_string())
                    .replace("{runs}", &runs.to_string_lossy())
            )
        ),
        _ => format!("{key}={v}"),
    }
}

fn safe_name(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || "-_.=".contains(c) {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Every combination of the grid's values (keys in sorted order); one empty combination without a grid.
fn grid_combinations(path: &Path, sweep: &SweepConfig) -> Result<Vec<Vec<(String, toml::Value)>>> {
    let mut combos: Vec<Vec<(String, toml::Value)>> = vec![vec![]];
    for (key, values) in &sweep.grid {
        if values.is_empty() {
            return Err(Error::at(path, format!("grid key `{key}` has no values")));
        }
        combos = combos
            .into_iter()
            .flat_map(|c| {
                values.iter().map(move |v| {
                    let mut c = c.clone();
                    c.push((key.clone(), v.clone()));
                    c
                })
            })
            .collect();
    }
    Ok(combos)
}

/// At least one variant, no name twice, and a baseline that names one of them.
fn check_variants(path: &Path, sweep: &SweepConfig) -> Result<()> {
    if sweep.variant.is_empty() {
        return Err(Error::at(path, "no [[variant]] given"));
    }
    let mut names = std::collections::HashSet::new();
    for v in &sweep.variant {
        if !names.insert(v.name.clone()) {
            return Err(Error::at(
                path,
                format!("variant `{}` is named twice", v.name),
            ));
        }
    }
    if let Some(b) = sweep
        .baseline
        .as_ref()
        .filter(|b| !sweep.variant.iter().any(|v| &v.name == *b))
    {
        return Err(Error::at(
            path,
            format!("baseline `{b}` is not one of the variants"),
        ));
    }
    Ok(())
}

/// Reads a sweep file and plans its runs; `extra` overrides (the CLI's `--set`) apply to every run.
/// `out` defaults to `S-runs` beside the sweep file.
pub fn plan(
    path: &Path,
    out: Option<&Path>,
    extra: &[String],
) -> Result<(SweepConfig, PathBuf, Vec<PlannedRun>)> {
    plan_seeds(path, out, extra, None)
}

/// [`plan`] with the file's `seeds` replaced by `seeds` when given (the CLI's `--seeds`).
pub fn plan_seeds(
    path: &Path,
    out: Option<&Path>,
    extra: &[String],
    seeds: Option<&[u64]>,
) -> Result<(SweepConfig, PathBuf, Vec<PlannedRun>)> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let mut sweep: SweepConfig = toml::from_str(&text).map_err(|e| {
        let c = crate::model::ConfigError::from_toml(path, &text, &e);
        Error::msg(c.to_string())
    })?;
    if let Some(seeds) = seeds {
        sweep.seeds = seeds.to_vec();
    }
    check_variants(path, &sweep)?;
    let here = path.parent().unwrap_or(Path::new("."));
    let out_dir = match out {
        Some(o) => o.to_path_buf(),
        None => {
            let stem = path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "sweep".into());
            here.join(format!("{stem}-runs"))
        }
    };
    let combos = grid_combinations(path, &sweep)?;
    let runs_dir = std::path::absolute(&out_dir).map_err(|e| Error::io(&out_dir, e))?;
    let mut runs = Vec::new();
    for variant in &sweep.variant {
        let config_path = variant
            .config
            .as_ref()
            .map(|c| here.join(c))
            .unwrap_or_else(|| here.join(&sweep.base));
        let base_seed = RunConfig::load(&config_path, &[])
            .map_err(|e| Error::msg(e.to_string()))?
            .train
            .seed;
        let seeds = if sweep.seeds.is_empty() {
            vec![base_seed]
        } else {
            sweep.seeds.clone()
        };
        for seed in &seeds {
            for combo in &combos {
                let mut overrides: Vec<String> = Vec::new();
                let spec = |(k, v): (&String, &toml::Value)| override_spec(k, v, *seed, &runs_dir);
                overrides.extend(sweep.set.iter().map(spec));
                overrides.extend(variant.set.iter().map(spec));
                overrides.extend(combo.iter().map(|(k, v)| spec((k, v))));
                overrides.push(format!("train.seed={seed}"));
                overrides.extend(extra.iter().cloned());
                let config = RunConfig::load(&config_path, &overrides)
                    .map_err(|e| Error::msg(format!("variant `{}`: {e}", variant.name)))?;
                let mut name = format!("{}-seed{seed}", variant.name);
                for (k, v) in combo {
                    name.push_str(&format!(
                        "-{}={}",
                        k.rsplit('.').next().unwrap_or(k),
                        value_text(v)
                    ));
                }
                let name = safe_name(&name);
                runs.push(PlannedRun {
                    run_dir: out_dir.join(&name),
                    name,
                    variant: variant.name.clone(),
                    seed: *seed,
                    grid: combo
                        .iter()
                        .map(|(k, v)| (k.clone(), value_text(v)))
                        .collect(),
                    config,
                    evaluate: variant.evaluate.unwrap_or(sweep.evaluate),
                    index: runs.len(),
                });
            }
        }
    }
    Ok((sweep, out_dir, runs))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seeds_in_values_stages_and_the_baseline() {
        let d = tempfile::tempdir().unwrap();
        let configs = Path::new(env!("CARGO_MANIFEST_DIR")).join("../configs");
        let sweep = d.path().join("s.toml");
        let text = format!(
            "base = {base:?}\nseeds = [3, 4]\nevaluate = true\nbaseline = \"vq\"\n\
             [[variant]]\nname = \"vq\"\nconfig = {vq:?}\nevaluate = false\n\
             [[variant]]\nname = \"gpt\"\nconfig = {gpt:?}\nset = {{ \"gpt.vqvae_run\" = \"{{runs}}/vq-seed{{seed}}\" }}\n",
            base = configs.join("tiny/fact.toml"),
            vq = configs.join("control/vqvae_tiny.toml"),
            gpt = configs.join("control/gpt_tiny.toml"),
        );
        std::fs::write(&sweep, &text).unwrap();
        let (config, out, runs) = plan(&sweep, None, &[]).unwrap();
        assert_eq!(config.baseline.as_deref(), Some("vq"));
        assert_eq!(out, d.path().join("s-runs"));
        let names: Vec<(&str, bool)> = runs.iter().map(|r| (r.name.as_str(), r.evaluate)).collect();
        assert_eq!(
            names,
            [
                ("vq-seed3", false),
                ("vq-seed4", false),
                ("gpt-seed3", true),
                ("gpt-seed4", true)
            ]
        );
        assert_eq!(
            runs[3].config.gpt.as_ref().unwrap().vqvae_run.as_deref(),
            Some(d.path().join("s-runs/vq-seed4").as_path())
        );
        let bad = d.path().join("bad.toml");
        std::fs::write(
            &bad,
            text.replace("baseline = \"vq\"", "baseline = \"vqq\""),
        )
        .unwrap();
        let e = plan(&bad, None, &[]).unwrap_err().to_string();
        assert!(
            e.contains("baseline `vqq` is not one of the variants"),
            "{e}"
        );
    }
}
