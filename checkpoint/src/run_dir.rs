//! A run directory `R/`: `config.toml`, `metrics.csv`, `train.log`, `loss.png`, `checkpoints/step-N/`, and a
//! `lock` file so two processes never train into the same run.
//!
//! Checkpoints are written into a hidden temporary directory and renamed into place, so a kill at any moment
//! leaves either a complete `step-N` or nothing under that name; leftovers are removed when the run reopens.

use std::path::{Path, PathBuf};

use qean_io::error::{Error, Result};

pub const LOCK: &str = "lock";
pub const CHECKPOINTS: &str = "checkpoints";

/// Holds the run directory's lock until dropped.
#[derive(Debug)]
pub struct RunLock {
    path: PathBuf,
}

fn process_alive(pid: u32) -> bool {
    Path::new(&format!("/proc/{pid}")).exists()
}

impl RunLock {
    /// Take the lock of `run_dir`, refusing if a live process holds it; a stale lock (dead process) is taken over.
    pub fn acquire(run_dir: &Path) -> Result<RunLock> {
        let path = run_dir.join(LOCK);
        for _ in 0..2 {
            match std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(mut f) => {
                    use std::io::Write;
                    writeln!(f, "{}", std::process::id()).map_err(|e| Error::io(&path, e))?;
                    return Ok(RunLock { path });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let text = std::fs::read_to_string(&path).unwrap_or_default();
                    match text.trim().parse::<u32>() {
                        Ok(pid) if pid != std::process::id() && process_alive(pid) => {
                            return Err(Error::at(
                                run_dir,
                                format!("run directory is in use by process {pid} (remove {LOCK} if that is wrong)"),
                            ));
                        }
                        _ => {
                            tracing::warn!("removing stale lock {}", path.display());
                            let _ = std::fs::remove_file(&path);
                        }
                    }
                }
                Err(e) => return Err(Error::io(&path, e)),
            }
        }
        Err(Error::at(&path, "could not take the run lock"))
    }
}

impl Drop for RunLock {
    fn drop(&mut self) {
        let _ = std::fs::remove_file(&self.path);
    }
}

pub fn checkpoint_name(step: u64) -> String {
    format!("step-{step}")
}

/// Complete checkpoints of a run, by step (ascending). Hidden temporaries are ignored.
pub fn list_checkpoints(run_dir: &Path) -> Result<Vec<(u64, PathBuf)>> {
    let dir = run_dir.join(CHECKPOINTS);
    if !dir.is_dir() {
        return Ok(vec![]);
    }
    let mut out = Vec::new();
    for e in std::fs::read_dir(&dir).map_err(|e| Error::io(&dir, e))? {
        let e = e.map_err(|e| Error::io(&dir, e))?;
        let name = e.file_name().to_string_lossy().into_owned();
        if let Some(step) = name
            .strip_prefix("step-")
            .and_then(|s| s.parse::<u64>().ok())
        {
            if e.path().is_dir() {
                out.push((step, e.path()));
            }
        }
    }
    out.sort();
    Ok(out)
}

/// Remove temporaries left by interrupted atomic writes (checkpoints, metrics.csv, loss.png, config.toml).
pub fn clean_temporaries(run_dir: &Path) -> Result<usize> {
    // Temporaries of atomic writes live beside their target: checkpoint directories in checkpoints/,
    // metrics.csv, loss.png and config.toml in the run directory itself.
    // The run is locked by this process, so every temporary there is a killed writer's.
    let mut n = 0;
    for dir in [run_dir.join(CHECKPOINTS), run_dir.to_path_buf()] {
        n += qean_io::fsutil::clean_all_temporaries(&dir)?;
    }
    Ok(n)
}

/// Which checkpoints to delete: keep the last `keep_last` and the one with the best validation loss.
pub fn to_prune(checkpoints: &[(u64, Option<f64>)], keep_last: usize) -> Vec<u64> {
    let best = checkpoints
        .iter()
        .filter_map(|(s, v)| v.filter(|x| x.is_finite()).map(|x| (*s, x)))
        .min_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
        .map(|(s, _)| s);
    let mut steps: Vec<u64> = checkpoints.iter().map(|c| c.0).collect();
    steps.sort();
    let cut = steps.len().saturating_sub(keep_last.max(1));
    steps[..cut]
        .iter()
        .copied()
        .filter(|s| Some(*s) != best)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lock_refuses_a_live_holder_and_takes_over_a_dead_one() {
        let d = tempfile::tempdir().unwrap();
        let lock = RunLock::acquire(d.path()).unwrap();
        // Same process again: our own pid is treated as stale, so simulate another live process: pid 1.
        std::fs::write(d.path().join(LOCK), "1\n").unwrap();
        let e = RunLock::acquire(d.path()).unwrap_err();
        assert!(e.to_string().contains("in use by process 1"), "{e}");
        // A dead pid is taken over.
        std::fs::write(d.path().join(LOCK), "4000000000\n").unwrap();
        let l2 = RunLock::acquire(d.path()).unwrap();
        drop(l2);
        assert!(!d.path().join(LOCK).exists());
        drop(lock);
    }

    #[test]
    fn checkpoints_listing_and_pruning() {
        let d = tempfile::tempdir().unwrap();
        let c = d.path().join(CHECKPOINTS);
        for s in [100, 20, 300] {
            std::fs::create_dir_all(c.join(checkpoint_name(s))).unwrap();
        }
        std::fs::create_dir_all(c.join(".step-400.123.tmp")).unwrap();
        let steps: Vec<u64> = list_checkpoints(d.path())
            .unwrap()
            .iter()
            .map(|x| x.0)
            .collect();
        assert_eq!(steps, vec![20, 100, 300]);
        std::fs::write(d.path().join(".loss.png.77.12.tmp"), b"half").unwrap();
        std::fs::write(d.path().join("metrics.csv"), b"kept").unwrap();
        assert_eq!(clean_temporaries(d.path()).unwrap(), 2);
        assert!(d.path().join("metrics.csv").exists());
        assert!(!d.path().join(".loss.png.77.12.tmp").exists());
        let ck = [
            (10, Some(0.5)),
            (20, Some(0.2)),
            (30, Some(0.4)),
            (40, None),
            (50, Some(0.3)),
        ];
        assert_eq!(to_prune(&ck, 2), vec![10, 30]);
        assert_eq!(to_prune(&ck, 10), Vec::<u64>::new());
    }
}
