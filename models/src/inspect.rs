//! `qean inspect CONFIG.toml`: the architecture a config describes and its exact parameter
//! count, counted from the instantiated module (lazy parameters: nothing is allocated), plus
//! SPEC §4.2's closed-form count that a test holds the module to.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use burn::module::Module;
use burn::tensor::Device;

use crate::input_fusion::QuaternionFusionConfig;
use crate::model::DanceModel;
use crate::tsmt::model::tsmt_params;
use crate::tsmt::Tsmt;
use qean_config::model::{
    load_model_config, Arch, AttentionKind, ConfigError, InputFusion, ModelConfig, PositionKind,
    QraConvInput, QraQkProj, QraTopology,
};
use qean_config::run::RunConfig;
use qean_config::tsmt::{AudioStreams, TsmtConfig};
use qean_config::ModelSpec;

/// What `inspect` reports.
#[derive(Clone, Debug)]
pub struct Inspection {
    /// The config file.
    pub path: PathBuf,
    /// Its `[model]` table, defaults and `extends` resolved.
    pub config: ModelConfig,
    /// Parameters of the instantiated model.
    pub params: usize,
    /// Printable summary (several lines, ends with a newline).
    pub summary: String,
}

/// Loads a config file, instantiates its model lazily and summarises it.
pub fn inspect(path: &Path) -> Result<Inspection, ConfigError> {
    let config = load_model_config(path)?;
    // FACT and QEAN need only the [model] table; the other families read the whole run config.
    let run = match config.arch {
        Arch::Fact | Arch::Qean => RunConfig {
            model: config.clone(),
            ..RunConfig::default()
        },
        _ => RunConfig::load(path, &[])?,
    };
    let (params, summary) = family_summary(&run, path)?;
    Ok(Inspection {
        path: path.to_path_buf(),
        config,
        params,
        summary,
    })
}

/// Parameters and summary of a run config's model (one dispatch on its family).
fn family_summary(run: &RunConfig, path: &Path) -> Result<(usize, String), ConfigError> {
    let device = Device::flex();
    Ok(match run.spec() {
        ModelSpec::FactQean(m) => {
            let model = DanceModel::new(m, &device)
                .map_err(|e| ConfigError::new(path, None, e.to_string()))?;
            (model.num_params(), summary(m, &model, Some(path)))
        }
        ModelSpec::Tsmt(t) => {
            let model = Tsmt::new(t, &device);
            (model.num_params(), tsmt_summary(t, &model, Some(path)))
        }
        ModelSpec::Inbetween(ib) => {
            let params = crate::inbetween::Inbetweener::new(ib, &device).num_params();
            (params, inbetween_summary(ib, params, Some(path)))
        }
        ModelSpec::GenreClf(g) => {
            let params = crate::control::genre_clf::GenreClassifier::new(g, &device).num_params();
            let summary = format!(
                "model: genre classifier (SPEC §13.10) from {}\n  pos72 [{}, 72] → Conv(72 → {w}) → 3 × Conv(k4, s2) → time mean → Linear({w} → 10)\n  closed form (§13.9): {}\n",
                path.display(),
                g.window,
                group_digits(crate::control::genre_clf::genre_clf_params(g)),
                w = g.width
            );
            (params, summary)
        }
        ModelSpec::GptGenre(g, c) => {
            let model = crate::control::genre::GenreGpt::new(g, c, c.code_dim, &device);
            let params = model.genre.num_params() + model.disc.num_params();
            let summary = format!(
                "{}{}",
                gpt_summary(g, &model.gpt, Some(path)),
                genre_summary(g, c, &model)
            );
            (params, summary)
        }
        ModelSpec::GptKeyframe(g, k) => {
            let model = crate::control::keyframe::KeyframeGpt::new(g, k.weights, &device);
            let params = model.keyframe.num_params();
            let copies = match k.weights {
                qean_config::keyframe::KfWeights::AttnOnly => format!(
                    "attention copies of {} M-Base + {} head blocks, (L_b + L_h)·4(D² + D) = {} (§13.9)",
                    g.base_layers,
                    g.head_layers,
                    group_digits(crate::control::keyframe::keyframe_params(g))
                ),
                qean_config::keyframe::KfWeights::FullCopy => format!(
                    "a full copy of the M-Base and head (keyframe.weights = full_copy) = {}",
                    group_digits(model.gpt.m_base.num_params() + model.gpt.head.num_params())
                ),
            };
            let summary = format!(
                "{}  keyframe module (trained; the GPT above is frozen): {copies}, + the Mask row {} = {}\n  mask attention (every position sees every other), k = {}, {:?} masks of ≤ {} centres, decode {:?}\n",
                gpt_summary(g, &model.gpt, Some(path)),
                g.hidden,
                group_digits(params),
                k.radius,
                k.train_mask,
                k.max_centres,
                k.decode
            );
            (params, summary)
        }
        ModelSpec::Gpt(g) => {
            let model = crate::control::gpt::Gpt::new(g, &device);
            (model.num_params(), gpt_summary(g, &model, Some(path)))
        }
        ModelSpec::Vqvae(vq) => {
            let model = crate::vqvae::VqVae::new(vq, &device);
            let (enc, dec) = crate::vqvae::network_params(&model);
            (enc + dec, vq_summary(vq, enc, dec, Some(path)))
        }
    })
}

