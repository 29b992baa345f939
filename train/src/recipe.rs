//! The `[recipe]` remedies applied to a training batch (qean-config's `recipe` module says what
//! each one is for): the model's own rollouts in place of the last ground-truth input frames
//! (auto-conditioning / scheduled sampling), noise on the input motion and shifts of the music
//! features. Every random draw is a
//! function of (seed, step), so a resumed run repeats them exactly.
//!
//! A batch for a run with K rollout frames is drawn with K lead frames: motion GT[s, s+K+Lm),
//! audio A[s, s+K+La), target GT[s+K+Lm, s+K+Lm+T). The model's input is always the window K
//! frames later, GT[s+K, s+K+Lm) with A[s+K, s+K+La); for a rolled-out item its last K frames
//! are the model's predictions from the earlier window instead.

use burn::module::Module;
use burn::tensor::{Device, Tensor, TensorData};
use qean_aistpp::windows::{Batch, WindowSpec, AUDIO_DIM};
use qean_models::autoregress::project_frame;
use qean_models::{DanceGenerator, DanceModel};
use qean_motion::motion::Layout;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use qean_config::recipe::{AudioNorm, Predict, RecipeConfig, RolloutMode};
use qean_config::run::RunConfig;

/// The window lengths the trainer draws for `config`: the model's, with the rollout lead frames
/// in front.
pub fn draw_spec(config: &RunConfig) -> WindowSpec {
    let base = config.window_spec();
    let lead = config.recipe.lead_frames();
    WindowSpec {
        motion_len: base.motion_len + lead,
        target_len: base.target_len,
        target_shift: base.target_shift + lead,
        audio_len: base.audio_len + lead,
    }
}

/// What happened to a batch (for the log).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Applied {
    pub rolled_out: usize,
}

