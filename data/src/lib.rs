//! qean-data: everything before the model. AIST++ files and splits, motion layouts, rotations and SMPL
//! forward kinematics, audio features, and the synthetic AIST++-format generator. Plain f64/f32 Rust.

pub mod audio;
pub mod error;
pub mod names;

pub use error::{Error, Result};
