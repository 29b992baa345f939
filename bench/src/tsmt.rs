//! `train-tsmt` and `sample-tsmt`: Li et al.'s two-stream motion transformer at the paper's size
//! (1,419,388 parameters, W = 480). Training: one update at batch 32 (masked CE, global-norm clip,
//! Adam with coupled L2, as the trainer). Sampling: 40 sequences (and 1) from a 120-frame seed, with
//! the KV cache and with full recomputation of the context every step (the reference's loop).

use std::time::Instant;

use burn::module::Module;
use burn::tensor::{Int, Tensor, TensorData};
use qean_models::tsmt::loss::masked_cross_entropy;
use qean_models::tsmt::sample::{generate, TsmtAudio, TsmtSampling};
use qean_models::tsmt::{Tsmt, TsmtInput};
use qean_train::trainer::{adam, apply_update};

use super::measures::{device, filler, load_config, median, Inputs, MeasureId, Sizes, TSMT_BATCH};
use super::report::Entry;

/// Tokens in 0..bins from the filler.
fn tokens(n: usize, bins: usize, seed: u64) -> Vec<i64> {
    filler(n, seed)
        .iter()
        .map(|x| ((x + 1.0) / 2.0 * (bins - 1) as f32) as i64)
        .collect()
}

pub fn train(backend: &str, inputs: &Inputs, sizes: &Sizes) -> crate::Result<Entry> {
    let config = load_config(inputs.config(MeasureId::TrainTsmt))?;
    let t = config.tsmt();
    let device = device(backend)?.autodiff();
    device.seed(0);
    let mut model = Tsmt::new(&t, &device);
    let params = model.num_params();
    let mut optim = adam(&config);
    let (b, w, n) = (TSMT_BATCH, t.window, t.coords());
    let steps = sizes.train_steps_tsmt.max(1);
    let mut times = Vec::new();
    for k in 0..=steps {
        let input = TsmtInput {
            tokens: Tensor::<3, Int>::from_data(
                TensorData::new(tokens(b * w * n, t.n_bins, 1), [b, w, n]),
                &device,
            ),
            mfcc: Tensor::from_data(TensorData::new(filler(b * w * 26, 2), [b, w, 26]), &device),
            beat: Tensor::<2, Int>::from_data(
                TensorData::new(tokens(b * w, 2, 3), [b, w]),
                &device,
            ),
            lengths: vec![w; b],
        };
        let target = Tensor::<3, Int>::from_data(
            TensorData::new(tokens(b * w * n, t.n_bins, 4), [b, w, n]),
            &device,
        );
        let start = Instant::now();
        let loss = masked_cross_entropy(model.forward(input), target, &vec![w; b]);
        let (next, value) =
            apply_update(model, &mut optim, loss, 1e-4, config.optim.grad_clip_norm);
        model = next;
        qean_pipeline::ensure!(value.is_finite(), "the benchmark loss is not finite");
        if k > 0 {
            times.push(start.elapsed().as_secs_f64());
        }
    }
    Ok(Entry::time(
        MeasureId::TrainTsmt,
        backend,
        median(times),
        "s per step",
        format!(
            "TSMT paper ({params} parameters), batch {b}, window {w}, masked CE + backward + clip + Adam (L2), median of {steps} after a warm-up"
        ),
    ))
}

/// Frames per second of one timed rollout of `rows` sequences.
fn rollout_fps(
    model: &Tsmt,
    device: &burn::tensor::Device,
    t: &qean_config::tsmt::TsmtConfig,
    rows: usize,
    frames: usize,
    cache: bool,
) -> f64 {
    let n = t.coords();
    let seed_frames = t.seed_frames;
    let seeds: Vec<Vec<u16>> = (0..rows)
        .map(|r| {
            tokens(seed_frames * n, t.n_bins, 10 + r as u64)
                .into_iter()
                .map(|k| k as u16)
                .collect()
        })
        .collect();
    let music_frames = seed_frames + frames + 1;
    let audio: Vec<TsmtAudio> = (0..rows)
        .map(|r| TsmtAudio {
            mfcc: filler(music_frames * 26, 100 + r as u64),
            beats: (0..music_frames).map(|f| (f % 30 == 0) as u8).collect(),
            frames: music_frames,
        })
        .collect();
    let opts = TsmtSampling {
        cache,
        ..TsmtSampling::of_config(t, 0)
    };
    let start = Instant::now();
    let out = generate(
        model,
        device,
        &seeds,
        &audio,
        frames,
        &opts,
        &mut |_, _| {},
        None,
    );
    let seconds = start.elapsed().as_secs_f64();
    assert_eq!(out.len(), rows);
    (rows * frames) as f64 / seconds
}

pub fn sampling(backend: &str, inputs: &Inputs, sizes: &Sizes) -> crate::Result<Entry> {
    let config = load_config(inputs.config(MeasureId::SampleTsmt))?;
    let t = config.tsmt();
    let device = device(backend)?;
    device.seed(0);
    let model = Tsmt::new(&t, &device);
    let params = model.num_params();
    let frames = sizes.sample_frames_tsmt.max(1);
    let many = sizes.sequences;
    // Warm-up (allocator, thread pools), not timed.
    rollout_fps(&model, &device, &t, many, 1, true);
    let cached = rollout_fps(&model, &device, &t, many, frames, true);
    let cached_one = rollout_fps(&model, &device, &t, 1, frames, true);
    let full = rollout_fps(&model, &device, &t, many, frames, false);
    let full_one = rollout_fps(&model, &device, &t, 1, frames, false);
    Ok(Entry::rate(
        MeasureId::SampleTsmt,
        backend,
        cached,
        "frames/s",
        format!(
            "TSMT paper ({params} parameters), {many} sequences in one batch with the KV cache, {frames} frames timed after a {}-frame seed; \
             1 sequence: {cached_one:.1} frames/s cached; full recompute of the context every step: {full:.1} frames/s ({many}), {full_one:.1} frames/s (1); \
             real time is 60 frames/s; once the {}-frame window is full, slide_stride {} rebuilds the cache every step",
            t.seed_frames, t.window, t.slide_stride
        ),
    ))
}
