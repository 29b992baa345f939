//! The `qean` package's library: what the binary does beyond dispatching to the workspace crates.

pub mod eval_cli;
pub mod logging;
