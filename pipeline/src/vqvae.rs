//! A motion VQ-VAE at work (SPEC §13.2.6, §13.10): tokenise whole sequences, decode them, and score the
//! reconstruction ceiling — root-relative MPJPE, codebook use (perplexity, codes used) and all of §7 on the
//! decoded ground truth of the test + val split (`qean eval --run VQRUN`).

use std::path::PathBuf;
use std::time::Instant;

use burn::tensor::{Device, Tensor, TensorData};
use qean_aistpp::dataset::Dataset;
use qean_checkpoint::checkpoint::Checkpoint;
use qean_checkpoint::vqvae::{denormalise, motion_pos72, normalise, pos72_options};
use qean_checkpoint::FamilyModel;
use qean_eval::config::{EvalConfig, MetricsMode};
use qean_eval::positions::Sequence;
use qean_eval::report::MetricsReport;
use qean_eval::run_report::frames_of;
use qean_models::vqvae::quantize::perplexity;
use qean_models::vqvae::VqVae;
use qean_motion::motion::Motion;
use qean_motion::pos72::{pos72_to_joints, POS72};
use qean_motion::FkRoot;
use serde::Serialize;

use crate::evaluate::RunEvalRequest;
use crate::{Error, Result};

/// A trained VQ-VAE on the CPU.
pub struct TrainedVq {
    pub model: VqVae,
    pub checkpoint: Checkpoint,
}

impl TrainedVq {
    /// The newest checkpoint of a run (or a checkpoint directory), which must be a VQ-VAE.
    pub fn load(run: &std::path::Path, checkpoint: Option<&str>) -> Result<TrainedVq> {
        let checkpoint = qean_checkpoint::checkpoint::resolve_in_run(run, checkpoint)?;
        let FamilyModel::Vqvae(model) = checkpoint.load_family(&Device::flex())? else {
            return Err(checkpoint.not_family("a VQ-VAE").into());
        };
        Ok(TrainedVq { model, checkpoint })
    }

    /// A motion's tokens (its frames cropped to a multiple of the rate) and its reconstruction as joints
    /// (the root integrated from the motion's own J_0(0)).
    pub fn round_trip(&self, motion: &Motion, root: FkRoot) -> Result<(Vec<usize>, Vec<[f64; 3]>)> {
        let c = self.checkpoint.config.vq_table();
        let rate = self.model.rate();
        let frames = motion.frames / rate * rate;
        if frames == 0 {
            return Err(Error::Invalid(format!(
                "a motion of {} frames is shorter than one token ({rate} frames)",
                motion.frames
            )));
        }
        let mut rows = motion_pos72(motion, c);
        rows.truncate(frames * POS72);
        normalise(&mut rows, c);
        let device = Device::flex();
        let x = Tensor::<3>::from_data(TensorData::new(rows, [1, frames, POS72]), &device);
        let tokens = self.model.tokens(x).map_err(Error::Invalid)?;
        let mut out: Vec<f32> =
            VqVae::host_rows(&self.model.decode_tokens(&tokens, 1, frames / rate));
        denormalise(&mut out, c);
        let start = motion.joints(root)[0];
        let decoded: Vec<f64> = out.iter().map(|&v| v as f64).collect();
        Ok((tokens, pos72_to_joints(&decoded, start, &pos72_options(c))))
    }
}

/// Root-relative mean joint error (m) over the 23 non-root joints of the frames both have.
pub fn root_relative_mpjpe(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for (fa, fb) in a.chunks_exact(24).zip(b.chunks_exact(24)) {
        for j in 1..24 {
            let d: f64 = (0..3)
                .map(|k| ((fa[j][k] - fa[0][k]) - (fb[j][k] - fb[0][k])).powi(2))
                .sum();
            s += d.sqrt();
            n += 1;
        }
    }
    s / n.max(1) as f64
}

/// The reconstruction report.
#[derive(Debug, Clone, Serialize)]
pub struct VqEvaluation {
    pub checkpoint: PathBuf,
    pub step: u64,
    pub sequences: usize,
    pub tokens: usize,
    /// Root-relative MPJPE (m), mean over sequences' frames, and the worst sequence's.
    pub mpjpe: f64,
    pub mpjpe_worst: f64,
    /// exp(entropy) of the code histogram of every token, and the codes used at least once.
    pub perplexity: f64,
    pub used_codes: usize,
    pub codes: usize,
    /// §7 on the decoded sequences against the whole dataset (the VQ ceiling of every token model).
    pub metrics: MetricsReport,
    pub seconds: f64,
}

