//! The music-to-dance GPT as a trainer [`Family`] (SPEC §13.3.6, stage 2): every sequence tokenised once by the
//! frozen VQ-VAE of `gpt.vqvae_run`, cut into windows of n tokens with their music tokens, and the music step's
//! cross-entropy over B × n targets. Without text data every step is a music step; the T-Base then never
//! receives a gradient, so neither its weights nor its optimiser state move.

use std::sync::Arc;

use burn::tensor::{Device, Int, Tensor, TensorData};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::feature_cache;
use qean_aistpp::windows::{Batch, Sequence, SequenceSet, WindowSpec};
use qean_config::gpt::GptConfig;
use qean_config::run::RunConfig;
use qean_io::error::{Error, Result};
use qean_models::control::gpt::{music_token_dim, Gpt};
use qean_models::tsmt::loss::masked_cross_entropy;
use qean_motion::motion::Layout;
use rand::{Rng, SeedableRng};

use crate::family::{Family, StepContext};
use qean_checkpoint::checkpoint::Checkpoint;
pub use qean_checkpoint::gpt::genre_embedding;
use qean_checkpoint::gpt::{music_tokens, FrozenVq, FEATURES};
use qean_checkpoint::FamilyModel;
use std::path::Path;

/// The GPT family: the frozen VQ-VAE once `prepare` has loaded it, and the text data of text steps.
#[derive(Default)]
pub struct GptFamily {
    vq: Option<FrozenVq>,
    texts: Vec<TextItem>,
}

/// One (text embedding, motion) pair of the training split: the embedding and the first codes of the motion.
#[derive(Debug, Clone)]
pub struct TextItem {
    pub name: String,
    pub embedding: Vec<f32>,
    pub codes: Vec<usize>,
}

/// A text step's batch: embeddings [B, text_dim], T-Base input tokens [B, n − 1], targets [B, n] and the
/// positions each row's loss counts (codes + End, at most n).
pub struct TextInputs {
    pub text: Tensor<2>,
    pub tokens: Tensor<2, Int>,
    pub targets: Tensor<2, Int>,
    pub lengths: Vec<usize>,
}

/// A GPT training batch: a music step or a text step (§13.3.6 "Alternation").
pub enum GptBatch {
    Music(GptInputs),
    Text(TextInputs),
}

/// T2M-GPT's text-step targets for one motion's codes (SPEC §13.3.6): with probability 1/3 the first or the
/// last code is dropped (even odds), then at most n − 1 codes, End (= K) and Pad (= K + 1) up to n; a longer
/// motion gives its first n codes and no End. Returns the n targets and the positions the loss counts.
pub fn text_targets(codes: &[usize], n: usize, k: usize, rng: &mut impl Rng) -> (Vec<i64>, usize) {
    let mut c: &[usize] = codes;
    if rng.random_range(0..3) == 2 && c.len() > 1 {
        c = if rng.random_bool(0.5) {
            &c[..c.len() - 1]
        } else {
            &c[1..]
        };
    }
    let mut t: Vec<i64> = c.iter().take(n).map(|&x| x as i64).collect();
    if t.len() == n {
        return (t, n);
    }
    t.push(k as i64);
    let counted = t.len();
    t.resize(n, k as i64 + 1);
    (t, counted)
}

/// Each token kept with probability `pkeep`, otherwise replaced by a uniform random code (T2M-GPT applies
/// this to every input position, End and Pad included).
pub fn corrupt(tokens: &mut [i64], codes: usize, pkeep: f64, rng: &mut impl Rng) {
    if pkeep >= 1.0 {
        return;
    }
    for t in tokens.iter_mut() {
        if !rng.random_bool(pkeep) {
            *t = rng.random_range(0..codes as i64);
        }
    }
}

/// Per-sample mean cross-entropy over each row's first `lengths[b]` positions, then the batch mean.
pub fn per_sample_cross_entropy(
    logits: Tensor<3>,
    targets: Tensor<2, Int>,
    lengths: &[usize],
) -> Tensor<1> {
    let [b, n, k] = logits.dims();
    let device = logits.device();
    let weights: Vec<f32> = lengths
        .iter()
        .flat_map(|&len| (0..n).map(move |t| if t < len { 1.0 / (len * b) as f32 } else { 0.0 }))
        .collect();
    let weights = Tensor::<3>::from_data(TensorData::new(weights, [b, n, 1]), &device);
    let targets = targets.clamp(0, k as i64 - 1).reshape([b, n, 1]);
    let picked = burn::tensor::activation::log_softmax(logits, 2).gather(2, targets);
    (picked * weights).sum().neg()
}

