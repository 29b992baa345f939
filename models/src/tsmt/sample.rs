//! TSMT's sampler (SPEC §11.8): seed frames, then one frame at a time, each coordinate read from its
//! own distribution ([`read`]: the paper's draw of a bin, or another decoding) with uniforms taken in the
//! order (step, row, coordinate) from one seeded stream (`coherent`: one smooth quantile per row instead),
//! so a rollout is a function of the model, its inputs and the seed.
//!
//! The context is the last frames fed, at positions 1..; when it would pass W frames it keeps the
//! last W − S (S = `slide_stride`) plus the newest and is renumbered. With the KV cache a step runs
//! only the new frame and a slide rebuilds the cache in one pass; without it every step recomputes
//! the whole context (the reference's loop). Both give the same tokens.

use burn::tensor::{Device, Int, Tensor, TensorData};
use qean_config::tsmt::{TsmtConfig, TsmtDecode};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::decode::{read, Reading, SmoothQuantile};
use super::model::{Tsmt, TsmtCache, TsmtInput, BEAT_PAD, MFCC_DIM};

/// One music as TSMT hears it: `frames` rows of MFCC + Δ (26 values) and a beat flag per frame.
#[derive(Clone, Debug, PartialEq)]
pub struct TsmtAudio {
    pub mfcc: Vec<f32>,
    pub beats: Vec<u8>,
    pub frames: usize,
}

/// How to sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TsmtSampling {
    /// Temperature τ (0 = argmax).
    pub temperature: f64,
    /// Keep the k most likely bins (0 = all).
    pub top_k: usize,
    /// Context length W.
    pub window: usize,
    /// Frames dropped at once when the context is full, S (1 = the reference).
    pub slide_stride: usize,
    /// Seed of the uniforms.
    pub seed: u64,
    /// Use the KV cache (false: recompute the whole context every step).
    pub cache: bool,
    /// How each coordinate's distribution becomes a bin and a value (`Bin`: the paper's).
    pub decode: TsmtDecode,
    /// `Subbin`: bins on each side of the drawn one.
    pub subbin_radius: usize,
    /// `Coherent`: the shortest period of the shared quantile, in frames.
    pub coherent_frames: f64,
}

impl TsmtSampling {
    /// The sampling a run's `[tsmt]` table asks for, with the KV cache and the draws' `seed`.
    pub fn of_config(t: &TsmtConfig, seed: u64) -> TsmtSampling {
        TsmtSampling {
            temperature: t.temperature,
            top_k: t.top_k,
            window: t.window,
            slide_stride: t.slide_stride,
            seed,
            cache: true,
            decode: t.decode,
            subbin_radius: t.subbin_radius,
            coherent_frames: t.coherent_seconds * qean_motion::motion::FPS / t.frame_step as f64,
        }
    }

    fn reading(&self) -> Reading {
        Reading {
            temperature: self.temperature,
            top_k: self.top_k,
            decode: self.decode,
            subbin_radius: self.subbin_radius,
        }
    }
}

/// One row's rollout: its tokens (seed included, frames × n) and each coordinate's position in bin units
/// (the value is lo + pos·w: a bin's centre k + ½ for the seed and the paper's decoding).
#[derive(Clone, Debug, PartialEq)]
pub struct Rollout {
    pub tokens: Vec<u16>,
    pub positions: Vec<f64>,
}

