//! TSMT's training loss (SPEC §11.7 step 2; the reference's `maskedCrossEntropy`): the cross-entropy
//! of every coordinate's bin, summed over valid steps and coordinates and divided by
//! (#valid steps · n). Padded steps contribute nothing.

use burn::tensor::activation::log_softmax;
use burn::tensor::{Int, Tensor, TensorData};

/// logits [B, T, n, C], targets [B, T, n] (bins; anything on padded steps), `lengths` valid steps
/// per row → the masked mean cross-entropy, [1].
pub fn masked_cross_entropy(
    logits: Tensor<4>,
    targets: Tensor<3, Int>,
    lengths: &[usize],
) -> Tensor<1> {
    let [b, t, n, c] = logits.dims();
    let device = logits.device();
    let mask: Vec<f32> = lengths
        .iter()
        .flat_map(|&len| (0..t).map(move |s| (s < len) as u8 as f32))
        .collect();
    let valid: usize = lengths.iter().map(|&l| l.min(t)).sum();
    let mask = Tensor::<4>::from_data(TensorData::new(mask, [b, t, 1, 1]), &device);
    // Padded targets may hold the padding class C: point them at bin 0 (masked out anyway).
    let targets = targets.clamp(0, c as i64 - 1).reshape([b, t, n, 1]);
    let picked = log_softmax(logits, 3).gather(3, targets) * mask;
    picked.sum().neg().div_scalar((valid.max(1) * n) as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::tensor::Device;

    #[test]
    fn equals_a_hand_computed_masked_mean() {
        let device = Device::flex();
        // B 2, T 3, n 2, C 3; row 1 has 2 valid steps.
        let (b, t, n, c) = (2, 3, 2, 3);
        let logits: Vec<f32> = (0..b * t * n * c)
            .map(|i| ((i * 7 % 11) as f32) * 0.3 - 1.0)
            .collect();
        let targets: Vec<i64> = (0..b * t * n).map(|i| (i * 5 % 3) as i64).collect();
        let lengths = [3, 2];
        let mut want = 0.0f64;
        for r in 0..b {
            for s in 0..lengths[r] {
                for d in 0..n {
                    let row = &logits[((r * t + s) * n + d) * c..][..c];
                    let lse = row.iter().map(|&x| (x as f64).exp()).sum::<f64>().ln();
                    want -= row[targets[(r * t + s) * n + d] as usize] as f64 - lse;
                }
            }
        }
        want /= (5 * n) as f64;
        let mut padded_targets = targets.clone();
        // A padded step's target may be the padding class: it must not matter.
        for d in 0..n {
            padded_targets[(t + 2) * n + d] = c as i64;
        }
        let got = masked_cross_entropy(
            Tensor::from_data(TensorData::new(logits.clone(), [b, t, n, c]), &device),
            Tensor::from_data(TensorData::new(padded_targets, [b, t, n]), &device),
            &lengths,
        )
        .into_scalar::<f32>() as f64;
        assert!((got - want).abs() < 1e-5, "{got} vs {want}");
        // Changing a padded step's logits changes nothing.
        let mut moved = logits;
        for x in &mut moved[(t + 2) * n * c..(t + 3) * n * c] {
            *x += 9.0;
        }
        let again = masked_cross_entropy(
            Tensor::from_data(TensorData::new(moved, [b, t, n, c]), &device),
            Tensor::from_data(TensorData::new(targets, [b, t, n]), &device),
            &lengths,
        )
        .into_scalar::<f32>() as f64;
        assert_eq!(again, got);
    }
}
