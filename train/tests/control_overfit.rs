//! SPEC §13.11 test 16, the overfit smoke of the tiny presets: the VQ-VAE reconstructs 4 windows of a real
//! AIST++ excerpt to a root-relative MPJPE below 2 cm, and the GPT reaches a cross-entropy below 0.1 on 4
//! windows. Release only (minutes in debug).

use std::path::PathBuf;
use std::time::Instant;

use burn::module::Module;
use burn::optim::{AdamConfig, GradientsParams};
use burn::tensor::{Device, Int, Tensor, TensorData};
use qean_checkpoint::vqvae::motion_pos72;
use qean_config::RunConfig;
use qean_models::control::gpt::{music_token_dim, Gpt};
use qean_models::vqvae::quantize::assign;
use qean_models::vqvae::VqVae;
use qean_motion::pos72::POS72;
use qean_train::family::Family;
use qean_train::vqvae::{vq_of, VqFamily, VqInputs};

fn preset(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../configs/control")
        .join(name)
}

/// Root-relative MPJPE (m) between pos72 rows: channels 3.. are the joints relative to the root.
fn mpjpe(a: &[f32], b: &[f32]) -> f64 {
    let (mut s, mut n) = (0.0, 0);
    for (ra, rb) in a.chunks_exact(POS72).zip(b.chunks_exact(POS72)) {
        for j in 1..24 {
            let d: f64 = (0..3)
                .map(|k| (ra[3 * j + k] - rb[3 * j + k]) as f64)
                .map(|x| x * x)
                .sum();
            s += d.sqrt();
            n += 1;
        }
    }
    s / n as f64
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug: run with --release")]
fn tiny_vq_vae_overfits_four_windows() {
    let config = RunConfig::load(&preset("vqvae_tiny.toml"), &[]).unwrap();
    let c = vq_of(&config).clone();
    let motion = qean_motion::Motion::read_pkl(
        &qean_io::testdata::shared_dir().join("aistpp/motions/softcat477_sample_with_scaling.pkl"),
    )
    .unwrap();
    let rows = motion_pos72(&motion, &c);
    let window = c.window;
    let x: Vec<f32> = [0, 20, 40, 60]
        .iter()
        .flat_map(|&s| rows[s * POS72..(s + window) * POS72].iter().copied())
        .collect();
    let device = Device::flex().autodiff();
    device.seed(3);
    let family = VqFamily::default();
    let mut model = VqVae::new(&c, &device);
    let mut optim = AdamConfig::new().with_epsilon(1e-8).init();
    let input = |device: &Device| {
        Tensor::<3>::from_data(TensorData::new(x.clone(), [4, window, POS72]), device)
    };
    let reconstruction = |m: &VqVae| {
        let plain = Device::flex();
        let z = m.encode(input(&plain)).unwrap();
        let (_, d) = m.codes();
        let idx = assign(&VqVae::host_rows(&z), &m.ema_state().codebook, d);
        VqVae::host_rows(&m.decode_tokens(&idx, 4, window / c.rate()))
    };
    let start = Instant::now();
    let mut error = f64::INFINITY;
    for step in 1..=3000u64 {
        let loss = family.loss(
            &model,
            VqInputs {
                x: input(&device),
                seed: step,
            },
            &config,
        );
        let grads = GradientsParams::from_grads(loss.backward(), &model);
        model = family.after_update(optim.step(1e-3, model, grads));
        if step % 250 == 0 {
            error = mpjpe(&reconstruction(&model.valid()), &x);
            if error < 0.02 {
                break;
            }
        }
    }
    println!(
        "tiny VQ-VAE on 4 windows: MPJPE {:.2} cm ({:.1} s)",
        100.0 * error,
        start.elapsed().as_secs_f64()
    );
    assert!(error < 0.02, "MPJPE {error} m");
}

#[test]
#[cfg_attr(debug_assertions, ignore = "slow in debug: run with --release")]
fn tiny_gpt_overfits_four_windows() {
    let mut g = RunConfig::load(&preset("gpt_tiny.toml"), &[])
        .unwrap()
        .gpt
        .unwrap();
    g.dropout = 0.0;
    let (b, n) = (4, g.window);
    let w = music_token_dim(&g);
    let device = Device::flex().autodiff();
    device.seed(4);
    let mut model = Gpt::new(&g, &device);
    let codes: Vec<i64> = (0..b * (n + 1))
        .map(|i| ((i * 37 + i / 7) % g.codes) as i64)
        .collect();
    let tokens: Vec<i64> = (0..b)
        .flat_map(|r| codes[r * (n + 1)..r * (n + 1) + n].iter().copied())
        .collect();
    let targets: Vec<i64> = (0..b)
        .flat_map(|r| codes[r * (n + 1) + 1..(r + 1) * (n + 1)].iter().copied())
        .collect();
    let music: Vec<f32> = (0..b * n * w).map(|i| (i as f32 * 0.37).sin()).collect();
    let batch = |device: &Device| {
        (
            Tensor::<2, Int>::from_data(TensorData::new(tokens.clone(), [b, n]), device),
            Tensor::<3>::from_data(TensorData::new(music.clone(), [b, n, w]), device),
            Tensor::<2, Int>::from_data(TensorData::new(targets.clone(), [b, n]), device),
        )
    };
    let mut optim = AdamConfig::new().with_epsilon(1e-8).init();
    let start = Instant::now();
    let mut ce = f64::INFINITY;
    for step in 1..=2000 {
        let (t, m, y) = batch(&device);
        let loss = qean_train::gpt::cross_entropy(model.music_logits(t, m), y);
        let grads = GradientsParams::from_grads(loss.backward(), &model);
        model = optim.step(1e-3, model, grads);
        if step % 100 == 0 {
            let plain = Device::flex();
            let (t, m, y) = batch(&plain);
            ce = qean_train::gpt::cross_entropy(model.valid().music_logits(t, m), y)
                .into_scalar::<f32>() as f64;
            if ce < 0.1 {
                break;
            }
        }
    }
    println!(
        "tiny GPT on 4 windows: CE {ce:.4} ({:.1} s)",
        start.elapsed().as_secs_f64()
    );
    assert!(ce < 0.1, "CE {ce}");
}
