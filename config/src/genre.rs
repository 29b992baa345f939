//! `[genre]`: the genre-control stage of the multi-modal control system (SPEC §13.5). A run with
//! `model.arch = "gpt_genre"` freezes the GPT of `gpt_run` and trains only the genre embedding network
//! (GEN), the eq. 3 cross-attention sub-layers and the discriminator D, against each other (eq. 4). Every
//! [DECISION] of §13.5 is a key here; defaults are the paper preset (MNET's sizes).

use serde::{Deserialize, Serialize};

/// Which M-Base positions query the genre tokens.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum XattnOn {
    /// The music stream only ("M" of eq. 3 is the music feature).
    #[default]
    Music,
    /// Every position of both streams.
    All,
}

/// The guidance a genre stage samples with (`genre.guidance`, `--genre-guidance`): 1 is the paper's.
pub const GUIDANCE_RANGE: std::ops::RangeInclusive<f64> = 0.0..=20.0;

/// The adversarial loss (eq. 4).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GanLoss {
    /// Non-saturating: L_D = −log σ(D_real) − log(1 − σ(D_fake)); L_G = −log σ(D_fake).
    #[default]
    Nsgan,
    /// MNET: L_D = ½[mean relu(1 − D_real) + mean relu(1 + D_fake)]; L_G = −mean D_fake.
    Hinge,
}

/// How fake token latents stay differentiable.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Relax {
    /// Gumbel straight-through: one-hot forward, softmax gradient.
    #[default]
    St,
    /// The Gumbel softmax itself (no hard one-hot).
    Soft,
}

/// The `[genre]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GenreConfig {
    /// The trained music-to-dance GPT run (its newest checkpoint) this stage controls;
    /// `--set genre.gpt_run=DIR` overrides it.
    pub gpt_run: Option<std::path::PathBuf>,
    /// Width C of the frozen VQ-VAE's codes, which D reads as latents (checked against it).
    pub code_dim: usize,
    /// Noise width of z (MNET 256; tiny 16).
    pub z_dim: usize,
    /// Genre tokens n_g per genre (1 = MNET exactly).
    pub tokens: usize,
    /// Which positions query the genre tokens.
    pub xattn_on: XattnOn,
    /// Dropout after the cross-attention output and inside D.
    pub dropout: f64,
    /// Discriminator width D_d, layers, feed-forward width and heads.
    pub disc_width: usize,
    pub disc_layers: usize,
    pub disc_ff: usize,
    pub disc_heads: usize,
    /// Whether D sees the music tokens (off: latents only).
    pub disc_music: bool,
    pub gan_loss: GanLoss,
    pub relax: Relax,
    /// Gumbel temperature τ.
    pub tau: f64,
    /// Weights of the adversarial and diversity terms of the generator loss.
    pub lambda_adv: f64,
    pub lambda_div: f64,
    /// Sampling: logits = l_plain + s·(l_genre − l_plain), l_plain the frozen GPT's without the genre tokens
    /// (classifier-free guidance, Ho & Salimans 2022; not in SPEC). 1 = the paper's (l_genre alone).
    pub guidance: f64,
    /// Ours (not in SPEC): the share of training windows whose own-genre cross-entropy hears the music of
    /// another window of the batch, one of another genre, so that only the genre tokens say which genre
    /// the target dance is. Each music track has one genre, so without it the frozen GPT already predicts
    /// the genre from the music and the module learns a push common to all genres. 0 = the paper's.
    pub music_swap: f64,
    /// The genre vocabulary: `aistpp` (AIST++'s ten branches and heads) or `finedance` (its sixteen).
    /// Training sets it from the data.
    pub genres: qean_aistpp::layout::GenreSet,
}

impl Default for GenreConfig {
    fn default() -> Self {
        Self::paper()
    }
}