/// Thousands separators: 120406977 → "120,406,977".
pub fn group_digits(n: usize) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, ch) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(ch);
    }
    out
}

/// How positions are encoded, in words.
fn positions_text(c: &ModelConfig) -> String {
    match (c.position, c.rope.keep_abs_pos) {
        (PositionKind::Learned, _) => "learned absolute".to_string(),
        (PositionKind::Rotary, keep) => format!(
            "rotary (SPE, {:?} pairs, base {}, cross positions {:?}){}",
            c.rope.pairing,
            c.rope.base,
            c.rope.cross_positions,
            if keep { " + learned absolute" } else { "" }
        ),
    }
}

/// The cross-modal attention, in words.
fn attention_text(c: &ModelConfig) -> String {
    match (c.attention, c.qra.topology) {
        (AttentionKind::Softmax, _) => "softmax".to_string(),
        (AttentionKind::Qra, QraTopology::SelfAttention) => {
            let n = (0..c.cross_layers).filter(|&l| c.layer_uses_qra(l)).count();
            format!(
                "QRA in {n} of {} layers (P {}, kernel {}, q/k head dim {}, 2π {}, conv input {:?}, positions {:?})",
                c.cross_layers,
                c.qra.periods,
                c.qra.kernel,
                c.qra_qk_head_dim(),
                c.qra.two_pi,
                c.qra.conv_input,
                c.qra.positions
            )
        }
        (AttentionKind::Qra, QraTopology::CrossPrefix) => format!(
            "softmax, after a motion→audio QRA block (P {}, kernel {})",
            c.qra.periods, c.qra.kernel
        ),
    }
}

/// The parameter count of each part of the model.
fn parts_of(model: &DanceModel) -> Vec<(&'static str, usize)> {
    match model {
        DanceModel::Fact(m) => vec![
            (
                "motion embedding + position",
                m.motion_embed.num_params() + m.motion_pos.num_params(),
            ),
            ("motion transformer", m.motion_transformer.num_params()),
            (
                "audio embedding + position",
                m.audio_embed.num_params() + m.audio_pos.num_params(),
            ),
            ("audio transformer", m.audio_transformer.num_params()),
            ("cross-modal transformer", m.cross_transformer.num_params()),
            ("output", m.output.num_params()),
        ],
        DanceModel::Qean(m) => vec![
            (
                "motion embedding + position",
                m.motion_embed.num_params() + m.motion_pos.num_params(),
            ),
            ("motion transformer", m.motion_transformer.num_params()),
            (
                "audio embedding + position",
                m.audio_embed.num_params() + m.audio_fusion.num_params() + m.audio_pos.num_params(),
            ),
            ("audio transformer", m.audio_transformer.num_params()),
            ("cross prefix (QRA)", m.cross_prefix.num_params()),
            ("cross-modal transformer", m.cross_transformer.num_params()),
            ("output", m.output.num_params()),
        ],
    }
}

