//! The VQ-VAE + GPT at work (SPEC §13.8, music-only): the seed's tokens, then one token at a time from the
//! music base and the shared head over a sliding window, decoded by the frozen VQ-VAE, the root integrated
//! from the seed's first frame, rotations by IK, exported like every dance.

use std::path::Path;

use burn::tensor::{Device, Int, Tensor, TensorData};
use qean_aistpp::layout::GenreSet;
use qean_checkpoint::checkpoint::Checkpoint;
use qean_checkpoint::gpt::{music_tokens, normal_noise, FrozenVq};
use qean_checkpoint::vqvae::{denormalise, pos72_options};
use qean_checkpoint::FamilyModel;
use qean_config::gpt::GptConfig;
use qean_io::error::{Error, Result};
use qean_models::control::genre::GenreModule;
use qean_models::control::gpt::{music_token_dim, Gpt};
use qean_models::vqvae::VqVae;
use qean_motion::fk::FkRoot;
use qean_motion::ik::motion_from_joints;
use qean_motion::motion::Motion;
use qean_motion::pos72::pos72_to_joints;
use rand::{Rng, SeedableRng};

use crate::generate::{export_motion, GenerateOptions, Generated, Song};
pub use crate::keyframe_control::KeyframeRequest;
use qean_config::keyframe::KeyframeConfig;
use qean_models::control::keyframe::KeyframeModule;

/// How each token is picked (SPEC §13.8 "Picking").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Picking {
    /// 1 = greedy (Bailando), 0 = the full distribution.
    pub top_k: usize,
    pub temperature: f64,
    pub seed: u64,
    /// Codes among the last `repetition_window` tokens have their logits divided by this (multiplied when
    /// negative) first; 1 = off.
    pub repetition_penalty: f64,
    pub repetition_window: usize,
    /// Genre runs: the guidance s instead of the run's `genre.guidance` (None: the run's).
    pub genre_guidance: Option<f64>,
}

impl Picking {
    /// The run's picking (`[gpt]`) with a command line's top-k, temperature and repetition penalty, and
    /// the draws' seed.
    pub fn of(g: &GptConfig, o: &PickingOverrides, seed: u64) -> Picking {
        Picking {
            top_k: o.top_k.unwrap_or(g.top_k),
            temperature: o.temperature.unwrap_or(g.temperature),
            seed,
            repetition_penalty: o.repetition_penalty.unwrap_or(g.repetition_penalty),
            repetition_window: g.repetition_window,
            genre_guidance: o.genre_guidance,
        }
    }
}

/// A command line's picking settings (None: the run's).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PickingOverrides {
    pub top_k: Option<usize>,
    pub temperature: Option<f64>,
    pub repetition_penalty: Option<f64>,
    pub genre_guidance: Option<f64>,
}

/// The logits with the repetition penalty applied to the codes of `recent` (CTRL's: positive logits
/// divided by θ, negative ones multiplied).
fn penalised(logits: &[f32], recent: &[usize], theta: f64) -> Vec<f32> {
    let mut l = logits.to_vec();
    if theta > 1.0 {
        let mut seen = vec![false; l.len()];
        for &c in recent.iter().filter(|&&c| c < l.len()) {
            seen[c] = true;
        }
        for (v, _) in l.iter_mut().zip(&seen).filter(|(_, &s)| s) {
            *v = if *v > 0.0 {
                (*v as f64 / theta) as f32
            } else {
                (*v as f64 * theta) as f32
            };
        }
    }
    l
}

/// The next code from logits over K + 1 outputs after the codes `recent`: End (index K) forbidden; the
/// repetition penalty on the recent codes; greedy takes the first maximum; otherwise logits/τ, entries
/// below the k-th largest dropped (ties kept), a categorical draw.
pub fn pick(
    logits: &[f32],
    codes: usize,
    p: &Picking,
    recent: &[usize],
    rng: &mut impl Rng,
) -> usize {
    let start = recent.len().saturating_sub(p.repetition_window);
    let l = &penalised(&logits[..codes], &recent[start..], p.repetition_penalty)[..];
    let best = l.iter().enumerate().fold(
        (0, f32::NEG_INFINITY),
        |b, (i, &v)| if v > b.1 { (i, v) } else { b },
    );
    if p.top_k == 1 || p.temperature == 0.0 {
        return best.0;
    }
    let mut sorted: Vec<f32> = l.to_vec();
    sorted.sort_by(|a, b| b.total_cmp(a));
    let floor = if p.top_k == 0 || p.top_k >= codes {
        f32::NEG_INFINITY
    } else {
        sorted[p.top_k - 1]
    };
    let weights: Vec<f64> = l
        .iter()
        .map(|&v| {
            if v >= floor {
                (((v - best.1) as f64) / p.temperature).exp()
            } else {
                0.0
            }
        })
        .collect();
    let total: f64 = weights.iter().sum();
    let mut u = rng.random::<f64>() * total;
    for (i, w) in weights.iter().enumerate() {
        if *w > 0.0 {
            if u < *w {
                return i;
            }
            u -= w;
        }
    }
    best.0
}

