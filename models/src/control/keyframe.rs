//! Keyframe control (SPEC §13.6; seed 001): a keyframe pose becomes a token, overwrites the generated token
//! at its position, and the k tokens on each side are predicted again, in one pass per keyframe, by a model
//! that sees the future (mask attention) with the re-predicted positions masked. This file holds the index
//! arithmetic, the static clip a pose is tokenised from, the re-prediction loop over any predictor, and the
//! keyframe module: per-layer copies of the attention projections of every M-Base and head block (§13.3.5
//! `mask`, `keyframe.weights = attn_only`) or a copy of the whole M-Base and head (`full_copy`), and the
//! M-Base's Mask row, trained in stage 3b over a frozen GPT.

use burn::module::{Module, ModuleMapper, Param};
use burn::nn::Linear;
use burn::tensor::{Device, Int, Tensor, TensorData};
use qean_config::gpt::GptConfig;
use qean_config::keyframe::KfWeights;
use qean_motion::pos72::{joints_to_pos72, Pos72Options};

use crate::control::gpt::{Block, Gpt, Head, MBase};

/// Tokens re-predicted on each side of a keyframe (k = 6 [READ]).
pub const RADIUS: usize = 6;
/// Tokens per re-prediction window.
pub const WINDOW: usize = 32;
/// The token taken from the codes of a static clip of 8 tokens (8 d frames; 64 at d = 8).
pub const STATIC_CLIP_TOKEN: usize = 4;

/// A keyframe on the token grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KeyToken {
    pub position: usize,
    pub token: usize,
}

/// Keyframes (frame, token) on the token grid of `rate` frames per token, ascending: p = ⌊f/d⌋; two keyframes
/// on one token count once and the later one (in the list) wins.
pub fn key_tokens(keys: &[(usize, usize)], rate: usize) -> Vec<KeyToken> {
    let mut out: Vec<KeyToken> = Vec::new();
    for &(frame, token) in keys {
        let position = frame / rate;
        match out.iter_mut().find(|k| k.position == position) {
            Some(k) => k.token = token,
            None => out.push(KeyToken { position, token }),
        }
    }
    out.sort_by_key(|k| k.position);
    out
}

/// The re-predicted positions (§13.6 "Index set"): ∪_p [p − k, p + k] ∩ [n_fixed, n) minus the keyframe
/// positions, ascending. A keyframe inside the seed (p < n_fixed) or past the sequence (p ≥ n) is an error.
pub fn kf_mask_positions(
    positions: &[usize],
    k: usize,
    n_fixed: usize,
    n: usize,
) -> Result<Vec<usize>, String> {
    if let Some(&p) = positions.iter().find(|&&p| p >= n || p < n_fixed) {
        return Err(format!(
            "a keyframe at token {p} is outside the generated tokens [{n_fixed}, {n})"
        ));
    }
    let mut masked = vec![false; n];
    for &p in positions {
        for m in masked
            .iter_mut()
            .take((p + k + 1).min(n))
            .skip(p.saturating_sub(k).max(n_fixed))
        {
            *m = true;
        }
    }
    for &p in positions {
        masked[p] = false;
    }
    Ok((0..n).filter(|&j| masked[j]).collect())
}

/// The window start for a keyframe at token p: s = clamp(p − window/2, 0, n − window) (0 when n < window).
pub fn kf_window(p: usize, n: usize, window: usize) -> usize {
    p.saturating_sub(window / 2).min(n.saturating_sub(window))
}

/// The static clip of one pose (24 joints): the pose held for `frames` frames (8 d) as pos72 rows (zero
/// root velocity), the VQ-VAE's input for the keyframe's token ([`STATIC_CLIP_TOKEN`] of its codes).
pub fn static_clip(pose: &[[f64; 3]], frames: usize, opts: &Pos72Options) -> Vec<f64> {
    assert_eq!(pose.len(), 24, "a pose is 24 joints");
    let joints: Vec<[f64; 3]> = (0..frames).flat_map(|_| pose.iter().copied()).collect();
    joints_to_pos72(&joints, opts)
}

