//! Logging for both binaries: `tracing` to stderr at warn (`-v` info, `-vv` debug); a filter in
//! `QEAN_LOG`, else `RUST_LOG`, wins (e.g. `QEAN_LOG=qean_train=debug`). The audio decoders' own
//! log lines are noise next to our one-line errors and stay off unless a filter asks for them.

/// Installs the subscriber (once; later calls do nothing).
pub fn init(verbose: u8) {
    let level = match verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_env("QEAN_LOG")
        .or_else(|_| tracing_subscriber::EnvFilter::try_from_default_env())
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(format!("{level},symphonia=off")));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .with_target(false)
        .try_init();
}