/// Generates `frames` frames after each row's seed tokens (`seeds[b]`: seed frames × n, every row
/// the same length), hearing `audio[b]` (the row for frame f is audio frame f + 1; past its end,
/// padding). Returns each row's tokens and positions, seed included. `progress(done, frames)` is called
/// after every step; `record` receives every step's logits [B, n, C] (tests).
#[allow(clippy::too_many_arguments)]
pub fn generate(
    model: &Tsmt,
    device: &Device,
    seeds: &[Vec<u16>],
    audio: &[TsmtAudio],
    frames: usize,
    opts: &TsmtSampling,
    progress: &mut dyn FnMut(usize, usize),
    mut record: Option<&mut Vec<Vec<f32>>>,
) -> Vec<Rollout> {
    let n = model.coords();
    let rows = seeds.len();
    assert_eq!(audio.len(), rows, "one music per seed");
    assert!(opts.slide_stride >= 1 && opts.slide_stride <= opts.window);
    let seed_len = seeds[0].len() / n;
    assert!(seed_len >= 1, "at least one seed frame");
    assert!(
        seeds.iter().all(|s| s.len() == seed_len * n),
        "every seed has the same length"
    );
    let mut out: Vec<Vec<u16>> = seeds.to_vec();
    let mut positions: Vec<Vec<f64>> = seeds
        .iter()
        .map(|s| s.iter().map(|&k| k as f64 + 0.5).collect())
        .collect();
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed);
    let shared: Vec<SmoothQuantile> = if opts.decode == TsmtDecode::Coherent {
        (0..rows)
            .map(|_| SmoothQuantile::new(opts.coherent_frames, || rng.random()))
            .collect()
    } else {
        Vec::new()
    };
    let reading = opts.reading();
    let mut start = seed_len.saturating_sub(opts.window);
    let mut cache = TsmtCache::default();
    let mut fed = start;
    for g in seed_len..seed_len + frames {
        if g - start > opts.window {
            start = g - (opts.window - opts.slide_stride + 1);
            cache = TsmtCache::default();
            fed = start;
        }
        let logits = if opts.cache {
            let (tokens, mfcc, beat) = inputs(&out, audio, n, fed, g, device);
            fed = g;
            model.forward_cached(tokens, mfcc, beat, &mut cache)
        } else {
            let (tokens, mfcc, beat) = inputs(&out, audio, n, start, g, device);
            let lengths = vec![g - start; rows];
            model.forward(TsmtInput {
                tokens,
                mfcc,
                beat,
                lengths,
            })
        };
        let [_, s, _, c] = logits.dims();
        let last: Vec<f32> = logits
            .slice([0..rows, s - 1..s])
            .into_data()
            .try_to_vec::<f32>()
            .expect("float logits");
        for (b, row) in last.chunks_exact(n * c).enumerate() {
            let frame_u = shared.get(b).map(|q| q.at(g - seed_len));
            for coordinate in row.chunks_exact(c) {
                let u: f64 = frame_u.unwrap_or_else(|| rng.random());
                let (k, pos) = read(coordinate, &reading, u);
                out[b].push(k as u16);
                positions[b].push(pos);
            }
        }
        if let Some(r) = record.as_deref_mut() {
            r.push(last);
        }
        progress(g + 1 - seed_len, frames);
    }
    out.into_iter()
        .zip(positions)
        .map(|(tokens, positions)| Rollout { tokens, positions })
        .collect()
}

