//! qean-keyframes: a dance as keyframes plus in-betweens, after Lin's thesis (SPEC §12).
//!
//! - `measure`: the measure grid and its segments (§12.2);
//! - `even`, `onset_keys`, `dp`: keyframe strategies (§12.3 a, b, e); `nmfd` and `stems` give the onset
//!   curves of strategies c and d;
//! - `euler`, `slerp`, `bezier`: representations and in-betweens (§12.1, §12.4 a–b);
//! - `mse`: the reconstruction error of §12.5;
//! - `select`: one entry point from a strategy name to keys.

pub mod bezier;
pub mod dp;
pub mod edit;
pub mod euler;
pub mod even;
pub mod measure;
pub mod mse;
pub mod mt19937;
pub mod nmfd;
pub mod onset_keys;
pub mod options;
pub mod select;
pub mod slerp;
pub mod stems;

pub use options::KeyframeOptions;
