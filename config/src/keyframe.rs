//! `[keyframe]`: keyframe control of the multi-modal control system (SPEC §13.6, stage 3b). A run with
//! `model.arch = "gpt_keyframe"` freezes the GPT of `gpt_run` and trains only the keyframe module: per-layer
//! copies of the attention projections of every M-Base and head block (initialised from the causal ones)
//! and the Mask row of the M-Base's token table, used with every position visible (`attn_mode = mask`).
//! Every [DECISION] of §13.6 is a key here.

use serde::{Deserialize, Serialize};

/// Which positions a training window masks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KfTrainMask {
    /// [p − k, p + k] \ {p} around each of 1 or 2 centres (`kf_train_mask`).
    #[default]
    Centres,
    /// The centres' spans plus uniform masking of the other positions at a ratio drawn from U(0.15, 0.5).
    Mixed,
}

/// What the keyframe module holds (SPEC §13.6 `keyframe.weights`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KfWeights {
    /// Copies of the q, k, v and output projections of every M-Base and head block; the GPT's LNs, MLPs,
    /// embeddings and logits are used as they are (`attn_only`).
    #[default]
    AttnOnly,
    /// A copy of the whole M-Base and head (embeddings, blocks, final LN and logits), all trained.
    FullCopy,
}

/// How a keyframe pose becomes a token.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KfTokenize {
    /// The pose held still over 8 tokens' frames, encoded; token 4 (`static_clip`).
    #[default]
    StaticClip,
    /// The pose written into token p's frames of the decoded dance, tokens p − 4 .. p + 4 encoded again;
    /// token p (`paste`).
    Paste,
}

/// How the masked positions of a window are filled at sampling.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum KfDecode {
    /// One pass: the argmax at every masked position.
    #[default]
    OneShot,
    /// MaskGIT-style: `passes` passes, each fixing the most confident of the positions still masked (a
    /// linear share per pass) and predicting the rest again with them visible.
    Iterative,
}

/// The `[keyframe]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct KeyframeConfig {
    /// The trained music-to-dance GPT run (its newest checkpoint) this stage edits;
    /// `--set keyframe.gpt_run=DIR` overrides it.
    pub gpt_run: Option<std::path::PathBuf>,
    /// What the trained module copies from the GPT.
    pub weights: KfWeights,
    /// How a keyframe pose becomes its token at sampling (training's centres take static-clip tokens).
    pub tokenize: KfTokenize,
    /// Tokens re-predicted on each side of a keyframe (k = 6 [READ]).
    pub radius: usize,
    /// Training windows hold 1 to `max_centres` keyframe centres, uniformly many.
    pub max_centres: usize,
    pub train_mask: KfTrainMask,
    /// Probability that a centre's token is replaced by its static-clip token (the token of the pose of
    /// the token's middle frame, held for 64 frames), as a keyframe's token is at sampling.
    pub static_prob: f64,
    pub decode: KfDecode,
    /// Passes of `decode = "iterative"`.
    pub passes: usize,
    /// Ours: frames on each side of a keyframe over which the decoded dance is warped to the keyframe's
    /// root-relative pose (a raised-cosine displacement map; 0 = off, the paper's tokens alone).
    pub warp_frames: usize,
}

impl Default for KeyframeConfig {
    fn default() -> Self {
        KeyframeConfig {
            gpt_run: None,
            weights: KfWeights::AttnOnly,
            tokenize: KfTokenize::StaticClip,
            radius: 6,
            max_centres: 2,
            train_mask: KfTrainMask::Centres,
            static_prob: 0.5,
            decode: KfDecode::OneShot,
            passes: 4,
            warp_frames: 0,
        }
    }
}

impl KeyframeConfig {
    /// Values no keyframe stage can use, as one message (`window`: the GPT's window in tokens).
    pub fn validate(&self) -> Result<(), String> {
        if self.radius == 0 || self.max_centres == 0 || self.passes == 0 {
            return Err(
                "keyframe.radius, keyframe.max_centres and keyframe.passes must be at least 1"
                    .into(),
            );
        }
        if !(0.0..=1.0).contains(&self.static_prob) {
            return Err(format!(
                "keyframe.static_prob must be in [0, 1], got {}",
                self.static_prob
            ));
        }
        Ok(())
    }

    /// Checks against the GPT's window: a keyframe's masked span (2k + 1 tokens) must fit in it.
    pub fn validate_window(&self, window: usize) -> Result<(), String> {
        if 2 * self.radius + 1 > window {
            return Err(format!(
                "keyframe.radius = {} masks {} tokens around a keyframe, more than the GPT's window of {} (gpt.window)",
                self.radius,
                2 * self.radius + 1,
                window
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_spec_and_bad_values_fail() {
        let c = KeyframeConfig::default();
        assert_eq!((c.radius, c.max_centres, c.static_prob), (6, 2, 0.5));
        assert!(c.validate().is_ok() && c.validate_window(32).is_ok());
        assert!(c.validate_window(12).unwrap_err().contains("gpt.window"));
        let bad = KeyframeConfig {
            static_prob: 1.5,
            ..c.clone()
        };
        assert!(bad.validate().unwrap_err().contains("static_prob"));
        let bad = KeyframeConfig { radius: 0, ..c };
        assert!(bad.validate().is_err());
    }
}