/// Keyframe re-prediction (§13.6 "Inference" steps 2–4) with `predict`: the keyframe tokens overwrite
/// `tokens`; then, for each keyframe in ascending position, the window from [`kf_window`] goes to
/// `predict(start, inputs)` with inputs `Some(token)`, or `None` (the Mask token) at the masked positions,
/// and its per-position picks are written back at the window's masked positions. A masked position stays
/// Mask in every window's input (as in training); where windows overlap, the later keyframe's pick stands
/// (our reading). Positions outside the masked set keep their tokens.
pub fn refill(
    tokens: &[usize],
    keys: &[KeyToken],
    (k, n_fixed, window): (usize, usize, usize),
    mut predict: impl FnMut(usize, &[Option<usize>]) -> Vec<usize>,
) -> Result<Vec<usize>, String> {
    let n = tokens.len();
    let positions: Vec<usize> = keys.iter().map(|key| key.position).collect();
    let masked = kf_mask_positions(&positions, k, n_fixed, n)?;
    let mut is_masked = vec![false; n];
    for &m in &masked {
        is_masked[m] = true;
    }
    let mut out = tokens.to_vec();
    for key in keys {
        out[key.position] = key.token;
    }
    let inputs: Vec<Option<usize>> = (0..n).map(|j| (!is_masked[j]).then_some(out[j])).collect();
    for key in keys {
        let s = kf_window(key.position, n, window);
        let e = (s + window).min(n);
        let picks = predict(s, &inputs[s..e]);
        if picks.len() != e - s {
            return Err(format!(
                "the predictor returned {} tokens for a window of {}",
                picks.len(),
                e - s
            ));
        }
        for (j, &pick) in (s..e).zip(&picks) {
            if is_masked[j] {
                out[j] = pick;
            }
        }
    }
    Ok(out)
}

/// A fresh parameter holding `p`'s values (a new id: it trains while the original stays frozen).
fn copy_param<const D: usize>(p: &Param<Tensor<D>>) -> Param<Tensor<D>> {
    leaf(p.val())
}

/// A new leaf parameter holding `t`'s values (through the host: no autodiff history).
fn leaf<const D: usize>(t: Tensor<D>) -> Param<Tensor<D>> {
    let device = t.device();
    Param::from_tensor(Tensor::from_data(t.into_data(), &device))
}

fn copy_linear(l: &Linear) -> Linear {
    Linear {
        weight: copy_param(&l.weight),
        bias: l.bias.as_ref().map(copy_param),
    }
}

/// One block's q, k, v and output projections for mask attention.
#[derive(Module, Debug)]
pub struct AttnCopy {
    pub query: Linear,
    pub key: Linear,
    pub value: Linear,
    pub proj: Linear,
}

impl AttnCopy {
    /// A copy of `b`'s projections (§13.6: "initialised from the causal weights").
    pub fn of(b: &Block) -> AttnCopy {
        AttnCopy {
            query: copy_linear(&b.query),
            key: copy_linear(&b.key),
            value: copy_linear(&b.value),
            proj: copy_linear(&b.proj),
        }
    }

    /// q, k, v and output, in the order [`Block::attend_through`] takes them.
    pub fn linears(&self) -> [&Linear; 4] {
        [&self.query, &self.key, &self.value, &self.proj]
    }
}

/// Every float parameter replaced by a new leaf holding its values ([`leaf`]).
struct Fresh;

impl ModuleMapper for Fresh {
    fn map_float<const D: usize>(&mut self, param: Param<Tensor<D>>) -> Param<Tensor<D>> {
        leaf(param.val())
    }
}

/// `keyframe.weights = full_copy`: the whole M-Base and head, copied.
#[derive(Module, Debug)]
pub struct FullCopy {
    pub m_base: MBase,
    pub head: Head,
}

/// The keyframe module (stage 3b's trainable part): an [`AttnCopy`] per M-Base block and per head block
/// (`attn_only`) or a [`FullCopy`] (`full_copy`, the copy lists then empty), and the Mask row of the
/// M-Base's token table ([D]).
#[derive(Module, Debug)]
pub struct KeyframeModule {
    pub m_attn: Vec<AttnCopy>,
    pub head_attn: Vec<AttnCopy>,
    pub mask_row: Param<Tensor<1>>,
    pub full: Option<FullCopy>,
}

