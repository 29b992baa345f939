//! The keyframe fidelity test (SPEC §13.10): on every paired test + val sequence, the ground truth's poses
//! at generated frames 240, 600 and 960 (those inside the dance) become keyframes; the run dances once with
//! them and once without, and the report compares the root-relative joint error at the keyframe frames
//! (and its minimum within ± d/2), the edited spans' acceleration against the rest (the seam), whether the
//! dances still dance, and FID_k / FID_g of both sets. `qean eval --run KEYFRAME_RUN --data D` writes
//! `R/eval/step-N[-TAG]/keyframe.{md,json}`.

use std::path::PathBuf;

use qean_aistpp::dataset::Dataset;
use qean_eval::config::EvalConfig;
use qean_eval::keyframe_fidelity::{keyframe_errors, seam_accel_ratio};
use qean_eval::motion_energy::{motion_energy, EnergyReference};
use qean_eval::positions::Sequence;
use qean_eval::run_report::{frames_of, pairings, Protocol};
use qean_motion::fk::FkRoot;
use qean_motion::motion::Motion;
use serde::Serialize;

use crate::evaluate::RunEvalRequest;
use crate::gpt::{Controls, GptRun, Picking};
use crate::keyframe_control::KeyframeRequest;
use crate::{Error, Result};

/// Generated frames that carry a keyframe (SPEC §13.10 [DECISION]), those before the dance's end.
pub const KEYFRAME_OFFSETS: [usize; 3] = [240, 600, 960];

/// One set of dances (edited or plain) as the report gives it.
#[derive(Debug, Clone, Serialize, Default)]
pub struct SetFidelity {
    /// KF-MPJPE (metres): mean over keyframes and joints at the keyframe frame, and its minimum within
    /// ± d/2 frames.
    pub kf_mpjpe: f64,
    pub kf_mpjpe_min: f64,
    /// Mean |acceleration| over the re-predicted spans' frames relative to the rest of the generated
    /// frames, averaged over dances (1: as smooth as the rest).
    pub seam_accel_ratio: f64,
    #[serde(flatten)]
    pub quality: SetQuality,
}

/// Whether a set of dances dances, and its §7 distance to the ground truth.
#[derive(Debug, Clone, Serialize, Default)]
pub struct SetQuality {
    /// Dances with every 5-s span at 0.6–1.6× the speed and ≤ 2× the acceleration of the ground truth.
    pub dancing: usize,
    pub min_span_speed_ratio: f64,
    pub max_span_accel_ratio: f64,
    /// §7 against the ground truth (all splits), the generated frames only.
    pub fid_k: f64,
    pub fid_g: f64,
}

/// [`SetQuality`] of `dances` (generated frames only) against `reference`.
pub(crate) fn set_quality(
    dances: &[Sequence],
    reference: &[Sequence],
    req: &RunEvalRequest,
) -> Result<SetQuality> {
    let yardstick = EnergyReference::fit(reference.iter().map(|s| s.joints.as_slice()));
    let (each, _) = motion_energy(dances.iter().map(|s| s.joints.as_slice()), &yardstick);
    let spans = || each.iter().flat_map(|e| e.spans.iter());
    let base = req.configs.first().cloned().unwrap_or_default();
    let cfg = EvalConfig {
        seed_frames: 0,
        music_offset: 0,
        max_frames: req.max_frames,
        ..base
    };
    let (fid_k, fid_g) = if dances.len() >= 2 {
        qean_eval::protocol::fid_within(dances, reference, reference, &cfg)?
    } else {
        (f64::NAN, f64::NAN)
    };
    Ok(SetQuality {
        dancing: each.iter().filter(|e| e.dances()).count(),
        min_span_speed_ratio: spans().map(|s| s.speed_ratio).fold(f64::INFINITY, f64::min),
        max_span_accel_ratio: spans().map(|s| s.accel_ratio).fold(0.0, f64::max),
        fid_k,
        fid_g,
    })
}

/// The keyframe fidelity report.
#[derive(Debug, Clone, Serialize)]
pub struct FidelityReport {
    pub checkpoint: PathBuf,
    pub step: u64,
    /// Generated frames per dance.
    pub frames: usize,
    pub dances: usize,
    pub keyframes: usize,
    /// With the keyframes as the run decodes them, the same with the tokens alone (the paper's; only when
    /// the run warps to the keyframes, `keyframe.warp_frames` > 0), and the same dances without keyframes.
    pub edited: SetFidelity,
    pub tokens_only: Option<SetFidelity>,
    pub plain: SetFidelity,
    /// `keyframe.warp_frames` of the run.
    pub warp_frames: usize,
}

/// What one dance contributed: per keyframe (error, minimum error), its seam ratio and joints.
struct Scored {
    errors: Vec<(f64, f64)>,
    seam: Option<f64>,
    sequence: Sequence,
}

