//! qean-io: the file formats and file operations every other crate shares. Python pickles (a safe VM for
//! AIST++ files, and a writer), `.npy` arrays, PCM WAV, atomic writes and directories, and the error type
//! that names the file a problem is about. No dependencies beyond std.

pub mod error;
pub mod fsutil;
pub mod npy;
pub mod pickle;
#[doc(hidden)]
pub mod testdata;
pub mod wav;

pub use error::{Error, Result};
