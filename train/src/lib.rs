//! qean-train: training FACT and QEAN from TOML run configs — LR schedules, metrics logs, run directories with
//! locking and atomic checkpoints.

pub mod metrics_log;
pub mod plot;
pub mod run_dir;
pub mod schedule;
