//! `[genre_clf]`: the genre classifier of the control evaluation (SPEC §13.10): pos72 windows → conv stack →
//! time mean → 10 genre logits. It judges whether `--genre` steers a dance.

use serde::{Deserialize, Serialize};

/// The `[genre_clf]` table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct GenreClfConfig {
    /// Conv width W (paper 256, tiny 64).
    pub width: usize,
    /// Window in frames (240).
    pub window: usize,
    /// Stride of the windows whose logits are summed into a sequence's verdict (120).
    pub eval_stride: usize,
}

impl Default for GenreClfConfig {
    fn default() -> Self {
        GenreClfConfig {
            width: 256,
            window: 240,
            eval_stride: 120,
        }
    }
}

impl GenreClfConfig {
    /// Values no classifier can use, as one message.
    pub fn validate(&self) -> Result<(), String> {
        if self.width == 0 || self.eval_stride == 0 {
            return Err("genre_clf.width and genre_clf.eval_stride must be at least 1".into());
        }
        if self.window < 16 {
            return Err(format!(
                "genre_clf.window must be at least 16 frames (three stride-2 convolutions), got {}",
                self.window
            ));
        }
        Ok(())
    }
}