/// A genre-control run's genre names, checked against the data it is evaluated on.
pub(crate) fn run_genres(
    ck: &qean_checkpoint::Checkpoint,
    ds: &qean_aistpp::dataset::Dataset,
) -> Result<Vec<&'static str>> {
    let set = ck.config.genre_table().genres;
    if ds.layout.genre_set() != Some(set) {
        return Err(Error::msg(format!(
            "{}: {} controls {set:?} genres, the data is {}",
            ds.root.display(),
            ck.dir.display(),
            ds.layout.name()
        )));
    }
    Ok(set.names().to_vec())
}

/// A requested genre (SPEC §13.8 "optional controls"): the genre index and the seed of the noise z.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct GenreChoice {
    pub genre: usize,
    pub z_seed: u64,
}

impl GenreChoice {
    /// A genre by its name in `set` (AIST++: BR, PO, LO, MH, LH, HO, WA, KR, JS, JB; FineDance: its labels).
    pub fn parse(code: &str, set: GenreSet, z_seed: u64) -> Result<GenreChoice> {
        let genre = set.index(code).ok_or_else(|| {
            Error::msg(format!(
                "unknown genre `{code}`: expected one of {}",
                set.names().join(", ")
            ))
        })?;
        Ok(GenreChoice { genre, z_seed })
    }

    /// The genre tokens G [1, n_g, D] of this choice.
    pub fn tokens(&self, module: &GenreModule, z_dim: usize) -> Tensor<3> {
        let z = normal_noise(self.z_seed, z_dim);
        let z = Tensor::from_data(TensorData::new(z, [1, z_dim]), &Device::flex());
        module.gen.forward(z, &[self.genre])
    }
}

/// A text control as asked for (SPEC §13.7): an embedding (a `.npy` of `gpt.text_dim` values, e.g. a CLIP
/// text embedding, or `genre:XX`, the synthetic text set's pseudo-embedding of genre XX) over an interval
/// of the output dance in seconds, seed included.
#[derive(Debug, Clone, PartialEq)]
pub struct TextRequest {
    pub embedding: TextEmbedding,
    pub from_s: f64,
    pub to_s: f64,
}

impl std::fmt::Display for TextEmbedding {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TextEmbedding::Named(name) => f.write_str(name),
            TextEmbedding::Values(v) => write!(f, "({} values)", v.len()),
        }
    }
}

/// Where a text control's embedding comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum TextEmbedding {
    /// `--text-embedding`: a `.npy` path or `genre:XX`.
    Named(String),
    /// Values already read (a caption's row of a text set), `gpt.text_dim` of them.
    Values(Vec<f32>),
}

/// A text control on the token grid: the embedding and the tokens [start, end) it covers.
#[derive(Debug, Clone, PartialEq)]
pub struct TextControl {
    pub embedding: Vec<f32>,
    pub start: usize,
    pub end: usize,
}

impl TextRequest {
    /// Each `--text-embedding` over the `--text-interval` given in the same place, in time order; two
    /// intervals may not overlap.
    pub fn list(embeddings: &[String], intervals: &[String]) -> Result<Vec<TextRequest>> {
        if embeddings.len() != intervals.len() {
            return Err(Error::msg(format!(
                "{} --text-embedding for {} --text-interval: give one interval per embedding",
                embeddings.len(),
                intervals.len()
            )));
        }
        let mut out = Vec::new();
        for (embedding, interval) in embeddings.iter().zip(intervals) {
            let (from_s, to_s) =
                Self::interval(interval).map_err(|e| Error::msg(format!("--text-interval {e}")))?;
            out.push(TextRequest {
                embedding: TextEmbedding::Named(embedding.clone()),
                from_s,
                to_s,
            });
        }
        out.sort_by(|a, b| a.from_s.total_cmp(&b.from_s));
        if let Some(w) = out.windows(2).find(|w| w[1].from_s < w[0].to_s) {
            return Err(Error::msg(format!(
                "--text-interval {}..{} overlaps {}..{}: one text at a time",
                w[0].from_s, w[0].to_s, w[1].from_s, w[1].to_s
            )));
        }
        Ok(out)
    }