impl KeyframeModule {
    /// Copies of `gpt`'s attention projections (or of its whole M-Base and head) and Mask row.
    pub fn of(gpt: &Gpt, weights: KfWeights) -> KeyframeModule {
        let table = gpt.m_base.tokens.weight.val();
        let [rows, d] = table.dims();
        let mask_row = leaf(table.narrow(0, rows - 1, 1).reshape([d]));
        match weights {
            KfWeights::AttnOnly => KeyframeModule {
                m_attn: gpt.m_base.blocks.iter().map(AttnCopy::of).collect(),
                head_attn: gpt.head.blocks.iter().map(AttnCopy::of).collect(),
                mask_row,
                full: None,
            },
            KfWeights::FullCopy => KeyframeModule {
                m_attn: Vec::new(),
                head_attn: Vec::new(),
                mask_row,
                full: Some(FullCopy {
                    m_base: gpt.m_base.clone().map(&mut Fresh),
                    head: gpt.head.clone().map(&mut Fresh),
                }),
            },
        }
    }

    /// The M-Base and head mask mode runs through: the module's full copy, or the GPT's own.
    fn bases<'a>(&'a self, gpt: &'a Gpt) -> (&'a MBase, &'a Head) {
        match &self.full {
            Some(f) => (&f.m_base, &f.head),
            None => (&gpt.m_base, &gpt.head),
        }
    }
}

/// The projections block `i` attends through: the module's copy, or (full copy) the block's own.
fn projections<'a>(copies: &'a [AttnCopy], i: usize, block: &'a Block) -> [&'a Linear; 4] {
    match copies.get(i) {
        Some(c) => c.linears(),
        None => [&block.query, &block.key, &block.value, &block.proj],
    }
}

/// The keyframe stage's model: the frozen GPT and the keyframe module (one checkpoint holds both).
#[derive(Module, Debug)]
pub struct KeyframeGpt {
    pub gpt: Gpt,
    pub keyframe: KeyframeModule,
}

impl KeyframeGpt {
    /// A fresh GPT and a module copied from it (training replaces the GPT by the frozen one and copies
    /// again: see `train::keyframe`).
    pub fn new(g: &GptConfig, weights: KfWeights, device: &Device) -> KeyframeGpt {
        let gpt = Gpt::new(g, device);
        let keyframe = KeyframeModule::of(&gpt, weights);
        KeyframeGpt { gpt, keyframe }
    }
}

/// SPEC §13.9's closed form of the attention copies: (L_b + L_h)·4(D² + D) (the Mask row adds D).
pub fn keyframe_params(g: &GptConfig) -> usize {
    (g.base_layers + g.head_layers) * 4 * (g.hidden * g.hidden + g.hidden)
}

/// Mask-mode logits [B, n, K+1] (§13.6 "Inference" 3, "Training"): position j of stream t holds c_{s+j}
/// unshifted, or the Mask token (K + 1, the module's Mask row); stream m as in §13.3.2; every position
/// sees every other, through the module's attention projections and the GPT's LNs and MLPs.
pub fn mask_logits(
    gpt: &Gpt,
    module: &KeyframeModule,
    tokens: Tensor<2, Int>,
    music: Tensor<3>,
) -> Tensor<3> {
    let (mb, head) = module.bases(gpt);
    let [b, n] = tokens.dims();
    let device = music.device();
    let [rows, d] = mb.tokens.weight.dims();
    let is_mask = tokens.clone().equal_elem((rows - 1) as i64);
    let masked = is_mask.clone().float().reshape([b, n, 1]);
    let safe = tokens.mask_fill(is_mask, 0);
    let t = mb.tokens.forward(safe) * (masked.clone().neg() + 1.0)
        + masked * module.mask_row.val().reshape([1, 1, d])
        + mb.pos_tokens.val().narrow(0, 0, n).unsqueeze::<3>();
    let m = mb.music(music) + mb.pos_music.val().narrow(0, 0, n).unsqueeze::<3>();
    let mut x = if mb.two_stream() {
        Tensor::cat(vec![m, t], 1)
    } else {
        m + t
    };
    let len = x.dims()[1];
    let everything = Tensor::<4>::zeros([1, 1, len, len], &device);
    x = mb.dropout.forward(x);
    for (i, block) in mb.blocks.iter().enumerate() {
        x = block.attend_through(x, everything.clone(), projections(&module.m_attn, i, block));
        x = block.feed_forward(x);
    }
    if mb.two_stream() {
        x = x.narrow(1, n, n);
    }
    let everything = Tensor::<4>::zeros([1, 1, n, n], &device);
    for (i, block) in head.blocks.iter().enumerate() {
        x = block.attend_through(
            x,
            everything.clone(),
            projections(&module.head_attn, i, block),
        );
        x = block.feed_forward(x);
    }
    head.logits.forward(head.ln.forward(x))
}

