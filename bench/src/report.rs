//! Results of `qean bench`: one entry per measure (and backend), the machine, the markdown table.

use serde::{Deserialize, Serialize};

use super::measures::{MeasureId, Sizes};

/// A peer's figure for one measure, in the entry's unit.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct PeerResult {
    /// Who: "librosa 0.8.1", "numpy protocol", "PyTorch 2.x".
    pub name: String,
    pub value: f64,
    pub peak_rss_mb: f64,
    pub detail: String,
}

/// One measure on one backend.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Entry {
    pub id: MeasureId,
    /// Backend of a model measure ("" otherwise).
    pub backend: String,
    /// The headline figure, in `unit`.
    pub value: f64,
    pub unit: String,
    /// Rates (frames/s) are better high, times low.
    pub higher_is_better: bool,
    pub peak_rss_mb: f64,
    pub detail: String,
    pub peer: Option<PeerResult>,
    /// Why the peer gave no figure (it failed to run).
    #[serde(default)]
    pub peer_error: Option<String>,
}

impl Entry {
    pub fn time(id: MeasureId, backend: &str, seconds: f64, unit: &str, detail: String) -> Entry {
        Entry {
            id,
            backend: backend.into(),
            value: seconds,
            unit: unit.into(),
            higher_is_better: false,
            peak_rss_mb: f64::NAN,
            detail,
            peer: None,
            peer_error: None,
        }
    }

    pub fn rate(id: MeasureId, backend: &str, rate: f64, unit: &str, detail: String) -> Entry {
        Entry {
            higher_is_better: true,
            ..Entry::time(id, backend, rate, unit, detail)
        }
    }

    /// Our time over the peer's time (below 1: we are faster).
    pub fn time_ratio(&self) -> Option<f64> {
        let peer = self.peer.as_ref()?;
        Some(if self.higher_is_better {
            peer.value / self.value
        } else {
            self.value / peer.value
        })
    }
}

/// Where the numbers were taken.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Machine {
    pub cpu: String,
    pub cores: usize,
    pub memory_gb: f64,
    pub date: String,
    pub qean_version: String,
}

impl Machine {
    pub fn here() -> Machine {
        let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
        let cpu = cpuinfo
            .lines()
            .find(|l| l.starts_with("model name"))
            .and_then(|l| l.split(':').nth(1))
            .map(|s| s.trim().to_string())
            .unwrap_or_else(|| std::env::consts::ARCH.to_string());
        let memory_gb = std::fs::read_to_string("/proc/meminfo")
            .ok()
            .and_then(|s| {
                let line = s.lines().find(|l| l.starts_with("MemTotal:"))?;
                line.split_whitespace().nth(1)?.parse::<f64>().ok()
            })
            .map_or(f64::NAN, |kb| kb / 1024.0 / 1024.0);
        Machine {
            cpu,
            cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            memory_gb,
            date: today(),
            qean_version: env!("CARGO_PKG_VERSION").to_string(),
        }
    }
}

/// UTC date as YYYY-MM-DD (civil-from-days, no date crate needed).
fn today() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let z = (secs / 86_400) as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}

/// The whole run.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct BenchReport {
    pub machine: Machine,
    pub sizes: Sizes,
    pub entries: Vec<Entry>,
}

/// Seconds as "850 ms", "12.3 s", "4.2 min" or "3.1 h".
pub fn duration_text(s: f64) -> String {
    if s < 1.0 {
        format!("{:.0} ms", s * 1e3)
    } else if s < 120.0 {
        format!("{s:.1} s")
    } else if s < 7200.0 {
        format!("{:.1} min", s / 60.0)
    } else {
        format!("{:.1} h", s / 3600.0)
    }
}

fn value_text(v: f64, unit: &str) -> String {
    if unit.starts_with("s ") {
        duration_text(v)
    } else if v >= 100.0 {
        format!("{v:.0} {unit}")
    } else {
        format!("{v:.2} {unit}")
    }
}

fn mb(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.0} MiB")
    } else {
        "-".into()
    }
}

/// The table of docs/performance.md: one row per entry, with the peer and the ratio.
pub fn markdown(report: &BenchReport) -> String {
    let m = &report.machine;
    let mut s = format!(
        "Machine: {}, {} cores, {:.0} GB; {}; qean {}.\n\n",
        m.cpu, m.cores, m.memory_gb, m.date, m.qean_version
    );
    s.push_str(
        "| measure | backend | ours | peak RSS | peer | peer value | peer peak RSS | time ours/peer | speed-up |\n\
         |---|---|---|---|---|---|---|---|---|\n",
    );
    for e in &report.entries {
        let (peer, pv, prss) = match &e.peer {
            Some(p) => (
                p.name.clone(),
                value_text(p.value, &e.unit),
                mb(p.peak_rss_mb),
            ),
            None => ("-".into(), "-".into(), "-".into()),
        };
        let (ratio, speedup) = match e.time_ratio() {
            Some(r) => (format!("{r:.3}"), format!("{:.1}×", 1.0 / r)),
            None => ("-".into(), "-".into()),
        };
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} |\n",
            e.id.name(),
            if e.backend.is_empty() {
                "-"
            } else {
                &e.backend
            },
            value_text(e.value, &e.unit),
            mb(e.peak_rss_mb),
            peer,
            pv,
            prss,
            ratio,
            speedup
        ));
    }
    s.push('\n');
    for e in &report.entries {
        let backend = if e.backend.is_empty() {
            String::new()
        } else {
            format!(" ({})", e.backend)
        };
        s.push_str(&format!("- {}{backend}: {}.", e.id.name(), e.detail));
        if let Some(p) = &e.peer {
            s.push_str(&format!(" Peer: {}.", p.detail));
        }
        if let Some(err) = &e.peer_error {
            s.push_str(&format!(" Peer failed: {err}"));
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ratios_follow_the_unit() {
        let mut t = Entry::time(MeasureId::Features, "", 0.5, "s per track", String::new());
        assert_eq!(t.time_ratio(), None);
        t.peer = Some(PeerResult {
            name: "librosa".into(),
            value: 20.0,
            peak_rss_mb: 100.0,
            detail: String::new(),
        });
        assert!((t.time_ratio().unwrap() - 0.025).abs() < 1e-12);
        let mut r = Entry::rate(
            MeasureId::SampleTiny,
            "flex",
            80.0,
            "frames/s",
            String::new(),
        );
        r.peer = Some(PeerResult {
            name: "PyTorch".into(),
            value: 40.0,
            peak_rss_mb: 100.0,
            detail: String::new(),
        });
        // Twice the frames per second is half the time.
        assert!((r.time_ratio().unwrap() - 0.5).abs() < 1e-12);
        let table = markdown(&BenchReport {
            machine: Machine::here(),
            sizes: Sizes::new(true),
            entries: vec![t, r],
        });
        assert!(table.contains("| features | - | 500 ms |"), "{table}");
        assert!(table.contains("| 0.025 | 40.0× |"), "{table}");
        assert!(
            table.contains("| sample-tiny | flex | 80.00 frames/s |"),
            "{table}"
        );
    }

    #[test]
    fn dates_and_durations() {
        let d = today();
        assert_eq!(d.len(), 10);
        assert!(d.starts_with("20"), "{d}");
        assert_eq!(duration_text(0.25), "250 ms");
        assert_eq!(duration_text(12.34), "12.3 s");
        assert_eq!(duration_text(600.0), "10.0 min");
    }
}
