//! glTF export (`qean convert X --out X.glb|.gltf`) through the binary: a real AIST++ excerpt written both ways,
//! checked by the Khronos glTF validator (npm `gltf-validator`) when it is installed — .ci/run installs it into
//! target/gltf-validator; QEAN_REQUIRE_GLTF_VALIDATOR makes its absence a failure — and bad outputs end in one
//! line with nothing written. The joint-position round trip through the node transforms is
//! `render/src/gltf.rs`'s unit test.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::Command;

/// The directory holding `node_modules/gltf-validator`, if node and the validator are here.
fn validator() -> Option<PathBuf> {
    let dir = std::env::var_os("QEAN_GLTF_VALIDATOR_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("target/gltf-validator"));
    let node = Command::new("node")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    let found = node && dir.join("node_modules/gltf-validator").is_dir();
    if !found {
        assert!(
            std::env::var("QEAN_REQUIRE_GLTF_VALIDATOR").is_err(),
            "QEAN_REQUIRE_GLTF_VALIDATOR is set but node or {} is missing",
            dir.join("node_modules/gltf-validator").display()
        );
        eprintln!("skipping the Khronos validator: node or gltf-validator is not installed");
    }
    found.then_some(dir)
}

/// The validator's report: (errors, warnings).
fn validate(dir: &Path, file: &Path) -> (u64, u64, String) {
    let script = "const v = require('gltf-validator'); const fs = require('fs'); \
        v.validateBytes(new Uint8Array(fs.readFileSync(process.argv[1]))).then(r => \
        console.log(JSON.stringify(r.issues))).catch(e => { console.error(String(e)); process.exit(1); });";
    let out = Command::new("node")
        .current_dir(dir)
        .args(["-e", script])
        .arg(file)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    let issues: serde_json::Value = serde_json::from_str(&text).unwrap();
    (
        issues["numErrors"].as_u64().unwrap(),
        issues["numWarnings"].as_u64().unwrap(),
        text,
    )
}

#[test]
fn convert_writes_valid_gltf_and_refuses_bad_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let pkl = shared().join("aistpp/motions/softcat477_SMPL-to-FBX_sample.pkl");
    let validator = validator();
    for ext in ["glb", "gltf"] {
        let out = dir.path().join(format!("dance.{ext}"));
        let printed = run_ok(qean().arg("convert").arg(&pkl).arg("--out").arg(&out));
        assert!(printed.contains("frames"), "{printed}");
        let bytes = std::fs::read(&out).unwrap();
        if ext == "glb" {
            assert_eq!(&bytes[..4], b"glTF");
        } else {
            let doc: serde_json::Value = serde_json::from_slice(&bytes).unwrap();
            assert_eq!(doc["nodes"].as_array().unwrap().len(), 25);
            assert_eq!(doc["skins"][0]["joints"].as_array().unwrap().len(), 24);
            let times = &doc["accessors"][0];
            let frames = times["count"].as_u64().unwrap();
            let last = times["max"][0].as_f64().unwrap();
            assert!(
                (last - (frames - 1) as f64 / 60.0).abs() < 1e-6,
                "60 fps keys"
            );
        }
        if let Some(v) = &validator {
            let (errors, warnings, text) = validate(v, &out);
            assert_eq!((errors, warnings), (0, 0), "{text}");
        }
    }
    let missing = dir.path().join("no/such/dir/dance.glb");
    assert_clean_failure(
        qean().arg("convert").arg(&pkl).arg("--out").arg(&missing),
        "output directory does not exist",
    );
    assert!(!dir.path().join("no").exists());
}
