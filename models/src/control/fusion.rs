//! Text control (SPEC §13.7; seed 001, eq. 2): inside a text interval the head reads a mix of the two bases,
//! F_j = h^T_j (1 − w_j) + h^M_j w_j, with the music weight w falling from 1 outside the interval towards 0
//! inside it over a ramp of r tokens on each side, so the dance turns to the described move and back to the
//! music without a jump.

use burn::tensor::{Tensor, TensorData};
pub use qean_config::gpt::TextSchedule;

/// The token interval [s, e) of a frame interval [f_s, f_e) at `rate` frames per token: s = ⌊f_s/d⌋,
/// e = ⌈f_e/d⌉.
pub fn interval_tokens(f_s: usize, f_e: usize, rate: usize) -> (usize, usize) {
    (f_s / rate, f_e.div_ceil(rate))
}

/// The music weight w_j of tokens j = 0..n for a text interval [s, e): 1 outside; inside, with
/// u = min(j − s + 1, e − j) and t = min(u / (r + 1), 1), `linear` 1 − t, `cosine` (1 + cos πt)/2, `step`
/// 0. An interval shorter than 2r + 2 tokens never reaches 0; r = 0 is `step`.
pub fn fusion_weights(
    n: usize,
    s: usize,
    e: usize,
    ramp: usize,
    schedule: TextSchedule,
) -> Vec<f64> {
    (0..n)
        .map(|j| {
            if j < s || j >= e {
                return 1.0;
            }
            let u = (j - s + 1).min(e - j) as f64;
            let t = (u / (ramp as f64 + 1.0)).min(1.0);
            match schedule {
                TextSchedule::Linear => 1.0 - t,
                TextSchedule::Cosine => (1.0 + (std::f64::consts::PI * t).cos()) / 2.0,
                TextSchedule::Step => 0.0,
            }
        })
        .collect()
}

/// F = h^T (1 − w) + h^M w per position (eq. 2): `h_text` and `h_music` [B, n, D], `w` n weights.
pub fn fuse(h_text: Tensor<3>, h_music: Tensor<3>, w: &[f64]) -> Tensor<3> {
    let [_, n, _] = h_music.dims();
    assert_eq!(w.len(), n, "one weight per position");
    let w: Vec<f32> = w.iter().map(|&x| x as f32).collect();
    let w = Tensor::<1>::from_data(TensorData::new(w, [n]), &h_music.device()).reshape([1, n, 1]);
    h_text * (w.clone().neg() + 1.0) + h_music * w
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_weights_ramp_down_and_back_up() {
        // [2, 12), r = 4: u = 1, 2, 3, 4, 5, 5, 4, 3, 2, 1; t = u/5.
        let w = fusion_weights(14, 2, 12, 4, TextSchedule::Linear);
        let want = [
            1.0, 1.0, 0.8, 0.6, 0.4, 0.2, 0.0, 0.0, 0.2, 0.4, 0.6, 0.8, 1.0, 1.0,
        ];
        for (a, b) in w.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{w:?}");
        }
        // Too short to reach 0; r = 0 is a step.
        assert!(fusion_weights(10, 3, 7, 4, TextSchedule::Linear)
            .iter()
            .all(|&x| x > 0.0));
        assert_eq!(
            fusion_weights(6, 1, 4, 0, TextSchedule::Linear),
            fusion_weights(6, 1, 4, 0, TextSchedule::Step)
        );
        assert_eq!(interval_tokens(32, 52, 8), (4, 7));
    }

    /// SPEC §13.11 test 14: w ≡ 1 gives the music-only logits and w ≡ 0 the T-Base + head logits, exactly.
    #[test]
    fn all_music_or_all_text_weights_give_each_base_alone() {
        use crate::control::gpt::Gpt;
        use burn::tensor::{Device, Distribution, Int};
        use qean_config::gpt::GptConfig;
        let device = Device::flex();
        let c = GptConfig::tiny();
        let gpt = Gpt::new(&c, &device);
        let n = 6;
        let ids: Vec<i64> = (0..n as i64).map(|i| (i * 5) % c.codes as i64).collect();
        let tokens = Tensor::<2, Int>::from_data(TensorData::new(ids.clone(), [1, n]), &device);
        let music = Tensor::<3>::random(
            [1, n, crate::control::gpt::music_token_dim(&c)],
            Distribution::Normal(0.0, 1.0),
            &device,
        );
        let text = Tensor::<2>::random([1, c.text_dim], Distribution::Normal(0.0, 1.0), &device);
        let h_m = gpt.m_base.forward(tokens.clone(), music.clone());
        let context: Vec<usize> = ids[..n - 1].iter().map(|&t| t as usize).collect();
        let h_t = gpt.t_base.forward_context(text.clone(), &context);
        let data = |t: Tensor<3>| t.into_data().convert::<f32>().try_to_vec::<f32>().unwrap();
        let music_only = gpt.head.forward(fuse(h_t.clone(), h_m.clone(), &[1.0; 6]));
        assert_eq!(data(music_only), data(gpt.music_logits(tokens, music)));
        let text_only = gpt.head.forward(fuse(h_t, h_m, &[0.0; 6]));
        let t_in = Tensor::<2, Int>::from_data(
            TensorData::new(ids[..n - 1].to_vec(), [1, n - 1]),
            &device,
        );
        assert_eq!(data(text_only), data(gpt.text_logits(text, t_in)));
    }
}
