//! The genre classifier's rows (SPEC §13.10): pos72 frames with the default options.

use qean_motion::motion::Motion;
use qean_motion::pos72::Pos72Options;

/// pos72 rows (f32, default options) of a motion.
pub fn pos72_rows(motion: &Motion) -> Vec<f32> {
    crate::vqvae::pos72_rows(motion, &Pos72Options::default())
}