/// Runs the test; writes the report beside the run's evaluations.
pub fn keyframe_fidelity(req: &RunEvalRequest) -> Result<(FidelityReport, String)> {
    let ck = qean_checkpoint::checkpoint::resolve_in_run(&req.run, req.checkpoint.as_deref())?;
    let qean_config::ModelSpec::GptKeyframe(g, k) = ck.config.spec() else {
        return Err(Error::Invalid(format!(
            "{}: the keyframe fidelity test needs a keyframe-control run (model.arch = \"gpt_keyframe\"), not {:?}",
            ck.dir.display(),
            ck.config.model.arch
        )));
    };
    let ds = Dataset::open(&req.data)?;
    let names = crate::evaluate::protocol_sequences(&ds, req.splits())?;
    let pairs = pairings(&names, Protocol::Paired, |n| ds.music_id(n));
    let (requests, starts) =
        crate::evaluate::sample_requests(&ds, &pairs, &ck.config, req.seed_start)?;
    let mut run = GptRun::load(&ck)?;
    run.decoding = req.sampling.decoding(run.decoding);
    let picking = Picking::of(g, &req.sampling.picking(), req.sampling.sample_seed);
    let (layout, seed_frames) = (ck.config.layout(), ck.config.seed_frames());
    let dim = qean_aistpp::windows::AUDIO_DIM;
    let pb =
        qean_checkpoint::progress::bar(requests.len() as u64, "keyframe fidelity", "sequences");
    let warp = run.decoding.warp_frames;
    let (mut edited, mut tokens_only, mut plain) = (Vec::new(), Vec::new(), Vec::new());
    for ((r, (motion, _, name)), &start) in requests.iter().zip(&pairs).zip(&starts) {
        let truth = ds.read_motion(motion)?;
        let keys = ground_truth_keys(
            &truth,
            motion,
            start + seed_frames,
            seed_frames,
            req.max_frames,
        );
        pb.inc(1);
        if keys.is_empty() {
            continue;
        }
        let seed = Motion::from_layout(&r.seed, layout).map_err(Error::Invalid)?;
        let audio = (r.audio.as_slice(), r.audio.len() / dim);
        let spans: Vec<std::ops::Range<usize>> = keys
            .iter()
            .map(|key| {
                let p = key.frame / g.rate;
                let from = (p.saturating_sub(k.radius) * g.rate).max(seed_frames);
                (from - seed_frames)..((p + k.radius + 1) * g.rate - seed_frames)
            })
            .collect();
        // As the run decodes, without keyframes, and (when it warps) with the tokens alone.
        let mut variants = vec![
            (&mut edited, keys.as_slice(), warp),
            (&mut plain, &[][..], warp),
        ];
        if warp > 0 {
            variants.push((&mut tokens_only, keys.as_slice(), 0));
        }
        // One music-driven sampling; the variants differ in the edit and the decoding only.
        let sampled = run
            .sample(
                g,
                &seed,
                audio,
                req.max_frames,
                &picking,
                Controls::default(),
                &mut |_, _| {},
            )?
            .ok_or_else(|| {
                Error::Invalid(format!("{name}: shorter than the seed and one token"))
            })?;
        for (out, keyframes, warp_frames) in variants {
            run.decoding.warp_frames = warp_frames;
            let dance = run.finish(g, &seed, &sampled, keyframes, req.max_frames)?;
            let joints = frames_of(dance.joints(req.root));
            out.push(score(
                name,
                &joints,
                &keys,
                (seed_frames, g.rate / 2),
                &spans,
            ));
        }
    }
    pb.finish_and_clear();
    finish(req, &ck, [edited, tokens_only, plain], warp, &ds)
}

/// The report of the three sets (edited as the run decodes, tokens alone, unedited), written beside the
/// run's evaluations.
fn finish(
    req: &RunEvalRequest,
    ck: &qean_checkpoint::Checkpoint,
    [edited, tokens_only, plain]: [Vec<Scored>; 3],
    warp: usize,
    ds: &Dataset,
) -> Result<(FidelityReport, String)> {
    if edited.is_empty() {
        return Err(Error::Invalid(format!(
            "no test or val sequence is long enough for a keyframe at generated frame {} (--max-frames {})",
            KEYFRAME_OFFSETS[0], req.max_frames
        )));
    }
    let reference = crate::evaluate::reference_set(ds, req.root, req.splits())?;
    let report = FidelityReport {
        checkpoint: ck.dir.clone(),
        step: ck.state.step,
        frames: req.max_frames,
        dances: edited.len(),
        keyframes: edited.iter().map(|s| s.errors.len()).sum(),
        edited: summarise(&edited, &reference, req)?,
        tokens_only: match warp {
            0 => None,
            _ => Some(summarise(&tokens_only, &reference, req)?),
        },
        plain: summarise(&plain, &reference, req)?,
        warp_frames: warp,
    };
    let md = markdown(&report);
    let out_dir = crate::evaluate::write_eval_files(req, report.step, "keyframe", &report, &md)?;
    Ok((
        report,
        md + &format!("\nreport: {}\n", out_dir.join("keyframe.md").display()),
    ))
}

