//! qean-bench, `qean bench`: the speed and memory of every stage a researcher waits on, measured the same way
//! each time, optionally side by side with the peer implementations in `bench/peer/`:
//!
//! | id | what | peer |
//! |---|---|---|
//! | `features` | 35-D features of a 60 s track (decode, resample to 30720 Hz, features) | librosa 0.8.1 + resampy 0.2.2 |
//! | `metrics` | FID_k, FID_g, Dist_k, Dist_g, BeatAlign: 40 generated vs 1363 reference sequences | Bailando's protocol in numpy/scipy |
//! | `train-tiny`, `train-mint` | one FACT training step, batch 16 (forward, backward, Adam) | the same FACT in PyTorch (CPU) |
//! | `sample-tiny`, `sample-mint` | autoregressive sampling of 40 sequences, frames per second | the same loop in PyTorch |
//!
//! Each measure reports its median time over repeats (after a warm-up where it has one) and the
//! process's peak resident memory during it (Linux: VmHWM, reset through /proc/self/clear_refs).
//! Sampling costs the same for every frame (no cache: each step is a full pass over the window),
//! so it is timed over a few frames and reported as frames per second with the 40 × 1200 time it
//! implies.

mod measures;
mod peers;
mod report;
mod tsmt;

use std::path::PathBuf;

use qean_pipeline::error::Context;

pub use qean_pipeline::{Error, Result};

pub use measures::{run_measure, Inputs, MeasureId, Sizes};
pub use peers::{PeerCommand, Peers};
pub use report::{markdown, BenchReport, Entry, Machine, PeerResult};

/// What to run.
#[derive(Debug, Clone)]
pub struct BenchOptions {
    /// Measures to run, in order.
    pub measures: Vec<MeasureId>,
    /// Backends for the model measures (train, sample), each measured on its own.
    pub backends: Vec<String>,
    pub sizes: Sizes,
    /// Run the peers too (None: ours only).
    pub peers: Option<Peers>,
    /// Scratch directory for the inputs both sides read (the track, the metric set, configs).
    pub work_dir: PathBuf,
    /// Run each measure in a child process of this executable (`qean bench --child ...`), so its
    /// peak memory is its own; None: in this process (peaks then include what earlier measures
    /// left allocated).
    pub isolate: Option<PathBuf>,
}

impl BenchOptions {
    /// The default selection: everything, or with `quick` the measures that take seconds
    /// (no mint-size model) at reduced repeats.
    pub fn new(quick: bool, work_dir: PathBuf) -> Self {
        let measures = if quick {
            vec![
                MeasureId::Features,
                MeasureId::FeaturesDataset,
                MeasureId::Metrics,
                MeasureId::TrainTiny,
                MeasureId::SampleTiny,
            ]
        } else {
            MeasureId::ALL.to_vec()
        };
        BenchOptions {
            measures,
            backends: vec![qean_models::backend::DEFAULT_BACKEND.to_string()],
            sizes: Sizes::new(quick),
            peers: None,
            work_dir,
            isolate: None,
        }
    }
}

/// Runs the selected measures (and their peers); `progress` is told each step's label.
pub fn run(opts: &BenchOptions, mut progress: impl FnMut(&str)) -> crate::Result<BenchReport> {
    std::fs::create_dir_all(&opts.work_dir).map_err(|e| qean_io::Error::io(&opts.work_dir, e))?;
    let inputs = measures::Inputs::prepare(&opts.work_dir, &opts.sizes)?;
    let sizes_json = opts.work_dir.join(SIZES_FILE);
    let sizes = serde_json::to_string(&opts.sizes).context("the benchmark sizes")?;
    qean_io::fsutil::atomic_write(&sizes_json, sizes.as_bytes())?;
    let mut entries = Vec::new();
    for &id in &opts.measures {
        let backends: Vec<&str> = if id.uses_model() {
            opts.backends.iter().map(String::as_str).collect()
        } else {
            vec![""]
        };
        for backend in backends {
            let label = if backend.is_empty() {
                id.name().to_string()
            } else {
                format!("{} ({backend})", id.name())
            };
            progress(&label);
            let mut entry = match &opts.isolate {
                Some(exe) => run_child(exe, id, backend, &opts.work_dir)?,
                None => run_measure(id, backend, &inputs, &opts.sizes)?,
            };
            if let Some(peers) = &opts.peers {
                // One peer run per measure, not per backend.
                if backend == opts.backends[0] || backend.is_empty() {
                    progress(&format!("{label}: peer"));
                    match peers.run(id, &inputs, &opts.sizes) {
                        Ok(p) => entry.peer = Some(p),
                        Err(e) => {
                            tracing::warn!("{e}");
                            entry.peer_error = Some(format!("{e:#}"));
                        }
                    }
                }
            }
            entries.push(entry);
        }
    }
    Ok(BenchReport {
        machine: Machine::here(),
        sizes: opts.sizes.clone(),
        entries,
    })
}

/// The sizes a child process reads from the work directory.
const SIZES_FILE: &str = "sizes.json";

/// Runs one measure in a child process and reads its entry (the last line of its stdout).
fn run_child(
    exe: &std::path::Path,
    id: MeasureId,
    backend: &str,
    work_dir: &std::path::Path,
) -> crate::Result<Entry> {
    let out = std::process::Command::new(exe)
        .args([
            "bench",
            "--child",
            id.name(),
            "--child-backend",
            backend,
            "--work-dir",
        ])
        .arg(work_dir)
        .stderr(std::process::Stdio::inherit())
        .output()
        .with_context(|| format!("{}: cannot start the measure process", exe.display()))?;
    qean_pipeline::ensure!(
        out.status.success(),
        "the {} measure process failed ({})",
        id.name(),
        out.status
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    let line = stdout
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("");
    serde_json::from_str(line)
        .with_context(|| format!("the {} measure process printed no result", id.name()))
}

/// The child side of [`BenchOptions::isolate`]: one measure on the inputs of `work_dir`, its
/// entry printed as one JSON line.
pub fn run_child_measure(
    id: MeasureId,
    backend: &str,
    work_dir: &std::path::Path,
) -> crate::Result<String> {
    let sizes_path = work_dir.join(SIZES_FILE);
    let text =
        std::fs::read_to_string(&sizes_path).map_err(|e| qean_io::Error::io(&sizes_path, e))?;
    let sizes: Sizes =
        serde_json::from_str(&text).with_context(|| format!("{}", sizes_path.display()))?;
    // The parent prepared them; the child only needs their paths and the set.
    let inputs = measures::Inputs::open(work_dir, &sizes);
    let entry = run_measure(id, backend, &inputs, &sizes)?;
    serde_json::to_string(&entry).context("the benchmark entry")
}
