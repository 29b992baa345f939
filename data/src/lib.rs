//! qean-data: everything before the model. AIST++ files and splits, motion layouts, rotations and SMPL
//! forward kinematics, audio features, and the synthetic AIST++-format generator. Plain f64/f32 Rust.

pub mod audio;
pub mod autoregress;
pub mod bvh;
pub mod dataset;
pub mod error;
pub mod export;
pub mod feature_cache;
pub mod fk;
pub mod fsutil;
pub mod inspect;
pub mod joints_file;
pub mod motion;
pub mod names;
pub mod npy;
pub mod pickle;
pub mod render;
pub mod rotation;
pub mod seam;
pub mod skeleton;
pub mod synth;
#[doc(hidden)]
pub mod testdata;
pub mod wav;
pub mod windows;

pub use error::{Error, Result};
pub use fk::FkRoot;
pub use motion::{Layout, Motion};