/// The ground truth's poses at the keyframe offsets after `from` (its frame where the dance's generated
/// part starts), as keyframes at the same generated frames of a dance with `seed_frames` seed frames.
fn ground_truth_keys(
    truth: &Motion,
    motion: &str,
    from: usize,
    seed_frames: usize,
    max_frames: usize,
) -> Vec<KeyframeRequest> {
    KEYFRAME_OFFSETS
        .iter()
        .filter(|&&off| off < max_frames && from + off < truth.frames)
        .map(|&off| KeyframeRequest {
            frame: seed_frames + off,
            pose: truth.slice(from + off, from + off + 1).joints(FkRoot::Smpl),
            spec: format!("{motion} frame {}", from + off),
        })
        .collect()
}

/// One dance's errors at its keyframes, its seam ratio over `spans` (frames of the generated part) and its
/// generated joints.
fn score(
    name: &str,
    joints: &[qean_eval::positions::Frame],
    keys: &[KeyframeRequest],
    (seed_frames, half): (usize, usize),
    spans: &[std::ops::Range<usize>],
) -> Scored {
    let errors = keys
        .iter()
        .filter(|key| key.frame < joints.len())
        .map(|key| {
            let pose = frames_of(key.pose.clone())[0];
            keyframe_errors(joints, key.frame, &pose, half)
        })
        .collect();
    let generated = &joints[seed_frames.min(joints.len())..];
    Scored {
        errors,
        seam: seam_accel_ratio(generated, spans),
        sequence: Sequence::new(name.to_string(), generated.to_vec()),
    }
}

fn summarise(set: &[Scored], reference: &[Sequence], req: &RunEvalRequest) -> Result<SetFidelity> {
    let errors: Vec<(f64, f64)> = set.iter().flat_map(|s| s.errors.iter().copied()).collect();
    let mean = |v: &mut dyn Iterator<Item = f64>| {
        let (sum, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x, n + 1));
        sum / n.max(1) as f64
    };
    let dances: Vec<Sequence> = set.iter().map(|s| s.sequence.clone()).collect();
    Ok(SetFidelity {
        kf_mpjpe: mean(&mut errors.iter().map(|e| e.0)),
        kf_mpjpe_min: mean(&mut errors.iter().map(|e| e.1)),
        seam_accel_ratio: mean(&mut set.iter().filter_map(|s| s.seam)),
        quality: set_quality(&dances, reference, req)?,
    })
}

fn markdown(r: &FidelityReport) -> String {
    let row = |label: &str, s: &SetFidelity| {
        format!(
            "| {label} | {:.1} | {:.1} | {:.2} | {} of {} | {:.2} | {:.2} | {:.1} | {:.1} |\n",
            100.0 * s.kf_mpjpe,
            100.0 * s.kf_mpjpe_min,
            s.seam_accel_ratio,
            s.quality.dancing,
            r.dances,
            s.quality.min_span_speed_ratio,
            s.quality.max_span_accel_ratio,
            s.quality.fid_k,
            s.quality.fid_g
        )
    };
    let ratio = r.edited.kf_mpjpe / r.plain.kf_mpjpe.max(1e-12);
    format!(
        "# Keyframe fidelity, step {}\n\nCheckpoint {}. {} dances of {} generated frames (every paired test + val \
         sequence), {} keyframes in all: the ground truth's poses at generated frames 240, 600 and 960 where the \
         dance reaches them (SPEC §13.10). KF-MPJPE: root-relative joint error at the keyframe frame, and its \
         minimum within ± d/2 frames. Seam: mean |acceleration| over the re-predicted spans' frames relative to \
         the rest. Dancing: every 5-s span at 0.6–1.6× the speed and ≤ 2× the acceleration of the ground truth.\n\n\
         | dances | KF-MPJPE (cm) | min ± d/2 (cm) | seam accel ratio | dancing | slowest span | sharpest span | FID_k | FID_g |\n\
         |---|---|---|---|---|---|---|---|---|\n{}{}\nWith the keyframes the error at the keyframe frames is {:.2} of the error without them.\n",
        r.step,
        r.checkpoint.display(),
        r.dances,
        r.frames,
        r.keyframes,
        row(&match r.warp_frames {
            0 => "with keyframes (tokens)".to_string(),
            w => format!("with keyframes (tokens, warped over ± {w} frames)"),
        }, &r.edited) + &r.tokens_only.as_ref().map(|t| row("with keyframes (tokens alone, the paper's)", t)).unwrap_or_default(),
        row("without (same dances, no edit)", &r.plain),
        ratio
    )
}
