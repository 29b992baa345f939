//! qean-motion: motion math on the SMPL skeleton. Rotations (axis-angle, matrices, projection onto SO(3)),
//! the skeleton's offsets and parents, forward kinematics, AIST++ motion files and the model's vector layouts
//! (225 / 219), FineDance's 6-D rotation rows (`finedance`), BVH, joint-position files, HumanML3D-layout joints (`humanml`), inverse kinematics from joint positions (`ik`), the seam that eases a generated dance out of its seed, the floor a decoded dance is pinned to (`floor`), and the 3-vector helpers they share (`vec3`).

pub mod bvh;
pub mod finedance;
pub mod fk;
pub mod floor;
pub mod humanml;
pub mod ik;
pub mod joints_file;
pub mod motion;
pub mod pos72;
pub mod rotation;
pub mod seam;
pub mod skeleton;
pub mod smooth;
pub mod vec3;

pub use fk::FkRoot;
pub use motion::{Layout, Motion};
