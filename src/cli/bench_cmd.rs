//! `qean bench`: speed and peak memory of features, metrics, training and sampling.

use std::path::PathBuf;

use clap::Args;
use qean_bench::{self as bench, BenchOptions, MeasureId, Peers};

/// Measure the speed and peak memory of every stage: 35-D features of a 60 s track, the five
/// metrics on 40 generated vs 1363 reference sequences, one FACT training step (batch 16, tiny and
/// mint size) and batched autoregressive sampling of 40 sequences (frames per second, tiny and mint
/// size); and Li et al.'s TSMT at the paper's size: one training step (batch 32) and sampling of 40
/// and 1 sequences with the KV cache and with full recomputation (60 frames/s is real time).
/// Release builds only give meaningful numbers (`cargo run --release -- bench`).
///
/// With --peers, each measure is repeated by its peer in bench/peer/ on the same inputs (librosa
/// 0.8.1, Bailando's metric protocol in numpy, the same FACT in PyTorch) and the table shows the ratio.
/// On 2 cores the full run takes about 4 minutes, 7 with peers (mint-size steps take half a minute
/// each); --quick (tiny model only, fewer repeats) takes about 15 seconds without peers.
///
/// Examples:
///   qean bench --quick
///   qean bench --only train-tiny,sample-tiny --backends flex,wgpu
///   qean bench --only train-tsmt,sample-tsmt
///   qean bench --peers --torch-python torch/bin/python --librosa-python lr/bin/python --json b.json
#[derive(Args, Debug)]
#[command(verbatim_doc_comment)]
#[command(about = "Measure the speed and memory of every stage, with peers side by side")]
pub struct BenchArgs {
    /// Only the tiny model, fewer repeats.
    #[arg(long)]
    pub quick: bool,
    /// Measures to run (comma-separated): features (one track), features-dataset (a dataset's tracks side
    /// by side, as `qean features --dataset`), metrics, train-tiny, train-mint, sample-tiny, sample-mint,
    /// train-tsmt, sample-tsmt. Default: all (with --quick: the five that take seconds).
    #[arg(long, value_delimiter = ',')]
    pub only: Vec<String>,
    /// Backends for the model measures, each measured (flex; ndarray and wgpu in builds with their
    /// cargo features).
    #[arg(long, value_delimiter = ',', default_value = "flex")]
    pub backends: Vec<String>,
    /// Also run the peers in bench/peer/ and report ours/peer ratios.
    #[arg(long)]
    pub peers: bool,
    /// Directory holding the peer scripts.
    #[arg(long, default_value = "bench/peer")]
    pub peer_dir: PathBuf,
    /// Python with librosa 0.8.1 + resampy 0.2.2 (features peer).
    #[arg(long, default_value = "python3", env = "QEAN_LIBROSA_PYTHON")]
    pub librosa_python: String,
    /// Python with numpy + scipy (metrics peer).
    #[arg(long, default_value = "python3", env = "QEAN_NUMPY_PYTHON")]
    pub numpy_python: String,
    /// Python with PyTorch (training and sampling peers).
    #[arg(long, default_value = "python3", env = "QEAN_TORCH_PYTHON")]
    pub torch_python: String,
    /// Timed sampling frames for the tiny model (default 30, --quick 5).
    #[arg(long)]
    pub sample_frames: Option<usize>,
    /// Timed training steps for the tiny model (default 10, --quick 3).
    #[arg(long)]
    pub train_steps: Option<usize>,
    /// Write the results as JSON here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the markdown table here (as in docs/performance.md).
    #[arg(long)]
    pub markdown: Option<PathBuf>,
    /// Scratch directory for the inputs (default: a temporary directory, removed afterwards).
    #[arg(long)]
    pub work_dir: Option<PathBuf>,
    /// Run every measure in this process (peak memory then includes earlier measures' leftovers).
    #[arg(long)]
    pub in_process: bool,
    /// Internal: run one measure in a child process and print its entry as JSON.
    #[arg(long, hide = true, requires = "work_dir")]
    pub child: Option<String>,
    /// Internal: the child's backend.
    #[arg(long, hide = true, default_value = "")]
    pub child_backend: String,
}

pub fn bench(a: BenchArgs) -> anyhow::Result<()> {
    if let (Some(name), Some(dir)) = (&a.child, &a.work_dir) {
        let id = MeasureId::parse(name)
            .ok_or_else(|| anyhow::anyhow!("--child: unknown measure `{name}`"))?;
        println!("{}", bench::run_child_measure(id, &a.child_backend, dir)?);
        return Ok(());
    }
    let temp;
    let work_dir = match &a.work_dir {
        Some(d) => d.clone(),
        None => {
            temp = tempfile::tempdir()?;
            temp.path().to_path_buf()
        }
    };
    let mut opts = BenchOptions::new(a.quick, work_dir);
    if !a.only.is_empty() {
        opts.measures = a
            .only
            .iter()
            .map(|s| {
                MeasureId::parse(s.trim()).ok_or_else(|| {
                    let names: Vec<&str> = MeasureId::ALL.iter().map(|m| m.name()).collect();
                    anyhow::anyhow!(
                        "--only: unknown measure `{s}` (expected {})",
                        names.join(", ")
                    )
                })
            })
            .collect::<anyhow::Result<_>>()?;
    }
    for b in &a.backends {
        qean_models::backend::device_named(b).map_err(|e| anyhow::anyhow!("--backends: {e}"))?;
    }
    opts.backends = a.backends.clone();
    if !a.in_process {
        opts.isolate = Some(std::env::current_exe()?);
    }
    if let Some(n) = a.sample_frames {
        opts.sizes.sample_frames_tiny = n.max(1);
    }
    if let Some(n) = a.train_steps {
        opts.sizes.train_steps_tiny = n.max(1);
    }
    if a.peers {
        anyhow::ensure!(
            a.peer_dir.join("fact_torch.py").is_file(),
            "{}: no peer scripts here (run from the repository root or pass --peer-dir)",
            a.peer_dir.display()
        );
        opts.peers = Some(Peers {
            script_dir: std::fs::canonicalize(&a.peer_dir)?,
            librosa_python: a.librosa_python.clone(),
            numpy_python: a.numpy_python.clone(),
            torch_python: a.torch_python.clone(),
        });
    }
    if cfg!(debug_assertions) {
        eprintln!(
            "warning: a debug build; run `cargo run --release -- bench` for meaningful numbers"
        );
    }
    let report = bench::run(&opts, |label| eprintln!("bench: {label}"))?;
    let table = bench::markdown(&report);
    print!("{table}");
    if let Some(p) = &a.json {
        qean_io::fsutil::atomic_write(p, serde_json::to_string_pretty(&report)?.as_bytes())?;
    }
    if let Some(p) = &a.markdown {
        qean_io::fsutil::atomic_write(p, table.as_bytes())?;
    }
    Ok(())
}
