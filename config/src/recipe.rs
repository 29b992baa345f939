//! `[recipe]`: how FACT and QEAN are trained and sampled beyond mint's plain teacher forcing
//! (issue 17: remedies for motion that freezes after the seed, or jitters).
//!
//! mint trains on ground-truth input windows only and feeds its raw outputs back at inference
//! (SPEC §5, §6): the model never sees its own outputs while training (exposure bias), and an L2
//! loss pulls uncertain futures towards the mean pose. Each remedy here is one key:
//!
//! - `input_noise`: Gaussian noise of this σ on the input motion window (model units: rotation
//!   matrix entries and metres), so the model learns to correct a drifting input;
//! - `gain_db`: every input window's music as if played up to this many dB louder or softer (a
//!   shift of MFCC 0 alone: the other columns do not depend on the level), so that a song mastered
//!   louder than the training music is heard as music and not as something new;
//! - `audio_shift`: a random offset per input window and music feature column, so that the
//!   model does not tie its motion to the exact feature levels of the few training recordings;
//! - `rollout_frames`, `rollout_mode`, `rollout_prob`, `rollout_ramp`: auto-conditioning /
//!   scheduled sampling — the last K frames of an input window replaced by the model's own
//!   predictions (acLSTM's auto-conditioning, seed 002's baseline), for a share of the batch that
//!   rises from 0 to `rollout_prob` over the steps `rollout_ramp`;
//! - `velocity_loss`, `accel_loss`: weights of the first and second differences of the predicted
//!   frames against the target's, added to the L2 loss;
//! - `feedback_project`: at inference, project fed-back rotations to SO(3) and zero the pad dims.
//! - `ensemble`, `ensemble_decay`: at inference, each frame the weighted mean of the predictions
//!   the last `ensemble` passes made for it (temporal ensembling; 1 = token 0 only, mint);
//! - `seam_frames`: at inference, the jump between the seed and the first generated frame
//!   faded out over this many frames (inertialization, `qean_motion::seam`; the VQ-VAE + GPT eases
//!   its decoded joint positions out of the seed's last pose the same way);
//! - `audio_norm`: music features standardised with the training split's statistics, or each track
//!   with its own (`per_track`);
//! - `predict`: future poses (mint) or offsets from the last input frame.
//!
//! `base` names a preset of all of them; keys set explicitly (anywhere in an `extends` chain or
//! with `--set`) override it. `base = "mint"` is SPEC §5 exactly (every remedy off) and is the
//! default; `base = "dance"` is the combination chosen by the measurements in docs/freezing.md.
//! The longer supervised horizon is `model.target_len`.

use serde::{Deserialize, Serialize};

/// A named set of remedy values.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RecipeBase {
    /// mint's training and sampling exactly: every remedy off.
    #[default]
    Mint,
    /// The remedies that keep tiny models dancing (docs/freezing.md).
    Dance,
}

/// How the 35-D music features enter the model.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum AudioNorm {
    /// As computed (mint): MFCC 0 is about −340 ± 130 while the beat column is 0 or 1, so the
    /// audio embedding is dominated by loudness and the small learned position embeddings vanish
    /// next to it.
    #[default]
    None,
    /// Each column standardised with the training split's mean and SD (`audio_mean`,
    /// `audio_std`, computed when training starts and stored in the run's config).
    Standardize,
    /// Each column standardised with the track's own mean and SD over the whole track, in training
    /// and at inference alike: a song louder, brighter or busier than the training music is heard
    /// at the level the model knows (docs/freezing.md, "Songs in general"). A constant column gets
    /// SD 1.
    PerTrack,
}

/// What the output tokens are trained to predict.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Predict {
    /// The future frames themselves (mint).
    #[default]
    Pose,
    /// Each future frame minus the last input frame; the sampler adds the last frame back. A
    /// model that has learnt nothing continues the last pose instead of jumping to the mean
    /// pose, and its per-frame error scales with the motion, not with the pose.
    Offset,
}

