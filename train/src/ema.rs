//! An exponential moving average of the weights (Polyak averaging; EDGE samples from one, decay 0.9999):
//! after every update `ema ← d·ema + (1 − d)·θ`, with the warm-up `d_t = min(d, (1 + t)/(10 + t))` at update
//! `t` so that the first, random weights fade fast. The average never feeds back into training: the run's
//! trajectory is the same with and without it, and `ema.bpk` is what validation, sampling and evaluation use.

use std::collections::HashMap;

use burn::module::{Module, ModuleMapper, ModuleVisitor, Param, ParamId};
use burn::tensor::{Bool, Int, Tensor};

/// The decay applied after update number `step` (1-based) for a configured `decay`.
pub fn decay_at(decay: f64, step: u64) -> f64 {
    decay.min((1.0 + step as f64) / (10.0 + step as f64))
}

/// Every parameter of a module, flattened, by id.
#[derive(Default)]
struct Collect {
    float: HashMap<ParamId, Tensor<1>>,
    int: HashMap<ParamId, Tensor<1, Int>>,
    bool: HashMap<ParamId, Tensor<1, Bool>>,
}

impl ModuleVisitor for Collect {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let t = param.val();
        let n = t.shape().num_elements();
        self.float.insert(param.id, t.reshape([n]));
    }
    fn visit_int<const D: usize>(&mut self, param: &Param<Tensor<D, Int>>) {
        let t = param.val();
        let n = t.shape().num_elements();
        self.int.insert(param.id, t.reshape([n]));
    }
    fn visit_bool<const D: usize>(&mut self, param: &Param<Tensor<D, Bool>>) {
        let t = param.val();
        let n = t.shape().num_elements();
        self.bool.insert(param.id, t.reshape([n]));
    }
}

/// Mixes each float parameter with the collected one; integer and boolean state is copied.
struct Mix {
    current: Collect,
    decay: f32,
}

impl ModuleMapper for Mix {
    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        let cur = self
            .current
            .float
            .remove(&param.id)
            .expect("the average and the model share parameter ids");
        let d = self.decay;
        param.map(|e| {
            let dims = e.dims();
            e.mul_scalar(d).add(cur.reshape(dims).mul_scalar(1.0 - d))
        })
    }
    fn map_int<const D: usize>(&mut self, param: Param<Tensor<D, Int>>) -> Param<Tensor<D, Int>> {
        let Some(cur) = self.current.int.remove(&param.id) else {
            return param;
        };
        param.map(|e| cur.reshape(e.dims()))
    }
    fn map_bool<const D: usize>(
        &mut self,
        param: Param<Tensor<D, Bool>>,
    ) -> Param<Tensor<D, Bool>> {
        let Some(cur) = self.current.bool.remove(&param.id) else {
            return param;
        };
        param.map(|e| cur.reshape(e.dims()))
    }
}

/// `ema` moved towards `model` by one update: `ema` and `model` must share parameter ids (the average
/// starts as `model.valid()`, and ids survive updates). `model` is read without autodiff.
pub fn update<M: Module>(ema: M, model: &M, decay: f64) -> M {
    let mut current = Collect::default();
    model.valid().visit(&mut current);
    let mut mix = Mix {
        current,
        decay: decay as f32,
    };
    let ema = ema.map(&mut mix);
    assert!(
        mix.current.float.is_empty(),
        "every parameter of the model has its average"
    );
    ema
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::nn::{Linear, LinearConfig};
    use burn::tensor::Device;

    fn weights(l: &Linear) -> Vec<f32> {
        l.weight.val().into_data().try_to_vec::<f32>().unwrap()
    }

    #[test]
    fn warm_up_then_the_configured_decay() {
        assert!((decay_at(0.999, 1) - 2.0 / 11.0).abs() < 1e-12);
        assert!((decay_at(0.999, 100) - 101.0 / 110.0).abs() < 1e-12);
        assert_eq!(decay_at(0.999, 1_000_000), 0.999);
        assert_eq!(decay_at(0.0, 5), 0.0);
    }

    #[test]
    fn the_average_moves_towards_the_model_by_one_minus_decay() {
        let device = Device::default();
        let a: Linear = LinearConfig::new(3, 2).init(&device);
        // b: a's weights + 1 everywhere, same ids.
        struct AddOne;
        impl ModuleMapper for AddOne {
            fn map_float<const D: usize>(&mut self, p: Param<Tensor<D>>) -> Param<Tensor<D>> {
                p.map(|t| t.add_scalar(1.0))
            }
        }
        let b = a.clone().map(&mut AddOne);
        let mixed = update(a.clone(), &b, 0.75);
        for (m, x) in weights(&mixed).iter().zip(weights(&a)) {
            assert!((m - (x + 0.25)).abs() < 1e-6, "{m} vs {x} + 0.25");
        }
        // Decay 0 copies the model; decay 1 keeps the average.
        let copied = update(a.clone(), &b, 0.0);
        assert_eq!(weights(&copied), weights(&b));
        let kept = update(a.clone(), &b, 1.0);
        assert_eq!(weights(&kept), weights(&a));
    }
}
