//! Kinetic features, 72-D (SPEC §7.2), after aist-api/Bailando `features/kinetic.py` and the helpers in
//! `features/utils.py`: per joint, the mean horizontal and vertical kinetic energy of the windowed
//! velocity and the mean energy expenditure |windowed acceleration|, over frames 1..T−1.

use crate::config::MetricsMode;
use crate::error::{Error, Result};
use crate::positions::{Frame, N_JOINTS};

pub const KINETIC_DIM: usize = 3 * N_JOINTS;
/// `KineticFeatures(frame_time=1./60)`: AIST++ is 60 FPS.
pub const FRAME_TIME: f64 = 1.0 / 60.0;
/// `sliding_window=2`: frames i−2..=i+2.
const WINDOW: usize = 2;
/// Fewer frames leave some window empty, where the reference divides by zero.
pub const MIN_FRAMES: usize = 4;

/// [KE_h, KE_v, EE] for each of the 24 joints, joint-major.
pub fn kinetic_features(joints: &[Frame], mode: MetricsMode) -> Result<Vec<f64>> {
    kinetic_features_at(joints, mode, FRAME_TIME)
}

/// [`kinetic_features`] with frame time `dt` (a protocol at another rate).
#[allow(clippy::needless_range_loop)] // j indexes the inner joint axis, as the reference loops do
pub fn kinetic_features_at(joints: &[Frame], mode: MetricsMode, dt: f64) -> Result<Vec<f64>> {
    let t = joints.len();
    if t < MIN_FRAMES {
        return Err(Error::Invalid(format!(
            "kinetic features need at least {MIN_FRAMES} frames, got {t}"
        )));
    }
    let mut out = Vec::with_capacity(KINETIC_DIM);
    // Per joint, the window terms once per k (the reference recomputes them for each i):
    // d[k] = p[k] − p[k−1] (k ≥ 1) and the acceleration a[k] (1 ≤ k ≤ T−2).
    let mut d = vec![[0.0; 3]; t];
    let mut acc = vec![[0.0; 3]; t];
    for j in 0..N_JOINTS {
        for k in 1..t {
            let (pk, pm) = (joints[k][j], joints[k - 1][j]);
            for a in 0..3 {
                d[k][a] = pk[a] - pm[a];
            }
            if k + 1 < t {
                let pp = joints[k + 1][j];
                for a in 0..3 {
                    let v2 = (pp[a] - pk[a]) / dt;
                    let v1 = match mode {
                        // `positions[k] - positions[k-1] / frame_time`: the precedence bug
                        // (Bailando issue #46, mint issue #62).
                        MetricsMode::Reference => pk[a] - pm[a] / dt,
                        MetricsMode::Corrected => (pk[a] - pm[a]) / dt,
                    };
                    acc[k][a] = (v2 - v1) / dt;
                }
            }
        }
        let (mut ke_h, mut ke_v, mut ee) = (0.0, 0.0, 0.0);
        for i in 1..t {
            // Window k = i−2..=i+2: velocity terms need k − 1 ≥ 0 and k < T
            // (calc_average_velocity_*), acceleration terms also k + 1 < T.
            let lo = i.saturating_sub(WINDOW).max(1);
            let hi_v = (i + WINDOW).min(t - 1);
            let hi_a = (i + WINDOW).min(t - 2);
            let mut vel = [0.0; 3];
            for dk in &d[lo..=hi_v] {
                for a in 0..3 {
                    vel[a] += dk[a];
                }
            }
            let scale = (hi_v + 1 - lo) as f64 * dt;
            let (vx, vy, vz) = (vel[0] / scale, vel[1] / scale, vel[2] / scale);
            ke_h += vx * vx + vz * vz;
            ke_v += vy * vy;
            if hi_a >= lo {
                let mut s = [0.0; 3];
                for ak in &acc[lo..=hi_a] {
                    for a in 0..3 {
                        s[a] += ak[a];
                    }
                }
                let n = (hi_a + 1 - lo) as f64;
                ee += ((s[0] / n).powi(2) + (s[1] / n).powi(2) + (s[2] / n).powi(2)).sqrt();
            }
        }
        let denom = (t - 1) as f64;
        out.extend_from_slice(&[ke_h / denom, ke_v / denom, ee / denom]);
    }
    Ok(out)
}
