//! A checkpoint's weights (Burn burnpack files) and its family state (`family.json`: what a family stores
//! beside the weights, e.g. TSMT's coordinate bins), and the check that a resumed stage still finds the
//! frozen run it was trained on.

use std::path::{Path, PathBuf};

use burn::module::Module;
use qean_io::error::{Error, Result};

use crate::checkpoint::Checkpoint;

/// The file a family's extra checkpoint state is written to, beside the weights.
pub const FAMILY_STATE_FILE: &str = "family.json";

/// The family state of a checkpoint (`family.json`), if it has one.
pub fn read_family_state(checkpoint: &Checkpoint) -> Result<Option<serde_json::Value>> {
    let path = checkpoint.dir.join(FAMILY_STATE_FILE);
    if !path.is_file() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
    serde_json::from_str(&text)
        .map(Some)
        .map_err(|e| Error::at(&path, format!("malformed family state: {e}")))
}

/// A resumed stage must find the frozen run it was trained on: the weights hash saved under `key` in the
/// resume checkpoint's family state equals `frozen`'s (`what`: "the VQ-VAE this GPT", …). No saved hash: fine.
pub fn check_frozen_hash(
    resume: Option<&Checkpoint>,
    key: &str,
    frozen: &Checkpoint,
    what: &str,
) -> Result<()> {
    let Some(ck) = resume else {
        return Ok(());
    };
    let saved = read_family_state(ck)?;
    let hash = saved.as_ref().and_then(|s| s[key].as_str());
    match hash.filter(|h| *h != frozen.sampled_hash()) {
        Some(h) => Err(Error::at(
            &frozen.dir,
            format!(
                "not {what} was trained on (weights hash {} there, {h} when training began)",
                frozen.sampled_hash()
            ),
        )),
        None => Ok(()),
    }
}

/// The trainer's error for a weights file.
fn weights_error(e: qean_models::Error) -> Error {
    match e {
        qean_models::Error::Weights { path, message } => Error::at(path, message),
        other => Error::msg(other.to_string()),
    }
}

/// Writes any model's weights to a burnpack file; returns the path written.
pub fn save_weights<M: Module>(model: &M, path: &Path) -> Result<PathBuf> {
    qean_models::model::save_weights(model, path).map_err(weights_error)
}

/// Loads weights saved by [`save_weights`] into a model of the same shape.
pub fn load_weights<M: Module>(model: M, path: &Path) -> Result<M> {
    qean_models::model::load_weights(model, path).map_err(weights_error)
}
