//! The VQ-VAE's rows (SPEC §13.2.1): pos72 frames with the run's `[vq]` options, normalised with the
//! statistics the run stores (`zscore`), and back.

use qean_config::vqvae::{VqConfig, VqNormalise};
use qean_motion::fk::FkRoot;
use qean_motion::motion::Motion;
use qean_motion::pos72::{joints_to_pos72, Pos72Options, POS72};

/// The pos72 options of a `[vq]` table.
pub fn pos72_options(c: &VqConfig) -> Pos72Options {
    Pos72Options {
        root: c.root,
        root_vel_scale: c.root_vel_scale,
    }
}

/// pos72 rows (f32) of a motion with the `[vq]` table's options.
pub fn motion_pos72(motion: &Motion, c: &VqConfig) -> Vec<f32> {
    pos72_rows(motion, &pos72_options(c))
}

/// pos72 rows (f32) of a motion: FK joints with the `smpl` root (SPEC §13.2.1).
pub fn pos72_rows(motion: &Motion, opts: &Pos72Options) -> Vec<f32> {
    joints_to_pos72(&motion.joints(FkRoot::Smpl), opts)
        .into_iter()
        .map(|v| v as f32)
        .collect()
}

/// Rows normalised in place with the table's statistics (`zscore`; no-op otherwise).
pub fn normalise(rows: &mut [f32], c: &VqConfig) {
    if c.normalise == VqNormalise::Zscore && c.mean.len() == POS72 {
        for row in rows.chunks_exact_mut(POS72) {
            for (k, v) in row.iter_mut().enumerate() {
                *v = ((*v as f64 - c.mean[k]) / c.std[k]) as f32;
            }
        }
    }
}

/// The inverse of [`normalise`].
pub fn denormalise(rows: &mut [f32], c: &VqConfig) {
    if c.normalise == VqNormalise::Zscore && c.mean.len() == POS72 {
        for row in rows.chunks_exact_mut(POS72) {
            for (k, v) in row.iter_mut().enumerate() {
                *v = (*v as f64 * c.std[k] + c.mean[k]) as f32;
            }
        }
    }
}