/// How the rolled-out frames of an input window are made.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RolloutMode {
    /// One pass: output tokens 0..K of the window K frames earlier (the model's own K-frame
    /// forecast; cheap, needs K ≤ target_len).
    #[default]
    Block,
    /// K passes, each keeping token 0 and sliding the window by one frame: exactly the sampler's
    /// loop (SPEC §6), K times the cost of a forward pass.
    Step,
}

/// The resolved recipe.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RecipeConfig {
    pub base: RecipeBase,
    /// σ of the Gaussian noise added to every non-pad input motion value (0 = off).
    pub input_noise: f64,
    /// σ of a per-window, per-column offset added to the model's music features (their units:
    /// standard deviations when standardised; 0 = off): a window's music as if from another
    /// recording, whose feature levels differ.
    pub audio_shift: f64,
    /// Loudness augmentation: each input window's music at a gain drawn uniformly from ±`gain_db`
    /// dB (0 = off). A gain of g dB adds √128·g to MFCC 0 (the DCT's first row over 128 mel bands in
    /// dB) and leaves every other column as it was (onsets and chroma are level-free).
    pub gain_db: f64,
    /// Frames at the end of the input window replaced by the model's own predictions (0 = off).
    pub rollout_frames: usize,
    pub rollout_mode: RolloutMode,
    /// Share of the batch rolled out once the ramp is over.
    pub rollout_prob: f64,
    /// [start, end] updates of the linear ramp of the rolled-out share from 0 to `rollout_prob`.
    pub rollout_ramp: [u64; 2],
    /// Weight of mean((Δpred − Δtarget)²) over consecutive predicted frames (0 = off).
    pub velocity_loss: f64,
    /// Weight of the same for second differences (0 = off).
    pub accel_loss: f64,
    /// Project fed-back frames to SO(3) at inference (the sampler's default for this run).
    pub feedback_project: bool,
    /// Music feature normalisation, and its statistics (35 values each, or empty before the
    /// run computes them from its training split).
    pub audio_norm: AudioNorm,
    pub audio_mean: Vec<f64>,
    pub audio_std: Vec<f64>,
    /// What the output tokens predict.
    pub predict: Predict,
    /// Temporal ensembling at inference: frame t averages the predictions of the last
    /// `ensemble` passes with weights exp(−ensemble_decay·k) (1 = token 0 only, mint).
    pub ensemble: usize,
    pub ensemble_decay: f64,
    /// Inertialization at the seed's end: the gap between the seed's continuation and the first
    /// generated frame fades out over this many frames (0 = off, mint).
    pub seam_frames: usize,
}

impl RecipeConfig {
    /// The values of a base.
    pub fn of(base: RecipeBase) -> RecipeConfig {
        match base {
            RecipeBase::Mint => RecipeConfig {
                base,
                input_noise: 0.0,
                audio_shift: 0.0,
                gain_db: 0.0,
                rollout_frames: 0,
                rollout_mode: RolloutMode::Block,
                rollout_prob: 0.0,
                rollout_ramp: [0, 0],
                velocity_loss: 0.0,
                accel_loss: 0.0,
                feedback_project: false,
                audio_norm: AudioNorm::None,
                audio_mean: Vec::new(),
                audio_std: Vec::new(),
                predict: Predict::Pose,
                ensemble: 1,
                ensemble_decay: 0.0,
                seam_frames: 0,
            },
            RecipeBase::Dance => RecipeConfig {
                base,
                input_noise: 0.02,
                feedback_project: true,
                audio_norm: AudioNorm::Standardize,
                ensemble: 8,
                seam_frames: 30,
                ..Self::of(RecipeBase::Mint)
            },
        }
    }

