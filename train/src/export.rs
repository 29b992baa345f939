//! `qean export`: a checkpoint's weights as one f32 safetensors file under stable names, and the
//! table of those names that docs/weights.md holds (generated here, checked by a test).

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use burn::module::Module;
use burn::tensor::Device;
use qean_config::ModelConfig;
use qean_io::error::{Error, Result};
use qean_models::params::{parameter_shapes, params_hash, write_safetensors};
use qean_models::DanceModel;

use qean_checkpoint::checkpoint::Checkpoint;
use qean_checkpoint::registry::Weights;

/// What an export wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportSummary {
    pub tensors: usize,
    pub values: usize,
    pub params_hash: String,
}

/// Writes every parameter of the checkpoint's model to `out` (f32, Burn's layouts: see
/// docs/weights.md). The header's metadata holds the model config, the step and the hash.
pub fn export_safetensors(ck: &Checkpoint, out: &Path) -> Result<ExportSummary> {
    // The weights samplers use: a run's moving average where it kept one.
    let params = ck.named_parameters_of(&Device::flex(), Weights::Sampled)?;
    let hash = params_hash(&params);
    let weights = if ck.config.train.ema_decay > 0.0 {
        format!(
            "moving average of the trained weights (train.ema_decay {})",
            ck.config.train.ema_decay
        )
    } else {
        "trained".to_string()
    };
    let metadata = HashMap::from([
        ("format".to_string(), "qean-weights-1".to_string()),
        ("weights".to_string(), weights),
        ("step".to_string(), ck.state.step.to_string()),
        ("params_hash".to_string(), hash.clone()),
        ("model_config".to_string(), ck.architecture_toml()),
        (
            "layout".to_string(),
            "burn: Linear weight is [in, out] (transpose for torch.nn.Linear)".to_string(),
        ),
    ]);
    write_safetensors(&params, metadata, out).map_err(Error::msg)?;
    Ok(ExportSummary {
        tensors: params.len(),
        values: params.iter().map(|p| p.values.len()).sum(),
        params_hash: hash,
    })
}

/// What a parameter does, from its name.
pub fn role(name: &str) -> String {
    let parts: Vec<&str> = name.split('.').collect();
    let last = parts.last().copied().unwrap_or("");
    let owner = if parts.len() >= 2 {
        parts[parts.len() - 2]
    } else {
        ""
    };
    let stack = if name.contains("motion_transformer") {
        "motion transformer"
    } else if name.contains("audio_transformer") {
        "audio transformer"
    } else if name.contains("cross_transformer") {
        "cross-modal transformer"
    } else {
        ""
    };
    let what = match owner {
        "qkv" => "fused q, k, v projection (columns: q | k | v)",
        "out" | "proj" | "output_proj" | "output"
            if name.contains("attention") || name.contains("mixer") =>
        {
            "attention output projection (hidden → hidden)"
        }
        "norm1" | "attention_norm" => "layer norm before attention",
        "norm2" | "mlp_norm" | "ffn_norm" => "layer norm before the MLP",
        "fc1" | "linear1" | "dense1" => "MLP first dense (tanh-GELU after)",
        "fc2" | "linear2" | "dense2" => "MLP second dense",
        "expand" => "MLP expand (hidden → ffn, tanh-GELU after)",
        "contract" => "MLP contract (ffn → hidden)",
        "motion_embed" => "motion input dense (motion_dim → hidden)",
        "audio_embed" => "audio input dense (35 → hidden)",
        "motion_pos" | "audio_pos" => "learned absolute position embedding",
        "output" => "output dense (hidden → motion_dim)",
        "conv" | "period_conv" | "omega_conv" | "theta_conv" => "QRA convolution making ω and θ",
        _ => "",
    };
    let what = if what.is_empty() {
        owner.replace('_', " ")
    } else {
        what.to_string()
    };
    let kind = match last {
        "weight" | "gamma" if owner.contains("norm") => "scale",
        "beta" | "bias" if owner.contains("norm") => "shift",
        "weight" => "weight",
        "bias" => "bias",
        other => other,
    };
    if stack.is_empty() {
        format!("{what}: {kind}")
    } else {
        format!("{stack}, {what}: {kind}")
    }
}

/// `a.layers.3.b` → `a.layers.{i}.b` (the layer index), returning the index.
fn layer_pattern(name: &str) -> (String, Option<usize>) {
    let parts: Vec<&str> = name.split('.').collect();
    for (k, w) in parts.windows(2).enumerate() {
        if w[0] == "layers" || w[0] == "blocks" {
            if let Ok(i) = w[1].parse::<usize>() {
                let mut p: Vec<String> = parts.iter().map(|s| s.to_string()).collect();
                p[k + 1] = "{i}".into();
                return (p.join("."), Some(i));
            }
        }
    }
    (name.to_string(), None)
}

