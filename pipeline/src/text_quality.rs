//! The text evaluation of SPEC §13.10 with the user's data: every paired test + val sequence dances three
//! times from its seed and music, with one caption of a HumanML3D-layout text set (its `split`, captions
//! taken in turn) over a fixed interval: without the text, fused as the run fuses (`gpt.text_schedule`), and
//! as a pure T-Base + head rollout of the same prompt (w ≡ 0 over the interval). The report gives §7 FID and
//! whether each set still dances, and the interval's mean root-relative joint distance from the fused (and
//! the music-only) dance to the pure text rollout [DECISION]. No text–motion evaluator (R-precision, T2M FID)
//! runs offline, so this measures how far the text pulls the dance, not whether it says the caption.
//! `qean eval --run GPT --data D --text-set T` writes `R/eval/step-N[-TAG]/text.{md,json}`.

use std::path::PathBuf;

use qean_aistpp::dataset::Dataset;
use qean_aistpp::text_set::TextSet;
use qean_config::gpt::{GptConfig, TextSchedule};
use qean_eval::keyframe_fidelity::pose_error;
use qean_eval::positions::{Frame, Sequence};
use qean_eval::run_report::{frames_of, pairings, Protocol};
use qean_motion::motion::Motion;
use serde::Serialize;

use crate::evaluate::RunEvalRequest;
use crate::gpt::{Controls, GptRun, Picking, TextEmbedding, TextRequest};
use crate::keyframe_fidelity::{set_quality, SetQuality};
use crate::{Error, Result};

/// The text set and the interval of the evaluation.
#[derive(Debug, Clone)]
pub struct TextEvalOptions {
    pub text_set: PathBuf,
    /// Split file of the set whose captions are the prompts (`test` → `test.txt`).
    pub split: String,
    /// The interval, seconds of the output dance (seed included).
    pub from_s: f64,
    pub to_s: f64,
}

/// The report.
#[derive(Debug, Clone, Serialize)]
pub struct TextQualityReport {
    pub checkpoint: PathBuf,
    pub step: u64,
    pub text_set: PathBuf,
    pub split: String,
    /// Generated frames per dance.
    pub frames: usize,
    pub dances: usize,
    /// Captions of the split (each dance takes the next in turn).
    pub prompts: usize,
    pub interval_s: [f64; 2],
    /// The run's `gpt.text_schedule` and ramp (tokens).
    pub schedule: TextSchedule,
    pub ramp: usize,
    pub plain: SetQuality,
    pub fused: SetQuality,
    pub text_only: SetQuality,
    /// Mean root-relative joint distance (metres) over the interval's frames to the pure text rollout.
    pub fused_to_text_only: f64,
    pub plain_to_text_only: f64,
}

/// Runs the evaluation; writes the report beside the run's evaluations.
pub fn text_quality(
    req: &RunEvalRequest,
    opts: &TextEvalOptions,
) -> Result<(TextQualityReport, String)> {
    let ck = qean_checkpoint::checkpoint::resolve_in_run(&req.run, req.checkpoint.as_deref())?;
    let g = match ck.config.spec() {
        qean_config::ModelSpec::Gpt(g) => g.clone(),
        _ => {
            return Err(Error::Invalid(format!(
                "{}: --text-set evaluates a GPT run with a trained T-Base, not {:?}",
                ck.dir.display(),
                ck.config.model.arch
            )))
        }
    };
    let prompts = prompts(&g, opts)?;
    let ds = Dataset::open(&req.data)?;
    let names = crate::evaluate::protocol_sequences(&ds, req.splits())?;
    let pairs = pairings(&names, Protocol::Paired, |n| ds.music_id(n));
    let (requests, _) = crate::evaluate::sample_requests(&ds, &pairs, &ck.config, req.seed_start)?;
    let mut run = GptRun::load(&ck)?;
    run.decoding = req.sampling.decoding(run.decoding);
    let picking = Picking::of(&g, &req.sampling.picking(), req.sampling.sample_seed);
    let text_only = GptConfig {
        text_schedule: TextSchedule::Step,
        text_ramp: 0,
        ..g.clone()
    };
    let (layout, dim) = (ck.config.layout(), qean_aistpp::windows::AUDIO_DIM);
    let span = (opts.from_s * 60.0).round() as usize..(opts.to_s * 60.0).round() as usize;
    let seed_frames = ck.config.seed_frames();
    let pb = qean_checkpoint::progress::bar(requests.len() as u64, "text evaluation", "sequences");
    let mut sets: [Vec<Vec<Frame>>; 3] = Default::default();
    for (i, (r, (_, _, name))) in requests.iter().zip(&pairs).enumerate() {
        pb.inc(1);
        let audio = (r.audio.as_slice(), r.audio.len() / dim);
        if audio.1.min(seed_frames + req.max_frames) < span.end + g.rate {
            tracing::warn!("{name}: its music ends before the text interval; left out");
            continue;
        }
        let seed = Motion::from_layout(&r.seed, layout).map_err(Error::Invalid)?;
        let text = [TextRequest {
            embedding: TextEmbedding::Values(prompts[i % prompts.len()].clone()),
            from_s: opts.from_s,
            to_s: opts.to_s,
        }];
        for (set, (config, texts)) in
            sets.iter_mut()
                .zip([(&g, &[][..]), (&g, &text[..]), (&text_only, &text[..])])
        {
            let controls = Controls {
                texts,
                ..Default::default()
            };
            let dance = run
                .dance(
                    config,
                    &seed,
                    audio,
                    req.max_frames,
                    &picking,
                    controls,
                    &mut |_, _| {},
                )?
                .ok_or_else(|| {
                    Error::Invalid(format!("{name}: shorter than the seed and one token"))
                })?;
            set.push(frames_of(dance.joints(req.root)));
        }
    }
    pb.finish_and_clear();
    finish(req, &ck, opts, &g, prompts.len(), sets, span, &ds)
}