impl GptFamily {
    /// The (embedding, motion) pairs of text steps, each with the first n + 1 codes of its motion: the
    /// training sequences named by `gpt.text_dir` or `gpt.synthetic_text`, and every caption of
    /// `gpt.text_set`'s `text_split`.
    fn load_texts(&self, g: &GptConfig, dataset: &Dataset, train: Split) -> Result<Vec<TextItem>> {
        if !g.has_text() {
            return Ok(Vec::new());
        }
        let mut items = self.sequence_texts(g, dataset, train)?;
        if let Some(root) = &g.text_set {
            items.extend(self.text_set_items(g, root)?);
        }
        if items.is_empty() {
            return Err(Error::at(
                g.text_set.as_deref().unwrap_or(&dataset.root),
                "text steps are configured (gpt.text_set, gpt.text_dir or gpt.synthetic_text) but no (embedding, motion) pair was found",
            ));
        }
        tracing::info!("text steps: {} (embedding, motion) pairs", items.len());
        Ok(items)
    }

    /// Text items of AIST++-layout training sequences: `gpt.text_dir/<sequence>.npy` or the synthetic
    /// genre embedding.
    fn sequence_texts(
        &self,
        g: &GptConfig,
        dataset: &Dataset,
        train: Split,
    ) -> Result<Vec<TextItem>> {
        if g.text_dir.is_none() && !g.synthetic_text {
            return Ok(Vec::new());
        }
        let vq = self.vq.as_ref().expect("the VQ-VAE is loaded first");
        let mut items = Vec::new();
        for name in dataset.split(train) {
            let embedding = match &g.text_dir {
                Some(dir) => {
                    let path = dir.join(format!("{name}.npy"));
                    if !path.is_file() {
                        continue;
                    }
                    qean_aistpp::text_set::read_embedding(&path, g.text_dim, g.text_l2_normalise)?
                }
                None => match dataset.genre(&name) {
                    Some(genre) => genre_embedding(genre, g.text_dim),
                    None => continue,
                },
            };
            let path = dataset.motion_path(&name);
            if !path.is_file() {
                continue;
            }
            let motion = dataset.read_motion(&name)?;
            let n = (motion.frames / g.rate).min(g.window + 1);
            if n == 0 {
                continue;
            }
            let codes = vq
                .tokens(&motion, n * g.rate)
                .map_err(|e| Error::msg(format!("{name}: {e}")))?;
            items.push(TextItem {
                name,
                embedding,
                codes,
            });
        }
        Ok(items)
    }

    /// Text items of a HumanML3D-layout set (SPEC §13.1): one per caption, its slice of the motion as
    /// 24 joints at 60 fps, tokenised.
    fn text_set_items(&self, g: &GptConfig, root: &Path) -> Result<Vec<TextItem>> {
        let vq = self.vq.as_ref().expect("the VQ-VAE is loaded first");
        let set = qean_aistpp::text_set::TextSet::open(root, &g.text_split)?;
        let opts = g.text_set_options();
        let bar = qean_checkpoint::progress::bar(set.ids.len() as u64, "text set", "motions");
        let mut items = Vec::new();
        for id in &set.ids {
            for clip in set.clips(id, &opts)? {
                let frames = clip.joints.len() / qean_motion::skeleton::NUM_JOINTS;
                let n = (frames / g.rate).min(g.window + 1);
                let codes = vq
                    .tokens_of_joints(&clip.joints, n * g.rate)
                    .map_err(|e| Error::msg(format!("{}: {id}: {e}", root.display())))?;
                items.push(TextItem {
                    name: format!("{id}#{}", clip.line),
                    embedding: clip.embedding,
                    codes,
                });
            }
            bar.inc(1);
        }
        bar.finish_and_clear();
        Ok(items)
    }

