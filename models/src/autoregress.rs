//! The autoregressive generation loop of SPEC §6 (mint `fact_model.infer_auto_regressive`), independent of the
//! network: the caller supplies a function from a batch of windows to the first output token of each.
//!
//! For i = 0, 1, …: stop when i + 240 > T_a (or repeat the last audio frame, `audio_pad = edge`); out =
//! model(X, A[i, i+240)); y = out[0] (the prediction for absolute frame 120 + i); append y; X ← X[1:] ++ y.
//! Generated frame g therefore sees motion frames [g, g+120) and audio frames [g, g+240), as in training.
//! Sequences of different lengths are batched together; a finished one simply leaves the batch (exact: there
//! are no masks, so each sequence's result does not depend on the others).

use qean_aistpp::windows::{WindowSpec, AUDIO_DIM};
use qean_motion::motion::Layout;
use qean_motion::rotation::project_to_so3;
use qean_motion::seam::{self, Seam};

/// What to do when the music ends before the requested number of frames (`--audio-pad`).
#[derive(
    Debug,
    Clone,
    Copy,
    PartialEq,
    Eq,
    Default,
    serde::Serialize,
    serde::Deserialize,
    clap::ValueEnum,
)]
#[serde(rename_all = "lowercase")]
pub enum AudioPad {
    /// Stop early (mint): L = min(frames, T_a − 239).
    #[default]
    Stop,
    /// Repeat the last audio frame so every sequence gets `frames` frames.
    Edge,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SampleOptions {
    /// Frames to generate after the seed (mint: 1200).
    pub frames: usize,
    pub audio_pad: AudioPad,
    /// Project fed-back rotation blocks to SO(3) and zero the pad dims (off in the reference).
    pub feedback_project: bool,
    /// The model predicts offsets from the last input frame (`recipe.predict = "offset"`): the
    /// frame is the window's last frame plus the output.
    pub offset_output: bool,
    /// Temporal ensembling (after action-chunking transformers): frame t is the weighted mean of
    /// the predictions of the last `ensemble` passes (token k of the pass k frames earlier,
    /// weight exp(−ensemble_decay·k)). 1 = token 0 only (mint).
    pub ensemble: usize,
    pub ensemble_decay: f64,
    /// Inertialization at the seed's end ([`qean_motion::seam`]): the gap between the seed's
    /// continuation and the first generated frame fades out over this many frames (0 = off, mint).
    pub seam_frames: usize,
    pub layout: Layout,
    pub spec: WindowSpec,
}

impl Default for SampleOptions {
    fn default() -> Self {
        SampleOptions {
            frames: 1200,
            audio_pad: AudioPad::Stop,
            feedback_project: false,
            offset_output: false,
            ensemble: 1,
            ensemble_decay: 0.0,
            seam_frames: 0,
            layout: Layout::L225,
            spec: WindowSpec::default(),
        }
    }
}

impl SampleOptions {
    /// Number of frames generated for music of `audio_frames` frames.
    pub fn generated_len(&self, audio_frames: usize) -> usize {
        match self.audio_pad {
            AudioPad::Stop => self
                .frames
                .min((audio_frames + 1).saturating_sub(self.spec.audio_len)),
            AudioPad::Edge => self.frames,
        }
    }
}

/// One sequence to generate: a seed of `spec.motion_len` frames and its music features.
#[derive(Debug, Clone)]
pub struct SampleRequest {
    /// motion_len × layout dim.
    pub seed: Vec<f32>,
    /// audio_frames × 35.
    pub audio: Vec<f32>,
}

/// Make a fed-back frame valid: rotation blocks projected to SO(3), pad dims zeroed.
pub fn project_frame(frame: &mut [f32], layout: Layout) {
    let off = layout.trans_offset();
    frame[..off].iter_mut().for_each(|x| *x = 0.0);
    for j in 0..24 {
        let b = off + 3 + 9 * j;
        let m: [f64; 9] = std::array::from_fn(|k| frame[b + k] as f64);
        let r = project_to_so3(&m);
        for k in 0..9 {
            frame[b + k] = r[k] as f32;
        }
    }
}

/// Why sampling failed: a request the loop cannot use (named by its index), or the model's own error.
#[derive(Debug, PartialEq)]
pub enum SampleError<E> {
    Request { index: usize, message: String },
    Model(E),
}

impl<E: std::fmt::Display> std::fmt::Display for SampleError<E> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SampleError::Request { index, message } => {
                write!(f, "sample request {index}: {message}")
            }
            SampleError::Model(e) => write!(f, "{e}"),
        }
    }
}

impl<E: std::fmt::Debug + std::fmt::Display> std::error::Error for SampleError<E> {}

