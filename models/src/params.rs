//! Every parameter of a model under a stable dotted name (`fact.cross_transformer.layers.3.attention.qkv.weight`),
//! its values, a hash of all of them (`params_hash`, what `qean inspect CHECKPOINT` prints), and the
//! safetensors export that moves trained weights to other frameworks (docs/weights.md).
//!
//! Names are the module field path Burn's derive reports; enum variants appear as their lower-case
//! name (`fact.` / `qean.`). Burn's `Linear` weight is stored `[in, out]` (PyTorch's is `[out, in]`).

use std::collections::HashMap;
use std::path::Path;

use burn::module::{Module, ModuleVisitor, Param};
use burn::tensor::Tensor;
use sha2::{Digest, Sha256};

/// One parameter: its name, shape and (when read) its values as f32.
#[derive(Clone, Debug, PartialEq)]
pub struct NamedParam {
    /// Dotted module path.
    pub name: String,
    /// Shape as Burn stores it.
    pub shape: Vec<usize>,
    /// Values in row-major order (empty when only shapes were asked for).
    pub values: Vec<f32>,
}

struct Walker {
    path: Vec<String>,
    read_values: bool,
    out: Vec<NamedParam>,
}

impl ModuleVisitor for Walker {
    fn enter_module(&mut self, name: &str, container_type: &str) {
        // Enum variants enter with the variant name; keep names lower-case and dotted.
        if container_type.starts_with("Enum:") {
            self.path.push(name.to_lowercase());
        } else {
            self.path.push(name.to_string());
        }
    }

    fn exit_module(&mut self, _name: &str, _container_type: &str) {
        self.path.pop();
    }

    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let name = self
            .path
            .iter()
            .filter(|p| !p.is_empty())
            .cloned()
            .collect::<Vec<_>>()
            .join(".");
        let (shape, values) = if self.read_values {
            let t = param.val();
            let shape = t.dims().to_vec();
            let values = t
                .into_data()
                .convert::<f32>()
                .try_to_vec::<f32>()
                .expect("float parameter converts to f32");
            (shape, values)
        } else {
            (param.lazy_shape().dims::<D>().to_vec(), Vec::new())
        };
        self.out.push(NamedParam {
            name,
            shape,
            values,
        });
    }
}

fn walk<M: Module>(module: &M, read_values: bool) -> Vec<NamedParam> {
    let mut w = Walker {
        path: Vec::new(),
        read_values,
        out: Vec::new(),
    };
    module.visit(&mut w);
    w.out
}

/// Names and shapes of every float parameter, in module order, without initialising lazy ones.
pub fn parameter_shapes<M: Module>(module: &M) -> Vec<NamedParam> {
    walk(module, false)
}

/// Names, shapes and f32 values of every float parameter, in module order.
pub fn named_parameters<M: Module>(module: &M) -> Vec<NamedParam> {
    walk(module, true)
}

/// SHA-256 over every parameter's name, shape and f32 bit pattern, in module order, as hex:
/// equal hashes mean bit-identical weights.
pub fn params_hash(params: &[NamedParam]) -> String {
    let mut h = Sha256::new();
    for p in params {
        h.update((p.name.len() as u64).to_le_bytes());
        h.update(p.name.as_bytes());
        h.update((p.shape.len() as u64).to_le_bytes());
        for d in &p.shape {
            h.update((*d as u64).to_le_bytes());
        }
        for v in &p.values {
            h.update(v.to_bits().to_le_bytes());
        }
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// Writes every parameter as an f32 tensor of a safetensors file (atomically: a scratch file
/// renamed into place), with `metadata` (e.g. the model config) in the header.
pub fn write_safetensors(
    params: &[NamedParam],
    metadata: HashMap<String, String>,
    path: &Path,
) -> Result<(), String> {
    let mut seen = std::collections::HashSet::new();
    let mut views = Vec::with_capacity(params.len());
    let bytes: Vec<Vec<u8>> = params
        .iter()
        .map(|p| p.values.iter().flat_map(|v| v.to_le_bytes()).collect())
        .collect();
    for (p, b) in params.iter().zip(&bytes) {
        if !seen.insert(p.name.as_str()) {
            return Err(format!("two parameters are named `{}`", p.name));
        }
        let view =
            safetensors::tensor::TensorView::new(safetensors::Dtype::F32, p.shape.clone(), b)
                .map_err(|e| format!("parameter `{}`: {e}", p.name))?;
        views.push((p.name.clone(), view));
    }
    let data = safetensors::serialize(views, Some(metadata))
        .map_err(|e| format!("{}: cannot serialise: {e}", path.display()))?;
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty());
    let dir = dir.unwrap_or_else(|| Path::new("."));
    let file_name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "weights".into());
    let tmp = dir.join(format!(".{file_name}.tmp-{}", std::process::id()));
    std::fs::write(&tmp, &data).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        format!("{}: cannot write: {e}", path.display())
    })?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        format!("{}: cannot write: {e}", path.display())
    })
}