    /// A text step's batch of `b` pairs drawn with the update's seed.
    fn text_batch(&self, g: &GptConfig, b: usize, seed: u64, device: &Device) -> TextInputs {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x7465_7874);
        let n = g.window;
        let (mut text, mut tokens, mut targets, mut lengths) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for _ in 0..b {
            let item = &self.texts[rng.random_range(0..self.texts.len())];
            let (t, counted) = text_targets(&item.codes, n, g.codes, &mut rng);
            let mut input = t[..n - 1].to_vec();
            corrupt(&mut input, g.codes, g.pkeep, &mut rng);
            text.extend_from_slice(&item.embedding);
            tokens.extend(input);
            targets.extend(t);
            lengths.push(counted);
        }
        TextInputs {
            text: Tensor::from_data(TensorData::new(text, [b, g.text_dim]), device),
            tokens: Tensor::from_data(TensorData::new(tokens, [b, n - 1]), device),
            targets: Tensor::from_data(TensorData::new(targets, [b, n]), device),
            lengths,
        }
    }

    /// Whether update `step` is a text step.
    fn is_text_step(&self, g: &GptConfig, step: u64) -> bool {
        !self.texts.is_empty() && step % g.text_every == g.text_every - 1
    }
}

/// A batch: input tokens [B, n], music tokens [B, n, 280], targets [B, n].
pub struct GptInputs {
    pub tokens: Tensor<2, Int>,
    pub music: Tensor<3>,
    pub targets: Tensor<2, Int>,
}

/// The `[gpt]` table of a GPT run.
pub fn gpt_of(config: &RunConfig) -> &GptConfig {
    config.gpt_table()
}

/// Windows of n input tokens (rows u..u+n−1 of [Start, c_0, …]), targets one row later, music rows
/// u+1+δ.. (row i ≥ 1 holds a_{i−1}).
pub fn window_spec(g: &GptConfig) -> WindowSpec {
    WindowSpec {
        motion_len: g.window,
        target_len: g.window,
        target_shift: 1,
        audio_len: g.window + 1 + g.music_lookahead,
    }
}

/// A batch as tensors; `pkeep` < 1 replaces each input token by a uniform random code with
/// probability 1 − pkeep (seeded).
pub fn tensors(batch: &Batch, g: &GptConfig, pkeep: f64, seed: u64, device: &Device) -> GptInputs {
    let (b, n) = (batch.len(), g.window);
    let w = music_token_dim(g);
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed ^ 0x6770_7400);
    let tokens: Vec<i64> = batch
        .motion
        .iter()
        .map(|&t| {
            if pkeep < 1.0 && t < g.codes as f32 && !rng.random_bool(pkeep) {
                rng.random_range(0..g.codes as i64)
            } else {
                t as i64
            }
        })
        .collect();
    let targets: Vec<i64> = batch.target.iter().map(|&t| t as i64).collect();
    let span = batch.spec.audio_len * w;
    let mut music = Vec::with_capacity(b * n * w);
    for row in batch.audio.chunks_exact(span) {
        let from = (1 + g.music_lookahead) * w;
        music.extend_from_slice(&row[from..from + n * w]);
    }
    GptInputs {
        tokens: Tensor::from_data(TensorData::new(tokens, [b, n]), device),
        music: Tensor::from_data(TensorData::new(music, [b, n, w]), device),
        targets: Tensor::from_data(TensorData::new(targets, [b, n]), device),
    }
}

/// The frozen GPT of a control stage (genre, keyframe).
pub struct FrozenGpt {
    pub checkpoint: Checkpoint,
}

impl FrozenGpt {
    /// The newest checkpoint of `run` (the stage's `TABLE.gpt_run`), a plain GPT run whose `[gpt]` sizes
    /// equal `g`'s.
    pub fn resolve(run: Option<&Path>, table: &str, g: &GptConfig) -> Result<FrozenGpt> {
        let run = run.ok_or_else(|| {
            Error::msg(format!(
                "{table}.gpt_run is not set: name the trained GPT run (--set {table}.gpt_run=DIR)"
            ))
        })?;
        let checkpoint = qean_checkpoint::checkpoint::resolve(run)
            .map_err(|e| Error::msg(format!("{table}.gpt_run: {e}")))?;
        let theirs = match checkpoint.config.spec() {
            qean_config::ModelSpec::Gpt(t) => t,
            _ => {
                return Err(Error::at(
                    &checkpoint.dir,
                    format!(
                        "{table}.gpt_run is not a music-to-dance GPT run (model.arch = {:?})",
                        checkpoint.config.model.arch
                    ),
                ))
            }
        };
        if theirs.shape() != g.shape() {
            return Err(Error::at(
                &checkpoint.dir,
                format!(
                    "the GPT run is {:?}, this config's [gpt] is {:?} ({})",
                    theirs.shape(),
                    g.shape(),
                    GptConfig::SHAPE_FIELDS
                ),
            ));
        }
        Ok(FrozenGpt { checkpoint })
    }