    /// `A..B` in seconds, A < B.
    pub fn interval(text: &str) -> std::result::Result<(f64, f64), String> {
        let (a, b) = text
            .split_once("..")
            .ok_or_else(|| format!("`{text}`: expected START..END in seconds, e.g. 4.0..6.5"))?;
        let parse = |x: &str| {
            x.trim()
                .parse::<f64>()
                .ok()
                .filter(|v| v.is_finite() && *v >= 0.0)
                .ok_or_else(|| format!("`{text}`: `{x}` is not a time in seconds"))
        };
        let (a, b) = (parse(a)?, parse(b)?);
        if a >= b {
            return Err(format!("`{text}`: the interval is empty or reversed"));
        }
        Ok((a, b))
    }

    /// The embedding's values, `gpt.text_dim` of them (unit length under `gpt.text_l2_normalise`, as the
    /// T-Base was trained).
    fn embedding(&self, g: &GptConfig) -> Result<Vec<f32>> {
        let dim = g.text_dim;
        let name = match &self.embedding {
            TextEmbedding::Named(name) => name,
            TextEmbedding::Values(v) if v.len() == dim => return Ok(v.clone()),
            TextEmbedding::Values(v) => {
                return Err(Error::msg(format!(
                    "a text embedding of {} values; this GPT's T-Base takes gpt.text_dim = {dim}",
                    v.len()
                )))
            }
        };
        if let Some(code) = name.strip_prefix("genre:") {
            let genre = GenreChoice::parse(code, GenreSet::Aistpp, 0)?.genre;
            return Ok(qean_checkpoint::gpt::genre_embedding(genre, dim));
        }
        qean_aistpp::text_set::read_embedding(Path::new(name), dim, g.text_l2_normalise)
    }

    /// What can be checked before any music is read: a GPT whose T-Base was trained, an embedding of its
    /// width, an interval after the seed of `seed_frames`.
    pub fn check(&self, g: &GptConfig, seed_frames: usize) -> Result<()> {
        self.control(g, seed_frames / g.rate, usize::MAX)
            .map(|_| ())
    }

    /// Every request's control (`requests` in time order, as `list` gives them); two intervals may not
    /// share a token.
    pub fn controls(
        requests: &[TextRequest],
        g: &GptConfig,
        seed_tokens: usize,
        n_total: usize,
    ) -> Result<Vec<TextControl>> {
        let controls = requests
            .iter()
            .map(|t| t.control(g, seed_tokens, n_total))
            .collect::<Result<Vec<_>>>()?;
        for k in 1..controls.len() {
            if controls[k].start < controls[k - 1].end {
                let (a, b) = (&requests[k - 1], &requests[k]);
                return Err(Error::msg(format!(
                    "--text-interval {}..{} and {}..{} share the token at {:.3} s ({} frames a token): start the second at {:.3} s or later",
                    a.from_s,
                    a.to_s,
                    b.from_s,
                    b.to_s,
                    (controls[k].start * g.rate) as f64 / 60.0,
                    g.rate,
                    (controls[k - 1].end * g.rate) as f64 / 60.0
                )));
            }
        }
        Ok(controls)
    }

    /// On the token grid of a dance of `seed_tokens` seed and `n_total` tokens in all; an interval that
    /// starts inside the seed or ends after the dance is an error, and so is a GPT whose T-Base was never
    /// trained.
    pub fn control(
        &self,
        g: &GptConfig,
        seed_tokens: usize,
        n_total: usize,
    ) -> Result<TextControl> {
        if !g.has_text() {
            return Err(Error::msg(
                "text control needs a GPT whose T-Base was trained (gpt.text_set, gpt.text_dir or gpt.synthetic_text); this run took music steps only",
            ));
        }
        let frame = |s: f64| (s * 60.0).round() as usize;
        let (start, end) = qean_models::control::fusion::interval_tokens(
            frame(self.from_s),
            frame(self.to_s),
            g.rate,
        );
        let seconds = |tokens: usize| (tokens * g.rate) as f64 / 60.0;
        if start < seed_tokens {
            return Err(Error::msg(format!(
                "--text-interval {}..{} starts inside the seed (its first {:.2} s)",
                self.from_s,
                self.to_s,
                seconds(seed_tokens)
            )));
        }
        if end > n_total {
            return Err(Error::msg(format!(
                "--text-interval {}..{} ends after the dance ({:.2} s: the music or --frames ends there)",
                self.from_s,
                self.to_s,
                seconds(n_total)
            )));
        }
        Ok(TextControl {
            embedding: self.embedding(g)?,
            start,
            end,
        })
    }
}

