//! Logs of a run: `tracing` events go to `R/train.log` (info and above, no colours) and to stderr
//! (warnings, or what `QEAN_LOG` asks for).

use std::fs::File;
use std::sync::Mutex;

use tracing_subscriber::filter::{EnvFilter, LevelFilter};
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::Layer;

/// Target of events that go to train.log only.
pub const FILE_ONLY: &str = "qean_file_only";

/// A subscriber writing to `file` and stderr (used for the duration of one run).
pub fn subscriber(file: File) -> impl tracing::Subscriber + Send + Sync {
    let to_file = tracing_subscriber::fmt::layer()
        .with_writer(Mutex::new(file))
        .with_ansi(false)
        .with_target(false)
        .with_filter(LevelFilter::INFO);
    // Events with target FILE_ONLY (the final error of a run, which the CLI prints itself) skip stderr.
    let stderr_filter = EnvFilter::try_from_env("QEAN_LOG")
        .unwrap_or_else(|_| EnvFilter::new("warn"))
        .add_directive(
            format!("{FILE_ONLY}=off")
                .parse()
                .expect("static directive"),
        );
    let to_stderr = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stderr)
        .with_target(false)
        .with_filter(stderr_filter);
    tracing_subscriber::registry().with(to_file).with(to_stderr)
}