    /// Takes the GPT's VQ-VAE run and the music as it heard it (its `recipe.audio_norm` and statistics)
    /// into the stage's config, after checking that its weights load.
    pub fn adopt(&self, config: &mut RunConfig) -> Result<()> {
        self.load(&Device::flex())?;
        let vq_run = self
            .checkpoint
            .config
            .gpt
            .as_ref()
            .and_then(|g| g.vqvae_run.clone());
        if let Some(g) = config.gpt.as_mut() {
            g.vqvae_run = vq_run;
        }
        let heard = &self.checkpoint.config.recipe;
        config.recipe.audio_norm = heard.audio_norm;
        config.recipe.audio_mean = heard.audio_mean.clone();
        config.recipe.audio_std = heard.audio_std.clone();
        Ok(())
    }

    /// A resumed `stage` ("genre", "keyframe") must find this same GPT (its weights hash); logs which.
    pub fn confirm(&self, resume: Option<&Checkpoint>, stage: &str) -> Result<()> {
        qean_checkpoint::weights::check_frozen_hash(
            resume,
            "gpt_params_hash",
            &self.checkpoint,
            &format!("the GPT this {stage} stage"),
        )?;
        tracing::info!(
            "{stage} control over the frozen GPT {} (step {})",
            self.checkpoint.dir.display(),
            self.checkpoint.state.step
        );
        Ok(())
    }

    /// A control stage's checkpoint state: the GPT family's `base` (its VQ-VAE) with this GPT's checkpoint
    /// and weights hash (a resume checks it).
    pub fn stage_state(&self, base: Option<serde_json::Value>) -> Option<serde_json::Value> {
        let mut state = base?;
        state["gpt_checkpoint"] = serde_json::json!(self.checkpoint.dir);
        state["gpt_params_hash"] = serde_json::json!(self.checkpoint.sampled_hash());
        Some(state)
    }

    /// Its weights on `device`.
    pub fn load(&self, device: &Device) -> Result<Gpt> {
        match self.checkpoint.load_family(device)? {
            FamilyModel::Gpt(m) => Ok(m),
            _ => Err(self.checkpoint.not_family("a music-to-dance GPT")),
        }
    }
}

/// Mean cross-entropy over every target.
pub fn cross_entropy(logits: Tensor<3>, targets: Tensor<2, Int>) -> Tensor<1> {
    let [b, n, k] = logits.dims();
    masked_cross_entropy(
        logits.reshape([b, n, 1, k]),
        targets.reshape([b, n, 1]),
        &vec![n; b],
    )
}

impl GptFamily {
    /// The frozen VQ-VAE, once `prepare` has loaded it.
    pub fn frozen_vq(&self) -> Option<&FrozenVq> {
        self.vq.as_ref()
    }
}

impl Family for GptFamily {
    type Model = Gpt;
    type Inputs = GptBatch;

    fn init(&self, config: &RunConfig, device: &Device) -> Result<Gpt> {
        Ok(Gpt::new(gpt_of(config), device))
    }

    /// Loads the frozen VQ-VAE; a resumed run must find the same one (its weights hash).
    fn prepare(
        &mut self,
        config: &mut RunConfig,
        dataset: &Dataset,
        train: Split,
        resume: Option<&Checkpoint>,
    ) -> Result<()> {
        let g = config
            .gpt
            .as_ref()
            .ok_or_else(|| Error::msg("model.arch = \"gpt\" needs a [gpt] table"))?;
        g.validate().map_err(Error::msg)?;
        let vq = FrozenVq::load(g, None)?;
        qean_checkpoint::weights::check_frozen_hash(
            resume,
            "vqvae_params_hash",
            &vq.checkpoint,
            "the VQ-VAE this GPT",
        )?;
        tracing::info!(
            "tokens from the frozen VQ-VAE {} (step {})",
            vq.checkpoint.dir.display(),
            vq.checkpoint.state.step
        );
        self.vq = Some(vq);
        self.texts = self.load_texts(gpt_of(config), dataset, train)?;
        // `recipe.audio_norm = "standardize"`: a resumed run keeps its statistics, a fresh one fits them.
        if let Some(ck) = resume.filter(|_| config.recipe.needs_audio_stats()) {
            config.recipe.audio_mean = ck.config.recipe.audio_mean.clone();
            config.recipe.audio_std = ck.config.recipe.audio_std.clone();
        }
        if config.recipe.needs_audio_stats() {
            let (mean, std) = crate::data::audio_stats(dataset, train)?;
            config.recipe.audio_mean = mean;
            config.recipe.audio_std = std;
        }
        Ok(())
    }

