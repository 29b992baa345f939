//! TSMT's training loss (SPEC §11.7 step 2; the reference's `maskedCrossEntropy`): the cross-entropy
//! of every coordinate's bin, summed over valid steps and coordinates and divided by
//! (#valid steps · n). Padded steps contribute nothing. With `tsmt.target_sigma` > 0 (ours, not the
//! paper's) each target is a Gaussian over the neighbouring bins instead of one bin.

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

/// The masked cross-entropy against soft targets: each target bin k spread as a Gaussian of SD `sigma`
/// bins over k − R..k + R (R = ⌈3σ⌉, weights renormalised over the bins that exist). σ = 0 is
/// [`masked_cross_entropy`]. Bins that are neighbours in space become neighbours in the loss, so a
/// prediction one bin off costs little: the model learns the bins' order instead of C unrelated classes.
pub fn smoothed_cross_entropy(
    logits: Tensor<4>,
    targets: Tensor<3, Int>,
    lengths: &[usize],
    sigma: f64,
) -> Tensor<1> {
    if sigma <= 0.0 {
        return masked_cross_entropy(logits, targets, lengths);
    }
    let [b, t, n, c] = logits.dims();
    let device = logits.device();
    let radius = (3.0 * sigma).ceil() as i64;
    let taps = (2 * radius + 1) as usize;
    let kernel: Vec<f64> = (-radius..=radius)
        .map(|o| (-(o * o) as f64 / (2.0 * sigma * sigma)).exp())
        .collect();
    let k: Vec<i64> = targets
        .into_data()
        .convert::<i64>()
        .try_to_vec::<i64>()
        .expect("integer targets");
    let mut index = Vec::with_capacity(k.len() * taps);
    let mut weight = Vec::with_capacity(k.len() * taps);
    for (i, &bin) in k.iter().enumerate() {
        let row = i / (t * n);
        let step = (i / n) % t;
        let valid = step < lengths[row];
        let bin = bin.clamp(0, c as i64 - 1);
        let total: f64 = (-radius..=radius)
            .zip(&kernel)
            .filter(|(o, _)| (0..c as i64).contains(&(bin + o)))
            .map(|(_, w)| w)
            .sum();
        for (o, w) in (-radius..=radius).zip(&kernel) {
            let j = bin + o;
            let inside = (0..c as i64).contains(&j);
            index.push(j.clamp(0, c as i64 - 1));
            weight.push(if inside && valid {
                (w / total) as f32
            } else {
                0.0
            });
        }
    }
    let valid: usize = lengths.iter().map(|&l| l.min(t)).sum();
    let index = Tensor::<4, Int>::from_data(TensorData::new(index, [b, t, n, taps]), &device);
    let weight = Tensor::<4>::from_data(TensorData::new(weight, [b, t, n, taps]), &device);
    let picked = log_softmax(logits, 3).gather(3, index) * weight;
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

    #[test]
    fn smoothed_targets_equal_a_hand_computed_mean_and_sigma_zero_is_the_paper() {
        let device = Device::flex();
        let (b, t, n, c) = (1, 2, 1, 8);
        let logits: Vec<f32> = (0..b * t * n * c)
            .map(|i| ((i * 5 % 7) as f32) * 0.4 - 1.0)
            .collect();
        // Step 0 targets bin 0 (an edge: only its right neighbours exist), step 1 bin 4; one valid step
        // plus a padded one in a second call.
        let targets = vec![0i64, 4];
        let sigma = 0.8;
        let lt =
            |v: &[f32]| Tensor::<4>::from_data(TensorData::new(v.to_vec(), [b, t, n, c]), &device);
        let tt =
            || Tensor::<3, Int>::from_data(TensorData::new(targets.clone(), [b, t, n]), &device);
        let mut want = 0.0f64;
        for (s, &k) in targets.iter().enumerate() {
            let row = &logits[s * c..(s + 1) * c];
            let lse = row.iter().map(|&x| (x as f64).exp()).sum::<f64>().ln();
            let w: Vec<f64> = (0..c)
                .map(|j| {
                    let o = j as f64 - k as f64;
                    if o.abs() <= 3.0 {
                        (-o * o / (2.0 * sigma * sigma)).exp()
                    } else {
                        0.0
                    }
                })
                .collect();
            let total: f64 = w.iter().sum();
            want -= (0..c)
                .map(|j| w[j] / total * (row[j] as f64 - lse))
                .sum::<f64>();
        }
        want /= 2.0;
        let got =
            smoothed_cross_entropy(lt(&logits), tt(), &[2], sigma).into_scalar::<f32>() as f64;
        assert!((got - want).abs() < 1e-5, "{got} vs {want}");
        let plain = masked_cross_entropy(lt(&logits), tt(), &[1]).into_scalar::<f32>();
        assert_eq!(
            smoothed_cross_entropy(lt(&logits), tt(), &[1], 0.0).into_scalar::<f32>(),
            plain
        );
        // A padded step contributes nothing.
        let one =
            smoothed_cross_entropy(lt(&logits), tt(), &[1], sigma).into_scalar::<f32>() as f64;
        let mut moved = logits.clone();
        for x in &mut moved[c..] {
            *x += 3.0;
        }
        let again =
            smoothed_cross_entropy(lt(&moved), tt(), &[1], sigma).into_scalar::<f32>() as f64;
        assert_eq!(one, again);
    }
}