/// Reads an f32 safetensors file back into named parameters (in the file's order, sorted by
/// name) and its metadata.
pub fn read_safetensors(path: &Path) -> Result<(Vec<NamedParam>, HashMap<String, String>), String> {
    let data = std::fs::read(path).map_err(|e| format!("{}: cannot read: {e}", path.display()))?;
    let (_, header) = safetensors::SafeTensors::read_metadata(&data)
        .map_err(|e| format!("{}: not a safetensors file: {e}", path.display()))?;
    let metadata = header.metadata().clone().unwrap_or_default();
    let st = safetensors::SafeTensors::deserialize(&data)
        .map_err(|e| format!("{}: not a safetensors file: {e}", path.display()))?;
    let mut out = Vec::new();
    let mut names = st.names();
    names.sort();
    for name in names {
        let t = st
            .tensor(name)
            .map_err(|e| format!("{}: {e}", path.display()))?;
        if t.dtype() != safetensors::Dtype::F32 {
            return Err(format!(
                "{}: tensor `{name}` is {:?}, expected F32",
                path.display(),
                t.dtype()
            ));
        }
        let values = t
            .data()
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        out.push(NamedParam {
            name: name.to_string(),
            shape: t.shape().to_vec(),
            values,
        });
    }
    Ok((out, metadata))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::DanceModel;
    use burn::tensor::Device;
    use qean_config::model::{Arch, AttentionKind, PositionKind};
    use qean_config::ModelConfig;

    fn tiny(arch: Arch) -> ModelConfig {
        ModelConfig {
            cross_layers: 1,
            ..crate::testing::micro_config(arch)
        }
    }

    #[test]
    fn names_are_unique_dotted_paths_covering_every_parameter() {
        let device = Device::flex();
        for c in [
            tiny(Arch::Fact),
            ModelConfig {
                position: PositionKind::Rotary,
                attention: AttentionKind::Qra,
                ..tiny(Arch::Qean)
            },
        ] {
            let model = DanceModel::new(&c, &device).unwrap();
            let shapes = parameter_shapes(&model);
            let total: usize = shapes
                .iter()
                .map(|p| p.shape.iter().product::<usize>())
                .sum();
            assert_eq!(total, model.num_params());
            let names: std::collections::HashSet<_> = shapes.iter().map(|p| &p.name).collect();
            assert_eq!(names.len(), shapes.len(), "names are unique");
            let prefix = if c.arch == Arch::Fact {
                "fact."
            } else {
                "qean."
            };
            assert!(
                shapes.iter().all(|p| p.name.starts_with(prefix)),
                "{shapes:?}"
            );
            assert!(shapes.iter().all(|p| !p.name.contains("..")));
            let values = named_parameters(&model);
            for (a, b) in shapes.iter().zip(&values) {
                assert_eq!((&a.name, &a.shape), (&b.name, &b.shape));
                assert_eq!(b.values.len(), b.shape.iter().product::<usize>());
            }
        }
    }

    #[test]
    fn hash_changes_with_any_value_and_round_trips_through_safetensors() {
        let device = Device::flex();
        device.seed(3);
        let model = DanceModel::new(&tiny(Arch::Fact), &device).unwrap();
        let params = named_parameters(&model);
        let h = params_hash(&params);
        assert_eq!(h.len(), 64);
        assert_eq!(h, params_hash(&named_parameters(&model)));
        let mut changed = params.clone();
        changed[3].values[0] = f32::from_bits(changed[3].values[0].to_bits() ^ 1);
        assert_ne!(h, params_hash(&changed));

        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("w.safetensors");
        let meta = HashMap::from([("format".to_string(), "qean".to_string())]);
        write_safetensors(&params, meta.clone(), &path).unwrap();
        let (back, back_meta) = read_safetensors(&path).unwrap();
        assert_eq!(back_meta, meta);
        let mut sorted = params.clone();
        sorted.sort_by(|a, b| a.name.cmp(&b.name));
        assert_eq!(back, sorted);
        let e = read_safetensors(&dir.path().join("none.safetensors")).unwrap_err();
        assert!(e.contains("none.safetensors"), "{e}");
        std::fs::write(dir.path().join("bad.safetensors"), b"garbage").unwrap();
        let e = read_safetensors(&dir.path().join("bad.safetensors")).unwrap_err();
        assert!(e.contains("not a safetensors"), "{e}");
    }
}