/// The head's input for the window [s, i] under text controls `texts` (eq. 2, disjoint intervals): h^M
/// where the music weight is 1, else F = h^T (1 − w) + h^M w with each position's h^T and w from the
/// interval that holds it.
fn text_window(
    model: &Gpt,
    g: &GptConfig,
    texts: &[TextControl],
    tokens: &[usize],
    (s, i): (usize, usize),
    h_m: Tensor<3>,
) -> Tensor<3> {
    use qean_models::control::fusion::{fuse, fusion_weights};
    let mut w = vec![1.0; i + 1 - s];
    let mut h_t: Option<Tensor<3>> = None;
    for t in texts {
        let wt = fusion_weights(i + 1, t.start, t.end, g.text_ramp, g.text_schedule);
        if wt[s..=i].iter().all(|&x| x == 1.0) {
            continue;
        }
        for (a, b) in w.iter_mut().zip(&wt[s..=i]) {
            *a = f64::min(*a, *b);
        }
        let part = text_rows(model, g, t, tokens, (s, i), h_m.dims()[2]);
        h_t = Some(match h_t {
            Some(acc) => acc + part,
            None => part,
        });
    }
    match h_t {
        Some(h_t) => fuse(h_t, h_m, &w),
        None => h_m,
    }
}

/// h^T of one text interval over the window [s, i] (zeros outside the interval): one causal T-Base pass over
/// [e_text, c_a, …, c_{last−1}] (last = min(i, end − 1); the context starts at the interval's start and
/// slides to stay within the window, e_text kept first).
fn text_rows(
    model: &Gpt,
    g: &GptConfig,
    t: &TextControl,
    tokens: &[usize],
    (s, i): (usize, usize),
    d: usize,
) -> Tensor<3> {
    let device = Device::flex();
    let last = i.min(t.end - 1);
    let a = t.start.max((last + 1).saturating_sub(g.window));
    let text = Tensor::<1>::from_data(
        TensorData::new(t.embedding.clone(), [t.embedding.len()]),
        &device,
    )
    .unsqueeze::<2>();
    let h_t = model.t_base.forward_context(text, &tokens[a..last]);
    // h^T_j for j in [a, last] ∩ [s, i]; zeros where w_j = 1.
    let (lo, hi) = (a.max(s), last.min(i));
    let mut parts = Vec::new();
    if lo > s {
        parts.push(Tensor::zeros([1, lo - s, d], &device));
    }
    parts.push(h_t.narrow(1, lo - a, hi - lo + 1));
    if hi < i {
        parts.push(Tensor::zeros([1, i - hi, d], &device));
    }
    Tensor::cat(parts, 1)
}

/// A genre request as the sampler applies it: the genre module, its tokens G [1, n_g, D] and the guidance s.
pub struct GenreSteer<'a> {
    pub module: &'a GenreModule,
    pub tokens: Tensor<3>,
    pub guidance: f64,
}

/// A `--genre-guidance` in range and with a genre to steer towards (`genre`), or one line saying why not.
pub fn check_guidance(guidance: Option<f64>, genre: bool) -> Result<()> {
    match guidance {
        Some(s) if !qean_config::genre::GUIDANCE_RANGE.contains(&s) => Err(Error::msg(format!(
            "--genre-guidance must be between 0 and 20 (1 = the paper's sampling), got {s}"
        ))),
        Some(_) if !genre => Err(Error::msg(
            "--genre-guidance steers genre-control dances: give --genre on a genre-control run",
        )),
        _ => Ok(()),
    }
}

/// l_plain + s·(l_genre − l_plain) (`genre.guidance`); the plain logits are computed only when s ≠ 1.
fn guided(steered: Vec<f32>, s: f64, plain: impl FnOnce() -> Vec<f32>) -> Vec<f32> {
    if s == 1.0 {
        return steered;
    }
    let s = s as f32;
    plain()
        .iter()
        .zip(&steered)
        .map(|(p, q)| p + s * (q - p))
        .collect()
}