/// Checks that every request holds a whole seed and whole audio frames.
fn check_requests<E>(
    requests: &[SampleRequest],
    opts: &SampleOptions,
) -> Result<(), SampleError<E>> {
    let (d, ml) = (opts.layout.dim(), opts.spec.motion_len);
    for (index, r) in requests.iter().enumerate() {
        let message = if r.seed.len() < ml * d {
            format!(
                "the seed holds {} values, fewer than the model's {ml} frames × {d}",
                r.seed.len()
            )
        } else if r.audio.len() % AUDIO_DIM != 0 {
            format!(
                "{} audio values are not whole {AUDIO_DIM}-D frames",
                r.audio.len()
            )
        } else {
            continue;
        };
        return Err(SampleError::Request { index, message });
    }
    Ok(())
}

/// Temporal ensembling: token j of this pass (`tokens`, e × D) predicts frame i + j; each is added to that
/// frame's running weighted sum in `q`, and frame i's weighted mean is returned. With `offset`, tokens are
/// offsets from `last`, the window's last frame.
fn ensemble_frame(
    q: &mut std::collections::VecDeque<(f64, Vec<f64>)>,
    weights: &[f64],
    tokens: &[f32],
    last: &[f32],
    offset: bool,
) -> Vec<f32> {
    let d = last.len();
    for (j, w) in weights.iter().enumerate() {
        if q.len() <= j {
            q.push_back((0.0, vec![0.0; d]));
        }
        let (ws, sum) = &mut q[j];
        *ws += w;
        let tok = &tokens[j * d..(j + 1) * d];
        for ((s, &x), &l) in sum.iter_mut().zip(tok).zip(last) {
            *s += w * (x as f64 + if offset { l as f64 } else { 0.0 });
        }
    }
    let (ws, sum) = q.pop_front().expect("frame i has a prediction");
    sum.iter().map(|s| (s / ws) as f32).collect()
}