/// A printable architecture summary with the per-part parameter counts.
pub fn summary(c: &ModelConfig, model: &DanceModel, path: Option<&Path>) -> String {
    let mut s = String::new();
    let arch = match c.arch {
        Arch::Fact => "FACT (mint)",
        Arch::Qean => "QEAN",
        Arch::Tsmt => "TSMT (configured by [tsmt])",
        Arch::Inbetween => "in-betweener (configured by [inbetween])",
        Arch::Vqvae => "motion VQ-VAE (configured by [vq])",
        Arch::Gpt => "music-to-dance GPT (configured by [gpt])",
        Arch::GptGenre => "genre control over a GPT (configured by [gpt] and [genre])",
        Arch::GenreClf => "genre classifier (configured by [genre_clf])",
        Arch::GptKeyframe => "keyframe control over a GPT (configured by [gpt] and [keyframe])",
    };
    let from = path
        .map(|p| format!(" from {}", p.display()))
        .unwrap_or_default();
    let _ = writeln!(s, "model: {arch}{from}");
    let _ = writeln!(
        s,
        "  width {}, heads {} (head dim {}), MLP {}, layers motion {} / audio {} / cross {}",
        c.hidden,
        c.heads,
        c.head_dim(),
        c.ffn,
        c.motion_layers,
        c.audio_layers,
        c.cross_layers
    );
    let positions = positions_text(c);
    let _ = writeln!(s, "  positions: {positions}");
    let audio_in = match c.input_fusion {
        InputFusion::Dense => format!("Dense({} → {})", c.audio_dim, c.hidden),
        InputFusion::Quaternion254 => format!(
            "[audio | motion] frames → QuaternionLinear({} → {} quaternions)",
            QuaternionFusionConfig::new(c.audio_dim, c.hidden).quaternions(),
            c.hidden / 4
        ),
    };
    let _ = writeln!(
        s,
        "  motion [B, {}, {}] → Dense({} → {}) → {} layers",
        c.motion_len,
        c.motion_dim(),
        c.motion_dim(),
        c.hidden,
        c.motion_layers
    );
    let _ = writeln!(
        s,
        "  audio  [B, {}, {}] → {} → {} layers",
        c.audio_len, c.audio_dim, audio_in, c.audio_layers
    );
    let attention = attention_text(c);
    let _ = writeln!(
        s,
        "  cross  [B, {}, {}] (motion first) → {} layers, attention: {attention}",
        c.motion_len + c.audio_len,
        c.hidden,
        c.cross_layers
    );
    let _ = writeln!(
        s,
        "  output Dense({} → {}) → [B, {}, {}]; loss on tokens 0..{}",
        c.hidden,
        c.motion_dim(),
        c.motion_len + c.audio_len,
        c.motion_dim(),
        c.target_len
    );
    let sites: Vec<String> = c.dropout_sites.iter().map(|d| format!("{d:?}")).collect();
    let _ = writeln!(
        s,
        "  score scale {:?} (1/sqrt({})), dropout {}{}",
        c.attn_scale,
        match c.attn_scale {
            qean_config::model::AttnScale::Hidden => c.hidden,
            qean_config::model::AttnScale::Head => c.head_dim(),
        },
        c.dropout,
        if c.dropout > 0.0 {
            format!(" at {}", sites.join(", ").to_lowercase())
        } else {
            String::new()
        }
    );
    let parts = parts_of(model);
    let _ = writeln!(s, "parameters: {}", group_digits(model.num_params()));
    for (name, n) in parts.into_iter().filter(|(_, n)| *n > 0) {
        let _ = writeln!(s, "  {name:<28} {:>13}", group_digits(n));
    }
    s
}