/// Tokens n_total = min(seed + wanted, music tokens) from `seed` tokens and music tokens (n_total × 280);
/// with `genre`, the genre module steers every M-Base block with the tokens G; with `text`, the head reads
/// the fusion of both bases inside its interval.
#[allow(clippy::too_many_arguments)]
pub fn sample_tokens(
    model: &Gpt,
    genre: Option<GenreSteer>,
    texts: &[TextControl],
    g: &GptConfig,
    seed: &[usize],
    music: &[f32],
    n_total: usize,
    picking: &Picking,
    progress: &mut dyn FnMut(usize, usize),
) -> Vec<usize> {
    let device = Device::flex();
    let w = music_token_dim(g);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(picking.seed);
    let mut tokens = seed.to_vec();
    for i in seed.len()..n_total {
        let s = (i + 1).saturating_sub(g.window);
        let len = i - s + 1;
        let inputs: Vec<i64> = (s..=i)
            .map(|j| {
                if j == 0 {
                    g.codes as i64
                } else {
                    tokens[j - 1] as i64
                }
            })
            .collect();
        let rows: Vec<f32> = (s..=i)
            .flat_map(|j| {
                let j = (j + g.music_lookahead).min(n_total - 1);
                music[j * w..(j + 1) * w].iter().copied()
            })
            .collect();
        let inputs = Tensor::<2, Int>::from_data(TensorData::new(inputs, [1, len]), &device);
        let rows = Tensor::from_data(TensorData::new(rows, [1, len, w]), &device);
        let last_logits = |h_m: Tensor<3>| -> Vec<f32> {
            let h = match texts {
                [] => h_m,
                _ => text_window(model, g, texts, &tokens, (s, i), h_m),
            };
            let logits = model.head.forward(h);
            logits
                .narrow(1, len - 1, 1)
                .into_data()
                .convert::<f32>()
                .try_to_vec()
                .expect("f32")
        };
        let last = match &genre {
            Some(steer) => {
                let steered = last_logits(model.m_base.forward_genre(
                    inputs.clone(),
                    rows.clone(),
                    Some((steer.module, steer.tokens.clone())),
                ));
                let s = picking.genre_guidance.unwrap_or(steer.guidance);
                guided(steered, s, || {
                    last_logits(model.m_base.forward(inputs, rows))
                })
            }
            None => last_logits(model.m_base.forward(inputs, rows)),
        };
        let next = pick(&last, g.codes, picking, &tokens, &mut rng);
        tokens.push(next);
        progress(
            (i + 1 - seed.len()) * g.rate,
            (n_total - seed.len()) * g.rate,
        );
    }
    tokens
}

/// How decoded tokens become a dance after the seed.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Decoding {
    /// Frames over which the body eases out of the seed's last pose (`recipe.seam_frames`).
    pub seam_frames: usize,
    /// Window of the floor pinning (`gpt.floor_window`; 0 = off).
    pub floor_window: usize,
    /// Window of the feet's glide removal (`gpt.slide_window`; 0 = off).
    pub slide_window: usize,
    /// σ in frames of the temporal filter on the decoded joints (`gpt.smooth_sigma`; 0 = off).
    pub smooth_sigma: f64,
    /// Frames on each side of a keyframe over which the decoded dance is warped to its pose
    /// (`keyframe.warp_frames`; 0 = off, the paper's tokens alone).
    pub warp_frames: usize,
}

impl Decoding {
    /// A GPT run's own decoding (its `recipe.seam_frames`, `gpt.floor_window` and `gpt.slide_window`).
    pub fn of(config: &qean_config::RunConfig) -> Decoding {
        let g = config.gpt_table();
        Decoding {
            seam_frames: config.recipe.seam_frames,
            floor_window: g.floor_window,
            slide_window: g.slide_window,
            smooth_sigma: g.smooth_sigma,
            warp_frames: config.keyframe_table().warp_frames,
        }
    }
}

