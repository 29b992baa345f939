//! Test helpers: f64 tensors and modules on a CPU device (BURN_NOTES "dtypes": values given to
//! `from_data` take the device's default F32 unless the creation options name F64).

use burn::module::{Module, ModuleMapper, Param};

use burn::tensor::{DType, Device, Distribution, Tensor, TensorCreationOptions, TensorData};
use qean_config::model::{Arch, ModelConfig};

/// Creation options for f64 tensors on `device`.
pub fn f64_options(device: &Device) -> TensorCreationOptions {
    TensorCreationOptions::new(device.clone()).with_dtype(DType::F64)
}

/// An f64 tensor from row-major values.
pub fn f64_tensor<const D: usize>(
    values: Vec<f64>,
    shape: [usize; D],
    device: &Device,
) -> Tensor<D> {
    Tensor::from_data(TensorData::new(values, shape), f64_options(device))
}

/// An f64 tensor of N(0, 1) values.
pub fn f64_normal<const D: usize>(shape: [usize; D], device: &Device) -> Tensor<D> {
    Tensor::random(shape, Distribution::Normal(0.0, 1.0), f64_options(device))
}

/// Values of a tensor of any rank as f64.
pub fn to_vec<const D: usize>(t: Tensor<D>) -> Vec<f64> {
    t.into_data().convert::<f64>().try_to_vec().unwrap()
}

/// Largest absolute difference between two tensors.
pub fn max_abs_diff<const D: usize>(a: Tensor<D>, b: Tensor<D>) -> f64 {
    assert_eq!(a.dims(), b.dims());
    to_vec(a)
        .iter()
        .zip(to_vec(b))
        .fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

struct CastF64;

impl ModuleMapper for CastF64 {
    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        param.map(|t| t.cast(DType::F64))
    }
}

/// The module with every float parameter cast to f64.
pub fn to_f64<M: Module>(module: M) -> M {
    module.map(&mut CastF64)
}

/// A model small enough for unit tests: width 16, 4 heads, MLP 32, layers 1-1-2, windows 6/10, 3
/// supervised frames; every other field at its default (mint's FACT, or QEAN with every switch off).
pub fn micro_config(arch: Arch) -> ModelConfig {
    ModelConfig {
        arch,
        hidden: 16,
        heads: 4,
        ffn: 32,
        motion_layers: 1,
        audio_layers: 1,
        cross_layers: 2,
        motion_len: 6,
        audio_len: 10,
        target_len: 3,
        ..ModelConfig::default()
    }
}
