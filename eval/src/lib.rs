//! qean-eval: the AIST++ dance metrics in plain f64, equal to the reference code's numbers
//! (Bailando `utils/metrics_new.py`, `utils/features/{kinetic,manual_new}.py`,
//! `utils/beat_align_score.py`; mint `tools/calculate_*_scores.py`), bugs included by default
//! (SPEC §7). Each report says which variants produced it.
//!
//! Entry points: [`evaluate`] (loaded joint sequences + a music-beat lookup → [`MetricsReport`]),
//! [`render_markdown`] (the paper-layout table), [`features_of`] and the per-metric modules for
//! single numbers, and [`cli`] for the `qean-eval` binary. File reading lives in [`io`] only.

pub mod beat_align;
pub mod cli;
pub mod config;
pub mod curves;
pub mod dist;
pub mod error;
pub mod fid;
pub mod geometric;
pub mod io;
pub mod kinetic;
pub mod motion_energy;
pub mod normalise;
pub mod positions;
pub mod protocol;
pub mod report;
pub mod run_eval;
pub mod synthetic;

pub use config::{
    BaSegment, BaVariant, EvalConfig, GeometricVariant, MetricsMode, MusicBeatSource, PositionMode,
};
pub use error::{Error, Result};
pub use motion_energy::{EnergyReference, MotionEnergy};
pub use positions::{Frame, Sequence, N_JOINTS};
pub use protocol::{evaluate, features_of, BeatLookup, Features};
pub use report::{render_markdown, MetricsReport, SequenceMetrics};