impl GenreConfig {
    /// `paper` (SPEC §13.9, MNET's `AISTPP.yaml`): z 256, D_d 768, 4 layers, FF 2048, 12 heads.
    pub fn paper() -> Self {
        GenreConfig {
            gpt_run: None,
            code_dim: 512,
            z_dim: 256,
            tokens: 1,
            xattn_on: XattnOn::Music,
            dropout: 0.1,
            disc_width: 768,
            disc_layers: 4,
            disc_ff: 2048,
            disc_heads: 12,
            disc_music: true,
            gan_loss: GanLoss::Nsgan,
            relax: Relax::St,
            tau: 1.0,
            lambda_adv: 1.0,
            lambda_div: 0.0,
            guidance: 1.0,
            music_swap: 0.0,
            genres: qean_aistpp::layout::GenreSet::Aistpp,
        }
    }

    /// `tiny` (CPU): z 16, D_d 64, 2 layers, FF 128, 4 heads.
    pub fn tiny() -> Self {
        GenreConfig {
            code_dim: 64,
            z_dim: 16,
            disc_width: 64,
            disc_layers: 2,
            disc_ff: 128,
            disc_heads: 4,
            ..Self::paper()
        }
    }

    /// Values no genre stage can use, as one message.
    pub fn validate(&self) -> Result<(), String> {
        if !GUIDANCE_RANGE.contains(&self.guidance) {
            return Err(format!(
                "genre.guidance must be between 0 and 20 (1 = the paper's sampling), got {}",
                self.guidance
            ));
        }
        if self.code_dim == 0
            || self.z_dim == 0
            || self.tokens == 0
            || self.disc_layers == 0
            || self.disc_ff == 0
        {
            return Err(
                "genre.code_dim, genre.z_dim, genre.tokens, genre.disc_layers and genre.disc_ff must be at least 1"
                    .into(),
            );
        }
        if self.disc_heads == 0 || !self.disc_width.is_multiple_of(self.disc_heads) {
            return Err(format!(
                "genre.disc_width = {} must be a positive multiple of genre.disc_heads = {}",
                self.disc_width, self.disc_heads
            ));
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return Err(format!(
                "genre.dropout must be in [0, 1), got {}",
                self.dropout
            ));
        }
        if !(0.0..=1.0).contains(&self.music_swap) {
            return Err(format!(
                "genre.music_swap is a share of windows, in [0, 1]; got {}",
                self.music_swap
            ));
        }
        if !(self.tau.is_finite() && self.tau > 0.0) {
            return Err(format!("genre.tau must be positive, got {}", self.tau));
        }
        for (name, v) in [
            ("lambda_adv", self.lambda_adv),
            ("lambda_div", self.lambda_div),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("genre.{name} must be finite and >= 0, got {v}"));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Guidance 1 (the paper's sampling) is the default; outside [0, 20] it is refused.
    #[test]
    fn guidance_defaults_to_the_papers_sampling() {
        assert_eq!(GenreConfig::paper().guidance, 1.0);
        assert_eq!(GenreConfig::tiny().guidance, 1.0);
        for bad in [-1.0, 21.0, f64::NAN] {
            let c = GenreConfig {
                guidance: bad,
                ..GenreConfig::tiny()
            };
            assert!(c.validate().unwrap_err().contains("guidance"), "{bad}");
        }
    }

    /// The music swap is off in both presets (the paper's training) and is a share in [0, 1].
    #[test]
    fn music_swap_is_a_share() {
        assert_eq!(GenreConfig::paper().music_swap, 0.0);
        assert_eq!(GenreConfig::tiny().music_swap, 0.0);
        for (v, ok) in [
            (0.5, true),
            (1.0, true),
            (-0.1, false),
            (1.5, false),
            (f64::NAN, false),
        ] {
            let c = GenreConfig {
                music_swap: v,
                ..GenreConfig::tiny()
            };
            assert_eq!(c.validate().is_ok(), ok, "{v}");
        }
    }
}