/// The dance of `tokens`: the seed motion as given, then the decoded frames after it (every token decoded,
/// the root integrated and continued from the seed's last frame, the body eased out of the seed's last pose
/// over `seam_frames` frames, its lowest point pinned to the seed's floor over `floor_window` frames and its
/// feet's glide taken away over `slide_window` frames, warped to each keyframe's pose over `warp_frames`
/// frames on each side), rotations by IK.
pub fn decode_dance(
    vq: &FrozenVq,
    seed: &Motion,
    (tokens, keys): (&[usize], &[KeyframeRequest]),
    d: Decoding,
) -> Motion {
    let c = vq.checkpoint.config.vq_table();
    let n = tokens.len();
    let mut rows = VqVae::host_rows(&vq.model.decode_tokens(tokens, 1, n));
    denormalise(&mut rows, c);
    let rows: Vec<f64> = rows.iter().map(|&v| v as f64).collect();
    let seed_joints = seed.joints(FkRoot::Smpl);
    let mut joints = pos72_to_joints(&rows, seed_joints[0], &pos72_options(c));
    // The decoder's frame-to-frame roughness, taken away before anything is fitted to the frames.
    qean_motion::smooth::gaussian_smooth(&mut joints, seed.frames, d.smooth_sigma);
    // The tail continues from the seed's last root: integrated from J_0(0) (SPEC §13.8) the decoded root
    // drifts over the seed tokens by their reconstruction error, which showed as a jump at the seam.
    let last = (seed.frames - 1) * 24;
    let shift: [f64; 3] = std::array::from_fn(|k| seed_joints[last][k] - joints[last][k]);
    for p in joints.iter_mut() {
        for k in 0..3 {
            p[k] += shift[k];
        }
    }
    // The body is off by the same reconstruction error (about 5 cm, one frame: a 2–3 m/s spike at the
    // seam); `recipe.seam_frames` fades it out (qean_motion::seam).
    let seed_last = &seed_joints[last..last + 24];
    qean_motion::seam::ease_joints(&mut joints, seed.frames - 1, seed_last, d.seam_frames);
    // The integrated root drifts with the decoded velocities' bias (the demo's dances sank 0.6–0.8 m and
    // glided 0.4–1.2 m in 20 s); the seed's lowest joint is the floor.
    let floor = qean_motion::floor::floor_of(&seed_joints);
    qean_motion::floor::pin_to_floor(&mut joints, seed.frames, floor, d.floor_window);
    qean_motion::floor::stop_sliding(&mut joints, seed.frames, floor, d.slide_window);
    if d.warp_frames > 0 {
        for k in keys {
            qean_motion::seam::warp_to_pose(&mut joints, k.frame, &k.pose, d.warp_frames);
        }
    }
    let tail = motion_from_joints(
        &joints[seed.frames * 24..],
        Default::default(),
        FkRoot::Smpl,
    );
    let mut poses = seed.poses.clone();
    poses.extend_from_slice(&tail.poses);
    let mut trans: Vec<f64> = seed.trans.iter().map(|x| x / seed.scaling).collect();
    trans.extend_from_slice(&tail.trans);
    Motion::new(poses, trans, 1.0).expect("whole frames")
}

/// What a GPT dance follows besides the music: a genre (genre-control runs), texts over intervals (a GPT
/// whose T-Base was trained), keyframes (keyframe-control runs).
#[derive(Debug, Clone, Copy, Default)]
pub struct Controls<'a> {
    pub genre: Option<GenreChoice>,
    pub texts: &'a [TextRequest],
    pub keyframes: &'a [KeyframeRequest],
}

impl Controls<'_> {
    /// A genre alone (or nothing).
    pub fn genre(genre: Option<GenreChoice>) -> Self {
        Controls {
            genre,
            ..Default::default()
        }
    }
}

/// The weights hash of the GPT a run samples with: its own (a GPT run), or the frozen GPT's that a genre or
/// keyframe stage recorded.
pub fn gpt_hash(ck: &Checkpoint) -> Result<String> {
    if let qean_config::ModelSpec::Gpt(_) = ck.config.spec() {
        return Ok(ck.sampled_hash().to_string());
    }
    let state = qean_checkpoint::weights::read_family_state(ck)?;
    state
        .as_ref()
        .and_then(|s| s["gpt_params_hash"].as_str())
        .map(str::to_string)
        .ok_or_else(|| {
            Error::at(
                &ck.dir,
                "the checkpoint does not record its GPT's weights hash",
            )
        })
}

/// A dance's tokens as the music-driven sampler left them: the seed's count, all tokens, the music tokens
/// (n × 280) they were sampled over.
pub struct Sampled {
    pub seed_tokens: usize,
    pub tokens: Vec<usize>,
    pub music: Vec<f32>,
}

/// A GPT run with its frozen VQ-VAE, loaded once; a genre-control run also brings its genre module (its
/// discriminator is not needed to sample), a keyframe-control run its keyframe module.
pub struct GptRun {
    pub model: Gpt,
    /// The genre module, z's width and the guidance (`genre.guidance`).
    pub genre: Option<(GenreModule, usize, f64)>,
    pub keyframe: Option<(KeyframeModule, KeyframeConfig)>,
    pub vq: FrozenVq,
    /// The seam's frames and the floor's and the glide's windows (the run's `recipe.seam_frames`,
    /// `gpt.floor_window` and `gpt.slide_window` unless a command line says otherwise).
    pub decoding: Decoding,
}

impl GptRun {
    pub fn load(ck: &Checkpoint) -> Result<GptRun> {
        let vq = FrozenVq::load(ck.config.gpt_table(), ck.run_dir().as_deref())?;
        let (model, genre, keyframe) = match ck.load_family(&Device::flex())? {
            FamilyModel::Gpt(model) => (model, None, None),
            FamilyModel::GptGenre(m) => {
                let c = ck.config.genre_table();
                (m.gpt, Some((m.genre, c.z_dim, c.guidance)), None)
            }
            FamilyModel::GptKeyframe(m) => (
                m.gpt,
                None,
                Some((m.keyframe, ck.config.keyframe_table().clone())),
            ),
            _ => return Err(ck.not_family("a music-to-dance GPT")),
        };
        Ok(GptRun {
            model,
            genre,
            keyframe,
            vq,
            decoding: Decoding::of(&ck.config),
        })
    }

