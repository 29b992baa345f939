//! The demo's keyframe-control section (SPEC §13.6, §13.10): the keyframe stage over the demo's GPT makes
//! the held-out dance pass through two poses of a test dance (`dances/keyframe/`), and the fidelity test
//! dances every test + val music with and without the ground truth's poses as keyframes.

use std::path::{Path, PathBuf};

use qean_checkpoint::checkpoint::Checkpoint;
use qean_eval::motion_energy::{motion_energy, EnergyReference};

use super::{dance, say, Budget, DanceResult, KEYFRAME};
use crate::evaluate::RunEvalRequest;
use crate::keyframe_control::KeyframeRequest;
use crate::keyframe_fidelity::{keyframe_fidelity, FidelityReport};

/// Output frames (seed included) of the held-out dance's keyframes.
pub const FRAMES: [usize; 2] = [360, 720];

/// What the section produced.
#[derive(Debug, Clone)]
pub struct KeyframeDemo {
    pub dance: DanceResult,
    /// The dance's keyframes: their source motion and frames.
    pub source: String,
    pub fidelity: FidelityReport,
    /// `runs/keyframe/eval/step-N/keyframe.md`.
    pub report_md: PathBuf,
}

/// The held-out dance's keyframes: the poses of the second test sequence (the first is the seed) at
/// [`FRAMES`] (those it reaches).
fn keyframes(data: &Path) -> crate::Result<(String, Vec<KeyframeRequest>)> {
    let ds = qean_aistpp::dataset::Dataset::open(data)?;
    let tests = ds.split(qean_aistpp::dataset::Split::Test);
    let name =
        tests.get(1).or(tests.first()).cloned().ok_or_else(|| {
            crate::Error::invalid(format!("{}: no test sequence", data.display()))
        })?;
    let path = ds.motion_path(&name);
    let frames = qean_motion::motion::read_motion(&path)?.frames;
    let at: Vec<usize> = FRAMES.iter().copied().filter(|&f| f < frames).collect();
    Ok((name, KeyframeRequest::from_motion(&path, &at)?))
}

/// Dances the held-out song through the keyframes and runs the fidelity test (whole dances of the budget's
/// length, so that keyframes at generated frames 240 and 600 fit).
pub fn run(
    out: &Path,
    data: &Path,
    ck: &Checkpoint,
    budget: &Budget,
    reference: &EnergyReference,
) -> crate::Result<KeyframeDemo> {
    let (source, keys) = keyframes(data)?;
    let frames: Vec<String> = keys.iter().map(|k| k.frame.to_string()).collect();
    let source = format!("{source} at frames {}", frames.join(", "));
    let (files, joints) = dance(out, data, KEYFRAME, ck, budget.dance_frames, (None, keys))?;
    let seed_frames = ck.config.seed_frames().min(joints.len());
    let (_, energy) = motion_energy([&joints[seed_frames..]], reference);
    say(format!("dance {KEYFRAME}: {}", energy.describe(reference)));
    let run_dir = out.join("runs").join(KEYFRAME);
    let req = RunEvalRequest {
        max_frames: budget.dance_frames,
        ..RunEvalRequest::new(&run_dir, data)
    };
    let (fidelity, _) = keyframe_fidelity(&req)?;
    let report_md = run_dir
        .join("eval")
        .join(qean_checkpoint::run_dir::checkpoint_name(fidelity.step))
        .join("keyframe.md");
    Ok(KeyframeDemo {
        dance: DanceResult {
            label: format!("tiny GPT + keyframe control ({source})"),
            dir: KEYFRAME.to_string(),
            files,
            energy,
            seed_frames,
        },
        source,
        fidelity,
        report_md,
    })
}

/// The section's lines: the held-out dance's verdict, the fidelity with and without keyframes, in words.
pub fn table(k: &KeyframeDemo) -> String {
    let f = &k.fidelity;
    let ratio = f.edited.kf_mpjpe / f.plain.kf_mpjpe.max(1e-12);
    let met = if ratio <= 0.5 { "met" } else { "NOT met" };
    let tokens = f
        .tokens_only
        .as_ref()
        .map(|t| {
            format!(
                "; the paper's tokens alone, without the warp: {:.1} cm",
                100.0 * t.kf_mpjpe
            )
        })
        .unwrap_or_default();
    let e = &k.dance.energy;
    let verdict = match e.dances() {
        true => "keeps dancing".to_string(),
        false => format!("does NOT dance: {}", e.verdict_word()),
    };
    format!(
        "\nKeyframe control (SPEC §13.6): the held-out dance through the poses of {} {verdict} (speed ratio per \
         5 s {}, accel ratio per 5 s {}). On every test + val music ({} dances, {} keyframes: the ground truth's \
         poses at generated frames 240 and 600), the joint error at the keyframe frames is {:.1} cm with the \
         keyframes (warped over ± {} frames{tokens}) and {:.1} cm without: {:.2} of it, at most half: {met}. {} \
         of the {} edited dances keep dancing ({} unedited); edited spans' acceleration {:.2}× the rest's. \
         Report: {}\n",
        k.source,
        e.span_speed_ratios(),
        e.span_accel_ratios(),
        f.dances,
        f.keyframes,
        100.0 * f.edited.kf_mpjpe,
        f.warp_frames,
        100.0 * f.plain.kf_mpjpe,
        ratio,
        f.edited.quality.dancing,
        f.dances,
        f.plain.quality.dancing,
        f.edited.seam_accel_ratio,
        k.report_md.display()
    )
}