/// What `qean inspect` prints for a GPT config (SPEC §13.3, counts of §13.9).
pub fn gpt_summary(
    c: &qean_config::gpt::GptConfig,
    model: &crate::control::gpt::Gpt,
    path: Option<&Path>,
) -> String {
    let from = path
        .map(|p| format!(" from {}", p.display()))
        .unwrap_or_default();
    let (m, h, t) = crate::control::gpt::gpt_params(c);
    let mut s = format!("model: music-to-dance GPT (SPEC §13.3, Bailando/T2M-GPT){from}\n");
    let _ = writeln!(
        s,
        "  M-Base {:?}: music MLP({} → {d}) + {} codes + Start/Mask, {} blocks (D {d}, {} heads), window {} tokens: {}",
        c.m_layout,
        crate::control::gpt::music_token_dim(c),
        c.codes,
        c.base_layers,
        c.heads,
        c.window,
        group_digits(model.m_base.num_params()),
        d = c.hidden,
    );
    let _ = writeln!(
        s,
        "  T-Base: text Linear({} → {}) + sincos positions, {} blocks: {}",
        c.text_dim,
        c.hidden,
        c.base_layers,
        group_digits(model.t_base.num_params())
    );
    let _ = writeln!(
        s,
        "  head (shared): {} blocks, LN, Linear({} → {} + End): {}",
        c.head_layers,
        c.hidden,
        c.codes,
        group_digits(model.head.num_params())
    );
    let _ = writeln!(
        s,
        "  music-only (M-Base + head): {}; frozen VQ-VAE: {}",
        group_digits(m + h),
        c.vqvae_run
            .as_ref()
            .map_or("not set (gpt.vqvae_run)".into(), |p| p
                .display()
                .to_string())
    );
    let _ = writeln!(
        s,
        "  closed form (§13.9): {} + {} + {} = {}",
        group_digits(m),
        group_digits(h),
        group_digits(t),
        group_digits(m + h + t)
    );
    s
}

/// The genre-control lines of `qean inspect` (SPEC §13.5; counts of §13.9): what the genre stage trains.
pub fn genre_summary(
    g: &qean_config::gpt::GptConfig,
    c: &qean_config::genre::GenreConfig,
    model: &crate::control::genre::GenreGpt,
) -> String {
    let (gen, xattn, disc) = crate::control::genre::genre_params(g, c, c.code_dim);
    let actual_xattn: usize = model.genre.xattn.iter().map(|x| x.num_params()).sum();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "  genre module (trained; the GPT above is frozen): GEN(z {} → {} × {}) {} + cross-attention (eq. 3, {} layers, {:?} positions) {} = {}",
        c.z_dim,
        c.tokens,
        g.hidden,
        group_digits(model.genre.gen.num_params()),
        g.base_layers,
        c.xattn_on,
        group_digits(actual_xattn),
        group_digits(model.genre.num_params())
    );
    let _ = writeln!(
        s,
        "  discriminator: latents {} + music {} → {}, {} layers (FF {}, {} heads), 10 genre heads: {}",
        c.code_dim,
        crate::control::gpt::music_token_dim(g),
        c.disc_width,
        c.disc_layers,
        c.disc_ff,
        c.disc_heads,
        group_digits(model.disc.num_params())
    );
    let _ = writeln!(
        s,
        "  closed form (§13.9): GEN {} + cross-attention {} ; D {}; GPT run: {}",
        group_digits(gen),
        group_digits(xattn),
        group_digits(disc),
        c.gpt_run
            .as_ref()
            .map_or("not set (genre.gpt_run)".into(), |p| p
                .display()
                .to_string())
    );
    s
}