/// The markdown table of every tensor of a model config, repeated layers folded to
/// `layers.{i}` with the index range.
pub fn weights_table(config: &ModelConfig) -> Result<String> {
    let model = DanceModel::new(config, &Device::flex()).map_err(|e| Error::msg(e.to_string()))?;
    let shapes = parameter_shapes(&model);
    // first position → (pattern, shape, layer range)
    type Row = (String, Vec<usize>, Option<(usize, usize)>);
    let mut rows: BTreeMap<usize, Row> = BTreeMap::new();
    let mut index: HashMap<(String, Vec<usize>), usize> = HashMap::new();
    for (pos, p) in shapes.iter().enumerate() {
        let (pattern, layer) = layer_pattern(&p.name);
        let key = (pattern.clone(), p.shape.clone());
        match index.get(&key) {
            Some(first) => {
                let row = rows.get_mut(first).expect("row exists");
                if let (Some((lo, hi)), Some(i)) = (&mut row.2, layer) {
                    *lo = (*lo).min(i);
                    *hi = (*hi).max(i);
                }
            }
            None => {
                index.insert(key, pos);
                rows.insert(pos, (pattern, p.shape.clone(), layer.map(|i| (i, i))));
            }
        }
    }
    let mut s = String::from("| name | shape | layers | role |\n|---|---|---|---|\n");
    for (pattern, shape, layers) in rows.values() {
        let shape = shape_text(shape);
        let layers = layers
            .map(|(lo, hi)| format!("{{i}} = {lo}..={hi}"))
            .unwrap_or_default();
        s.push_str(&format!(
            "| `{pattern}` | {shape} | {layers} | {} |\n",
            role(pattern)
        ));
    }
    Ok(s)
}

/// A shape as the table writes it: `[225, 800]`.
fn shape_text(shape: &[usize]) -> String {
    format!("{shape:?}")
}

/// Does `name` with `shape` appear in a table made by [`weights_table`]?
pub fn table_lists(table: &str, name: &str, shape: &[usize]) -> bool {
    let (pattern, layer) = layer_pattern(name);
    let shape = shape_text(shape);
    table.lines().any(|line| {
        let cells: Vec<&str> = line.split('|').map(str::trim).collect();
        if cells.len() < 5 || cells[1] != format!("`{pattern}`") || cells[2] != shape {
            return false;
        }
        match layer {
            None => true,
            Some(i) => cells[3]
                .strip_prefix("{i} = ")
                .and_then(|r| r.split_once("..="))
                .and_then(|(lo, hi)| Some((lo.parse::<usize>().ok()?, hi.parse::<usize>().ok()?)))
                .is_some_and(|(lo, hi)| (lo..=hi).contains(&i)),
        }
    })
}

/// The presets docs/weights.md documents (path under configs/, description).
pub const DOCUMENTED_PRESETS: [(&str, &str); 5] = [
    ("fact.toml", "mint's FACT"),
    (
        "qean/baseline.toml",
        "QEAN ablation baseline (FACT architecture, 16 heads)",
    ),
    (
        "qean/spe.toml",
        "QEAN +SPE (rotary positions; no absolute embeddings)",
    ),
    ("qean/qra.toml", "QEAN +QRA"),
    ("qean/full.toml", "QEAN (SPE + QRA)"),
];

/// The whole of docs/weights.md, generated from the presets under `configs`.
pub fn weights_doc(configs: &Path) -> Result<String> {
    let mut s = String::from(
        "# Weight names, shapes and layouts (`qean export`)\n\n\
`qean export R[/checkpoints/step-N] --out W.safetensors` writes every parameter of a checkpoint as an f32\n\
tensor under the names below. The file's `__metadata__` holds `model_config` (the `[model]` table, TOML),\n\
`step`, `params_hash` and `layout`.\n\n\
Layouts (Burn's, not PyTorch's):\n\n\
- A dense layer's `weight` is `[in, out]` and computes `y = x · W + b`; `torch.nn.Linear` stores `[out, in]`:\n\
  transpose it.\n\
- The fused attention projection `qkv.weight` is `[hidden, 3·hidden]`: columns `0..h` give q, `h..2h` k,\n\
  `2h..3h` v; within each, head `j` owns columns `j·d_head..(j+1)·d_head`.\n\
- Layer norms have `gamma` (scale) and `beta` (shift), ε = 1e-5 as mint (PyTorch's default).\n\
- Position embeddings are `[tokens, hidden]`.\n\
- Rows with `{i}` stand for one tensor per layer, `i` over the range given.\n\n\
This file is generated from the presets (`QEAN_BLESS=1 cargo test --workspace --test weights_doc`\n\
rewrites it); a test checks that it lists every tensor of each preset with its shape.\n",
    );
    for (file, what) in DOCUMENTED_PRESETS {
        let path = configs.join(file);
        let config =
            qean_config::model::load_model_config(&path).map_err(|e| Error::msg(e.to_string()))?;
        let count = DanceModel::new(&config, &Device::flex())
            .map_err(|e| Error::at(&path, e.to_string()))?
            .num_params();
        s.push_str(&format!(
            "\n## `configs/{file}`: {what}, {} parameters\n\n",
            qean_models::inspect::group_digits(count)
        ));
        s.push_str(&weights_table(&config)?);
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layer_patterns_fold_indices() {
        assert_eq!(
            layer_pattern("fact.cross_transformer.layers.11.attention.qkv.weight"),
            (
                "fact.cross_transformer.layers.{i}.attention.qkv.weight".to_string(),
                Some(11)
            )
        );
        assert_eq!(
            layer_pattern("fact.output.bias"),
            ("fact.output.bias".to_string(), None)
        );
    }
}
