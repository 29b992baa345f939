//! What the GPT reads and writes besides its weights (SPEC §13.3): the frozen VQ-VAE whose tokens it
//! predicts, the music tokens of a feature matrix, and the seeded noise z of genre control.

use burn::tensor::{Device, Tensor, TensorData};
use qean_config::gpt::GptConfig;
use qean_io::error::{Error, Result};
use qean_models::vqvae::VqVae;
use qean_motion::motion::Motion;
use qean_motion::pos72::{joints_to_pos72_f32, POS72};

use crate::checkpoint::Checkpoint;
use crate::registry::FamilyModel;
use crate::vqvae::{motion_pos72, normalise, pos72_options};

/// Music feature columns.
pub const FEATURES: usize = 35;

/// The frozen VQ-VAE a GPT run predicts the tokens of.
pub struct FrozenVq {
    pub model: VqVae,
    pub checkpoint: Checkpoint,
}

impl FrozenVq {
    /// The newest checkpoint of `gpt.vqvae_run`, checked against the GPT's codes and rate; `owner`, the
    /// run whose config names it, if any ([`crate::checkpoint::resolve_linked`]).
    pub fn load(g: &GptConfig, owner: Option<&std::path::Path>) -> Result<FrozenVq> {
        let run = g.vqvae_run.as_ref().ok_or_else(|| {
            Error::msg(
                "gpt.vqvae_run is not set: name the trained VQ-VAE run (--set gpt.vqvae_run=DIR)",
            )
        })?;
        let checkpoint = crate::checkpoint::resolve_linked(run, owner)
            .map_err(|e| Error::msg(format!("gpt.vqvae_run: {e}")))?;
        let qean_config::ModelSpec::Vqvae(vq) = checkpoint.config.spec() else {
            return Err(Error::at(
                &checkpoint.dir,
                format!(
                    "gpt.vqvae_run is not a VQ-VAE run (model.arch = {:?})",
                    checkpoint.config.model.arch
                ),
            ));
        };
        if vq.codes != g.codes || vq.rate() != g.rate {
            return Err(Error::at(
                &checkpoint.dir,
                format!(
                    "the VQ-VAE has {} codes at {} frames per token; this GPT is built for {} codes at {} (gpt.codes, gpt.rate)",
                    vq.codes,
                    vq.rate(),
                    g.codes,
                    g.rate
                ),
            ));
        }
        let FamilyModel::Vqvae(model) = checkpoint.load_family(&Device::flex())? else {
            unreachable!("a VQ-VAE spec loads a VQ-VAE");
        };
        Ok(FrozenVq { model, checkpoint })
    }

    /// The tokens of a motion's first `frames` frames (a multiple of the rate).
    pub fn tokens(&self, motion: &Motion, frames: usize) -> Result<Vec<usize>> {
        let c = self.checkpoint.config.vq_table();
        self.tokens_of_rows(motion_pos72(motion, c), frames)
    }

    /// The tokens of the first `frames` frames (a multiple of the rate) of joint positions (frames × 24).
    pub fn tokens_of_joints(&self, joints: &[[f64; 3]], frames: usize) -> Result<Vec<usize>> {
        let c = self.checkpoint.config.vq_table();
        let rows = joints_to_pos72_f32(joints, &pos72_options(c));
        self.tokens_of_rows(rows, frames)
    }

    fn tokens_of_rows(&self, mut rows: Vec<f32>, frames: usize) -> Result<Vec<usize>> {
        let c = self.checkpoint.config.vq_table();
        rows.truncate(frames * POS72);
        normalise(&mut rows, c);
        let x = Tensor::<3>::from_data(TensorData::new(rows, [1, frames, POS72]), &Device::flex());
        self.model.tokens(x).map_err(Error::msg)
    }
}

impl FrozenVq {
    /// The static-clip token of each pose of 24 joints (SPEC §13.6 "Keyframe → token"): the pose held for
    /// 8 tokens' frames (v = 0), encoded, and token 4 of its codes quantised.
    pub fn static_tokens(&self, poses: &[&[[f64; 3]]]) -> Result<Vec<usize>> {
        use qean_models::control::keyframe::{static_clip, STATIC_CLIP_TOKEN};
        let c = self.checkpoint.config.vq_table();
        let opts = pos72_options(c);
        let frames = 2 * STATIC_CLIP_TOKEN * c.rate();
        let mut out = Vec::with_capacity(poses.len());
        for chunk in poses.chunks(64) {
            let mut rows: Vec<f32> = Vec::with_capacity(chunk.len() * frames * POS72);
            for pose in chunk {
                rows.extend(static_clip(pose, frames, &opts).iter().map(|&v| v as f32));
            }
            normalise(&mut rows, c);
            let x = Tensor::<3>::from_data(
                TensorData::new(rows, [chunk.len(), frames, POS72]),
                &Device::flex(),
            );
            let tokens = self.model.tokens(x).map_err(Error::msg)?;
            let per = tokens.len() / chunk.len();
            out.extend((0..chunk.len()).map(|b| tokens[b * per + STATIC_CLIP_TOKEN]));
        }
        Ok(out)
    }
}

impl FrozenVq {
    /// The `paste` token of a pose at token `p` of `tokens` (SPEC §13.6 `keyframe.tokenize = "paste"`): the
    /// 8 tokens around p decoded, the pose's root-relative joints written into token p's frames (the
    /// decoded root channels kept), the frames encoded again, and token p of the result.
    pub fn paste_token(&self, tokens: &[usize], p: usize, pose: &[[f64; 3]]) -> Result<usize> {
        use qean_models::control::keyframe::{static_clip, STATIC_CLIP_TOKEN};
        let c = self.checkpoint.config.vq_table();
        let d = c.rate();
        let span = 2 * STATIC_CLIP_TOKEN;
        let hi = (p.saturating_sub(STATIC_CLIP_TOKEN) + span).min(tokens.len());
        let lo = hi.saturating_sub(span);
        let mut rows = VqVae::host_rows(&self.model.decode_tokens(&tokens[lo..hi], 1, hi - lo));
        let mut held: Vec<f32> = static_clip(pose, d, &pos72_options(c))
            .iter()
            .map(|&v| v as f32)
            .collect();
        normalise(&mut held, c);
        for (u, frame) in held.chunks_exact(POS72).enumerate() {
            let at = ((p - lo) * d + u) * POS72;
            rows[at + 3..at + POS72].copy_from_slice(&frame[3..]);
        }
        let x = Tensor::<3>::from_data(
            TensorData::new(rows, [1, (hi - lo) * d, POS72]),
            &Device::flex(),
        );
        let codes = self.model.tokens(x).map_err(Error::msg)?;
        Ok(codes[p - lo])
    }
}

/// Music tokens a_i[35u + c] = A[rate·i + u, c] of the first `n` tokens of a feature matrix (frames × 35).
pub fn music_tokens(features: &[f32], n: usize, rate: usize) -> Vec<f32> {
    features[..n * rate * FEATURES].to_vec()
}

pub use qean_aistpp::text_set::{genre_embedding, normal_noise};