    /// One line: the base and every remedy that is on.
    pub fn describe(&self) -> String {
        let mut on = Vec::new();
        if self.input_noise > 0.0 {
            on.push(format!("input noise {}", self.input_noise));
        }
        if self.gain_db > 0.0 {
            on.push(format!("music at ±{} dB", self.gain_db));
        }
        if self.audio_shift > 0.0 {
            on.push(format!("music shift {}", self.audio_shift));
        }
        if self.rollout_frames > 0 && self.rollout_prob > 0.0 {
            on.push(format!(
                "{:?} rollouts of {} frames for {} of the batch (ramp {}..{})",
                self.rollout_mode,
                self.rollout_frames,
                self.rollout_prob,
                self.rollout_ramp[0],
                self.rollout_ramp[1]
            ));
        }
        if self.velocity_loss > 0.0 {
            on.push(format!("velocity loss {}", self.velocity_loss));
        }
        if self.accel_loss > 0.0 {
            on.push(format!("acceleration loss {}", self.accel_loss));
        }
        if self.feedback_project {
            on.push("feedback projected".into());
        }
        match self.audio_norm {
            AudioNorm::Standardize => on.push("music standardised".into()),
            AudioNorm::PerTrack => on.push("music standardised per track".into()),
            AudioNorm::None => {}
        }
        if self.predict == Predict::Offset {
            on.push("offsets predicted".into());
        }
        if self.ensemble > 1 {
            on.push(format!(
                "{} passes ensembled (decay {})",
                self.ensemble, self.ensemble_decay
            ));
        }
        if self.seam_frames > 0 {
            on.push(format!("seed's end eased over {} frames", self.seam_frames));
        }
        let base = format!("{:?}", self.base).to_lowercase();
        if on.is_empty() {
            format!("recipe {base} (no remedies)")
        } else {
            format!("recipe {base}: {}", on.join(", "))
        }
        .to_lowercase()
    }

    /// Whether the sampler projects fed-back frames, given a command line's `--feedback-project`
    /// and `--raw-feedback` (either overrides this recipe's `feedback_project`).
    pub fn feedback_project_with(&self, project: bool, raw: bool) -> bool {
        if project || raw {
            project
        } else {
            self.feedback_project
        }
    }

    /// Whether the music features still need their statistics.
    pub fn needs_audio_stats(&self) -> bool {
        self.audio_norm == AudioNorm::Standardize && self.audio_mean.is_empty()
    }

    /// Music features of `frames × dim` as the model sees them (standardised when configured).
    pub fn model_audio(&self, mut data: Vec<f32>, dim: usize) -> Vec<f32> {
        if self.audio_norm == AudioNorm::PerTrack {
            let (mean, std) = track_stats(&data, dim);
            for row in data.chunks_exact_mut(dim) {
                for (k, x) in row.iter_mut().enumerate() {
                    *x = ((*x as f64 - mean[k]) / std[k]) as f32;
                }
            }
            return data;
        }
        if self.audio_norm == AudioNorm::Standardize && self.audio_mean.len() == dim {
            for row in data.chunks_exact_mut(dim) {
                for (k, x) in row.iter_mut().enumerate() {
                    *x = ((*x as f64 - self.audio_mean[k]) / self.audio_std[k]) as f32;
                }
            }
        }
        data
    }

    /// Whether training differs from mint's plain teacher forcing.
    pub fn is_mint_training(&self) -> bool {
        self.audio_norm == AudioNorm::None
            && self.predict == Predict::Pose
            && self.input_noise == 0.0
            && self.audio_shift == 0.0
            && self.gain_db == 0.0
            && (self.rollout_frames == 0 || self.rollout_prob == 0.0)
            && self.velocity_loss == 0.0
            && self.accel_loss == 0.0
    }

    /// The share of a batch rolled out at update `step` (0-based).
    pub fn rollout_share(&self, step: u64) -> f64 {
        if self.rollout_frames == 0 {
            return 0.0;
        }
        let [a, b] = self.rollout_ramp;
        if step >= b {
            self.rollout_prob
        } else if step < a {
            0.0
        } else {
            self.rollout_prob * (step - a) as f64 / (b - a) as f64
        }
    }

    /// Extra frames a training window needs before the model's input (the rolled-out frames).
    pub fn lead_frames(&self) -> usize {
        if self.rollout_prob > 0.0 {
            self.rollout_frames
        } else {
            0
        }
    }

