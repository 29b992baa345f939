//! `qean inspect` of a checkpoint or a run directory: what was trained, how far, and whether the weights
//! on disk are the ones the trainer recorded.

use std::fmt::Write;
use std::path::Path;

use qean_checkpoint::checkpoint::{self, Checkpoint};
use qean_checkpoint::registry::Weights;
use qean_config::RunConfig;
use qean_io::error::{Error, Result};

/// A checkpoint directory: step, config, optimiser state and the hash of every parameter value
/// (recomputed from the weights and checked against the one recorded), and the hash of the moving
/// average samplers use when the run kept one.
pub fn checkpoint(dir: &Path) -> Result<String> {
    let ck = Checkpoint::read(dir)?;
    let device = burn::tensor::Device::flex();
    let params = ck.named_parameters(&device)?;
    let hash = qean_models::params::params_hash(&params);
    if hash != ck.state.params_hash {
        return Err(Error::at(
            dir,
            format!(
                "weights do not match the recorded params_hash ({} recorded, {hash} found)",
                ck.state.params_hash
            ),
        ));
    }
    let s = &ck.state;
    let o = &ck.config.optim;
    let opt_path = dir.join(checkpoint::OPTIMIZER_FILE);
    let opt = burn::optim::OptimizerRecord::load(&opt_path)
        .map_err(|e| Error::at(&opt_path, e.to_string()))?;
    let values: usize = params.iter().map(|p| p.values.len()).sum();
    let mut t = String::new();
    let _ = writeln!(t, "checkpoint: {}", dir.display());
    let _ = writeln!(t, "step: {} of {}", s.step, s.total_steps);
    let _ = writeln!(t, "config: {}", ck.config.summary());
    let _ = writeln!(t, "parameters: {} tensors, {} values", params.len(), values);
    let _ = writeln!(t, "params_hash: {hash}");
    if ck.config.train.ema_decay > 0.0 {
        let avg = ck.named_parameters_of(&device, Weights::Sampled)?;
        let avg_hash = qean_models::params::params_hash(&avg);
        if let Some(recorded) = ck
            .state
            .ema_params_hash
            .as_ref()
            .filter(|h| **h != avg_hash)
        {
            return Err(Error::at(
                dir.join(checkpoint::EMA_FILE),
                format!("weights do not match the recorded ema_params_hash ({recorded} recorded, {avg_hash} found)"),
            ));
        }
        let _ = writeln!(
            t,
            "sampled weights: the moving average (train.ema_decay {}), {}, hash {}",
            ck.config.train.ema_decay,
            checkpoint::EMA_FILE,
            avg_hash
        );
    }
    let _ = writeln!(
        t,
        "optimiser: adam beta1 {} beta2 {} epsilon {:e} weight_decay {}; {} state tensors; next lr {:e}",
        o.beta1,
        o.beta2,
        o.epsilon,
        o.weight_decay,
        opt.len(),
        s.next_lr
    );
    let _ = writeln!(
        t,
        "stream: seed {} epoch {} position {}",
        s.sampler.seed, s.sampler.epoch, s.sampler.position
    );
    let f = |x: Option<f64>| x.map(|v| format!("{v:.6e}")).unwrap_or_else(|| "-".into());
    let best = s
        .best
        .map(|b| format!("{:.6e} at step {}", b.val_loss, b.step))
        .unwrap_or_else(|| "-".into());
    let _ = writeln!(
        t,
        "loss: {}  val_loss: {}  best: {best}",
        f(s.last_loss),
        f(s.val_loss)
    );
    let _ = writeln!(t, "trained: {:.1} s on {}", s.elapsed_seconds, s.backend);
    Ok(t)
}

/// A run directory: config, checkpoints and the last metrics row.
pub fn run(dir: &Path) -> Result<String> {
    let config =
        RunConfig::load(&dir.join("config.toml"), &[]).map_err(|e| Error::msg(e.to_string()))?;
    let mut t = String::new();
    let _ = writeln!(t, "run: {}", dir.display());
    let _ = writeln!(t, "config: {}", config.summary());
    let list = qean_checkpoint::run_dir::list_checkpoints(dir)?;
    let _ = writeln!(t, "checkpoints: {}", list.len());
    let f = |x: Option<f64>| x.map(|v| format!("{v:.4e}")).unwrap_or_else(|| "-".into());
    for (_, path) in &list {
        let _ = match Checkpoint::read(path) {
            Ok(c) => writeln!(
                t,
                "  {}  val_loss {}  params_hash {}",
                path.display(),
                f(c.state.val_loss),
                short_hash(&c.state.params_hash)
            ),
            Err(e) => writeln!(t, "  {}  unreadable: {e}", path.display()),
        };
    }
    if let Some(r) = crate::metrics_log::read(&dir.join("metrics.csv"))
        .ok()
        .and_then(|rows| rows.last().cloned())
    {
        let _ = writeln!(
            t,
            "last row: step {} lr {:e} loss {} val_loss {}",
            r.step,
            r.lr,
            f(r.loss),
            f(r.val_loss)
        );
    }
    Ok(t)
}

/// The first 16 characters of a hash.
fn short_hash(hash: &str) -> String {
    hash.chars().take(16).collect()
}

#[cfg(test)]
mod tests {
    #[test]
    fn short_hash_takes_sixteen_characters_of_any_hash() {
        assert_eq!(
            super::short_hash("0123456789abcdef0123"),
            "0123456789abcdef"
        );
        assert_eq!(super::short_hash("abc"), "abc");
        assert_eq!(super::short_hash("ééééééééééééééééé"), "éééééééééééééééé");
        assert_eq!(super::short_hash(""), "");
    }
}
