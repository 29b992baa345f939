//! qean-eval: the AIST++ dance metrics in plain f64, equal to the reference code's numbers
//! (Bailando `utils/metrics_new.py`, `utils/features/{kinetic,manual_new}.py`,
//! `utils/beat_align_score.py`; mint `tools/calculate_*_scores.py`), bugs included by default
//! (SPEC §7). Each report says which variants produced it.
//!
//! Entry points: [`evaluate`] (loaded joint sequences + a music-beat lookup → [`MetricsReport`]),
//! [`render_markdown`] (the paper-layout table), [`features_of`] and the per-metric modules for
//! single numbers, [`dirs`] for directory mode, [`run_report`] for what checkpoint mode reports (the
//! sampling itself lives in `qean-pipeline`), [`curves`] for metrics against training steps. File reading
//! lives in [`io`] only. No Burn: this crate knows joint positions, not models.

pub mod beat_align;
pub mod config;
pub mod curves;
pub mod dirs;
pub mod dist;
pub mod diversity;
pub mod error;
pub mod fid;
pub mod geometric;
pub mod io;
pub mod keyframe_fidelity;
pub mod kinetic;
pub mod li_metrics;
pub mod motion_beats;
pub mod motion_energy;
pub mod normalise;
pub mod pfc;
pub mod plausibility;
pub mod positions;
pub mod preset;
pub mod protocol;
pub mod report;
pub mod run_report;
pub mod stats;
pub mod synthetic;

pub use config::{
    BaSegment, BaVariant, EvalConfig, GeometricVariant, MetricsMode, MusicBeatSource, PositionMode,
};
pub use error::{Error, Result};
pub use li_metrics::LiMetrics;
pub use motion_energy::{EnergyReference, MotionEnergy};
pub use pfc::PfcVariant;
pub use positions::{Frame, Sequence, N_JOINTS};
pub use protocol::{evaluate, features_of, BeatLookup, Features};
pub use report::{render_markdown, MetricsReport, SequenceMetrics};
