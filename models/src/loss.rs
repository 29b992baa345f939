//! The training loss (mint fact_model.py `compute_motion_generation_loss`, SPEC §5.3):
//! L = mean((target − prediction[:, 0..T])²) over B × T × D, T = 20 target frames, every
//! feature included (the zero pad dims of the 225 layout too).

use burn::tensor::Tensor;

/// prediction [B, N, D], target [B, T, D] with T ≤ N → mean squared error over the first T
/// output tokens.
pub fn motion_loss(prediction: Tensor<3>, target: Tensor<3>) -> Tensor<1> {
    let [b, t, d] = target.dims();
    let [pb, n, pd] = prediction.dims();
    assert!(
        b == pb && d == pd && t <= n,
        "motion_loss: prediction {:?} does not cover target {:?}",
        [pb, n, pd],
        [b, t, d]
    );
    (target - prediction.narrow(1, 0, t)).square().mean()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{f64_normal, to_vec};
    use burn::tensor::Device;

    #[test]
    fn loss_reads_only_the_first_target_tokens() {
        // SPEC §9 item 8: the loss touches only tokens 0..20.
        let device = Device::flex().autodiff();
        let pred = f64_normal([2, 30, 5], &device).require_grad();
        let target = f64_normal([2, 20, 5], &device);
        let loss = motion_loss(pred.clone(), target.clone());
        // Value: mean over 2·20·5 squared differences.
        let (p, t) = (to_vec(pred.clone()), to_vec(target.clone()));
        let mut want = 0.0;
        for b in 0..2 {
            for i in 0..20 {
                for d in 0..5 {
                    want += (t[(b * 20 + i) * 5 + d] - p[(b * 30 + i) * 5 + d]).powi(2);
                }
            }
        }
        want /= 200.0;
        assert!((to_vec(loss.clone())[0] - want).abs() < 1e-12);
        // Gradient: nonzero on tokens 0..20, exactly zero on 20..30.
        let grads = loss.backward();
        let g = to_vec(pred.grad(&grads).unwrap());
        for b in 0..2 {
            for i in 0..30 {
                let row = &g[(b * 30 + i) * 5..(b * 30 + i + 1) * 5];
                if i < 20 {
                    assert!(row.iter().any(|x| *x != 0.0));
                } else {
                    assert!(row.iter().all(|x| *x == 0.0), "token {i} has gradient");
                }
            }
        }
    }
}
