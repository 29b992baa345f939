//! The `qean` package's library: what the binary does beyond dispatching to the workspace crates.

pub mod bench;
pub mod demo;
pub mod demo_genre;
pub mod demo_inbetween;
pub mod eval_cli;
pub mod keyframe_settings;
pub mod logging;
