//! `qean curves --evaluate`: checkpoint mode for every checkpoint of a run that has no current report yet.

use std::path::Path;

use qean_eval::curves::has_report;

use crate::evaluate::{evaluate_run, RunEvalRequest};

/// Evaluates the checkpoints of `run` (only `steps`, when given) that lack a report made for
/// `template.max_frames` frames. `template` gives every setting but the run and the checkpoint.
pub fn evaluate_missing(run: &Path, steps: &[u64], template: &RunEvalRequest) -> crate::Result<()> {
    for (step, dir) in qean_checkpoint::run_dir::list_checkpoints(run)? {
        if !steps.is_empty() && !steps.contains(&step) {
            continue;
        }
        let protocol = template.configs.first().and_then(|c| c.preset);
        if has_report(
            run,
            step,
            template.tag.as_deref(),
            template.max_frames,
            protocol,
        ) {
            continue;
        }
        eprintln!("curves: evaluating {} step {step}", run.display());
        let req = RunEvalRequest {
            run: run.to_path_buf(),
            checkpoint: Some(dir.to_string_lossy().into_owned()),
            ..template.clone()
        };
        let quiet = tracing::subscriber::NoSubscriber::default();
        tracing::subscriber::with_default(quiet, || evaluate_run(&req))?;
    }
    Ok(())
}