    /// The genre tokens of `choice` (an error for a run without a genre module).
    fn genre_tokens(&self, choice: Option<GenreChoice>) -> Result<Option<GenreSteer<'_>>> {
        match (choice, &self.genre) {
            (None, _) => Ok(None),
            (Some(c), Some((module, z_dim, guidance))) => Ok(Some(GenreSteer {
                module,
                tokens: c.tokens(module, *z_dim),
                guidance: *guidance,
            })),
            (Some(_), None) => Err(Error::msg(
                "--genre needs a genre-control run (model.arch = \"gpt_genre\", configs/control/genre_tiny.toml); this GPT has no genre module",
            )),
        }
    }

    /// One dance: the seed then up to `frames` generated frames for music features (frames × 35); `None`
    /// when the music is shorter than the seed and one token.
    #[allow(clippy::too_many_arguments)]
    pub fn dance(
        &self,
        g: &GptConfig,
        seed: &Motion,
        music: (&[f32], usize),
        frames: usize,
        picking: &Picking,
        controls: Controls,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Option<Motion>> {
        let Some(sampled) = self.sample(g, seed, music, frames, picking, controls, progress)?
        else {
            return Ok(None);
        };
        self.finish(g, seed, &sampled, controls.keyframes, frames)
            .map(Some)
    }

    /// The music-driven tokens of one dance (genre and texts applied, keyframes not yet): `None` when the
    /// music is shorter than the seed and one token.
    #[allow(clippy::too_many_arguments)]
    pub fn sample(
        &self,
        g: &GptConfig,
        seed: &Motion,
        music: (&[f32], usize),
        frames: usize,
        picking: &Picking,
        controls: Controls,
        progress: &mut dyn FnMut(usize, usize),
    ) -> Result<Option<Sampled>> {
        check_guidance(picking.genre_guidance, controls.genre.is_some())?;
        let genre = self.genre_tokens(controls.genre)?;
        let seed_tokens = self.vq.tokens(seed, seed.frames / g.rate * g.rate)?;
        let available = music.1 / g.rate;
        let n_total = (seed_tokens.len() + frames.div_ceil(g.rate)).min(available);
        if n_total <= seed_tokens.len() {
            return Ok(None);
        }
        let texts = TextRequest::controls(controls.texts, g, seed_tokens.len(), n_total)?;
        let music = music_tokens(music.0, n_total, g.rate);
        let tokens = sample_tokens(
            &self.model,
            genre,
            &texts,
            g,
            &seed_tokens,
            &music,
            n_total,
            picking,
            progress,
        );
        Ok(Some(Sampled {
            seed_tokens: seed_tokens.len(),
            tokens,
            music,
        }))
    }

    /// The dance of `sampled` tokens edited by `keyframes` (if any: re-predicted around them, the decoding
    /// warped to them), the seed and up to `frames` generated frames.
    pub fn finish(
        &self,
        g: &GptConfig,
        seed: &Motion,
        sampled: &Sampled,
        keyframes: &[KeyframeRequest],
        frames: usize,
    ) -> Result<Motion> {
        let mut tokens = sampled.tokens.clone();
        if !keyframes.is_empty() {
            let Some((module, c)) = &self.keyframe else {
                return Err(Error::msg(
                    "--keyframe needs a keyframe-control run (model.arch = \"gpt_keyframe\", configs/control/keyframe_tiny.toml); this GPT has no keyframe module",
                ));
            };
            tokens = crate::keyframe_control::apply_keyframes(
                (&self.model, module, c),
                &self.vq,
                g,
                &tokens,
                sampled.seed_tokens,
                &sampled.music,
                keyframes,
            )?;
        }
        let motion = decode_dance(&self.vq, seed, (&tokens, keyframes), self.decoding);
        Ok(motion.slice(0, (seed.frames + frames).min(motion.frames)))
    }
}

