//! `qean sweep --config S.toml`: a base run config, a list of variants (each a config file
//! and/or overrides), seeds and a grid of any other fields; every combination is one run in
//! `S-runs/<variant>-seed<k>[-<key>=<value>…]/`, trained in order (finished runs are skipped,
//! interrupted ones resumed), then `S-runs/summary.md` and `summary.csv`.
//!
//! ```toml
//! base = "../tiny/baseline.toml"        # relative to this file
//! seeds = [0, 1]
//! evaluate = false                      # also compute the AIST++ metrics per run
//! eval_frames = 1200                    # generated frames per sequence when evaluating
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

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use qean_io::error::{Error, Result};
use serde::Deserialize;

use crate::run::RunConfig;
/// One variant: a config file (default: the sweep's base) plus overrides.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Variant {
    pub name: String,
    pub config: Option<PathBuf>,
    #[serde(default)]
    pub set: BTreeMap<String, toml::Value>,
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
    /// Generated frames per sequence when evaluating (default 1200, as the protocol).
    #[serde(default)]
    pub eval_frames: Option<usize>,
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
}

fn value_text(v: &toml::Value) -> String {
    match v {
        toml::Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

fn override_spec(key: &str, v: &toml::Value) -> String {
    format!("{key}={v}")
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

/// Reads a sweep file and plans its runs; `extra` overrides (the CLI's `--set`) apply to every run.
/// `out` defaults to `S-runs` beside the sweep file.
pub fn plan(
    path: &Path,
    out: Option<&Path>,
    extra: &[String],
) -> Result<(SweepConfig, PathBuf, Vec<PlannedRun>)> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let sweep: SweepConfig = toml::from_str(&text).map_err(|e| {
        let c = crate::model::ConfigError::from_toml(path, &text, &e);
        Error::msg(c.to_string())
    })?;
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
                overrides.extend(sweep.set.iter().map(|(k, v)| override_spec(k, v)));
                overrides.extend(variant.set.iter().map(|(k, v)| override_spec(k, v)));
                overrides.extend(combo.iter().map(|(k, v)| override_spec(k, v)));
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
                });
            }
        }
    }
    Ok((sweep, out_dir, runs))
}