    /// Checks the values; `target_len` and `motion_len` come from `[model]`.
    pub fn validate(&self, motion_len: usize, target_len: usize) -> Result<(), String> {
        let nonneg = [
            ("recipe.input_noise", self.input_noise),
            ("recipe.audio_shift", self.audio_shift),
            ("recipe.gain_db", self.gain_db),
            ("recipe.velocity_loss", self.velocity_loss),
            ("recipe.accel_loss", self.accel_loss),
        ];
        for (key, v) in nonneg {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("{key} must be a finite number ≥ 0, got {v}"));
            }
        }
        if !(0.0..=1.0).contains(&self.rollout_prob) {
            return Err(format!(
                "recipe.rollout_prob must be in [0, 1], got {}",
                self.rollout_prob
            ));
        }
        if self.rollout_ramp[0] > self.rollout_ramp[1] {
            return Err(format!(
                "recipe.rollout_ramp must be [start, end] with start ≤ end, got {:?}",
                self.rollout_ramp
            ));
        }
        if self.rollout_frames >= motion_len {
            return Err(format!(
                "recipe.rollout_frames = {} must be below model.motion_len = {motion_len}",
                self.rollout_frames
            ));
        }
        if self.rollout_mode == RolloutMode::Block && self.rollout_frames > target_len {
            return Err(format!(
                "recipe.rollout_frames = {} exceeds model.target_len = {target_len}: block rollouts read \
                 the supervised output tokens only (use rollout_mode = \"step\")",
                self.rollout_frames
            ));
        }
        if (self.velocity_loss > 0.0 && target_len < 2) || (self.accel_loss > 0.0 && target_len < 3)
        {
            return Err("recipe.velocity_loss needs model.target_len ≥ 2 (accel_loss ≥ 3)".into());
        }
        check_ensemble(
            ("recipe.ensemble", self.ensemble),
            ("recipe.ensemble_decay", self.ensemble_decay),
            target_len,
        )?;
        if self.audio_mean.len() != self.audio_std.len() {
            return Err(format!(
                "recipe.audio_mean has {} values but recipe.audio_std {}",
                self.audio_mean.len(),
                self.audio_std.len()
            ));
        }
        if let Some(s) = self
            .audio_std
            .iter()
            .find(|s| !(s.is_finite() && **s > 0.0))
        {
            return Err(format!("recipe.audio_std values must be positive, got {s}"));
        }
        if self.audio_mean.iter().any(|m| !m.is_finite()) {
            return Err("recipe.audio_mean values must be finite".into());
        }
        Ok(())
    }
}

/// Checks temporal-ensembling settings (each named as its caller's user spells it): 1 to
/// `target_len` passes (a pass predicts `target_len` frames) and a finite decay ≥ 0.
pub fn check_ensemble(
    (ensemble_name, ensemble): (&str, usize),
    (decay_name, decay): (&str, f64),
    target_len: usize,
) -> Result<(), String> {
    if ensemble == 0 || ensemble > target_len {
        return Err(format!(
            "{ensemble_name} must be between 1 and the model's target_len ({target_len}), got {ensemble}"
        ));
    }
    if !(decay.is_finite() && decay >= 0.0) {
        return Err(format!(
            "{decay_name} must be a finite number ≥ 0, got {decay}"
        ));
    }
    Ok(())
}

impl Default for RecipeConfig {
    fn default() -> Self {
        Self::of(RecipeBase::Mint)
    }
}

/// What a file may hold: every key optional; missing ones come from `base`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RecipeFile {
    base: Option<RecipeBase>,
    input_noise: Option<f64>,
    audio_shift: Option<f64>,
    gain_db: Option<f64>,
    rollout_frames: Option<usize>,
    rollout_mode: Option<RolloutMode>,
    rollout_prob: Option<f64>,
    rollout_ramp: Option<[u64; 2]>,
    velocity_loss: Option<f64>,
    accel_loss: Option<f64>,
    feedback_project: Option<bool>,
    audio_norm: Option<AudioNorm>,
    audio_mean: Option<Vec<f64>>,
    audio_std: Option<Vec<f64>>,
    predict: Option<Predict>,
    ensemble: Option<usize>,
    ensemble_decay: Option<f64>,
    seam_frames: Option<usize>,
}