/// What `qean inspect` prints for a motion VQ-VAE config (SPEC §13.2, counts of §13.9).
pub fn vq_summary(
    c: &qean_config::vqvae::VqConfig,
    enc: usize,
    dec: usize,
    path: Option<&Path>,
) -> String {
    let from = path
        .map(|p| format!(" from {}", p.display()))
        .unwrap_or_default();
    let mut s = format!("model: motion VQ-VAE (SPEC §13.2, T2M-GPT encoder/decoder){from}\n");
    let rate = c.rate();
    let _ = writeln!(
        s,
        "  encoder pos72 [T, 72] → Conv(72 → {w}) → {d} × [Conv(k4, s2) + {depth} residual blocks ({:?})] → Conv({w} → {c}) → z [T/{rate}, {c}]: {}",
        c.enc_dilations,
        group_digits(enc),
        w = c.width,
        d = c.down_t,
        depth = c.depth,
        c = c.code_dim,
    );
    let _ = writeln!(
        s,
        "  quantiser {:?}: {} codes × {} (codebook buffer {}, not counted; μ {}, commitment β {})",
        c.quantizer,
        c.codes,
        c.code_dim,
        group_digits(c.codes * c.code_dim),
        c.mu,
        c.commit
    );
    let _ = writeln!(
        s,
        "  decoder {:?}: {}; window {} frames = {} tokens",
        c.decoder,
        group_digits(dec),
        c.window,
        c.window / rate
    );
    let _ = writeln!(
        s,
        "  closed form (§13.9): encoder {} + decoder {} = {}",
        group_digits(crate::vqvae::encdec::encoder_params(c)),
        group_digits(crate::vqvae::encdec::decoder_params(c)),
        group_digits(
            crate::vqvae::encdec::encoder_params(c) + crate::vqvae::encdec::decoder_params(c)
        )
    );
    s
}

/// What `qean inspect` prints for an in-betweener config (SPEC §12.4c).
pub fn inbetween_summary(
    c: &qean_config::inbetween::InbetweenConfig,
    params: usize,
    path: Option<&Path>,
) -> String {
    use qean_config::inbetween::Variant;
    let from = path
        .map(|p| format!(" from {}", p.display()))
        .unwrap_or_default();
    let mut s = format!(
        "model: in-betweener {} (Lin 2022, §3.5.3){from}\n",
        c.variant.name()
    );
    let input = match c.variant {
        Variant::Motion => "B [T, 225]".to_string(),
        Variant::Genre => "[B | genre one-hot] [T, 234]".to_string(),
        Variant::MergedFull | Variant::MergedDrum => {
            format!("[B | music encoding] [T, {}]", 225 + c.hidden)
        }
        Variant::CrossFull | Variant::CrossDrum => "B [T, 225]".to_string(),
    };
    if c.variant.has_audio() {
        let _ =
            writeln!(
            s,
            "  music  {} feature [T, 22] → Dense(22 → {}) + positions [{}, {}] → {} pre-LN layers",
            if c.variant.drums() { "drums-stem" } else { "full-mix" },
            c.hidden,
            c.max_len,
            c.hidden,
            c.audio_layers
        );
    }
    let stack = if c.variant.is_cross() {
        format!(
            "{} decoder layers ({:?}: cross-attention to the music)",
            c.layers, c.decoder
        )
    } else {
        format!("{} self-attention layers", c.layers)
    };
    let _ = writeln!(
        s,
        "  motion {input} → Dense → {} + positions [{}, {}] → {stack} (heads {}, FFN {}, dropout {}, scale {:?})",
        c.hidden, c.max_len, c.hidden, c.heads, c.ffn, c.dropout, c.scale
    );
    let _ = writeln!(
        s,
        "  output Dense({} → 225) + B ({:?} base over {} keys per measure)",
        c.hidden, c.base, c.train_keys
    );
    let _ = writeln!(
        s,
        "  closed form (§12.4c): {}",
        group_digits(crate::inbetween::inbetween_params(c))
    );
    let _ = params;
    s
}