    fn draw_spec(&self, config: &RunConfig) -> WindowSpec {
        window_spec(gpt_of(config))
    }

    /// Every sequence as token rows [Start, c_0, …] (1 value each) with music rows [0, a_0, …].
    fn load_set(
        &self,
        dataset: &Dataset,
        split: Split,
        spec: WindowSpec,
        config: &RunConfig,
    ) -> Result<SequenceSet> {
        let g = gpt_of(config);
        let vq = self.vq.as_ref().expect("prepare loads the VQ-VAE");
        qean_checkpoint::features::ensure_features(dataset, &dataset.split(split))?;
        let span = spec.span() * g.rate;
        let frame_spec = WindowSpec {
            motion_len: span,
            target_len: span,
            target_shift: 0,
            audio_len: span,
        };
        let frames = SequenceSet::load(dataset, split, Layout::L219, frame_spec, |id| {
            feature_cache::load(dataset, id)
        })?;
        let w = music_token_dim(g);
        let mut sequences = Vec::new();
        let mut skipped = frames.skipped.clone();
        // SPEC §13.2.6 `token_shift_aug`: the training split tokenised from every frame offset of a token.
        let offsets = if g.token_shift_aug && split == config.data.train_split {
            g.rate
        } else {
            1
        };
        for seq in &frames.sequences {
            let motion = dataset.read_motion(&seq.name)?;
            let features = config.recipe.model_audio(seq.audio.to_vec(), FEATURES);
            for offset in 0..offsets {
                let frames_left = seq
                    .motion_frames
                    .min(seq.audio_frames)
                    .saturating_sub(offset);
                let n = frames_left / g.rate;
                if n + 1 < spec.span() {
                    if offset == 0 {
                        skipped.push(seq.name.clone());
                    }
                    continue;
                }
                let shifted = motion.slice(offset, motion.frames);
                let tokens = vq
                    .tokens(&shifted, n * g.rate)
                    .map_err(|e| Error::msg(format!("{}: {e}", seq.name)))?;
                let mut rows = vec![g.codes as f32];
                rows.extend(tokens.iter().map(|&t| t as f32));
                let mut audio = vec![0f32; w];
                audio.extend(music_tokens(&features[offset * FEATURES..], n, g.rate));
                sequences.push(Sequence {
                    // The name keeps its AIST++ form (genre control reads the genre code from it).
                    name: if offset == 0 {
                        seq.name.clone()
                    } else {
                        format!("{}@{offset}", seq.name)
                    },
                    motion: rows,
                    motion_frames: n + 1,
                    audio: Arc::new(audio),
                    audio_frames: n + 1,
                });
            }
        }
        if sequences.is_empty() {
            return Err(Error::at(
                &dataset.root,
                format!(
                    "no {} sequence is long enough for a window of {} tokens ({} frames)",
                    split.name(),
                    g.window,
                    (spec.span() - 1) * g.rate
                ),
            ));
        }
        Ok(SequenceSet {
            layout: Layout::L219,
            dim: 1,
            audio_dim: w,
            spec,
            sequences,
            skipped,
            visits: Vec::new(),
        })
    }

    /// A music step's windows, or (every `text_every`-th update, when text data exists) a text step's pairs.
    fn inputs(&self, drawn: Batch, _model: &Gpt, device: &Device, ctx: &StepContext) -> GptBatch {
        let g = gpt_of(ctx.config);
        if self.is_text_step(g, ctx.step) {
            return GptBatch::Text(self.text_batch(g, drawn.len(), ctx.rng_seed, device));
        }
        GptBatch::Music(tensors(&drawn, g, g.m_pkeep, ctx.rng_seed, device))
    }

    /// Music: CE over every target through M-Base + head. Text: per-sample CE over codes + End through
    /// T-Base + head, then the batch mean. The idle base gets no gradient (§13.11 test 8).
    fn loss(&self, model: &Gpt, inputs: GptBatch, _config: &RunConfig) -> Tensor<1> {
        match inputs {
            GptBatch::Music(x) => cross_entropy(model.music_logits(x.tokens, x.music), x.targets),
            GptBatch::Text(x) => {
                per_sample_cross_entropy(model.text_logits(x.text, x.tokens), x.targets, &x.lengths)
            }
        }
    }

