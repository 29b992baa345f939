//! The shipped presets (configs/): parameter counts, output shapes, and that every tiny preset
//! overfits one fixed batch (loss down 100×). The overfit tests are meant for release builds
//! (`cargo test --release -p qean-models`); in debug builds they are ignored.

use std::path::{Path, PathBuf};
use std::time::Instant;

use burn::module::Module;
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::{Device, Tensor, TensorData};
use qean_config::ModelConfig;
use qean_models::inspect::{formula_param_count, inspect};
use qean_models::loss::motion_loss;
use qean_models::DanceModel;

fn preset(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../configs")
        .join(name)
}

#[test]
fn paper_presets_have_the_spec_parameter_counts() {
    for (name, want) in [
        ("fact.toml", 120_406_977),
        ("qean/baseline.toml", 120_406_977),
        ("qean/spe.toml", 120_118_977),
        ("qean/qra.toml", 121_637_313),
        ("qean/full.toml", 121_349_313),
    ] {
        let report = inspect(&preset(name)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(report.params, want, "{name}");
        assert_eq!(formula_param_count(&report.config), want, "{name}");
        assert!(report.summary.contains("parameters:"), "{}", report.summary);
    }
    let full = inspect(&preset("qean/full.toml")).unwrap();
    assert_eq!(full.config.heads, 16);
    assert_eq!(full.config.dropout, 0.1);
    println!("{}", full.summary);
}

#[test]
fn mint_fact_output_is_batch_by_360_by_225() {
    let config = inspect(&preset("fact.toml")).unwrap().config;
    let device = Device::flex();
    device.seed(1);
    let model = DanceModel::new(&config, &device).unwrap();
    let motion = Tensor::<3>::zeros([1, 120, 225], &device);
    let audio = Tensor::<3>::zeros([1, 240, 35], &device);
    let out = model.forward(motion, audio);
    assert_eq!(out.dims(), [1, 360, 225]);
}

/// A fixed smooth batch: motion frames are sums of sinusoids (pad dims zero), the target the
/// next `target_len` frames, audio a different set of sinusoids.
fn batch(c: &ModelConfig, batch: usize, device: &Device) -> (Tensor<3>, Tensor<3>, Tensor<3>) {
    let d = c.motion_dim();
    let pad = d - 219;
    let frame = |b: usize, t: usize| -> Vec<f32> {
        (0..d)
            .map(|k| {
                if k < pad {
                    return 0.0;
                }
                let f = 0.02 + 0.01 * (k % 5) as f64;
                let phase = 0.7 * k as f64 + 1.3 * b as f64;
                (0.8 * (f * t as f64 + phase).sin()) as f32
            })
            .collect()
    };
    let motion: Vec<f32> = (0..batch)
        .flat_map(|b| (0..c.motion_len).flat_map(move |t| frame(b, t)))
        .collect();
    let target: Vec<f32> = (0..batch)
        .flat_map(|b| (0..c.target_len).flat_map(move |t| frame(b, c.motion_len + t)))
        .collect();
    let audio: Vec<f32> = (0..batch * c.audio_len * c.audio_dim)
        .map(|i| ((i as f64 * 0.37).sin() * 0.5) as f32)
        .collect();
    (
        Tensor::from_data(TensorData::new(motion, [batch, c.motion_len, d]), device),
        Tensor::from_data(
            TensorData::new(audio, [batch, c.audio_len, c.audio_dim]),
            device,
        ),
        Tensor::from_data(TensorData::new(target, [batch, c.target_len, d]), device),
    )
}

/// Trains on one batch; returns (initial loss, final loss, steps, seconds). Losses are measured
/// without dropout (`valid()`), training runs with the preset's dropout.
fn overfit(name: &str) -> (f64, f64, usize, f64) {
    let config = qean_config::model::load_model_config(&preset(name)).unwrap();
    let device = Device::flex().autodiff();
    device.seed(7);
    let mut model = DanceModel::new(&config, &device).unwrap();
    let (motion, audio, target) = batch(&config, 2, &device);
    let eval = |model: &qean_models::DanceModel| -> f64 {
        let plain = Device::flex();
        let m = Tensor::<3>::from_data(motion.to_data(), &plain);
        let a = Tensor::<3>::from_data(audio.to_data(), &plain);
        let t = Tensor::<3>::from_data(target.to_data(), &plain);
        motion_loss(model.valid().forward(m, a), t).into_scalar::<f32>() as f64
    };
    let initial = eval(&model);
    let mut optim = AdamConfig::new().with_epsilon(1e-8).init();
    let start = Instant::now();
    let max_steps = 400;
    let mut steps = 0;
    let mut last = initial;
    while steps < max_steps {
        let out = model.forward_with_penalty(motion.clone(), audio.clone());
        let mut loss = motion_loss(out.prediction, target.clone());
        if let Some(p) = out.penalty {
            loss = loss + p;
        }
        let grads = GradientsParams::from_grads(loss.backward(), &model);
        let lr = if steps < 300 { 1e-3 } else { 3e-4 };
        model = optim.step(lr, model, grads);
        steps += 1;
        if steps % 25 == 0 {
            last = eval(&model);
            if last < initial / 100.0 {
                break;
            }
        }
    }
    (initial, last, steps, start.elapsed().as_secs_f64())
}

fn assert_overfits(name: &str) {
    let (initial, last, steps, secs) = overfit(name);
    println!(
        "{name}: loss {initial:.4e} → {last:.4e} (×{:.0}) in {steps} steps, {secs:.1} s",
        initial / last
    );
    assert!(
        last < initial / 100.0,
        "{name}: loss fell only ×{:.1} ({initial:.3e} → {last:.3e})",
        initial / last
    );
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug: run with --release")]
fn tiny_fact_overfits_one_batch() {
    assert_overfits("tiny/fact.toml");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug: run with --release")]
fn tiny_baseline_overfits_one_batch() {
    assert_overfits("tiny/baseline.toml");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug: run with --release")]
fn tiny_spe_overfits_one_batch() {
    assert_overfits("tiny/spe.toml");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug: run with --release")]
fn tiny_qra_overfits_one_batch() {
    assert_overfits("tiny/qra.toml");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug: run with --release")]
fn tiny_full_overfits_one_batch() {
    assert_overfits("tiny/full.toml");
}

/// SPEC §11.6: `qean inspect` of the TSMT presets.
#[test]
fn tsmt_presets_have_the_spec_parameter_counts() {
    for (name, want) in [("tsmt/paper.toml", 1_419_388), ("tsmt/tiny.toml", 37_524)] {
        let report = inspect(&preset(name)).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(report.params, want, "{name}");
        assert!(report.summary.contains("TSMT"), "{}", report.summary);
        println!("{}", report.summary);
    }
}

/// SPEC §11.13.12: tiny TSMT overfits one batch (masked CE below 0.05 within 2000 steps): two
/// 64-frame windows of smooth binned motion with their MFCC rows and beats.
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug: run with --release")]
fn tiny_tsmt_overfits_one_batch() {
    use burn::tensor::Int;
    use qean_models::tsmt::loss::masked_cross_entropy;
    use qean_models::tsmt::{Tsmt, TsmtInput};
    let c = qean_config::RunConfig::load(&preset("tsmt/tiny.toml"), &[])
        .unwrap()
        .tsmt();
    let (b, w, n, bins) = (2, c.window, c.coords(), c.n_bins as i64);
    let device = Device::flex().autodiff();
    device.seed(7);
    let mut model = Tsmt::new(&c, &device);
    let token = |r: usize, t: usize, d: usize| -> i64 {
        let x = (0.05 * t as f64 + 0.9 * d as f64 + 1.7 * r as f64).sin();
        ((x + 1.0) / 2.0 * (bins - 1) as f64).round() as i64
    };
    let tokens: Vec<i64> = (0..b)
        .flat_map(|r| (0..w).flat_map(move |t| (0..n).map(move |d| token(r, t, d))))
        .collect();
    let targets: Vec<i64> = (0..b)
        .flat_map(|r| (0..w).flat_map(move |t| (0..n).map(move |d| token(r, t + 1, d))))
        .collect();
    let mfcc: Vec<f32> = (0..b * w * 26)
        .map(|i| ((i as f32) * 0.37).sin() * 30.0)
        .collect();
    let beat: Vec<i64> = (0..b * w).map(|i| (i % 30 == 0) as i64).collect();
    let input = |device: &Device| TsmtInput {
        tokens: Tensor::<3, Int>::from_data(TensorData::new(tokens.clone(), [b, w, n]), device),
        mfcc: Tensor::from_data(TensorData::new(mfcc.clone(), [b, w, 26]), device),
        beat: Tensor::<2, Int>::from_data(TensorData::new(beat.clone(), [b, w]), device),
        lengths: vec![w; b],
    };
    let target = |device: &Device| {
        Tensor::<3, Int>::from_data(TensorData::new(targets.clone(), [b, w, n]), device)
    };
    // CE without dropout (training runs with the preset's 0.1).
    let plain = Device::flex();
    let eval = |model: &Tsmt| -> f64 {
        masked_cross_entropy(
            model.valid().forward(input(&plain)),
            target(&plain),
            &vec![w; b],
        )
        .into_scalar::<f32>() as f64
    };
    let mut optim = AdamConfig::new().with_epsilon(1e-8).init();
    let start = Instant::now();
    let (mut steps, mut last) = (0, f64::INFINITY);
    while steps < 2000 && last >= 0.05 {
        let loss =
            masked_cross_entropy(model.forward(input(&device)), target(&device), &vec![w; b]);
        let grads = GradientsParams::from_grads(loss.backward(), &model);
        model = optim.step(3e-3, model, grads);
        steps += 1;
        if steps % 50 == 0 {
            last = eval(&model);
        }
    }
    println!(
        "tiny TSMT: CE {last:.4} after {steps} steps, {:.1} s",
        start.elapsed().as_secs_f64()
    );
    assert!(last < 0.05, "CE {last} after {steps} steps");
}

/// SPEC §12.8.10: tiny in-betweeners overfit one batch (the residual MSE falls 100×): two 120-frame
/// measures whose true residual over the base is a fixed smooth pattern, for the motion and genre
/// variants and the music-reading cross_full.
#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug: run with --release")]
fn tiny_inbetweeners_overfit_one_batch() {
    use qean_config::inbetween::Variant;
    use qean_models::inbetween::{Conditioning, Inbetweener, MOTION_DIM, MUSIC_DIM};
    for variant in [Variant::Motion, Variant::Genre, Variant::CrossFull] {
        let mut c = qean_config::RunConfig::load(
            &preset(&format!("inbetween/tiny_{}.toml", variant.name())),
            &[],
        )
        .unwrap()
        .inbetween();
        c.dropout = 0.0;
        let (b, t) = (2, 120);
        let device = Device::flex().autodiff();
        device.seed(5);
        let mut model = Inbetweener::new(&c, &device);
        let wave = |i: usize, f: f32| (i as f32 * f).sin();
        let base: Vec<f32> = (0..b * t * MOTION_DIM).map(|i| wave(i, 0.013)).collect();
        let target: Vec<f32> = base
            .iter()
            .enumerate()
            .map(|(i, x)| x + 0.2 * wave(i / MOTION_DIM, 0.05) * wave(i % MOTION_DIM, 0.7))
            .collect();
        let music: Vec<f32> = (0..b * t * MUSIC_DIM).map(|i| wave(i, 0.31)).collect();
        let genre: Vec<f32> = (0..b * 9).map(|i| (i % 9 == i / 9) as u8 as f32).collect();
        let tensors = |device: &Device| {
            let t3 = |v: &Vec<f32>, w: usize| {
                Tensor::<3>::from_data(TensorData::new(v.clone(), [b, t, w]), device)
            };
            let cond = Conditioning {
                music: variant.has_audio().then(|| t3(&music, MUSIC_DIM)),
                genre: (variant == Variant::Genre)
                    .then(|| Tensor::from_data(TensorData::new(genre.clone(), [b, 9]), device)),
                lengths: None,
                taper: None,
            };
            (t3(&base, MOTION_DIM), t3(&target, MOTION_DIM), cond)
        };
        let loss_of = |model: &Inbetweener, device: &Device| {
            let (x, y, cond) = tensors(device);
            let d = model.forward(x, &cond) - y;
            (d.clone() * d).mean()
        };
        let first = loss_of(&model, &device).into_scalar::<f32>() as f64;
        let mut optim = AdamConfig::new().with_epsilon(1e-8).init();
        let start = Instant::now();
        let mut last = first;
        for step in 1..=600 {
            let loss = loss_of(&model, &device);
            let grads = GradientsParams::from_grads(loss.backward(), &model);
            model = optim.step(1e-3, model, grads);
            if step % 50 == 0 {
                last = loss_of(&model.valid(), &Device::flex()).into_scalar::<f32>() as f64;
                if last < first / 100.0 {
                    break;
                }
            }
        }
        println!(
            "tiny in-betweener {}: residual MSE {first:.5} → {last:.6} ({:.1} s)",
            variant.name(),
            start.elapsed().as_secs_f64()
        );
        assert!(last < first / 100.0, "{}: {first} → {last}", variant.name());
    }
}
