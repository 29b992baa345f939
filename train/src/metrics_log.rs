//! `R/metrics.csv`: one row per logged step (step, lr, loss, val_loss, seconds). On resume from step N the rows
//! after N are dropped first, so a resumed run's file equals an uninterrupted run's (up to wall-clock seconds).

use std::io::Write;
use std::path::{Path, PathBuf};

use qean_io::error::{Error, Result};

pub const HEADER: &str = "step,lr,loss,val_loss,seconds";

/// One row of metrics.csv.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub step: u64,
    pub lr: f64,
    pub loss: Option<f64>,
    pub val_loss: Option<f64>,
    pub seconds: f64,
}

impl Row {
    fn to_line(&self) -> String {
        // Shortest round-trip forms: the values read back bit-exact.
        let opt = |x: Option<f64>| x.map(|v| format!("{v:e}")).unwrap_or_default();
        format!(
            "{},{:e},{},{},{:.3}",
            self.step,
            self.lr,
            opt(self.loss),
            opt(self.val_loss),
            self.seconds
        )
    }

    fn parse(line: &str) -> Option<Row> {
        let f: Vec<&str> = line.split(',').collect();
        if f.len() != 5 {
            return None;
        }
        let opt = |s: &str| {
            if s.is_empty() {
                Some(None)
            } else {
                s.parse().ok().map(Some)
            }
        };
        Some(Row {
            step: f[0].parse().ok()?,
            lr: f[1].parse().ok()?,
            loss: opt(f[2])?,
            val_loss: opt(f[3])?,
            seconds: f[4].parse().ok()?,
        })
    }
}

/// Read every row of a metrics file.
pub fn read(path: &Path) -> Result<Vec<Row>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate().skip(1) {
        if line.trim().is_empty() {
            continue;
        }
        rows.push(
            Row::parse(line)
                .ok_or_else(|| Error::at(path, format!("malformed row at line {}", i + 1)))?,
        );
    }
    Ok(rows)
}

/// Like [`read`], but a malformed last line (a row cut short by a kill) is dropped.
fn read_tolerant(path: &Path) -> Result<Vec<Row>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let lines: Vec<&str> = text
        .lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .collect();
    let mut rows = Vec::new();
    for (i, line) in lines.iter().enumerate() {
        match Row::parse(line) {
            Some(r) => rows.push(r),
            None if i + 1 == lines.len() => {
                tracing::warn!("{}: dropping a partial last row", path.display())
            }
            None => return Err(Error::at(path, format!("malformed row at line {}", i + 2))),
        }
    }
    Ok(rows)
}

/// Appends rows to metrics.csv.
pub struct MetricsLog {
    path: PathBuf,
    file: std::fs::File,
}

impl MetricsLog {
    /// Open for a run that has completed `resume_step` updates (0 for a fresh run): rows with a larger step are
    /// removed (atomically) before appending.
    pub fn open(path: &Path, resume_step: u64) -> Result<MetricsLog> {
        let keep: Vec<Row> = if path.exists() {
            read_tolerant(path)?
                .into_iter()
                .filter(|r| r.step <= resume_step)
                .collect()
        } else {
            vec![]
        };
        let mut text = String::from(HEADER);
        text.push('\n');
        for r in &keep {
            text.push_str(&r.to_line());
            text.push('\n');
        }
        qean_io::fsutil::atomic_write(path, text.as_bytes())?;
        let file = std::fs::OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(|e| Error::io(path, e))?;
        Ok(MetricsLog {
            path: path.to_path_buf(),
            file,
        })
    }

    pub fn append(&mut self, row: &Row) -> Result<()> {
        writeln!(self.file, "{}", row.to_line()).map_err(|e| Error::io(&self.path, e))?;
        self.file.flush().map_err(|e| Error::io(&self.path, e))
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(step: u64, loss: f64) -> Row {
        Row {
            step,
            lr: 1e-4,
            loss: Some(loss),
            val_loss: if step.is_multiple_of(20) {
                Some(loss * 2.0)
            } else {
                None
            },
            seconds: step as f64 * 0.1,
        }
    }

    #[test]
    fn resume_truncates_later_rows() {
        let d = tempfile::tempdir().unwrap();
        let p = d.path().join("metrics.csv");
        let mut log = MetricsLog::open(&p, 0).unwrap();
        for s in (10..=50).step_by(10) {
            log.append(&row(s, 1.0 / s as f64)).unwrap();
        }
        drop(log);
        let rows = read(&p).unwrap();
        assert_eq!(rows.len(), 5);
        assert_eq!(rows[1].val_loss, Some(2.0 / 20.0));
        let mut log = MetricsLog::open(&p, 30).unwrap();
        log.append(&row(40, 0.5)).unwrap();
        let rows = read(&p).unwrap();
        assert_eq!(
            rows.iter().map(|r| r.step).collect::<Vec<_>>(),
            vec![10, 20, 30, 40]
        );
        assert_eq!(rows[3].loss, Some(0.5));
        // Losses survive the text round trip exactly enough to compare runs.
        assert_eq!(rows[0].loss, Some(0.1));
    }
}