/// A standard normal draw (Box–Muller).
fn normal(rng: &mut ChaCha8Rng) -> f64 {
    let u1: f64 = 1.0 - rng.random::<f64>();
    let u2: f64 = rng.random::<f64>();
    (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
}

/// The batch the model trains on: `drawn` itself when the recipe changes no input (no noise, no
/// music shift, no rollout lead frames), else [`apply`]'s.
pub fn model_inputs(
    drawn: Batch,
    config: &RunConfig,
    model: &DanceModel,
    plain: &Device,
    rng_seed: u64,
    step: u64,
) -> Batch {
    let r = &config.recipe;
    if r.input_noise == 0.0 && r.audio_shift == 0.0 && r.gain_db == 0.0 && r.lead_frames() == 0 {
        drawn
    } else {
        apply(&drawn, config, model, plain, rng_seed, step).0
    }
}

/// How much MFCC 0 moves per dB of gain: the orthonormal DCT's first row over librosa's 128 mel bands,
/// 1/√128 each, sums 128 equal dB shifts to √128 (measured on a real recording at −10 dB: −113.13).
pub const MFCC0_PER_DB: f64 = 11.313_708_498_984_761;

/// The model inputs of a drawn batch under the recipe: a batch with the model's window lengths.
/// `model` is the training model (rollouts run on its inference copy, without dropout).
#[allow(clippy::too_many_arguments)]
pub fn apply(
    drawn: &Batch,
    config: &RunConfig,
    model: &DanceModel,
    plain: &Device,
    rng_seed: u64,
    step: u64,
) -> (Batch, Applied) {
    let r = &config.recipe;
    let spec = config.window_spec();
    let layout = config.layout();
    let lead = drawn.spec.motion_len - spec.motion_len;
    let d = drawn.dim;
    let b = drawn.len();
    let (ml, al) = (spec.motion_len, spec.audio_len);
    let (dml, dal) = (drawn.spec.motion_len, drawn.spec.audio_len);
    let mut rng = ChaCha8Rng::seed_from_u64(rng_seed ^ 0x7265_6369_7065_0001);

    // The input window K frames in.
    let mut motion = Vec::with_capacity(b * ml * d);
    let mut audio = Vec::with_capacity(b * al * AUDIO_DIM);
    for i in 0..b {
        let m0 = (i * dml + lead) * d;
        motion.extend_from_slice(&drawn.motion[m0..m0 + ml * d]);
        let a0 = (i * dal + lead) * AUDIO_DIM;
        audio.extend_from_slice(&drawn.audio[a0..a0 + al * AUDIO_DIM]);
    }

    let mut applied = Applied::default();
    let share = r.rollout_share(step);
    if lead > 0 && share > 0.0 {
        let rolled: Vec<usize> = (0..b).filter(|_| rng.random::<f64>() < share).collect();
        if !rolled.is_empty() {
            let preds = rollout(drawn, &rolled, r, layout, spec, lead, model, plain);
            for (n, &i) in rolled.iter().enumerate() {
                let dst = (i * ml + ml - lead) * d;
                motion[dst..dst + lead * d]
                    .copy_from_slice(&preds[n * lead * d..(n + 1) * lead * d]);
            }
            applied.rolled_out = rolled.len();
        }
    }

    if r.input_noise > 0.0 {
        let off = layout.trans_offset();
        for frame in motion.chunks_exact_mut(d) {
            for x in &mut frame[off..] {
                *x += (r.input_noise * normal(&mut rng)) as f32;
            }
        }
    }

    if r.gain_db > 0.0 {
        // A gain of g dB adds √128·g to MFCC 0 (column 1), in the model's units.
        let unit = match r.audio_norm {
            AudioNorm::None => 1.0,
            AudioNorm::Standardize => 1.0 / r.audio_std.get(1).copied().unwrap_or(1.0),
            // Each track is centred on its own mean: a constant gain cancels.
            AudioNorm::PerTrack => 0.0,
        };
        for window in audio.chunks_exact_mut(al * AUDIO_DIM) {
            let g = r.gain_db * (2.0 * rng.random::<f64>() - 1.0);
            let shift = (MFCC0_PER_DB * g * unit) as f32;
            for row in window.chunks_exact_mut(AUDIO_DIM) {
                row[1] += shift;
            }
        }
    }

    if r.audio_shift > 0.0 {
        for window in audio.chunks_exact_mut(al * AUDIO_DIM) {
            let shift: Vec<f32> = (0..AUDIO_DIM)
                .map(|_| (r.audio_shift * normal(&mut rng)) as f32)
                .collect();
            for row in window.chunks_exact_mut(AUDIO_DIM) {
                for (x, s) in row.iter_mut().zip(&shift) {
                    *x += s;
                }
            }
        }
    }

    let batch = Batch {
        motion,
        audio,
        target: drawn.target.clone(),
        names: drawn.names.clone(),
        starts: drawn.starts.iter().map(|s| s + lead).collect(),
        dim: d,
        audio_dim: AUDIO_DIM,
        spec,
    };
    (batch, applied)
}

/// The model's predictions of frames [s+Lm, s+Lm+K) for the items `rolled` of the drawn batch,
/// [rolled, K, D] row-major.
#[allow(clippy::too_many_arguments)]
fn rollout(
    drawn: &Batch,
    rolled: &[usize],
    r: &RecipeConfig,
    layout: Layout,
    spec: WindowSpec,
    lead: usize,
    model: &DanceModel,
    plain: &Device,
) -> Vec<f32> {
    let net = model.valid();
    let d = drawn.dim;
    let n = rolled.len();
    let (ml, al) = (spec.motion_len, spec.audio_len);
    let (dml, dal) = (drawn.spec.motion_len, drawn.spec.audio_len);
    let gt = |i: usize, f: usize| &drawn.motion[(i * dml + f) * d..(i * dml + f + 1) * d];
    let au = |i: usize, f: usize, len: usize| {
        &drawn.audio[(i * dal + f) * AUDIO_DIM..(i * dal + f + len) * AUDIO_DIM]
    };
    let tensor = |v: Vec<f32>, t: usize, w: usize| {
        Tensor::<3>::from_data(TensorData::new(v, [n, t, w]), plain)
    };
    let to_vec = |t: Tensor<3>| -> Vec<f32> {
        t.into_data()
            .convert::<f32>()
            .try_to_vec::<f32>()
            .expect("f32 output")
    };
    // An output becomes a frame as in the sampler: the window's last frame added (offset
    // outputs), then projected (feedback_project).
    let to_frame = |y: &mut [f32], last: &[f32]| {
        if r.predict == Predict::Offset {
            for (x, v) in y.iter_mut().zip(last) {
                *x += v;
            }
        }
        if r.feedback_project {
            project_frame(y, layout);
        }
    };
    let mut preds = vec![0f32; n * lead * d];
    match r.rollout_mode {
        RolloutMode::Block => {
            let mut m = Vec::with_capacity(n * ml * d);
            let mut a = Vec::with_capacity(n * al * AUDIO_DIM);
            for &i in rolled {
                for f in 0..ml {
                    m.extend_from_slice(gt(i, f));
                }
                a.extend_from_slice(au(i, 0, al));
            }
            let out = net.forward(tensor(m, ml, d), tensor(a, al, AUDIO_DIM));
            preds = to_vec(out.narrow(1, 0, lead));
            for (j, &i) in rolled.iter().enumerate() {
                for frame in preds[j * lead * d..(j + 1) * lead * d].chunks_exact_mut(d) {
                    to_frame(frame, gt(i, ml - 1));
                }
            }
        }
        RolloutMode::Step => {
            for k in 0..lead {
                let mut m = Vec::with_capacity(n * ml * d);
                let mut a = Vec::with_capacity(n * al * AUDIO_DIM);
                for (j, &i) in rolled.iter().enumerate() {
                    for f in k..ml {
                        m.extend_from_slice(gt(i, f));
                    }
                    m.extend_from_slice(&preds[j * lead * d..(j * lead + k) * d]);
                    a.extend_from_slice(au(i, k, al));
                }
                let mut y = to_vec(net.generate(tensor(m, ml, d), tensor(a, al, AUDIO_DIM)));
                for (j, &i) in rolled.iter().enumerate() {
                    let last = if k == 0 {
                        gt(i, ml - 1).to_vec()
                    } else {
                        preds[(j * lead + k - 1) * d..(j * lead + k) * d].to_vec()
                    };
                    let frame = &mut y[j * d..(j + 1) * d];
                    to_frame(frame, &last);
                    preds[(j * lead + k) * d..(j * lead + k + 1) * d].copy_from_slice(frame);
                }
            }
        }
    }
    preds
}

#[cfg(test)]
mod tests {
    use super::*;
    use qean_config::recipe::RecipeBase;

    fn config(recipe: RecipeConfig) -> RunConfig {
        let mut c = RunConfig::default();
        c.model.hidden = 16;
        c.model.heads = 2;
        c.model.ffn = 16;
        c.model.motion_layers = 1;
        c.model.audio_layers = 1;
        c.model.cross_layers = 1;
        c.model.motion_len = 6;
        c.model.audio_len = 8;
        c.model.target_len = 3;
        c.recipe = recipe;
        c
    }

    /// A drawn batch whose values encode (item, frame): motion value = 1000·item + frame.
    fn drawn(c: &RunConfig, b: usize) -> Batch {
        let spec = draw_spec(c);
        let d = c.layout().dim();
        Batch {
            motion: (0..b * spec.motion_len * d)
                .map(|x| (1000 * (x / (spec.motion_len * d)) + (x / d) % spec.motion_len) as f32)
                .collect(),
            audio: (0..b * spec.audio_len * AUDIO_DIM)
                .map(|x| ((x / AUDIO_DIM) % spec.audio_len) as f32)
                .collect(),
            target: vec![0.5; b * spec.target_len * d],
            names: (0..b).map(|i| format!("s{i}")).collect(),
            starts: vec![0; b],
            dim: d,
            audio_dim: AUDIO_DIM,
            spec,
        }
    }

    #[test]
    fn mint_recipe_passes_the_batch_through() {
        let c = config(RecipeConfig::default());
        assert_eq!(draw_spec(&c), c.window_spec());
        let device = Device::flex();
        let model = DanceModel::new(&c.model, &device).unwrap();
        let d = drawn(&c, 3);
        let (out, applied) = apply(&d, &c, &model, &device, 7, 0);
        assert_eq!(out, d);
        assert_eq!(applied.rolled_out, 0);
    }

    #[test]
    fn rollouts_replace_the_last_frames_and_shift_the_window() {
        let device = Device::flex();
        for mode in [RolloutMode::Block, RolloutMode::Step] {
            let c = config(RecipeConfig {
                rollout_frames: 2,
                rollout_mode: mode,
                rollout_prob: 1.0,
                rollout_ramp: [0, 0],
                ..RecipeConfig::of(RecipeBase::Mint)
            });
            let spec = draw_spec(&c);
            assert_eq!(
                (spec.motion_len, spec.audio_len, spec.target_shift),
                (8, 10, 8)
            );
            let model = DanceModel::new(&c.model, &device).unwrap();
            let d = drawn(&c, 2);
            let (out, applied) = apply(&d, &c, &model, &device, 7, 5);
            assert_eq!(applied.rolled_out, 2);
            assert_eq!(out.spec, c.window_spec());
            let dim = d.dim;
            for i in 0..2 {
                // Frames 0..4 of the input are ground truth frames 2..6 of the drawn window.
                for f in 0..4 {
                    let v = out.motion[(i * 6 + f) * dim + 10];
                    assert_eq!(v, (1000 * i + f + 2) as f32, "{mode:?}");
                }
                // Frames 4..6 are the model's, not the ground truth's 6, 7.
                for f in 4..6 {
                    let v = out.motion[(i * 6 + f) * dim + 10];
                    assert!((v - (1000 * i + f + 2) as f32).abs() > 1.0, "{mode:?}");
                }
                // Audio starts two frames in.
                assert_eq!(out.audio[i * 8 * AUDIO_DIM], 2.0);
            }
            // Deterministic in (seed, step).
            assert_eq!(apply(&d, &c, &model, &device, 7, 5).0, out);
        }
    }

    #[test]
    fn step_rollouts_are_the_samplers_loop() {
        // K step rollouts equal K passes of the autoregressive sampler from the same window,
        // with pose and with offset outputs, raw and projected feedback.
        for (predict, feedback_project) in [
            (Predict::Pose, false),
            (Predict::Offset, false),
            (Predict::Offset, true),
        ] {
            step_rollouts_match(predict, feedback_project);
        }
    }

    fn step_rollouts_match(predict: Predict, feedback_project: bool) {
        let device = Device::flex();
        let c = config(RecipeConfig {
            rollout_frames: 3,
            rollout_mode: RolloutMode::Step,
            rollout_prob: 1.0,
            rollout_ramp: [0, 0],
            predict,
            feedback_project,
            ..RecipeConfig::default()
        });
        let model = DanceModel::new(&c.model, &device).unwrap();
        let d = drawn(&c, 1);
        let (out, _) = apply(&d, &c, &model, &device, 1, 0);
        let dim = d.dim;
        let spec = c.window_spec();
        let req = qean_models::autoregress::SampleRequest {
            seed: d.motion[..spec.motion_len * dim].to_vec(),
            audio: d.audio.clone(),
        };
        let opts = qean_models::autoregress::SampleOptions {
            frames: 3,
            spec,
            layout: c.layout(),
            offset_output: predict == Predict::Offset,
            feedback_project,
            ..Default::default()
        };
        let net = model.valid();
        let gen = qean_models::sampler::sample(&net, &device, &[req], &opts, |_, _| {}).unwrap();
        let sampled = &gen[0][spec.motion_len * dim..];
        let rolled = &out.motion[3 * dim..6 * dim];
        for (a, b) in sampled.iter().zip(rolled) {
            assert!(
                (a - b).abs() < 1e-3 * a.abs().max(1.0),
                "{predict:?}: {a} vs {b}"
            );
        }
    }

    #[test]
    fn noise_has_the_configured_spread_and_spares_the_pad() {
        let c = config(RecipeConfig {
            input_noise: 0.1,
            ..RecipeConfig::default()
        });
        let device = Device::flex();
        let model = DanceModel::new(&c.model, &device).unwrap();
        let d = drawn(&c, 8);
        let (out, _) = apply(&d, &c, &model, &device, 3, 0);
        let dim = d.dim;
        let mut diffs = Vec::new();
        for (k, (a, b)) in out.motion.iter().zip(&d.motion).enumerate() {
            if k % dim < 6 {
                assert_eq!(a, b);
            } else {
                diffs.push((a - b) as f64);
            }
        }
        let n = diffs.len() as f64;
        let mean = diffs.iter().sum::<f64>() / n;
        let sd = (diffs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n).sqrt();
        assert!(mean.abs() < 0.01 && (sd - 0.1).abs() < 0.01, "{mean} {sd}");
        assert_ne!(apply(&d, &c, &model, &device, 4, 0).0, out);
    }

    #[test]
    fn music_shift_is_one_offset_per_window_and_column() {
        let c = config(RecipeConfig {
            audio_shift: 0.5,
            ..RecipeConfig::default()
        });
        let device = Device::flex();
        let model = DanceModel::new(&c.model, &device).unwrap();
        let d = drawn(&c, 8);
        let (out, _) = apply(&d, &c, &model, &device, 5, 0);
        assert_eq!(out.motion, d.motion);
        let al = c.window_spec().audio_len;
        let mut shifts = Vec::new();
        for (w, (a, b)) in out
            .audio
            .chunks_exact(al * AUDIO_DIM)
            .zip(d.audio.chunks_exact(al * AUDIO_DIM))
            .enumerate()
        {
            for k in 0..AUDIO_DIM {
                let first = a[k] - b[k];
                for t in 1..al {
                    let i = t * AUDIO_DIM + k;
                    assert!((a[i] - b[i] - first).abs() < 1e-4, "window {w} column {k}");
                }
                shifts.push(first as f64);
            }
        }
        let n = shifts.len() as f64;
        let sd = (shifts.iter().map(|x| x * x).sum::<f64>() / n).sqrt();
        assert!((sd - 0.5).abs() < 0.1, "{sd}");
    }

    #[test]
    fn a_gain_moves_mfcc0_alone_by_the_same_amount_over_a_window() {
        let c = config(RecipeConfig {
            gain_db: 6.0,
            ..RecipeConfig::default()
        });
        let device = Device::flex();
        let model = DanceModel::new(&c.model, &device).unwrap();
        let d = drawn(&c, 16);
        let (out, _) = apply(&d, &c, &model, &device, 9, 0);
        assert_eq!(out.motion, d.motion);
        let al = c.window_spec().audio_len;
        let mut gains = Vec::new();
        for (a, b) in out
            .audio
            .chunks_exact(al * AUDIO_DIM)
            .zip(d.audio.chunks_exact(al * AUDIO_DIM))
        {
            let first = (a[1] - b[1]) as f64;
            for (ra, rb) in a.chunks_exact(AUDIO_DIM).zip(b.chunks_exact(AUDIO_DIM)) {
                for k in 0..AUDIO_DIM {
                    let shift = (ra[k] - rb[k]) as f64;
                    if k == 1 {
                        assert!((shift - first).abs() < 1e-3 * first.abs().max(1.0));
                    } else {
                        assert_eq!(shift, 0.0, "column {k}");
                    }
                }
            }
            // Raw features (audio_norm none): √128 per dB, within ±6 dB.
            gains.push(first / MFCC0_PER_DB);
        }
        assert!(gains.iter().all(|g| g.abs() <= 6.0 + 1e-3), "{gains:?}");
        assert!(gains.iter().any(|g| g.abs() > 1.0), "{gains:?}");
        // Standardised features move by the same dB over MFCC 0's SD.
        let mut std = vec![1.0; AUDIO_DIM];
        std[1] = 50.0;
        let s = config(RecipeConfig {
            gain_db: 6.0,
            audio_norm: AudioNorm::Standardize,
            audio_mean: vec![0.0; AUDIO_DIM],
            audio_std: std,
            ..RecipeConfig::default()
        });
        let (scaled, _) = apply(&d, &s, &model, &device, 9, 0);
        let ratio = (scaled.audio[1] - d.audio[1]) as f64 / (out.audio[1] - d.audio[1]) as f64;
        assert!((ratio - 1.0 / 50.0).abs() < 1e-4, "{ratio}");
    }
}
