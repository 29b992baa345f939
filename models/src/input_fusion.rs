//! QEAN §3.2 read literally (`input_fusion = quaternion_254`, experimental; SPEC §4.7): the
//! audio branch embeds each window frame's joint [music | motion] vector as quaternions.
//!
//! 1. u_t = [audio_t (35) | 219-D motion_t if t < 120, else 0] for the 240 audio frames (music
//!    first, in the order the paper lists it).
//! 2. u_t[0..252) = 63 interleaved quaternions (4 consecutive dims = r, i, j, k); the last two
//!    dims (R_23[2,1], R_23[2,2]) are dropped, as the paper's 254 = 4·63 + 2 implies.
//! 3. Reordered to QuaternionLinear's block layout [r | i | j | k], then
//!    QuaternionLinear(63 → C/4 quaternions) = C features. Replaces Dense(35 → C).

use burn::config::Config;
use burn::module::Module;
use burn::tensor::{Device, Tensor};

use crate::quaternion_linear::{QuaternionLinear, QuaternionLinearConfig};

/// Width of the 219-D motion layout, the part of the frame vector the paper fuses.
const MOTION_219: usize = 219;

/// Configuration of [`QuaternionFusion`].
#[derive(Config, Debug)]
pub struct QuaternionFusionConfig {
    /// Audio features per frame (35).
    pub audio_dim: usize,
    /// Output width C (divisible by 4).
    pub hidden: usize,
}

/// The literal 254 → 63-quaternion input embedding.
#[derive(Module, Debug)]
pub struct QuaternionFusion {
    /// QuaternionLinear(63 → C/4).
    pub linear: QuaternionLinear,
    quaternions: usize,
}

impl QuaternionFusionConfig {
    /// Quaternions kept per frame: floor((audio_dim + 219) / 4) = 63.
    pub fn quaternions(&self) -> usize {
        (self.audio_dim + MOTION_219) / 4
    }

    /// Builds the layer.
    pub fn init(&self, device: &Device) -> QuaternionFusion {
        QuaternionFusion {
            linear: QuaternionLinearConfig::new(self.quaternions(), self.hidden / 4).init(device),
            quaternions: self.quaternions(),
        }
    }
}

impl QuaternionFusion {
    /// The block-layout quaternion input [B, La, 4·63] of the window.
    /// audio [B, La, A]; motion [B, Lm, 225 or 219] (Lm ≤ La; frames t ≥ Lm get zero motion).
    pub fn frame_quaternions(&self, audio: Tensor<3>, motion: Tensor<3>) -> Tensor<3> {
        let [b, la, _] = audio.dims();
        let [_, lm, dm] = motion.dims();
        // The 219-D layout: drop mint's six leading pad zeros when given 225-D motion.
        let motion = motion.narrow(2, dm - MOTION_219, MOTION_219);
        let motion = if lm < la {
            let pad =
                Tensor::<3>::zeros([b, la - lm, MOTION_219], (&audio.device(), audio.dtype()));
            Tensor::cat(vec![motion, pad], 1)
        } else {
            motion
        };
        let q = self.quaternions;
        Tensor::cat(vec![audio, motion], 2)
            .narrow(2, 0, 4 * q)
            .reshape([b, la, q, 4])
            .swap_dims(2, 3)
            .reshape([b, la, 4 * q])
    }

    /// audio [B, La, A], motion [B, Lm, D] → [B, La, C].
    pub fn forward(&self, audio: Tensor<3>, motion: Tensor<3>) -> Tensor<3> {
        self.linear.forward(self.frame_quaternions(audio, motion))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{f64_tensor, to_vec};

    #[test]
    fn frames_become_block_layout_quaternions() {
        let device = Device::flex();
        let fusion = QuaternionFusionConfig::new(35, 8).init(&device);
        assert_eq!(fusion.quaternions, 63);
        let (la, lm) = (3, 2);
        // audio value 1000·t + f, motion (225-D) value −(1000·t + f) with the pad dims at 0.
        let audio: Vec<f64> = (0..la)
            .flat_map(|t| (0..35).map(move |f| (1000 * t + f) as f64))
            .collect();
        let motion: Vec<f64> = (0..lm)
            .flat_map(|t| (0..225).map(move |f| if f < 6 { 0.0 } else { -((1000 * t + f) as f64) }))
            .collect();
        let u = to_vec(fusion.frame_quaternions(
            f64_tensor(audio, [1, la, 35], &device),
            f64_tensor(motion, [1, lm, 225], &device),
        ));
        let at = |t: usize, i: usize| u[t * 252 + i];
        // Frame 1: quaternion q = 0 is u[0..4] = audio 0..3: r block holds u[0], i block u[1].
        assert_eq!(at(1, 0), 1000.0);
        assert_eq!(at(1, 63), 1001.0);
        assert_eq!(at(1, 126), 1002.0);
        assert_eq!(at(1, 189), 1003.0);
        // u[36] (q = 9, real) is motion dim 1 of the 219-D layout = 225-D dim 7.
        assert_eq!(at(1, 9), -1007.0);
        // Frame 2 has no motion: u[36] is zero; u[34] (q = 8, j part) is audio 34.
        assert_eq!(at(2, 9), 0.0);
        assert_eq!(at(2, 126 + 8), 2034.0);
        assert_eq!(at(1, 189 + 8), -1006.0);
        // The last kept value u[251] (q = 62, k) is 219-D dim 216 = 225-D dim 222.
        assert_eq!(at(0, 189 + 62), -222.0);
    }
}