/// The embedding of every caption of the split.
fn prompts(g: &GptConfig, opts: &TextEvalOptions) -> Result<Vec<Vec<f32>>> {
    if !g.has_text() {
        return Err(Error::Invalid(
            "--text-set: this GPT took music steps only (no gpt.text_set, gpt.text_dir or gpt.synthetic_text): its T-Base is untrained".into(),
        ));
    }
    let set = TextSet::open(&opts.text_set, &opts.split)?;
    let read = g.text_set_options();
    // Only the embeddings are kept: a real set's joints would fill memory for nothing.
    let mut prompts = Vec::new();
    for id in &set.ids {
        prompts.extend(set.clips(id, &read)?.into_iter().map(|c| c.embedding));
    }
    if prompts.is_empty() {
        return Err(Error::Invalid(format!(
            "{}: no caption of the {} split covers a whole token",
            opts.text_set.display(),
            opts.split
        )));
    }
    Ok(prompts)
}

/// Mean root-relative joint distance between two dances over the frames of `span` both reach.
fn interval_distance(a: &[Frame], b: &[Frame], span: &std::ops::Range<usize>) -> f64 {
    let end = span.end.min(a.len()).min(b.len());
    let n = end.saturating_sub(span.start);
    (span.start..end)
        .map(|t| pose_error(&a[t], &b[t]))
        .sum::<f64>()
        / n.max(1) as f64
}

#[allow(clippy::too_many_arguments)]
fn finish(
    req: &RunEvalRequest,
    ck: &qean_checkpoint::Checkpoint,
    opts: &TextEvalOptions,
    g: &GptConfig,
    prompts: usize,
    [plain, fused, text_only]: [Vec<Vec<Frame>>; 3],
    span: std::ops::Range<usize>,
    ds: &Dataset,
) -> Result<(TextQualityReport, String)> {
    if plain.is_empty() {
        return Err(Error::Invalid(format!(
            "no test or val sequence's music reaches the end of the text interval ({} s)",
            opts.to_s
        )));
    }
    let mean = |a: &[Vec<Frame>], b: &[Vec<Frame>]| {
        a.iter()
            .zip(b)
            .map(|(x, y)| interval_distance(x, y, &span))
            .sum::<f64>()
            / a.len() as f64
    };
    let seed_frames = ck.config.seed_frames();
    let generated = |set: &[Vec<Frame>]| -> Vec<Sequence> {
        set.iter()
            .enumerate()
            .map(|(i, j)| {
                Sequence::new(format!("dance{i}"), j[seed_frames.min(j.len())..].to_vec())
            })
            .collect()
    };
    let reference = crate::evaluate::reference_set(ds, req.root, req.splits())?;
    let report = TextQualityReport {
        checkpoint: ck.dir.clone(),
        step: ck.state.step,
        text_set: opts.text_set.clone(),
        split: opts.split.clone(),
        frames: req.max_frames,
        dances: plain.len(),
        prompts,
        interval_s: [opts.from_s, opts.to_s],
        schedule: g.text_schedule,
        ramp: g.text_ramp,
        plain: set_quality(&generated(&plain), &reference, req)?,
        fused: set_quality(&generated(&fused), &reference, req)?,
        text_only: set_quality(&generated(&text_only), &reference, req)?,
        fused_to_text_only: mean(&fused, &text_only),
        plain_to_text_only: mean(&plain, &text_only),
    };
    let md = markdown(&report);
    let out_dir = crate::evaluate::write_eval_files(req, report.step, "text", &report, &md)?;
    Ok((
        report,
        md + &format!("\nreport: {}\n", out_dir.join("text.md").display()),
    ))
}

fn markdown(r: &TextQualityReport) -> String {
    let row = |label: &str, s: &SetQuality, distance: Option<f64>| {
        format!(
            "| {label} | {} | {} of {} | {:.2} | {:.2} | {:.1} | {:.1} |\n",
            distance.map_or("–".to_string(), |d| format!("{:.1}", 100.0 * d)),
            s.dancing,
            r.dances,
            s.min_span_speed_ratio,
            s.max_span_accel_ratio,
            s.fid_k,
            s.fid_g
        )
    };
    format!(
        "# Text control, step {}\n\nCheckpoint {}. {} dances of {} generated frames (every paired test + val \
         sequence), each with the next of the {} captions of {} ({} split) over {:.2}–{:.2} s of the dance \
         (SPEC §13.10). Fused: the run's schedule ({:?}, ramp {} tokens); text only: w ≡ 0 over the \
         interval (the T-Base + head alone). Distance: mean root-relative joint distance over the interval's \
         frames to the text-only dance. Dancing: every 5-s span at 0.6–1.6× the speed and ≤ 2× the \
         acceleration of the ground truth.\n\n\
         | dances | distance to text only (cm) | dancing | slowest span | sharpest span | FID_k | FID_g |\n\
         |---|---|---|---|---|---|---|\n{}{}{}",
        r.step,
        r.checkpoint.display(),
        r.dances,
        r.frames,
        r.prompts,
        r.text_set.display(),
        r.split,
        r.interval_s[0],
        r.interval_s[1],
        r.schedule,
        r.ramp,
        row("music only", &r.plain, Some(r.plain_to_text_only)),
        row("fused (the run's schedule)", &r.fused, Some(r.fused_to_text_only)),
        row("text only (w ≡ 0)", &r.text_only, None),
    )
}