impl<'de> Deserialize<'de> for RecipeConfig {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let f = RecipeFile::deserialize(d)?;
        let b = RecipeConfig::of(f.base.unwrap_or_default());
        Ok(RecipeConfig {
            base: b.base,
            input_noise: f.input_noise.unwrap_or(b.input_noise),
            audio_shift: f.audio_shift.unwrap_or(b.audio_shift),
            gain_db: f.gain_db.unwrap_or(b.gain_db),
            rollout_frames: f.rollout_frames.unwrap_or(b.rollout_frames),
            rollout_mode: f.rollout_mode.unwrap_or(b.rollout_mode),
            rollout_prob: f.rollout_prob.unwrap_or(b.rollout_prob),
            rollout_ramp: f.rollout_ramp.unwrap_or(b.rollout_ramp),
            velocity_loss: f.velocity_loss.unwrap_or(b.velocity_loss),
            accel_loss: f.accel_loss.unwrap_or(b.accel_loss),
            feedback_project: f.feedback_project.unwrap_or(b.feedback_project),
            audio_norm: f.audio_norm.unwrap_or(b.audio_norm),
            audio_mean: f.audio_mean.unwrap_or(b.audio_mean),
            audio_std: f.audio_std.unwrap_or(b.audio_std),
            predict: f.predict.unwrap_or(b.predict),
            ensemble: f.ensemble.unwrap_or(b.ensemble),
            ensemble_decay: f.ensemble_decay.unwrap_or(b.ensemble_decay),
            seam_frames: f.seam_frames.unwrap_or(b.seam_frames),
        })
    }
}

