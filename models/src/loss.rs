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

/// Mean squared error of the `order`-th temporal differences (1: velocity, 2: acceleration) of
/// the first T predicted frames against the target's, over B × (T − order) × D. A recipe option
/// (issue 17): an L2 loss on poses alone lets uncertain futures shrink towards a still mean pose.
pub fn difference_loss(prediction: Tensor<3>, target: Tensor<3>, order: usize) -> Tensor<1> {
    let [_, t, _] = target.dims();
    assert!(
        order >= 1 && t > order,
        "difference_loss: {t} frames, order {order}"
    );
    let diff = |x: Tensor<3>| {
        let mut x = x;
        for _ in 0..order {
            let n = x.dims()[1];
            x = x.clone().narrow(1, 1, n - 1) - x.narrow(1, 0, n - 1);
        }
        x
    };
    (diff(target) - diff(prediction.narrow(1, 0, t)))
        .square()
        .mean()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{f64_normal, to_vec};
    use burn::tensor::Device;

    #[test]
    fn difference_loss_matches_a_loop() {
        let device = Device::flex();
        let pred = f64_normal([2, 9, 3], &device);
        let target = f64_normal([2, 6, 3], &device);
        let (p, t) = (to_vec(pred.clone()), to_vec(target.clone()));
        for order in [1usize, 2] {
            let got = to_vec(difference_loss(pred.clone(), target.clone(), order))[0];
            let mut want = 0.0;
            let mut n = 0.0;
            for b in 0..2 {
                for i in 0..6 - order {
                    for d in 0..3 {
                        let pv = |k: usize| p[(b * 9 + k) * 3 + d];
                        let tv = |k: usize| t[(b * 6 + k) * 3 + d];
                        let (dp, dt) = if order == 1 {
                            (pv(i + 1) - pv(i), tv(i + 1) - tv(i))
                        } else {
                            (
                                pv(i + 2) - 2.0 * pv(i + 1) + pv(i),
                                tv(i + 2) - 2.0 * tv(i + 1) + tv(i),
                            )
                        };
                        want += (dp - dt).powi(2);
                        n += 1.0;
                    }
                }
            }
            assert!((got - want / n).abs() < 1e-12, "order {order}");
        }
        // A prediction that is the target plus a constant has no velocity error.
        let shifted = target.clone() + 0.3;
        assert!(to_vec(difference_loss(shifted, target, 1))[0].abs() < 1e-12);
    }

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
