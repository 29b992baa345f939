//! Li et al.'s Two-Stream Motion Transformer (SPEC §11): binned joint coordinates ([`bins`]), the
//! causal two-stream model ([`model`]), its masked cross-entropy ([`loss`]) and how one bin is drawn
//! when sampling ([`draw`]), and how drawn bins become coordinates ([`decode`]).

pub mod bins;
pub mod coarse;
pub mod decode;
pub mod draw;
pub mod loss;
pub mod model;
pub mod sample;

pub use bins::{coords_to_joints, pose_coords, Bins};
pub use model::{Tsmt, TsmtCache, TsmtInput};