/// `qean eval --run VQRUN`: every test + val sequence through the VQ-VAE, scored; writes
/// `R/eval/step-N/report.{md,json}` and returns the report and its markdown.
pub fn evaluate_vq(req: &RunEvalRequest) -> Result<(VqEvaluation, String)> {
    let started = Instant::now();
    let vq = TrainedVq::load(&req.run, req.checkpoint.as_deref())?;
    let ck = &vq.checkpoint;
    let ds = Dataset::open(&req.data)?;
    let names = crate::evaluate::protocol_sequences(&ds, Default::default())?;
    let codes = vq.model.codes().0;
    let mut counts = vec![0f32; codes];
    let (mut decoded, mut total, mut worst, mut frames) = (Vec::new(), 0.0, 0.0f64, 0usize);
    for name in &names {
        let motion = ds.read_motion(name)?;
        let (tokens, joints) = vq
            .round_trip(&motion, req.root)
            .map_err(|e| Error::Invalid(format!("{name}: {e}")))?;
        for &t in &tokens {
            counts[t] += 1.0;
        }
        let gt = motion.joints(req.root);
        let e = root_relative_mpjpe(&joints, &gt);
        let n = joints.len() / 24;
        total += e * n as f64;
        frames += n;
        worst = worst.max(e);
        decoded.push(Sequence {
            music: ds.music_id(name),
            ..Sequence::new(name.clone(), frames_of(joints))
        });
    }
    let tokens = counts.iter().sum::<f32>() as usize;
    let reference = crate::evaluate::reference_set(&ds, req.root, Default::default())?;
    let cfg = EvalConfig {
        metrics_mode: MetricsMode::Corrected,
        seed_frames: 0,
        max_frames: usize::MAX,
        ..EvalConfig::default()
    };
    let wav = ds.audio_dir();
    let beats = qean_eval::dirs::music_beats(
        &wav,
        names.iter().filter_map(|n| ds.music_id(n)),
        req.ba_music_beats,
    )?;
    let lookup = |id: &str| qean_eval::dirs::beats_of(&beats, &wav, id);
    let metrics = qean_eval::protocol::evaluate(&decoded, &reference, Some(&lookup), &cfg)?;
    let report = VqEvaluation {
        checkpoint: ck.dir.clone(),
        step: ck.state.step,
        sequences: names.len(),
        tokens,
        mpjpe: total / frames.max(1) as f64,
        mpjpe_worst: worst,
        perplexity: perplexity(&counts, tokens),
        used_codes: counts.iter().filter(|&&c| c > 0.0).count(),
        codes,
        metrics,
        seconds: started.elapsed().as_secs_f64(),
    };
    let md = markdown(&report);
    crate::evaluate::write_eval_files(req, ck.state.step, "report", &report, &md)?;
    Ok((report, md))
}

/// The report as markdown.
pub fn markdown(r: &VqEvaluation) -> String {
    let m = &r.metrics;
    format!(
        "# VQ-VAE reconstruction, step {}\n\nCheckpoint {}. {} test + val sequences tokenised whole ({} tokens) and \
         decoded, the root integrated from each sequence's first frame.\n\n\
         | root-relative MPJPE (cm) | worst sequence (cm) | perplexity | codes used |\n|---|---|---|---|\n\
         | {:.2} | {:.2} | {:.1} | {} / {} |\n\n\
         The ceiling of every token model on this VQ-VAE (§7 on the decoded ground truth, corrected mode):\n\n\
         | | FID_k ↓ | FID_g ↓ | Dist_k | Dist_g | BeatAlign |\n|---|---|---|---|---|---|\n\
         | ground truth | - | - | {:.4} | {:.4} | {} |\n\
         | decoded ground truth | {:.4} | {:.4} | {:.4} | {:.4} | {} |\n\n\
         Motion of the decoded ground truth against the data's (a token model's dances inherit it): {}.\n",
        r.step,
        r.checkpoint.display(),
        r.sequences,
        r.tokens,
        100.0 * r.mpjpe,
        100.0 * r.mpjpe_worst,
        r.perplexity,
        r.used_codes,
        r.codes,
        m.gt_div_k,
        m.gt_div_g,
        m.gt_beat_align.map_or("-".into(), |b| format!("{b:.4}")),
        m.fid_k,
        m.fid_g,
        m.div_k,
        m.div_g,
        m.beat_align.map_or("-".into(), |b| format!("{b:.4}")),
        m.motion_energy.as_ref().map_or("not measured".into(), |e| format!(
            "speed ratio {:.2}, acceleration ratio {:.2}, {:.0} % of 1-s windows frozen",
            e.speed_ratio,
            e.accel_ratio,
            100.0 * e.freeze_fraction
        )),
    )
}