/// Per-column mean and SD (ddof 0) of the rows of `data` (`dim` values each); a column with SD below
/// 1e-6 gets SD 1, so it maps to 0 instead of dividing by zero.
pub fn track_stats(data: &[f32], dim: usize) -> (Vec<f64>, Vec<f64>) {
    let rows = (data.len() / dim.max(1)).max(1) as f64;
    let mut mean = vec![0.0; dim];
    for row in data.chunks_exact(dim) {
        for (m, &x) in mean.iter_mut().zip(row) {
            *m += x as f64;
        }
    }
    mean.iter_mut().for_each(|m| *m /= rows);
    let mut var = vec![0.0; dim];
    for row in data.chunks_exact(dim) {
        for ((v, &x), m) in var.iter_mut().zip(row).zip(&mean) {
            *v += (x as f64 - m).powi(2);
        }
    }
    let std = var
        .iter()
        .map(|v| {
            let s = (v / rows).sqrt();
            if s < 1e-6 {
                1.0
            } else {
                s
            }
        })
        .collect();
    (mean, std)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `per_track` standardises each column over the track at any row width (TSMT's 26 MFCC/Δ columns as
    /// well as the 35 features); a constant column maps to 0.
    #[test]
    fn per_track_standardises_each_column_of_any_width() {
        let r = RecipeConfig {
            audio_norm: AudioNorm::PerTrack,
            ..RecipeConfig::default()
        };
        let dim = 26;
        let data: Vec<f32> = (0..50 * dim)
            .map(|i| {
                if i % dim == 3 {
                    7.0
                } else {
                    ((i * 37 % 101) as f32) * (1.0 + (i % dim) as f32) - 340.0
                }
            })
            .collect();
        let out = r.model_audio(data, dim);
        let (mean, std) = track_stats(&out, dim);
        for k in 0..dim {
            assert!(mean[k].abs() < 1e-5, "column {k}: mean {}", mean[k]);
            // The constant column maps to 0, whose SD track_stats reports as 1 too.
            assert!((std[k] - 1.0).abs() < 1e-4, "column {k}: sd {}", std[k]);
        }
        assert!(out.chunks_exact(dim).all(|row| row[3] == 0.0));
    }

    fn parse(text: &str) -> Result<RecipeConfig, String> {
        toml::from_str::<RecipeConfig>(text).map_err(|e| e.to_string())
    }

    #[test]
    fn base_fills_missing_keys_and_explicit_keys_win() {
        assert_eq!(parse("").unwrap(), RecipeConfig::of(RecipeBase::Mint));
        assert!(parse("").unwrap().is_mint_training());
        let d = parse("base = \"dance\"").unwrap();
        assert_eq!(d, RecipeConfig::of(RecipeBase::Dance));
        assert!(!d.is_mint_training());
        let d = parse("base = \"dance\"\ninput_noise = 0.5").unwrap();
        assert_eq!(d.input_noise, 0.5);
        assert_eq!(
            d.rollout_frames,
            RecipeConfig::of(RecipeBase::Dance).rollout_frames
        );
        let m = parse("velocity_loss = 2.0").unwrap();
        assert_eq!(
            (m.base, m.velocity_loss, m.input_noise),
            (RecipeBase::Mint, 2.0, 0.0)
        );
        assert!(parse("input_nosie = 1")
            .unwrap_err()
            .contains("input_nosie"));
    }

    #[test]
    fn resolved_recipe_reads_back_to_itself() {
        let d = parse("base = \"dance\"\nrollout_mode = \"step\"\nrollout_ramp = [5, 9]").unwrap();
        let text = toml::to_string(&d).unwrap();
        assert_eq!(parse(&text).unwrap(), d);
    }

    #[test]
    fn the_dance_base_is_the_measured_recipe() {
        // docs/freezing.md: standardised music, input noise 0.02, projected feedback, 8
        // ensembled passes and the seed's end eased over 30 frames; rollouts, difference losses
        // and offsets stay off.
        let d = RecipeConfig::of(RecipeBase::Dance);
        assert_eq!(d.audio_norm, AudioNorm::Standardize);
        assert_eq!(
            (d.input_noise, d.ensemble, d.feedback_project, d.seam_frames),
            (0.02, 8, true, 30)
        );
        assert_eq!(
            (d.rollout_frames, d.velocity_loss, d.predict),
            (0, 0.0, Predict::Pose)
        );
        assert!(d.validate(30, 20).is_ok());
        assert!(d.validate(30, 4).unwrap_err().contains("ensemble"));
    }

    #[test]
    fn rollout_share_ramps_linearly() {
        let r = RecipeConfig {
            rollout_frames: 4,
            rollout_prob: 0.5,
            rollout_ramp: [100, 300],
            ..RecipeConfig::default()
        };
        assert_eq!(r.rollout_share(0), 0.0);
        assert_eq!(r.rollout_share(100), 0.0);
        assert_eq!(r.rollout_share(200), 0.25);
        assert_eq!(r.rollout_share(300), 0.5);
        assert_eq!(r.rollout_share(10_000), 0.5);
        assert_eq!(r.lead_frames(), 4);
        let off = RecipeConfig {
            rollout_prob: 0.0,
            ..r
        };
        assert_eq!(off.lead_frames(), 0);
    }

    #[test]
    fn bad_values_name_their_key() {
        let bad = [
            ("input_noise = -1.0", "input_noise"),
            ("rollout_prob = 1.5", "rollout_prob"),
            ("rollout_ramp = [9, 3]", "rollout_ramp"),
            ("rollout_frames = 120", "motion_len"),
            ("rollout_frames = 30", "target_len"),
        ];
        for (text, key) in bad {
            let e = parse(text).unwrap().validate(120, 20).unwrap_err();
            assert!(e.contains(key), "{text}: {e}");
        }
        assert!(parse("rollout_frames = 30\nrollout_mode = \"step\"")
            .unwrap()
            .validate(120, 20)
            .is_ok());
    }
}