/// A printable summary of a TSMT model (SPEC §11.5) with its parts' parameter counts and the
/// closed form of §11.6.
pub fn tsmt_summary(c: &TsmtConfig, model: &Tsmt, path: Option<&Path>) -> String {
    let mut s = String::new();
    let from = path
        .map(|p| format!(" from {}", p.display()))
        .unwrap_or_default();
    let n = c.coords();
    let _ = writeln!(
        s,
        "model: TSMT (Li et al. 2020, two-stream motion transformer){from}"
    );
    let _ = writeln!(
        s,
        "  pose   [B, {w}, {n}] bins of {} ({:?}, root {:?}) → Emb({} × {}) → Linear({} → {}) → {} causal post-LN blocks (heads {} × {})",
        c.n_bins,
        c.bins_mode,
        c.root_mode,
        c.n_bins + 1,
        c.embed,
        n * c.embed,
        c.hidden,
        c.layers,
        c.heads,
        c.head_dim,
        w = c.window,
    );
    let streams = match c.audio_streams {
        AudioStreams::Single => "one stream over [tanh(MFCC) ; beat]",
        AudioStreams::Split => "a beat stream and an MFCC stream",
    };
    let _ = writeln!(
        s,
        "  audio  [B, {}, 26 MFCC + Δ | beat] → {streams}, width {}, {} blocks (heads {} × {})",
        c.window, c.audio_hidden, c.audio_layers, c.audio_heads, c.audio_head_dim
    );
    let _ = writeln!(
        s,
        "  head   Linear → [B, {}, {n}, {}] → Linear({} → {}) shared over coordinates; dropout {}",
        c.window, c.d_out, c.d_out, c.n_bins, c.dropout
    );
    let audio = model.audio.num_params();
    let parts = [
        (
            "pose embedding + stream",
            model.pose_embed.num_params() + model.pose.num_params(),
        ),
        ("audio embedding + stream", audio),
        (
            "fusion + classifier",
            model.fuse.num_params() + model.classifier.num_params(),
        ),
    ];
    let _ = writeln!(
        s,
        "parameters: {} (closed form {})",
        group_digits(model.num_params()),
        group_digits(tsmt_params(c))
    );
    for (name, k) in parts {
        let _ = writeln!(s, "  {name:<28} {:>13}", group_digits(k));
    }
    s
}

/// SPEC §4.2's closed-form parameter count, extended to every option of the schema.
pub fn formula_param_count(c: &ModelConfig) -> usize {
    let (w, f, h) = (c.hidden, c.ffn, c.heads);
    let layer_norms = 2 * (2 * w);
    let mlp = w * f + f + f * w + w;
    let output = w * w + w;
    let dk = c.qra_qk_head_dim();
    let qra = || {
        let projections = match c.qra.qk_proj {
            QraQkProj::Dense => w * (2 * h * dk + w),
            // Two QuaternionLinear(w/4 → h·dk/4) with a 4·(h·dk/4) bias, and a bias-free v.
            QraQkProj::Quaternion => 2 * (4 * (w / 4) * (h * dk / 4) + h * dk) + w * w,
        };
        let conv_in = match c.qra.conv_input {
            QraConvInput::Normed => w,
            QraConvInput::Projected => h * dk,
        };
        let channels = h * c.qra.periods;
        projections + 4 * (conv_in * c.qra.kernel * channels + channels) + output
    };
    let softmax_block = layer_norms + 3 * w * w + output + mlp;
    let qra_block = layer_norms + mlp + qra();
    let encoders = (c.motion_layers + c.audio_layers) * softmax_block;
    let cross: usize = (0..c.cross_layers)
        .map(|l| {
            if c.layer_uses_qra(l) {
                qra_block
            } else {
                softmax_block
            }
        })
        .sum();
    let d = c.motion_dim();
    let motion_in = d * w + w;
    let audio_in = match c.input_fusion {
        InputFusion::Dense => c.audio_dim * w + w,
        InputFusion::Quaternion254 => {
            let q = QuaternionFusionConfig::new(c.audio_dim, w).quaternions();
            4 * q * (w / 4) + w
        }
    };
    let positions = if c.learned_positions() {
        (c.motion_len + c.audio_len) * w
    } else {
        0
    };
    let prefix = if c.attention == AttentionKind::Qra && c.qra.topology == QraTopology::CrossPrefix
    {
        2 * (2 * w) + qra()
    } else {
        0
    };
    encoders + cross + motion_in + audio_in + positions + w * d + d + prefix
}

