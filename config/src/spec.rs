//! The model family of a run, typed: one enum whose variants carry the family's own config. Every crate
//! dispatches on it with one `match` (no `is_x()` ladders); the TOML keeps its shape (`model.arch` and the
//! family's table), and [`RunConfig::spec`] builds the view.

use std::sync::LazyLock;

use crate::genre::GenreConfig;
use crate::genre_clf::GenreClfConfig;
use crate::gpt::GptConfig;
use crate::inbetween::InbetweenConfig;
use crate::keyframe::KeyframeConfig;
use crate::model::{Arch, ModelConfig};
use crate::tsmt::TsmtConfig;
use crate::vqvae::VqConfig;
use crate::RunConfig;

/// A run's model family with its config (SPEC §4, §11, §12, §13).
#[derive(Debug, Clone, Copy)]
pub enum ModelSpec<'a> {
    /// mint's FACT or QEAN (`arch = "fact"` / `"qean"`, SPEC §4): the `[model]` table.
    FactQean(&'a ModelConfig),
    /// Li et al.'s two-stream motion transformer (`arch = "tsmt"`, SPEC §11): `[tsmt]`.
    Tsmt(&'a TsmtConfig),
    /// Lin's transformer in-betweeners (`arch = "inbetween"`, SPEC §12): `[inbetween]`.
    Inbetween(&'a InbetweenConfig),
    /// The motion VQ-VAE (`arch = "vqvae"`, SPEC §13.2): `[vq]`.
    Vqvae(&'a VqConfig),
    /// The music-to-dance GPT over a frozen VQ-VAE's tokens (`arch = "gpt"`, SPEC §13.3): `[gpt]`.
    Gpt(&'a GptConfig),
    /// Genre control over a frozen GPT (`arch = "gpt_genre"`, SPEC §13.5): `[gpt]` and `[genre]`.
    GptGenre(&'a GptConfig, &'a GenreConfig),
    /// The genre classifier of the control evaluation (`arch = "genre_clf"`, SPEC §13.10): `[genre_clf]`.
    GenreClf(&'a GenreClfConfig),
    /// Keyframe control over a frozen GPT (`arch = "gpt_keyframe"`, SPEC §13.6): `[gpt]` and `[keyframe]`.
    GptKeyframe(&'a GptConfig, &'a KeyframeConfig),
}

// A config built in code may lack its family's table; it then reads the preset defaults, as loading fills in.
static TSMT: LazyLock<TsmtConfig> = LazyLock::new(TsmtConfig::default);
static INBETWEEN: LazyLock<InbetweenConfig> = LazyLock::new(InbetweenConfig::default);
static VQ: LazyLock<VqConfig> = LazyLock::new(VqConfig::default);
static GPT: LazyLock<GptConfig> = LazyLock::new(GptConfig::default);
static GENRE: LazyLock<GenreConfig> = LazyLock::new(GenreConfig::default);
static GENRE_CLF: LazyLock<GenreClfConfig> = LazyLock::new(GenreClfConfig::default);
static KEYFRAME: LazyLock<KeyframeConfig> = LazyLock::new(KeyframeConfig::default);

impl RunConfig {
    /// The run's family and its config: `model.arch` with its table (the defaults where a config built in
    /// code has none; loading fills them in).
    pub fn spec(&self) -> ModelSpec<'_> {
        match self.model.arch {
            Arch::Fact | Arch::Qean => ModelSpec::FactQean(&self.model),
            Arch::Tsmt => ModelSpec::Tsmt(self.tsmt_table()),
            Arch::Inbetween => ModelSpec::Inbetween(self.inbetween_table()),
            Arch::Vqvae => ModelSpec::Vqvae(self.vq_table()),
            Arch::Gpt => ModelSpec::Gpt(self.gpt_table()),
            Arch::GptGenre => ModelSpec::GptGenre(self.gpt_table(), self.genre_table()),
            Arch::GenreClf => ModelSpec::GenreClf(self.genre_clf_table()),
            Arch::GptKeyframe => ModelSpec::GptKeyframe(self.gpt_table(), self.keyframe_table()),
        }
    }

    /// `[tsmt]`, or its defaults where a config built in code has none (loading fills the family's in).
    pub fn tsmt_table(&self) -> &TsmtConfig {
        self.tsmt.as_ref().unwrap_or(&TSMT)
    }

    /// `[inbetween]`, or its defaults.
    pub fn inbetween_table(&self) -> &InbetweenConfig {
        self.inbetween.as_ref().unwrap_or(&INBETWEEN)
    }

    /// `[vq]`, or its defaults.
    pub fn vq_table(&self) -> &VqConfig {
        self.vq.as_ref().unwrap_or(&VQ)
    }

    /// `[gpt]`, or its defaults.
    pub fn gpt_table(&self) -> &GptConfig {
        self.gpt.as_ref().unwrap_or(&GPT)
    }

    /// `[genre]`, or its defaults.
    pub fn genre_table(&self) -> &GenreConfig {
        self.genre.as_ref().unwrap_or(&GENRE)
    }

    /// `[genre_clf]`, or its defaults.
    pub fn genre_clf_table(&self) -> &GenreClfConfig {
        self.genre_clf.as_ref().unwrap_or(&GENRE_CLF)
    }

    /// `[keyframe]`, or its defaults.
    pub fn keyframe_table(&self) -> &KeyframeConfig {
        self.keyframe.as_ref().unwrap_or(&KEYFRAME)
    }
}

impl ModelSpec<'_> {
    /// The family's name, which is also its module's in every crate (`config/src/<name>.rs`,
    /// `train/src/<name>.rs`, …): `fact_qean`, `tsmt`, `inbetween`, `vqvae`, `gpt`, `genre`, `genre_clf`, `keyframe`.
    pub fn family(self) -> &'static str {
        match self {
            ModelSpec::FactQean(_) => "fact_qean",
            ModelSpec::Tsmt(_) => "tsmt",
            ModelSpec::Inbetween(_) => "inbetween",
            ModelSpec::Vqvae(_) => "vqvae",
            ModelSpec::Gpt(_) => "gpt",
            ModelSpec::GptGenre(..) => "genre",
            ModelSpec::GenreClf(_) => "genre_clf",
            ModelSpec::GptKeyframe(..) => "keyframe",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every architecture maps to its family; a table missing from a config built in code reads the
    /// defaults, as loading would fill them in.
    #[test]
    fn every_arch_has_a_family() {
        let names = [
            (Arch::Fact, "fact_qean"),
            (Arch::Qean, "fact_qean"),
            (Arch::Tsmt, "tsmt"),
            (Arch::Inbetween, "inbetween"),
            (Arch::Vqvae, "vqvae"),
            (Arch::Gpt, "gpt"),
            (Arch::GptGenre, "genre"),
            (Arch::GenreClf, "genre_clf"),
            (Arch::GptKeyframe, "keyframe"),
        ];
        for (arch, name) in names {
            let mut c = RunConfig::default();
            c.model.arch = arch;
            assert_eq!(c.spec().family(), name, "{arch:?}");
        }
        let mut c = RunConfig::default();
        c.model.arch = Arch::Tsmt;
        match c.spec() {
            ModelSpec::Tsmt(t) => assert_eq!(*t, TsmtConfig::default()),
            other => panic!("{other:?}"),
        }
    }
}