/// Tokens, MFCC rows and beats of frames `from..to` of every row.
fn inputs(
    tokens: &[Vec<u16>],
    audio: &[TsmtAudio],
    n: usize,
    from: usize,
    to: usize,
    device: &Device,
) -> (Tensor<3, Int>, Tensor<3>, Tensor<2, Int>) {
    let (rows, s) = (tokens.len(), to - from);
    let mut t = Vec::with_capacity(rows * s * n);
    let mut m = Vec::with_capacity(rows * s * MFCC_DIM);
    let mut b = Vec::with_capacity(rows * s);
    for (row, music) in tokens.iter().zip(audio) {
        t.extend(row[from * n..to * n].iter().map(|&k| k as i64));
        for f in from..to {
            let a = f + 1;
            if a < music.frames {
                m.extend_from_slice(&music.mfcc[a * MFCC_DIM..(a + 1) * MFCC_DIM]);
                b.push(music.beats[a] as i64);
            } else {
                m.extend([0.0; MFCC_DIM]);
                b.push(BEAT_PAD);
            }
        }
    }
    (
        Tensor::from_data(TensorData::new(t, [rows, s, n]), device),
        Tensor::from_data(TensorData::new(m, [rows, s, MFCC_DIM]), device),
        Tensor::from_data(TensorData::new(b, [rows, s]), device),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The paper's sampling settings around what a test sets.
    fn paper() -> TsmtSampling {
        TsmtSampling {
            temperature: 1.0,
            top_k: 0,
            window: 64,
            slide_stride: 1,
            seed: 0,
            cache: true,
            decode: TsmtDecode::Bin,
            subbin_radius: 3,
            coherent_frames: 120.0,
        }
    }

    fn music(frames: usize, salt: usize) -> TsmtAudio {
        TsmtAudio {
            mfcc: (0..frames * MFCC_DIM)
                .map(|i| ((i * 7 + salt) as f32 * 0.13).sin() * 40.0)
                .collect(),
            beats: (0..frames)
                .map(|f| (f + salt).is_multiple_of(15) as u8)
                .collect(),
            frames,
        }
    }

    /// SPEC §11.8.4: with tsmt_tiny, random weights and the same uniforms, cached and recomputed
    /// rollouts of 100 steps across window slides (W = 64) give identical tokens and logits within
    /// 1e-5; with a stride of 8 too.
    #[test]
    fn kv_cache_equals_full_recompute_across_slides() {
        let c = TsmtConfig::tiny();
        let device = Device::flex();
        device.seed(5);
        let model = Tsmt::new(&c, &device);
        let n = c.coords();
        let seeds: Vec<Vec<u16>> = (0..2)
            .map(|r| {
                (0..40 * n)
                    .map(|i| ((i * 13 + r * 101) % c.n_bins) as u16)
                    .collect()
            })
            .collect();
        let audio = vec![music(400, 0), music(130, 3)];
        for stride in [1, 8] {
            let mut opts = TsmtSampling {
                temperature: 1.0,
                top_k: 0,
                window: c.window,
                slide_stride: stride,
                seed: 11,
                cache: true,
                ..paper()
            };
            let (mut cached, mut full) = (Vec::new(), Vec::new());
            let a = generate(
                &model,
                &device,
                &seeds,
                &audio,
                100,
                &opts,
                &mut |_, _| {},
                Some(&mut cached),
            );
            opts.cache = false;
            let b = generate(
                &model,
                &device,
                &seeds,
                &audio,
                100,
                &opts,
                &mut |_, _| {},
                Some(&mut full),
            );
            assert_eq!(a, b, "stride {stride}: tokens");
            let worst = cached
                .iter()
                .flatten()
                .zip(full.iter().flatten())
                .map(|(x, y)| (x - y).abs())
                .fold(0.0f32, f32::max);
            println!("stride {stride}: worst logit difference {worst:e}");
            assert!(worst <= 1e-5, "stride {stride}: {worst}");
            assert_eq!(a[0].tokens.len(), 140 * n);
            // The rollout moves: generated frames are not all the last seed frame.
            assert!(a[0].tokens[40 * n..]
                .chunks(n)
                .any(|f| f != &seeds[0][39 * n..]));
        }
    }

    #[test]
    fn same_seed_same_rollout_other_seed_other_rollout() {
        let c = TsmtConfig {
            window: 16,
            ..TsmtConfig::tiny()
        };
        let device = Device::flex();
        device.seed(1);
        let model = Tsmt::new(&c, &device);
        let seeds = vec![vec![7u16; 4 * c.coords()]];
        let audio = vec![music(60, 1)];
        let opts = TsmtSampling {
            temperature: 1.0,
            top_k: 5,
            window: 16,
            slide_stride: 1,
            seed: 3,
            cache: true,
            ..paper()
        };
        let a = generate(
            &model,
            &device,
            &seeds,
            &audio,
            20,
            &opts,
            &mut |_, _| {},
            None,
        );
        assert_eq!(
            a,
            generate(
                &model,
                &device,
                &seeds,
                &audio,
                20,
                &opts,
                &mut |_, _| {},
                None
            )
        );
        let other = TsmtSampling { seed: 4, ..opts };
        assert_ne!(
            a,
            generate(
                &model,
                &device,
                &seeds,
                &audio,
                20,
                &other,
                &mut |_, _| {},
                None
            )
        );
        // τ = 0 ignores the uniforms.
        let greedy = TsmtSampling {
            temperature: 0.0,
            ..opts
        };
        assert_eq!(
            generate(
                &model,
                &device,
                &seeds,
                &audio,
                20,
                &greedy,
                &mut |_, _| {},
                None
            ),
            generate(
                &model,
                &device,
                &seeds,
                &audio,
                20,
                &TsmtSampling { seed: 9, ..greedy },
                &mut |_, _| {},
                None
            )
        );
    }
}