#[cfg(test)]
mod tests {
    use super::*;
    use qean_config::model::{Arch, QraDk, QraLayers, QraOptions, RopeOptions};

    fn count(c: &ModelConfig) -> usize {
        DanceModel::new(c, &Device::flex()).unwrap().num_params()
    }

    fn qean() -> ModelConfig {
        ModelConfig {
            arch: Arch::Qean,
            heads: 16,
            dropout: 0.1,
            ..ModelConfig::default()
        }
    }

    #[test]
    fn mint_fact_has_120_406_977_parameters() {
        let c = ModelConfig::default();
        assert_eq!(count(&c), 120_406_977);
        assert_eq!(formula_param_count(&c), 120_406_977);
        // SPEC §4.2: 16 layers × 7,483,072 + 677,825, independent of the head count.
        assert_eq!(16 * 7_483_072 + 677_825, 120_406_977);
        assert_eq!(count(&qean()), 120_406_977);
    }

    #[test]
    fn spec_variant_counts() {
        // SPEC §4.2 (225 layout unless stated; H = 16, P = 2, kernel 1, QRA in all 12 layers).
        let layout_219 = ModelConfig {
            motion_layout: qean_motion::motion::Layout::L219,
            ..ModelConfig::default()
        };
        let spe = ModelConfig {
            position: PositionKind::Rotary,
            ..qean()
        };
        let qra = ModelConfig {
            attention: AttentionKind::Qra,
            ..qean()
        };
        let full = ModelConfig {
            position: PositionKind::Rotary,
            attention: AttentionKind::Qra,
            ..qean()
        };
        for (c, want) in [
            (layout_219, 120_397_371),
            (spe, 120_118_977),
            (qra, 121_637_313),
            (full, 121_349_313),
        ] {
            assert_eq!(count(&c), want, "{c:?}");
            assert_eq!(formula_param_count(&c), want);
        }
    }

    #[test]
    fn formula_matches_the_module_for_every_option() {
        let base = ModelConfig {
            attention: AttentionKind::Qra,
            hidden: 64,
            heads: 4,
            ffn: 96,
            ..qean()
        };
        let variants = [
            ModelConfig {
                qra: QraOptions {
                    dk: QraDk::RoundUp,
                    ..QraOptions::default()
                },
                heads: 16,
                hidden: 80,
                ..base.clone()
            },
            ModelConfig {
                qra: QraOptions {
                    qk_proj: QraQkProj::Quaternion,
                    ..QraOptions::default()
                },
                heads: 16,
                hidden: 80,
                ..base.clone()
            },
            ModelConfig {
                qra: QraOptions {
                    kernel: 3,
                    conv_input: QraConvInput::Projected,
                    ..QraOptions::default()
                },
                ..base.clone()
            },
            ModelConfig {
                qra: QraOptions {
                    layers: QraLayers::LastK,
                    layers_k: 5,
                    periods: 4,
                    ..QraOptions::default()
                },
                ..base.clone()
            },
            ModelConfig {
                qra: QraOptions {
                    topology: QraTopology::CrossPrefix,
                    ..QraOptions::default()
                },
                ..base.clone()
            },
            ModelConfig {
                input_fusion: InputFusion::Quaternion254,
                position: PositionKind::Rotary,
                rope: RopeOptions {
                    keep_abs_pos: true,
                    ..RopeOptions::default()
                },
                ..base.clone()
            },
        ];
        for c in variants {
            c.validate().unwrap();
            assert_eq!(count(&c), formula_param_count(&c), "{c:?}");
        }
    }

    #[test]
    fn group_digits_inserts_commas() {
        assert_eq!(group_digits(120406977), "120,406,977");
        assert_eq!(group_digits(999), "999");
        assert_eq!(group_digits(1000), "1,000");
    }
}
