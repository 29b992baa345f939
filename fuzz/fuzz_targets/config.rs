//! TOML run configs (with `extends` chains, which may point at the file itself) and sweep files.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    let path = common::scratch("config.toml", data);
    let _ = qean_config::RunConfig::load(&path, &[]);
    let _ = qean_config::sweep::plan(&path, Some(std::path::Path::new("/nonexistent")), &[]);
});
