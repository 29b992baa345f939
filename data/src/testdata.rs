//! Test helpers: where the shared real data lives (`../shared/data` beside the repository).

use std::path::PathBuf;

/// The shared data directory: `$QEAN_SHARED_DATA`, else `<repo>/../shared/data`, else `/work/shared/data`.
pub fn shared_dir() -> PathBuf {
    if let Ok(p) = std::env::var("QEAN_SHARED_DATA") {
        return PathBuf::from(p);
    }
    let repo = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let beside = repo.join("../shared/data");
    if beside.is_dir() {
        return beside;
    }
    PathBuf::from("/work/shared/data")
}