/// Generate every request. `model(motion, audio, batch)` receives motion [batch, motion_len, D] and audio
/// [batch, audio_len, 35] (row-major) and returns the first `opts.ensemble` output tokens of each,
/// [batch, ensemble, D]. `progress(step, total)` is called after each model pass. Returns seed ++
/// generated per request.
pub fn autoregress<E>(
    requests: &[SampleRequest],
    opts: &SampleOptions,
    mut model: impl FnMut(&[f32], &[f32], usize) -> Result<Vec<f32>, E>,
    mut progress: impl FnMut(usize, usize),
) -> Result<Vec<Vec<f32>>, SampleError<E>> {
    check_requests(requests, opts)?;
    let d = opts.layout.dim();
    let (ml, al) = (opts.spec.motion_len, opts.spec.audio_len);
    let audio_frames: Vec<usize> = requests.iter().map(|r| r.audio.len() / AUDIO_DIM).collect();
    let lens: Vec<usize> = audio_frames
        .iter()
        .map(|&t| opts.generated_len(t))
        .collect();
    let total = lens.iter().copied().max().unwrap_or(0);
    let mut outputs: Vec<Vec<f32>> = requests
        .iter()
        .zip(&lens)
        .map(|(r, &l)| {
            let mut v = Vec::with_capacity((ml + l) * d);
            v.extend_from_slice(&r.seed[..ml * d]);
            v
        })
        .collect();
    // The motion window currently fed back, per request (may differ from the stored output when projecting).
    let mut windows: Vec<Vec<f32>> = requests.iter().map(|r| r.seed[..ml * d].to_vec()).collect();
    // Temporal ensembling: per request, the weighted sums of the predictions of the next frames.
    let e = opts.ensemble.max(1);
    let weights: Vec<f64> = (0..e)
        .map(|k| (-opts.ensemble_decay * k as f64).exp())
        .collect();
    let mut pending: Vec<std::collections::VecDeque<(f64, Vec<f64>)>> =
        vec![std::collections::VecDeque::new(); requests.len()];
    // The gap at the seed's end, per request, measured on the first generated frame.
    let mut seams: Vec<Option<Seam>> = vec![None; requests.len()];
    let mut motion = Vec::new();
    let mut audio = Vec::new();
    for i in 0..total {
        let active: Vec<usize> = (0..requests.len()).filter(|&k| i < lens[k]).collect();
        motion.clear();
        audio.clear();
        for &k in &active {
            motion.extend_from_slice(&windows[k]);
            let a = &requests[k].audio;
            let ta = audio_frames[k];
            for t in i..i + al {
                // Edge padding repeats the last frame; with Stop, t < ta always holds here.
                let src = t.min(ta.saturating_sub(1));
                audio.extend_from_slice(&a[src * AUDIO_DIM..(src + 1) * AUDIO_DIM]);
            }
        }
        let out = model(&motion, &audio, active.len()).map_err(SampleError::Model)?;
        assert_eq!(
            out.len(),
            active.len() * e * d,
            "model returned the wrong number of values"
        );
        for (n, &k) in active.iter().enumerate() {
            let last = &windows[k][(ml - 1) * d..ml * d];
            let mut y = if e == 1 {
                out[n * d..(n + 1) * d].to_vec()
            } else {
                let tokens = &out[n * e * d..(n + 1) * e * d];
                ensemble_frame(&mut pending[k], &weights, tokens, last, opts.offset_output)
            };
            if opts.offset_output && e == 1 {
                for (x, l) in y.iter_mut().zip(last) {
                    *x += l;
                }
            }
            if i < opts.seam_frames {
                if i == 0 {
                    // The seed's second-to-last frame (its last one for a 1-frame seed).
                    let p = ml.saturating_sub(2);
                    let prev = &windows[k][p * d..(p + 1) * d];
                    seams[k] = Some(Seam::measure(prev, last, &y, opts.layout));
                }
                if let Some(s) = &seams[k] {
                    s.apply(&mut y, seam::weight(i, opts.seam_frames), opts.layout);
                }
            }
            if opts.feedback_project {
                project_frame(&mut y, opts.layout);
            }
            outputs[k].extend_from_slice(&y);
            let w = &mut windows[k];
            w.drain(..d);
            w.extend_from_slice(&y);
        }
        progress(i + 1, total);
    }
    Ok(outputs)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request(seed_val: f32, audio_frames: usize, d: usize) -> SampleRequest {
        SampleRequest {
            seed: (0..120 * d).map(|x| seed_val + (x / d) as f32).collect(),
            audio: (0..audio_frames * AUDIO_DIM)
                .map(|x| (x / AUDIO_DIM) as f32)
                .collect(),
        }
    }

    /// SPEC §9.11: a stub that returns its last input motion token makes every generated frame equal seed
    /// frame 119, and L = min(1200, T_a − 239).
    #[test]
    fn stub_model_repeats_the_last_seed_frame() {
        let d = 225;
        let opts = SampleOptions::default();
        let reqs = vec![
            request(0.0, 1500, d),
            request(1000.0, 600, d),
            request(5.0, 239, d),
        ];
        let out = autoregress::<()>(
            &reqs,
            &opts,
            |motion, _audio, b| {
                let mut y = Vec::with_capacity(b * d);
                for k in 0..b {
                    y.extend_from_slice(&motion[(k * 120 + 119) * d..(k * 120 + 120) * d]);
                }
                Ok(y)
            },
            |_, _| {},
        )
        .unwrap();
        for (r, (o, ta)) in reqs.iter().zip(out.iter().zip([1500usize, 600, 239])) {
            let l = 1200usize.min((ta + 1).saturating_sub(240));
            assert_eq!(o.len(), (120 + l) * d, "T_a = {ta}");
            let last_seed = &r.seed[119 * d..120 * d];
            for g in 0..l {
                assert_eq!(&o[(120 + g) * d..(121 + g) * d], last_seed);
            }
        }
        assert_eq!(opts.generated_len(1500), 1200);
        assert_eq!(opts.generated_len(600), 361);
        assert_eq!(opts.generated_len(239), 0);
    }

    /// The audio window of step i is A[i, i+240); edge padding repeats the last frame.
    #[test]
    fn audio_windows_slide_and_pad() {
        let d = 219;
        for pad in [AudioPad::Stop, AudioPad::Edge] {
            let opts = SampleOptions {
                frames: 20,
                audio_pad: pad,
                layout: Layout::L219,
                ..Default::default()
            };
            let mut step = 0;
            let out = autoregress::<()>(
                &[request(0.0, 250, d)],
                &opts,
                |_m, audio, b| {
                    assert_eq!(audio.len(), b * 240 * AUDIO_DIM);
                    assert_eq!(audio[0], step as f32);
                    let last = audio[239 * AUDIO_DIM];
                    assert_eq!(last, (step + 239).min(249) as f32);
                    step += 1;
                    Ok(vec![0.5; b * d])
                },
                |_, _| {},
            )
            .unwrap();
            let want = if pad == AudioPad::Stop { 11 } else { 20 };
            assert_eq!(out[0].len(), (120 + want) * d);
        }
    }

    /// With offset outputs, a model that outputs zeros holds the last seed frame; one that
    /// outputs a constant step walks by that step per frame.
    #[test]
    fn offset_outputs_are_added_to_the_last_frame() {
        let d = 225;
        let opts = SampleOptions {
            frames: 5,
            offset_output: true,
            ..Default::default()
        };
        let req = request(3.0, 400, d);
        let out = autoregress::<()>(
            std::slice::from_ref(&req),
            &opts,
            |_m, _a, b| Ok(vec![0.25; b * d]),
            |_, _| {},
        )
        .unwrap();
        let last = &req.seed[119 * d..120 * d];
        for g in 0..5 {
            let f = &out[0][(120 + g) * d..(121 + g) * d];
            for (x, l) in f.iter().zip(last) {
                assert_eq!(*x, l + 0.25 * (g + 1) as f32);
            }
        }
    }

    /// Ensembling averages the overlapping predictions of each frame: a stub whose token j of
    /// pass i says i + j predicts frame i + j as i + j from every pass, so frames come out exact;
    /// one whose tokens say the pass index gives each frame the weighted mean of the passes.
    #[test]
    fn ensembling_averages_overlapping_predictions() {
        let d = 219;
        let layout = Layout::L219;
        for decay in [0.0, 0.5] {
            let opts = SampleOptions {
                frames: 8,
                ensemble: 3,
                ensemble_decay: decay,
                layout,
                ..Default::default()
            };
            let mut pass = 0usize;
            let out = autoregress::<()>(
                &[request(0.0, 400, d)],
                &opts,
                |_m, _a, b| {
                    let mut y = Vec::new();
                    for _ in 0..b {
                        for _j in 0..3 {
                            y.extend(std::iter::repeat_n(pass as f32, d));
                        }
                    }
                    pass += 1;
                    Ok(y)
                },
                |_, _| {},
            )
            .unwrap();
            let w: Vec<f64> = (0..3).map(|k| (-decay * k as f64).exp()).collect();
            for i in 0..8usize {
                // Frame i is predicted by passes i − j (token j) for j ≤ min(i, 2).
                let (mut num, mut den) = (0.0, 0.0);
                for (j, wj) in w.iter().enumerate().take(i.min(2) + 1) {
                    num += wj * (i - j) as f64;
                    den += wj;
                }
                let got = out[0][(120 + i) * d];
                assert!(
                    (got as f64 - num / den).abs() < 1e-5,
                    "decay {decay} frame {i}: {got}"
                );
            }
        }
    }

    #[test]
    fn feedback_projection_makes_rotations() {
        let mut f = vec![0.3f32; 225];
        project_frame(&mut f, Layout::L225);
        assert!(f[..6].iter().all(|&x| x == 0.0));
        let r: [f64; 9] = std::array::from_fn(|k| f[9 + k] as f64);
        assert!((qean_motion::rotation::determinant(&r) - 1.0).abs() < 1e-5);
    }

    /// The seam: a model that always answers one pose 10 cm away from a still seed. Without
    /// the seam the dance jumps 10 cm in one frame; with it the first frame continues the seed,
    /// the gap closes smoothly (no step above 1.6 × 10 cm / 20 frames) and from frame 20 on the
    /// frames are the model's.
    #[test]
    fn seam_closes_the_gap_smoothly() {
        let layout = Layout::L219;
        let d = layout.dim();
        let mut still = vec![0.0f32; d];
        for j in 0..24 {
            for k in [0, 4, 8] {
                still[3 + 9 * j + k] = 1.0;
            }
        }
        let mut target = still.clone();
        target[0] = 0.1;
        let spec = WindowSpec {
            motion_len: 4,
            audio_len: 4,
            ..Default::default()
        };
        let req = SampleRequest {
            seed: still.repeat(4),
            audio: vec![0.0; 40 * AUDIO_DIM],
        };
        let run = |seam_frames| {
            let opts = SampleOptions {
                frames: 30,
                seam_frames,
                feedback_project: true,
                layout,
                spec,
                ..Default::default()
            };
            let out = autoregress::<()>(
                std::slice::from_ref(&req),
                &opts,
                |_m, _a, b| Ok(target.repeat(b)),
                |_, _| {},
            )
            .unwrap();
            (0..34).map(|f| out[0][f * d] as f64).collect::<Vec<_>>()
        };
        let raw = run(0);
        assert!((raw[4] - 0.1).abs() < 1e-7, "no seam: jumps at once");
        let eased = run(20);
        assert!(
            eased[4].abs() < 1e-7,
            "first frame continues the still seed"
        );
        let steps: Vec<f64> = eased.windows(2).map(|p| p[1] - p[0]).collect();
        assert!(
            steps
                .iter()
                .all(|&s| (-1e-7..=1.6 * 0.1 / 20.0).contains(&s)),
            "{steps:?}"
        );
        assert!(eased[24..].iter().all(|&x| (x - 0.1).abs() < 1e-7));
    }

    #[test]
    fn a_short_seed_is_an_error_naming_the_request() {
        let opts = SampleOptions::default();
        let d = opts.layout.dim();
        let mut short = request(0.0, 400, d);
        short.seed.truncate(10 * d);
        let reqs = [request(0.0, 400, d), short];
        let e = autoregress::<String>(&reqs, &opts, |_m, _a, b| Ok(vec![0.0; b * d]), |_, _| {})
            .unwrap_err();
        assert!(
            e.to_string()
                .starts_with("sample request 1: the seed holds"),
            "{e}"
        );
    }
}