/// One window's picks (§13.6 "Inference" 3–4): `inputs` with None at the masked positions, `music` its
/// music tokens [1, n, 280]; the argmax over the K codes at every position (`one_shot`), or over `passes`
/// passes that each fix the most confident of the positions still masked, a linear share per pass
/// (`iterative`, MaskGIT-style). Unmasked positions give their input back.
pub fn predict_window(
    gpt: &Gpt,
    module: &KeyframeModule,
    inputs: &[Option<usize>],
    music: Tensor<3>,
    passes: usize,
) -> Vec<usize> {
    let device = music.device();
    let [rows, _] = gpt.m_base.tokens.weight.dims();
    let (codes, mask) = (rows - 2, rows - 1);
    let n = inputs.len();
    let mut current: Vec<Option<usize>> = inputs.to_vec();
    let total = current.iter().filter(|x| x.is_none()).count();
    for pass in 0..passes.max(1) {
        let ids: Vec<i64> = current
            .iter()
            .map(|x| x.map_or(mask as i64, |t| t as i64))
            .collect();
        let ids = Tensor::<2, Int>::from_data(TensorData::new(ids, [1, n]), &device);
        let logits: Vec<f32> = mask_logits(gpt, module, ids, music.clone())
            .into_data()
            .convert::<f32>()
            .try_to_vec()
            .expect("f32");
        let k1 = logits.len() / n;
        // (confidence, position, code) of every position still masked: the softmax's top code among K.
        let mut open: Vec<(f32, usize, usize)> = (0..n)
            .filter(|&j| current[j].is_none())
            .map(|j| {
                let row = &logits[j * k1..j * k1 + codes];
                let (best, top) =
                    row.iter()
                        .enumerate()
                        .fold(
                            (0, f32::NEG_INFINITY),
                            |a, (c, &v)| if v > a.1 { (c, v) } else { a },
                        );
                let z: f32 = row.iter().map(|&v| (v - top).exp()).sum();
                (1.0 / z, j, best)
            })
            .collect();
        let last = pass + 1 >= passes.max(1);
        let keep_open = if last {
            0
        } else {
            total - (total * (pass + 1)).div_ceil(passes)
        };
        open.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        for &(_, j, code) in open.iter().take(open.len().saturating_sub(keep_open)) {
            current[j] = Some(code);
        }
        if current.iter().all(|x| x.is_some()) {
            break;
        }
    }
    current
        .into_iter()
        .map(|x| x.expect("every position filled"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mask_positions_cover_both_sides_and_skip_keys_and_seed() {
        // One keyframe at 20, k 6: 14..=26 without 20.
        let m = kf_mask_positions(&[20], 6, 10, 40).unwrap();
        assert_eq!(m, (14..=26).filter(|&j| j != 20).collect::<Vec<_>>());
        // Near the seed (n_fixed 15) and the end (n 30): clipped.
        assert_eq!(
            kf_mask_positions(&[16], 6, 15, 30).unwrap(),
            vec![15, 17, 18, 19, 20, 21, 22]
        );
        assert_eq!(
            kf_mask_positions(&[28], 6, 15, 30).unwrap(),
            vec![22, 23, 24, 25, 26, 27, 29]
        );
        // Overlapping: one union, both keys left out; the seed's tokens never.
        let m = kf_mask_positions(&[20, 24], 6, 15, 40).unwrap();
        assert_eq!(m.len(), (15..=30).count() - 2);
        assert!(kf_mask_positions(&[40], 6, 15, 40).is_err());
        assert!(kf_mask_positions(&[10], 6, 15, 40).is_err());
    }

    #[test]
    fn keys_on_one_token_count_once_the_later_wins() {
        let k = key_tokens(&[(200, 5), (90, 7), (203, 9)], 8);
        assert_eq!(
            k,
            vec![
                KeyToken {
                    position: 11,
                    token: 7
                },
                KeyToken {
                    position: 25,
                    token: 9
                }
            ]
        );
    }

    #[test]
    fn windows_clamp_to_the_sequence() {
        assert_eq!(kf_window(40, 100, 32), 24);
        assert_eq!(kf_window(5, 100, 32), 0);
        assert_eq!(kf_window(95, 100, 32), 68);
        assert_eq!(kf_window(10, 20, 32), 0);
    }

    #[test]
    fn the_static_clip_stands_still() {
        let pose: Vec<[f64; 3]> = (0..24)
            .map(|j| [0.1 * j as f64, 0.9, -0.02 * j as f64])
            .collect();
        let clip = static_clip(&pose, 64, &Pos72Options::default());
        assert_eq!(clip.len(), 64 * 72);
        for row in clip.chunks(72) {
            assert_eq!(&row[..3], &[0.0; 3], "root velocity");
            assert_eq!(row, &clip[..72], "every frame the same");
        }
    }

    /// SPEC §13.11 test 13: only masked positions change, and a predictor that knows the original
    /// sequence gives it back.
    #[test]
    fn refill_changes_only_masked_positions_and_a_perfect_predictor_restores() {
        let original: Vec<usize> = (0..60).map(|j| (j * 7 + 3) % 128).collect();
        let keys = key_tokens(&[(8 * 25, original[25]), (8 * 31, original[31])], 8);
        let perfect = |s: usize, w: &[Option<usize>]| original[s..s + w.len()].to_vec();
        let generated: Vec<usize> = (0..60).map(|j| (j * 11) % 128).collect();
        let mut mixed = generated.clone();
        mixed[..15].copy_from_slice(&original[..15]);
        let mut outside = mixed.clone();
        for (j, t) in outside.iter_mut().enumerate() {
            if !(19..=37).contains(&j) {
                *t = original[j];
            }
        }
        let restored = refill(&outside, &keys, (RADIUS, 15, WINDOW), perfect).unwrap();
        assert_eq!(restored, original);
        // A predictor that always says 0: exactly the masked positions become 0, keys take their tokens.
        let zeros = refill(&mixed, &keys, (RADIUS, 15, WINDOW), |_, w| vec![0; w.len()]).unwrap();
        let masked = kf_mask_positions(&[25, 31], RADIUS, 15, 60).unwrap();
        for j in 0..60 {
            let want = match j {
                25 | 31 => original[j],
                _ if masked.contains(&j) => 0,
                _ => mixed[j],
            };
            assert_eq!(zeros[j], want, "token {j}");
        }
        // The predictor sees Mask (None) exactly at the masked positions of its window.
        let mut seen = Vec::new();
        refill(&mixed, &keys, (RADIUS, 15, WINDOW), |s, w| {
            seen.push((s, w.iter().filter(|x| x.is_none()).count()));
            vec![0; w.len()]
        })
        .unwrap();
        assert_eq!(seen, vec![(9, masked.len()), (15, masked.len())]);
    }

    fn window_inputs(
        g: &GptConfig,
        device: &Device,
        change: Option<(usize, i64)>,
    ) -> (Tensor<2, Int>, Tensor<3>) {
        let n = g.window;
        let mut ids: Vec<i64> = (0..n as i64).map(|j| (j * 5) % g.codes as i64).collect();
        ids[7] = g.codes as i64 + 1;
        if let Some((j, t)) = change {
            ids[j] = t;
        }
        let music: Vec<f32> = (0..n * 280)
            .map(|i| ((i * 37) % 101) as f32 / 50.0 - 1.0)
            .collect();
        (
            Tensor::from_data(TensorData::new(ids, [1, n]), device),
            Tensor::from_data(TensorData::new(music, [1, n, 280]), device),
        )
    }

    /// SPEC §13.3.5 `mask` and §13.9: the copies start as the causal projections under new parameter ids
    /// ((L_b + L_h)·4(D² + D), plus the Mask row), and every position sees every other: a later token
    /// changes an earlier position's logits.
    #[test]
    fn mask_attention_sees_the_future_through_copies_of_the_causal_weights() {
        let device = Device::flex();
        let g = GptConfig {
            dropout: 0.0,
            ..GptConfig::tiny()
        };
        let model = KeyframeGpt::new(&g, KfWeights::AttnOnly, &device);
        assert_eq!(model.keyframe.num_params(), keyframe_params(&g) + g.hidden);
        assert_eq!(keyframe_params(&GptConfig::tiny()), 66_560);
        assert_eq!(keyframe_params(&GptConfig::paper()), 28_348_416);
        let block = &model.gpt.m_base.blocks[1];
        let copy = &model.keyframe.m_attn[1];
        assert_ne!(block.query.weight.id, copy.query.weight.id);
        let x = Tensor::<3>::from_data(
            TensorData::new(
                (0..5 * 64)
                    .map(|i| (i % 13) as f32 / 7.0)
                    .collect::<Vec<_>>(),
                [1, 5, 64],
            ),
            &device,
        );
        let bias = Tensor::<4>::zeros([1, 1, 5, 5], &device);
        let same: f32 = (block.attend(x.clone(), bias.clone())
            - block.attend_through(x, bias, copy.linears()))
        .abs()
        .max()
        .into_scalar();
        assert_eq!(same, 0.0);
        let logits = |change| {
            let (t, m) = window_inputs(&g, &device, change);
            mask_logits(&model.gpt, &model.keyframe, t, m)
        };
        let (a, b) = (logits(None), logits(Some((12, 3))));
        assert_eq!(a.dims(), [1, g.window, g.codes + 1]);
        let earlier: f32 = (a.narrow(1, 2, 1) - b.narrow(1, 2, 1))
            .abs()
            .max()
            .into_scalar();
        assert!(earlier > 0.0, "position 2 does not see token 12");
    }

    /// `keyframe.weights = full_copy`: the module holds the whole M-Base and head under new ids (and the
    /// Mask row), no attention copies, and starts with the same mask-mode logits as the attention copies.
    #[test]
    fn a_full_copy_starts_as_the_attention_copies() {
        let device = Device::flex();
        let g = GptConfig {
            dropout: 0.0,
            ..GptConfig::tiny()
        };
        let attn = KeyframeGpt::new(&g, KfWeights::AttnOnly, &device);
        let full = KeyframeModule::of(&attn.gpt, KfWeights::FullCopy);
        let copy = full.full.as_ref().unwrap();
        assert!(full.m_attn.is_empty() && full.head_attn.is_empty());
        assert_eq!(
            full.num_params(),
            attn.gpt.m_base.num_params() + attn.gpt.head.num_params() + g.hidden
        );
        assert_ne!(
            copy.m_base.blocks[0].fc.weight.id,
            attn.gpt.m_base.blocks[0].fc.weight.id
        );
        assert_ne!(copy.head.logits.weight.id, attn.gpt.head.logits.weight.id);
        let (t, m) = window_inputs(&g, &device, None);
        let a = mask_logits(&attn.gpt, &attn.keyframe, t.clone(), m.clone());
        let b = mask_logits(&attn.gpt, &full, t, m);
        let diff: f32 = (a - b).abs().max().into_scalar();
        assert_eq!(diff, 0.0);
    }

    /// A window's picks keep every visible token, fill every masked one with a code (never End), and the
    /// iterative decoding fills them all too.
    #[test]
    fn window_predictions_fill_the_masked_positions_only() {
        let device = Device::flex();
        let g = GptConfig::tiny();
        let model = KeyframeGpt::new(&g, KfWeights::AttnOnly, &device);
        let inputs: Vec<Option<usize>> = (0..g.window)
            .map(|j| (!(4..=9).contains(&j) || j == 6).then_some(j * 3))
            .collect();
        let music = window_inputs(&g, &device, None).1;
        for passes in [1, 4] {
            let picks = predict_window(&model.gpt, &model.keyframe, &inputs, music.clone(), passes);
            for (j, (pick, input)) in picks.iter().zip(&inputs).enumerate() {
                match input {
                    Some(t) => assert_eq!(pick, t, "visible position {j}"),
                    None => assert!(*pick < g.codes, "position {j}: {pick}"),
                }
            }
        }
    }
}