/// `qean sample` for a GPT run: one dance per song from the same seed.
pub fn generate(
    ck: &Checkpoint,
    songs: &[Song],
    seed: &Motion,
    opts: &GenerateOptions,
    out: &Path,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Vec<Generated>> {
    let g = ck.config.gpt_table();
    let mut run = GptRun::load(ck)?;
    if let Some(dir) = &opts.keyframe_run {
        let (module, c) = crate::keyframe_control::keyframe_module_for(dir, &gpt_hash(ck)?)?;
        run.decoding.warp_frames = c.warp_frames;
        run.keyframe = Some((module, c));
    }
    run.decoding.seam_frames = opts.seam_frames;
    if let Some(w) = opts.floor_window {
        run.decoding.floor_window = w;
    }
    if let Some(w) = opts.slide_window {
        run.decoding.slide_window = w;
    }
    if let Some(s) = opts.smooth_sigma {
        run.decoding.smooth_sigma = s;
    }
    let picking = Picking::of(
        g,
        &PickingOverrides {
            top_k: opts.top_k,
            temperature: opts.temperature,
            repetition_penalty: opts.repetition_penalty,
            genre_guidance: opts.genre_guidance,
        },
        opts.sample_seed,
    );
    let mut written = Vec::new();
    for song in songs {
        // As the run heard music in training (`recipe.audio_norm`: split or per-track statistics).
        let features = ck
            .config
            .recipe
            .model_audio(song.features.data.clone(), qean_aistpp::windows::AUDIO_DIM);
        let music = (features.as_slice(), song.features.frames);
        let Some(motion) = run.dance(
            g,
            seed,
            music,
            opts.frames,
            &picking,
            Controls {
                genre: opts.genre,
                texts: &opts.text,
                keyframes: &opts.keyframes,
            },
            progress,
        )?
        else {
            return Err(Error::at(
                &song.path,
                format!(
                    "the music has {} frames: shorter than the seed and one token ({} frames)",
                    song.features.frames,
                    seed.frames + g.rate
                ),
            ));
        };
        if motion.frames - seed.frames < opts.frames {
            tracing::warn!(
                "{}: the music ends after {} frames: generating {} frames instead of {}",
                song.path.display(),
                song.features.frames,
                motion.frames - seed.frames,
                opts.frames
            );
        }
        written.push(export_motion(out, song, &motion, seed.frames, opts.render)?);
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Guidance 1 is the steered logits as they are (the plain ones never computed), 0 the plain ones, and
    /// 2 goes as far again beyond the steered ones.
    #[test]
    fn genre_guidance_extrapolates_from_the_plain_logits() {
        let steered = vec![1.0f32, -2.0, 0.5];
        let plain = vec![0.0f32, -1.0, 0.5];
        assert_eq!(guided(steered.clone(), 1.0, || unreachable!()), steered);
        assert_eq!(guided(steered.clone(), 0.0, || plain.clone()), plain);
        assert_eq!(
            guided(steered.clone(), 2.0, || plain.clone()),
            vec![2.0, -3.0, 0.5]
        );
    }

    #[test]
    fn picking_forbids_end_keeps_ties_and_is_greedy_by_default() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let greedy = Picking {
            top_k: 1,
            temperature: 1.0,
            seed: 0,
            repetition_penalty: 1.0,
            repetition_window: 8,
            genre_guidance: None,
        };
        // End (index 3) has the largest logit but is never picked; ties go to the first maximum.
        assert_eq!(pick(&[1.0, 2.0, 2.0, 9.0], 3, &greedy, &[], &mut rng), 1);
        // top-2 keeps both tied entries (and only them).
        let top2 = Picking { top_k: 2, ..greedy };
        for _ in 0..50 {
            let k = pick(&[0.0, 2.0, 2.0, 2.0, 9.0], 4, &top2, &[], &mut rng);
            assert!((1..=3).contains(&k), "{k}");
        }
        let full = Picking { top_k: 0, ..greedy };
        let drawn: std::collections::HashSet<usize> = (0..200)
            .map(|_| pick(&[0.0, 0.0, 0.0, 50.0], 3, &full, &[], &mut rng))
            .collect();
        assert_eq!(drawn.len(), 3);
    }

    #[test]
    fn the_repetition_penalty_steers_greedy_picking_off_recent_codes() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(0);
        let p = Picking {
            top_k: 1,
            temperature: 1.0,
            seed: 0,
            repetition_penalty: 2.0,
            repetition_window: 2,
            genre_guidance: None,
        };
        let logits = [3.0f32, 2.0, -1.0, 9.0];
        // Code 0 (3.0) was just used: 3/2 = 1.5 < 2.0, so code 1 wins.
        assert_eq!(pick(&logits, 3, &p, &[0], &mut rng), 1);
        // Outside the window it counts no more.
        assert_eq!(pick(&logits, 3, &p, &[0, 2, 2], &mut rng), 0);
        // A negative logit is pushed further down, and θ = 1 is the paper's picking.
        assert_eq!(penalised(&[-1.0, 1.0], &[0, 1], 2.0), vec![-2.0, 0.5]);
        let off = Picking {
            repetition_penalty: 1.0,
            ..p
        };
        assert_eq!(pick(&logits, 3, &off, &[0], &mut rng), 0);
    }
}