    /// Teacher-forced cross-entropy of every sequence's first window.
    fn validation_loss(
        &self,
        model: &Gpt,
        set: &SequenceSet,
        config: &RunConfig,
        device: &Device,
    ) -> f64 {
        let g = gpt_of(config);
        crate::family::mean_over_first_windows(set, config.train.batch_size, |batch| {
            let x = tensors(&batch, g, 1.0, 0, device);
            cross_entropy(model.music_logits(x.tokens, x.music), x.targets)
        })
    }

    /// The frozen VQ-VAE's checkpoint and weights hash (a resume checks it).
    fn checkpoint_state(&self) -> Option<serde_json::Value> {
        let vq = self.vq.as_ref()?;
        Some(serde_json::json!({
            "vqvae_checkpoint": vq.checkpoint.dir,
            "vqvae_params_hash": vq.checkpoint.sampled_hash(),
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Four standard deviations of a binomial proportion.
    fn within(count: usize, trials: usize, p: f64) -> bool {
        let sd = (p * (1.0 - p) / trials as f64).sqrt();
        ((count as f64 / trials as f64) - p).abs() < 4.0 * sd
    }

    /// §13.11 test 9: End/Pad layout, the first/last-token drop frequency and the pkeep corruption rate.
    #[test]
    fn text_batches_follow_the_t2m_gpt_rules() {
        let (n, k) = (16, 128);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        // Layout: a short motion gives its codes, End, then Pad; a long one its first n codes, no End.
        let short: Vec<usize> = (10..20).collect();
        let long: Vec<usize> = (0..40).collect();
        let (mut kept, mut first, mut last) = (0, 0, 0);
        let trials = 30_000;
        for _ in 0..trials {
            let (t, counted) = text_targets(&short, n, k, &mut rng);
            assert_eq!(t.len(), n);
            let codes = counted - 1;
            assert_eq!(t[codes], k as i64, "{t:?}");
            assert!(t[counted..].iter().all(|&x| x == k as i64 + 1), "{t:?}");
            match (codes, t[0]) {
                (10, 10) => kept += 1,
                (9, 11) => first += 1,
                (9, 10) => {
                    assert_eq!(t[8], 18);
                    last += 1
                }
                other => panic!("{other:?}"),
            }
            let (t, counted) = text_targets(&long, n, k, &mut rng);
            assert_eq!(counted, n);
            assert!(t.iter().all(|&x| x < k as i64));
        }
        assert_eq!(kept + first + last, trials);
        assert!(within(first + last, trials, 1.0 / 3.0), "{first} + {last}");
        assert!(within(first, trials, 1.0 / 6.0), "{first}");
        // pkeep 0.5: a token changes when it is replaced (1 − pkeep) by another code (1 − 1/K).
        let mut tokens = vec![5i64; 50_000];
        corrupt(&mut tokens, k, 0.5, &mut rng);
        let changed = tokens.iter().filter(|&&t| t != 5).count();
        assert!(
            within(changed, tokens.len(), 0.5 * (1.0 - 1.0 / k as f64)),
            "{changed}"
        );
        assert!(tokens.iter().all(|&t| (0..k as i64).contains(&t)));
        let mut same = vec![7i64; 100];
        corrupt(&mut same, k, 1.0, &mut rng);
        assert!(same.iter().all(|&t| t == 7));
    }

    /// Per-sample CE: each row's mean over its own positions, then the batch mean.
    #[test]
    fn text_loss_weights_each_sample_equally() {
        let device = Device::flex();
        let logits: Vec<f32> = (0..2 * 3 * 4).map(|i| ((i * 5 % 7) as f32) * 0.4).collect();
        let t = Tensor::<3>::from_data(TensorData::new(logits.clone(), [2, 3, 4]), &device);
        let targets = [1i64, 2, 3, 0, 3, 1];
        let y = Tensor::<2, Int>::from_data(TensorData::new(targets.to_vec(), [2, 3]), &device);
        let got: f32 = per_sample_cross_entropy(t, y, &[3, 1]).into_scalar();
        let nll = |row: usize, pos: usize| -> f64 {
            let l = &logits[(row * 3 + pos) * 4..(row * 3 + pos + 1) * 4];
            let m = l.iter().cloned().fold(f32::MIN, f32::max) as f64;
            let z: f64 = l.iter().map(|&v| (v as f64 - m).exp()).sum();
            -((l[targets[row * 3 + pos] as usize] as f64 - m) - z.ln())
        };
        let want = ((nll(0, 0) + nll(0, 1) + nll(0, 2)) / 3.0 + nll(1, 0)) / 2.0;
        assert!((got as f64 - want).abs() < 1e-5, "{got} vs {want}");
    }
}
