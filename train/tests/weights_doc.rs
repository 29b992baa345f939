//! docs/weights.md lists every tensor of the FACT and QEAN presets with its shape, and is exactly
//! what `export::weights_doc` generates (`QEAN_BLESS=1` rewrites it).

use std::path::Path;

use burn::tensor::Device;
use qean_models::params::parameter_shapes;
use qean_models::DanceModel;
use qean_train::export::{table_lists, weights_doc, DOCUMENTED_PRESETS};

#[test]
fn weights_doc_lists_every_tensor_of_every_preset() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let configs = root.join("configs");
    let doc_path = root.join("docs/weights.md");
    let generated = weights_doc(&configs).unwrap();
    if std::env::var("QEAN_BLESS").is_ok() {
        std::fs::write(&doc_path, &generated).unwrap();
    }
    let doc = std::fs::read_to_string(&doc_path).unwrap();
    assert!(
        doc == generated,
        "docs/weights.md is out of date: QEAN_BLESS=1 cargo test --workspace --test weights_doc"
    );
    for (file, _) in DOCUMENTED_PRESETS {
        let config = qean_config::model::load_model_config(&configs.join(file)).unwrap();
        let section = doc
            .split(&format!("## `configs/{file}`"))
            .nth(1)
            .unwrap()
            .split("\n## ")
            .next()
            .unwrap();
        let shapes = parameter_shapes(&DanceModel::new(&config, &Device::flex()).unwrap());
        assert!(shapes.len() > 50, "{file}");
        for p in shapes {
            assert!(
                table_lists(section, &p.name, &p.shape),
                "{file}: {} {:?} not listed",
                p.name,
                p.shape
            );
        }
    }
}
