//! Atomic file output: write to a temporary sibling, then rename, so readers and crashes never see a
//! half-written file.

use std::io::Write;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result};

/// The extension of `path`, lower-cased ("" when there is none): how every reader picks a format.
pub fn extension_lower(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

/// A temporary path next to `path` (same directory, so the final rename is atomic).
pub fn temp_sibling(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "out".into());
    let unique = format!(
        ".{name}.{}.{}.tmp",
        std::process::id(),
        std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map(|d| d.subsec_nanos())
            .unwrap_or(0)
    );
    path.with_file_name(unique)
}

/// The writer's process id in a [`temp_sibling`] name (`.NAME.PID.NANOS.tmp`).
fn temp_owner(name: &str) -> Option<u32> {
    let inner = name.strip_prefix('.')?.strip_suffix(".tmp")?;
    let mut fields = inner.rsplitn(3, '.');
    let _nanos = fields.next()?;
    fields.next()?.parse().ok()
}

/// Whether process `pid` is alive (Linux: /proc; elsewhere every process counts as alive, so
/// nothing is removed).
fn process_alive(pid: u32) -> bool {
    if pid == std::process::id() {
        return true;
    }
    if !Path::new("/proc/self").exists() {
        return true;
    }
    Path::new("/proc").join(pid.to_string()).exists()
}

/// Remove the temporaries that killed writers left in `dir` ([`temp_sibling`] names whose process
/// is gone); a live writer's temporary is left alone. Returns how many were removed.
pub fn clean_stale_temporaries(dir: &Path) -> Result<usize> {
    remove_temporaries(dir, |name| {
        temp_owner(name).is_some_and(|pid| !process_alive(pid))
    })
}

/// Remove every temporary (`.NAME….tmp`) in `dir`, whoever wrote it: for a directory this process
/// holds locked, where no other writer can be at work. Returns how many were removed.
pub fn clean_all_temporaries(dir: &Path) -> Result<usize> {
    remove_temporaries(dir, |name| name.starts_with('.') && name.ends_with(".tmp"))
}

/// Remove the files and directories in `dir` whose names `pick` accepts (none if `dir` is missing).
fn remove_temporaries(dir: &Path, pick: impl Fn(&str) -> bool) -> Result<usize> {
    if !dir.is_dir() {
        return Ok(0);
    }
    let mut n = 0;
    for e in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
        let e = e.map_err(|e| Error::io(dir, e))?;
        if !pick(&e.file_name().to_string_lossy()) {
            continue;
        }
        let p = e.path();
        let r = if p.is_dir() {
            std::fs::remove_dir_all(&p)
        } else {
            std::fs::remove_file(&p)
        };
        r.map_err(|err| Error::io(&p, err))?;
        n += 1;
    }
    Ok(n)
}

/// Write `bytes` to `path` atomically. The parent directory must exist.
pub fn atomic_write(path: &Path, bytes: &[u8]) -> Result<()> {
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
    if let Some(dir) = parent {
        if !dir.is_dir() {
            return Err(Error::at(dir, "output directory does not exist"));
        }
    }
    let tmp = temp_sibling(path);
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if let Err(e) = result {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::io(path, e));
    }
    Ok(())
}

/// Remove `dir` so that no half-deleted copy is ever visible under its name: rename it to a
/// temporary sibling first (one atomic step), then delete that. A kill during the deletion leaves
/// only the temporary, which [`clean_stale_temporaries`] (or a run directory's own cleaner) removes.
pub fn atomic_remove_dir(dir: &Path) -> Result<()> {
    let tmp = temp_sibling(dir);
    std::fs::rename(dir, &tmp).map_err(|e| Error::io(dir, e))?;
    std::fs::remove_dir_all(&tmp).map_err(|e| Error::io(&tmp, e))
}

/// Create `dir` by building it under a temporary name with `fill`, then renaming it into place.
/// If `fill` fails, nothing is left behind. `dir` must not exist yet.
pub fn atomic_dir<T>(dir: &Path, fill: impl FnOnce(&Path) -> Result<T>) -> Result<T> {
    if dir.exists() {
        return Err(Error::at(dir, "already exists (refusing to overwrite)"));
    }
    let parent = dir.parent().filter(|p| !p.as_os_str().is_empty());
    if let Some(p) = parent {
        if !p.is_dir() {
            return Err(Error::at(p, "parent directory does not exist"));
        }
    }
    let tmp = temp_sibling(dir);
    std::fs::create_dir(&tmp).map_err(|e| Error::io(&tmp, e))?;
    match fill(&tmp) {
        Ok(v) => {
            if let Err(e) = std::fs::rename(&tmp, dir) {
                let _ = std::fs::remove_dir_all(&tmp);
                return Err(Error::io(dir, e));
            }
            Ok(v)
        }
        Err(e) => {
            let _ = std::fs::remove_dir_all(&tmp);
            Err(e)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_remove_leaves_nothing_under_the_name() {
        let d = tempfile::tempdir().unwrap();
        let dir = d.path().join("step-3");
        std::fs::create_dir(&dir).unwrap();
        std::fs::write(dir.join("model.bpk"), b"w").unwrap();
        atomic_remove_dir(&dir).unwrap();
        assert!(!dir.exists());
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
        let e = atomic_remove_dir(&dir).unwrap_err().to_string();
        assert!(e.contains("step-3"), "{e}");
    }

    #[test]
    fn stale_temporaries_of_dead_writers_are_removed_live_ones_kept() {
        let d = tempfile::tempdir().unwrap();
        let mine = temp_sibling(&d.path().join("a.npy"));
        std::fs::write(&mine, b"being written").unwrap();
        // No process has id 4294967295 (Linux caps pids far below it).
        let dead = d.path().join(".b.npy.4294967295.123.tmp");
        std::fs::write(&dead, b"half").unwrap();
        let dead_dir = d.path().join(".step-3.4294967295.9.tmp");
        std::fs::create_dir(&dead_dir).unwrap();
        std::fs::write(d.path().join("c.npy"), b"whole").unwrap();
        std::fs::write(d.path().join(".hidden"), b"not ours").unwrap();
        let removed = clean_stale_temporaries(d.path()).unwrap();
        if Path::new("/proc/self").exists() {
            assert_eq!(removed, 2);
            assert!(!dead.exists() && !dead_dir.exists());
        }
        assert!(mine.exists());
        assert!(d.path().join("c.npy").exists() && d.path().join(".hidden").exists());
        assert_eq!(temp_owner(".x.npy.42.7.tmp"), Some(42));
        assert_eq!(temp_owner(".x.npy.tmp"), None);
        assert_eq!(clean_stale_temporaries(&d.path().join("none")).unwrap(), 0);
    }

    #[test]
    fn atomic_dir_leaves_nothing_on_failure() {
        let root = tempfile::tempdir().unwrap();
        let target = root.path().join("out");
        let r: Result<()> = atomic_dir(&target, |tmp| {
            std::fs::write(tmp.join("a.txt"), b"x").unwrap();
            Err(Error::msg("boom"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_dir(root.path()).unwrap().count(), 0);
        atomic_dir(&target, |tmp| {
            std::fs::write(tmp.join("a.txt"), b"x").map_err(|e| Error::io(tmp, e))
        })
        .unwrap();
        assert!(target.join("a.txt").is_file());
    }

    #[test]
    fn atomic_write_missing_dir() {
        let root = tempfile::tempdir().unwrap();
        let e = atomic_write(&root.path().join("nope/x.bin"), b"1").unwrap_err();
        assert!(e.to_string().contains("does not exist"));
    }
}
