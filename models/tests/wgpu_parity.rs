//! The GPU path computes what the CPU path computes: for every tiny preset, the same weights and
//! inputs give the same forward output, loss and parameter gradients (within 1e-4) on flex and on
//! wgpu. Built only with `--features wgpu`; needs a Vulkan (or GL) adapter — on CPU-only machines
//! Mesa's lavapipe (Debian `mesa-vulkan-drivers`), which `.ci/run` installs.
//!
//! Dropout is set to 0: the two backends draw different random masks by design.
#![cfg(feature = "wgpu")]

use std::path::{Path, PathBuf};

use burn::module::{Module, ModuleVisitor, Param};
use burn::tensor::{Device, Tensor, TensorData};
use qean_config::model::load_model_config;
use qean_config::ModelConfig;
use qean_models::loss::motion_loss;
use qean_models::{backend, DanceModel};

const TOLERANCE: f64 = 1e-4;

fn preset(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../configs/tiny")
        .join(name)
}

fn values<const D: usize>(t: Tensor<D>) -> Vec<f64> {
    t.into_data().convert::<f64>().try_to_vec().unwrap()
}

/// Deterministic smooth inputs (no RNG, so both devices see identical values).
fn inputs(c: &ModelConfig, b: usize, device: &Device) -> (Tensor<3>, Tensor<3>, Tensor<3>) {
    let d = c.motion_dim();
    let wave = |n: usize, f: f64| -> Vec<f32> {
        (0..n)
            .map(|i| (0.6 * (f * i as f64).sin()) as f32)
            .collect()
    };
    let motion = wave(b * c.motion_len * d, 0.013);
    let audio = wave(b * c.audio_len * c.audio_dim, 0.071);
    let target = wave(b * c.target_len * d, 0.029);
    (
        Tensor::from_data(TensorData::new(motion, [b, c.motion_len, d]), device),
        Tensor::from_data(
            TensorData::new(audio, [b, c.audio_len, c.audio_dim]),
            device,
        ),
        Tensor::from_data(TensorData::new(target, [b, c.target_len, d]), device),
    )
}

/// Gradients of every float parameter, in visiting order.
struct GradCollector<'a> {
    grads: &'a burn::tensor::Gradients,
    out: Vec<Vec<f64>>,
}

impl ModuleVisitor for GradCollector<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        let g = param.val().grad(self.grads).map(values).unwrap_or_default();
        self.out.push(g);
    }
}

struct Pass {
    output: Vec<f64>,
    loss: f64,
    grads: Vec<Vec<f64>>,
}

fn run(config: &ModelConfig, weights: &Path, device: &Device) -> Pass {
    let model = DanceModel::new(config, device)
        .unwrap()
        .load_weights(weights)
        .unwrap();
    let (motion, audio, target) = inputs(config, 2, device);
    let out = model.forward_with_penalty(motion, audio);
    let mut loss = motion_loss(out.prediction.clone(), target);
    if let Some(p) = out.penalty {
        loss = loss + p;
    }
    let output = values(out.prediction);
    let loss_value = values(loss.clone())[0];
    let grads = loss.backward();
    let mut collector = GradCollector {
        grads: &grads,
        out: Vec::new(),
    };
    model.visit(&mut collector);
    Pass {
        output,
        loss: loss_value,
        grads: collector.out,
    }
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).fold(0.0, |m, (x, y)| m.max((x - y).abs()))
}

#[test]
fn every_tiny_variant_matches_between_flex_and_wgpu() {
    let gpu = match backend::device(backend::Backend::Wgpu) {
        Ok(d) => d,
        Err(e) => panic!("{e} (install a Vulkan driver, e.g. mesa-vulkan-drivers)"),
    };
    let dir = tempfile::tempdir().unwrap();
    for name in [
        "fact.toml",
        "baseline.toml",
        "spe.toml",
        "qra.toml",
        "full.toml",
    ] {
        // The preset's wiring and switches at small shapes: lavapipe runs shaders on the CPU.
        let mut config = load_model_config(&preset(name)).unwrap();
        config.dropout = 0.0;
        config.hidden = 32;
        config.heads = 4;
        config.ffn = 64;
        config.motion_len = 8;
        config.audio_len = 16;
        config.target_len = 4;
        let cpu = Device::flex();
        cpu.seed(11);
        let weights = DanceModel::new(&config, &cpu)
            .unwrap()
            .save_weights(&dir.path().join(name.replace(".toml", "")))
            .unwrap();
        let start = std::time::Instant::now();
        let a = run(&config, &weights, &cpu.autodiff());
        let b = run(&config, &weights, &gpu.clone().autodiff());
        let out_diff = max_diff(&a.output, &b.output);
        let loss_diff = (a.loss - b.loss).abs();
        assert_eq!(a.grads.len(), b.grads.len());
        let mut grad_diff: f64 = 0.0;
        let mut grad_max: f64 = 0.0;
        for (ga, gb) in a.grads.iter().zip(&b.grads) {
            assert!(!ga.is_empty(), "{name}: a parameter has no gradient");
            grad_diff = grad_diff.max(max_diff(ga, gb));
            grad_max = ga.iter().fold(grad_max, |m, x| m.max(x.abs()));
        }
        println!(
            "{name}: output Δ {out_diff:.2e}, loss {:.6} Δ {loss_diff:.2e}, {} gradients (max |g| {grad_max:.2e}) Δ {grad_diff:.2e}, {:.1} s",
            a.loss,
            a.grads.len(),
            start.elapsed().as_secs_f64()
        );
        assert!(
            out_diff <= TOLERANCE,
            "{name}: forward differs by {out_diff:e}"
        );
        assert!(
            loss_diff <= TOLERANCE,
            "{name}: loss differs by {loss_diff:e}"
        );
        assert!(
            grad_diff <= TOLERANCE,
            "{name}: gradients differ by {grad_diff:e}"
        );
    }
}
