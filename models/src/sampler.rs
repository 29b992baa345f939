//! The autoregressive sampler of SPEC §6 on a Burn model: the loop itself is
//! [`crate::autoregress::autoregress`] (plain Rust, tested with stub models); this file
//! supplies the model pass — one forward per generated frame for the whole batch, keeping the
//! first output token.

use crate::autoregress::{autoregress, SampleError, SampleOptions, SampleRequest};
use burn::tensor::{Device, Tensor, TensorData};
use qean_aistpp::windows::AUDIO_DIM;

use crate::model::DanceGenerator;

/// One model pass: motion [b, motion_len, D] and audio [b, audio_len, 35] (row-major) → the first
/// `opts.ensemble` output tokens of each window, [b, ensemble, D].
pub fn first_tokens<M: DanceGenerator>(
    model: &M,
    device: &Device,
    opts: &SampleOptions,
    motion: &[f32],
    audio: &[f32],
    batch: usize,
) -> Vec<f32> {
    let d = opts.layout.dim();
    let m = Tensor::<3>::from_data(
        TensorData::new(motion.to_vec(), [batch, opts.spec.motion_len, d]),
        device,
    );
    let a = Tensor::<3>::from_data(
        TensorData::new(audio.to_vec(), [batch, opts.spec.audio_len, AUDIO_DIM]),
        device,
    );
    let tokens = if opts.ensemble <= 1 {
        model.generate(m, a)
    } else {
        model.generate_tokens(m, a, opts.ensemble)
    };
    tokens
        .into_data()
        .convert::<f32>()
        .try_to_vec::<f32>()
        .expect("float output")
}

/// Generates every request in one batch (exact: the model has no masks, so each sequence's
/// frames do not depend on its batch mates). `model` must live on a plain (non-autodiff)
/// device, so dropout is off. Returns seed ++ generated frames per request; an error names a request
/// the loop cannot use (a seed shorter than the model's motion window).
pub fn sample<M: DanceGenerator>(
    model: &M,
    device: &Device,
    requests: &[SampleRequest],
    opts: &SampleOptions,
    progress: impl FnMut(usize, usize),
) -> Result<Vec<Vec<f32>>, SampleError<std::convert::Infallible>> {
    autoregress(
        requests,
        opts,
        |m, a, b| Ok(first_tokens(model, device, opts, m, a, b)),
        progress,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::DanceModel;
    use qean_aistpp::windows::WindowSpec;
    use qean_config::model::{Arch, AttentionKind, PositionKind};
    use qean_config::ModelConfig;
    use qean_motion::motion::Layout;

    fn tiny() -> ModelConfig {
        ModelConfig {
            heads: 2,
            cross_layers: 1,
            position: PositionKind::Rotary,
            attention: AttentionKind::Qra,
            dropout: 0.1,
            ..crate::testing::micro_config(Arch::Qean)
        }
    }

    fn request(k: usize, audio_frames: usize) -> SampleRequest {
        SampleRequest {
            seed: (0..6 * 225)
                .map(|i| ((i * 7 + k * 13) % 17) as f32 / 17.0)
                .collect(),
            audio: (0..audio_frames * AUDIO_DIM)
                .map(|i| ((i * 3 + k) % 11) as f32 / 11.0)
                .collect(),
        }
    }

    #[test]
    fn batched_sampling_equals_one_by_one() {
        let device = Device::flex();
        device.seed(5);
        let model = DanceModel::new(&tiny(), &device).unwrap();
        let opts = SampleOptions {
            frames: 12,
            layout: Layout::L225,
            spec: WindowSpec {
                motion_len: 6,
                target_len: 3,
                target_shift: 6,
                audio_len: 10,
            },
            ..SampleOptions::default()
        };
        // Different music lengths: 8 sequences, some stopping early.
        let requests: Vec<SampleRequest> = (0..8).map(|k| request(k, 14 + 2 * k)).collect();
        let batched = sample(&model, &device, &requests, &opts, |_, _| {}).unwrap();
        for (k, r) in requests.iter().enumerate() {
            let alone = sample(&model, &device, std::slice::from_ref(r), &opts, |_, _| {}).unwrap();
            assert_eq!(batched[k].len(), (6 + opts.generated_len(14 + 2 * k)) * 225);
            let diff = batched[k]
                .iter()
                .zip(&alone[0])
                .fold(0f32, |m, (a, b)| m.max((a - b).abs()));
            assert!(diff < 1e-5, "sequence {k}: batched differs by {diff}");
        }
    }
}
