//! Checkpoint mode of the metrics (`qean eval --run R --data DIR`, SPEC §1.6): sample the test + val
//! sequences with a trained checkpoint (seed = the first ground-truth frames, `max_frames` generated,
//! batched), then every metric against the ground-truth reference set (all non-ignored sequences, full
//! length), written to `R/eval/step-N/report.{json,md}` with the generated joints beside them.

use std::path::{Path, PathBuf};

use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::feature_cache;
use qean_eval::config::{value_name, EvalConfig, MetricsMode, MusicBeatSource};
use qean_eval::dirs::{music_beats, EvaluationFile};
use qean_eval::io::write_json_atomic;
use qean_eval::positions::Sequence;
use qean_eval::preset::{ProtocolPreset, Splits};
use qean_eval::protocol::evaluate;
use qean_eval::report::{render_markdown, MetricsReport};
use qean_eval::run_report::{
    average_beat_align, frames_of, frozen_dances, pairings, repaired_dances, Baselines, Pairing,
    Protocol, RunReport, SeedStart,
};
use qean_models::autoregress::{AudioPad, SampleOptions, SampleRequest};
use qean_motion::motion::Motion;

use crate::{Error, Result};
use qean_config::ModelSpec;

/// Sampling settings of checkpoint mode; `None` takes the run's recipe.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SamplingOverrides {
    /// Project fed-back rotations to SO(3) (`Some(false)`: raw, as mint).
    pub feedback_project: Option<bool>,
    /// Temporal ensembling: passes averaged per frame.
    pub ensemble: Option<usize>,
    /// The ensembling weights' decay per pass.
    pub ensemble_decay: Option<f64>,
    /// Frames over which the jump at the seed's end fades out.
    pub seam_frames: Option<usize>,
    /// Backend for sampling (default: the run's).
    pub backend: Option<qean_models::backend::Backend>,
    /// Keep generating past the end of the music by repeating its last frame.
    pub audio_pad: AudioPad,
    /// TSMT: temperature, top-k (None: the run's), the seed of the draws of the main rollout, and
    /// how many rollouts per input S-music-D takes (None: 5, with seeds sample_seed..+5).
    pub temperature: Option<f64>,
    pub top_k: Option<usize>,
    /// TSMT: how sampled bins become coordinates (None: the run's `tsmt.decode`).
    pub decode: Option<qean_config::tsmt::TsmtDecode>,
    /// GPT: the repetition penalty (None: the run's `gpt.repetition_penalty`).
    pub repetition_penalty: Option<f64>,
    /// Genre runs: the guidance s (None: the run's `genre.guidance`).
    pub genre_guidance: Option<f64>,
    /// GPT: the floor's window (None: the run's `gpt.floor_window`; 0 = off).
    pub floor_window: Option<usize>,
    /// GPT: the feet's glide window (None: the run's `gpt.slide_window`; 0 = off).
    pub slide_window: Option<usize>,
    /// GPT and TSMT: σ of the decoded joints' temporal filter (None: the run's `gpt.smooth_sigma` or
    /// `tsmt.smooth_sigma`; 0 = off).
    pub smooth_sigma: Option<f64>,
    pub sample_seed: u64,
    pub music_rollouts: Option<usize>,
}

impl SamplingOverrides {
    /// A GPT run's decoding (its `recipe.seam_frames`, `gpt.floor_window`, `gpt.slide_window`) with these
    /// overrides applied.
    pub fn decoding(&self, run: crate::gpt::Decoding) -> crate::gpt::Decoding {
        crate::gpt::Decoding {
            seam_frames: self.seam_frames.unwrap_or(run.seam_frames),
            floor_window: self.floor_window.unwrap_or(run.floor_window),
            slide_window: self.slide_window.unwrap_or(run.slide_window),
            smooth_sigma: self.smooth_sigma.unwrap_or(run.smooth_sigma),
            warp_frames: run.warp_frames,
        }
    }

    /// The GPT's share of the overrides.
    pub fn picking(&self) -> crate::gpt::PickingOverrides {
        crate::gpt::PickingOverrides {
            top_k: self.top_k,
            temperature: self.temperature,
            repetition_penalty: self.repetition_penalty,
            genre_guidance: self.genre_guidance,
        }
    }
}

/// What checkpoint mode evaluates.
#[derive(Debug, Clone)]
pub struct RunEvalRequest {
    /// The training run directory.
    pub run: PathBuf,
    /// Which checkpoint of the run (step-N, N or a path; `None`: the newest).
    pub checkpoint: Option<String>,
    /// The AIST++-layout dataset (motions/, wav/, splits).
    pub data: PathBuf,
    pub protocol: Protocol,
    /// Where each seed starts in its ground-truth motion (frame 0 by default, as mint).
    pub seed_start: SeedStart,
    /// Generated frames per sequence.
    pub max_frames: usize,
    pub sampling: SamplingOverrides,
    /// The metrics' configurations (one report each; `seed_frames`, `max_frames` and `music_offset` are
    /// set here).
    pub configs: Vec<EvalConfig>,
    pub ba_music_beats: MusicBeatSource,
    /// Root convention of forward kinematics for the generated joints.
    pub root: qean_motion::FkRoot,
    /// Write under `R/eval/step-N-TAG/` instead of `R/eval/step-N/`.
    pub tag: Option<String>,
    /// Also score the chance baselines (frozen seed pose, random music pairing).
    pub baselines: bool,
    /// Also write the reports here as JSON.
    pub json: Option<PathBuf>,
}

impl RunEvalRequest {
    /// The splits the configurations' protocol scores (the first configuration's; presets agree).
    pub fn splits(&self) -> Splits {
        self.configs.first().map(|c| c.splits).unwrap_or_default()
    }

    /// The request with the defaults of `qean eval --run`: paired protocol, 1200 frames, the run's
    /// sampling recipe, both metrics modes, Bailando's music beats, SMPL root, no baselines.
    pub fn new(run: impl Into<PathBuf>, data: impl Into<PathBuf>) -> Self {
        RunEvalRequest {
            run: run.into(),
            checkpoint: None,
            data: data.into(),
            protocol: Protocol::Paired,
            seed_start: SeedStart::Zero,
            max_frames: 1200,
            sampling: SamplingOverrides::default(),
            configs: [MetricsMode::Reference, MetricsMode::Corrected]
                .into_iter()
                .map(|metrics_mode| EvalConfig {
                    metrics_mode,
                    ..EvalConfig::default()
                })
                .collect(),
            ba_music_beats: MusicBeatSource::Bailando,
            root: qean_motion::FkRoot::Smpl,
            tag: None,
            baselines: false,
            json: None,
        }
    }
}

/// What checkpoint mode returns: the reports, the markdown table (with the report's path) and the
/// whole `report.json` (baselines included), written to `dir`.
#[derive(Debug, Clone)]
pub struct RunEvaluation {
    pub file: EvaluationFile,
    pub table: String,
    pub report: RunReport,
    /// `R/eval/step-N[-TAG]/`.
    pub dir: PathBuf,
}

/// Checkpoint mode for any family: the VQ-VAE's reconstruction report, the genre classifier's accuracy,
/// genre control's control test (with the judge `classifier`), keyframe control's fidelity test, the
/// text evaluation (`tests.text`), or the dance metrics of the rest; returns
/// the markdown to print.
pub fn evaluate_family(req: &RunEvalRequest, tests: &FamilyTests) -> Result<String> {
    let ck = qean_checkpoint::checkpoint::resolve_in_run(&req.run, req.checkpoint.as_deref())?;
    if let Some(text) = &tests.text {
        return Ok(crate::text_quality::text_quality(req, text)?.1);
    }
    match (ck.config.spec(), tests.classifier.as_deref()) {
        (ModelSpec::Vqvae(_), _) => Ok(crate::vqvae::evaluate_vq(req)?.1),
        (ModelSpec::GenreClf(_), _) => Ok(crate::genre_clf::evaluate_clf(req)?.1),
        (ModelSpec::GptKeyframe(..), None) => {
            Ok(crate::keyframe_fidelity::keyframe_fidelity(req)?.1)
        }
        (_, Some(clf)) => Ok(crate::genre_control::control_test(req, clf)?.1),
        _ => Ok(evaluate_run(req)?.table),
    }
}

/// The family-specific tests `qean eval --run` may be asked for instead of the dance metrics.
#[derive(Debug, Clone, Default)]
pub struct FamilyTests {
    /// Genre-control runs: the control test with this genre classifier run.
    pub classifier: Option<PathBuf>,
    /// GPT runs with a trained T-Base: the text evaluation on this text set.
    pub text: Option<crate::text_quality::TextEvalOptions>,
}

/// Runs checkpoint mode.
pub fn evaluate_run(req: &RunEvalRequest) -> Result<RunEvaluation> {
    let ck = qean_checkpoint::checkpoint::resolve_in_run(&req.run, req.checkpoint.as_deref())?;
    let out_dir = req
        .run
        .join("eval")
        .join(eval_dir_name(ck.state.step, req.tag.as_deref())?);
    let ds = Dataset::open(&req.data)?;
    let splits = req.splits();
    let names = protocol_sequences(&ds, splits)?;
    let config = &ck.config;
    let seed_frames = config.seed_frames();
    let pairs = pairings(&names, req.protocol, |n| ds.music_id(n));
    let (requests, starts) = sample_requests(&ds, &pairs, config, req.seed_start)?;
    let opts = sample_options(req, config)?;
    // A genre-control run dances each track in the track's own genre (SPEC §13.10).
    let genres: Vec<Option<usize>> = pairs
        .iter()
        .map(|(_, music, _)| crate::genre_control::music_genre(&ds, music))
        .collect();
    let dances = sample_dances(
        req,
        &ck,
        (&requests, &genres),
        &opts,
        req.sampling.sample_seed,
    )?;
    let (generated, pairings_out) = write_generated(
        &out_dir,
        &pairs,
        &dances,
        &starts,
        (&opts, seed_frames),
        req.root,
    )?;
    let reference = reference_set(&ds, req.root, splits)?;

    let keys = generated
        .iter()
        .map(|s| s.name.as_str())
        .chain(names.iter().map(String::as_str))
        .filter_map(|n| ds.music_id(n));
    let wav = ds.audio_dir();
    let beats = music_beats(&wav, keys, req.ba_music_beats)?;
    let lookup = |id: &str| qean_eval::dirs::beats_of(&beats, &wav, id);
    let configs = eval_configs(req, seed_frames, &ds);
    let mut reports = configs
        .iter()
        .map(|cfg| evaluate(&generated, &reference, Some(&lookup), cfg))
        .collect::<qean_eval::Result<Vec<_>>>()?;
    if let ModelSpec::Tsmt(_) = config.spec() {
        let more = more_rollouts(req, &ck, &requests, &opts, &generated)?;
        let sets: Vec<&[Sequence]> = std::iter::once(generated.as_slice())
            .chain(more.iter().map(Vec::as_slice))
            .collect();
        for (r, cfg) in reports.iter_mut().zip(&configs) {
            r.li.s_music_d = qean_eval::li_metrics::s_music_d_of(&sets, &reference, cfg)?;
        }
    }
    let baselines = match configs.first() {
        Some(cfg) if req.baselines => Some(chance_baselines(&generated, &reference, &lookup, cfg)?),
        _ => None,
    };
    let report = RunReport {
        checkpoint: ck.dir.clone(),
        step: ck.state.step,
        protocol: req.protocol,
        frames: req.max_frames,
        feedback_project: opts.feedback_project,
        ensemble: opts.ensemble,
        seam_frames: opts.seam_frames,
        seed_start: req.seed_start,
        sampler: sampler_label(req, config),
        pairings: pairings_out,
        reports,
        baselines,
    };
    let table = write_report(
        &out_dir,
        &report,
        &label(config, ck.state.step),
        seed_frames,
    )?;
    let file = EvaluationFile {
        reports: report.reports.clone(),
    };
    if let Some(path) = &req.json {
        write_json_atomic(path, &file)?;
    }
    Ok(RunEvaluation {
        file,
        table: format!("{table}\nreport: {}\n", out_dir.join("report.md").display()),
        report,
        dir: out_dir,
    })
}

/// The AIST++ metrics of a run's newest checkpoint (checkpoint mode of qean-eval with the chance
/// baselines, on the run's dataset): the `reference`-mode numbers, comparable with published
/// tables, and the motion energy (speed and acceleration ratios, frozen share).
pub fn checkpoint_metrics(
    run_dir: &Path,
    frames: usize,
    protocol: Option<ProtocolPreset>,
) -> Result<Vec<(String, f64)>> {
    let config = qean_config::RunConfig::load(&run_dir.join("config.toml"), &[])?;
    let data = config
        .data
        .dir
        .ok_or_else(|| Error::Invalid(format!("{}: no data.dir", run_dir.display())))?;
    let mut req = RunEvalRequest {
        max_frames: frames,
        baselines: true,
        ..RunEvalRequest::new(run_dir, data)
    };
    req.configs.truncate(1); // the `reference` mode only
    if let Some(p) = protocol {
        req.configs = req.configs.drain(..).map(|c| p.apply(c)).collect();
    }
    let report = evaluate_run(&req)?.report;
    let r = report
        .reports
        .first()
        .ok_or_else(|| Error::Invalid("evaluation produced no report".into()))?;
    let mut out = vec![
        ("fid_k".to_string(), r.fid_k),
        ("fid_g".to_string(), r.fid_g),
        ("dist_k".to_string(), r.div_k),
        ("dist_g".to_string(), r.div_g),
    ];
    if let Some(ba) = r.beat_align {
        out.push(("beat_align".to_string(), ba));
    }
    if let Some(e) = &r.motion_energy {
        out.push(("speed_ratio".to_string(), e.speed_ratio));
        out.push(("accel_ratio".to_string(), e.accel_ratio));
        out.push(("freeze_fraction".to_string(), e.freeze_fraction));
        let min_span = e
            .spans
            .iter()
            .map(|s| s.speed_ratio)
            .fold(f64::MAX, f64::min);
        out.push(("min_span_speed_ratio".to_string(), min_span));
    }
    if let Some(p) = r.pfc {
        out.push(("pfc".to_string(), p));
    }
    // The reference set scored the same way (the same frames after the seed), and the chance levels.
    out.push(("gt_dist_k".to_string(), r.gt_div_k));
    out.push(("gt_dist_g".to_string(), r.gt_div_g));
    if let Some(ba) = r.gt_beat_align {
        out.push(("gt_beat_align".to_string(), ba));
    }
    if let Some(p) = r.gt_pfc {
        out.push(("gt_pfc".to_string(), p));
    }
    if let Some(b) = &report.baselines {
        out.push(("frozen_fid_k".to_string(), b.frozen.fid_k));
        if let Some(ba) = b.random_pairing.as_ref().and_then(|r| r.beat_align) {
            out.push(("random_beat_align".to_string(), ba));
        }
    }
    Ok(out)
}

/// How a sweep scores its runs: [`checkpoint_metrics`] of `frames` generated frames per sequence (the
/// preset's own length when none is given, else 1,200) under `protocol`. (`qean sweep` passes the sweep
/// file's `eval_frames` only without a preset; its `--eval-frames` always.)
pub struct SweepScoring {
    pub frames: usize,
    pub protocol: Option<ProtocolPreset>,
}

impl SweepScoring {
    pub fn new(frames: Option<usize>, protocol: Option<ProtocolPreset>) -> Self {
        SweepScoring {
            frames: frames
                .or(protocol.map(|p| p.sample_frames()))
                .unwrap_or(1200),
            protocol,
        }
    }

    /// The key a run's recorded metrics carry: recorded under another key, they are computed again.
    pub fn key(&self) -> String {
        let protocol = self.protocol.map_or(String::new(), |p| {
            format!(", protocol preset {}", qean_eval::config::value_name(p))
        });
        format!(
            "checkpoint mode, reference metrics, {} frames{protocol}",
            self.frames
        )
    }

    /// The metrics of a run's newest checkpoint.
    pub fn metrics(&self, run_dir: &Path) -> qean_io::error::Result<Vec<(String, f64)>> {
        checkpoint_metrics(run_dir, self.frames, self.protocol)
            .map_err(|e| qean_io::error::Error::msg(format!("{e:#}")))
    }
}

/// The request's metric configurations, scoring the frames after the seed, up to `req.max_frames`.
fn eval_configs(req: &RunEvalRequest, seed_frames: usize, ds: &Dataset) -> Vec<EvalConfig> {
    req.configs
        .iter()
        .map(|c| EvalConfig {
            seed_frames,
            music_offset: 0,
            reference_name: ds.layout.title().to_string(),
            // A protocol preset fixes its own clip length; the request's is how long the dances are.
            max_frames: match c.preset {
                Some(_) => c.max_frames,
                None => req.max_frames,
            },
            ..c.clone()
        })
        .collect()
}

/// Writes a report as `STEM.json` (pretty, newline-terminated) and `STEM.md` under `R/eval/step-N[-TAG]/`
/// (the VQ-VAE, classifier and control-test reports); returns that directory.
pub(crate) fn write_eval_files<T: serde::Serialize>(
    req: &RunEvalRequest,
    step: u64,
    stem: &str,
    report: &T,
    md: &str,
) -> Result<PathBuf> {
    let out_dir = req
        .run
        .join("eval")
        .join(qean_eval::curves::eval_dir_name(step, req.tag.as_deref()));
    std::fs::create_dir_all(&out_dir).map_err(|e| qean_io::Error::io(&out_dir, e))?;
    let json = serde_json::to_string_pretty(report).expect("plain data") + "\n";
    qean_io::fsutil::atomic_write(&out_dir.join(format!("{stem}.json")), json.as_bytes())?;
    qean_io::fsutil::atomic_write(&out_dir.join(format!("{stem}.md")), md.as_bytes())?;
    Ok(out_dir)
}

/// `step-N`, or `step-N-TAG` for a tag of letters, digits, '-', '_' or '.'.
fn eval_dir_name(step: u64, tag: Option<&str>) -> Result<String> {
    if let Some(tag) = tag {
        let ok = !tag.is_empty()
            && tag
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c));
        if !ok {
            return Err(Error::Invalid(format!(
                "--tag {tag:?}: use letters, digits, '-', '_' or '.'"
            )));
        }
    }
    Ok(qean_eval::curves::eval_dir_name(step, tag))
}

/// The test and val sequences (the test ones only under EDGE's splits) whose motion files exist (at
/// least 2), with their music features cached.
pub(crate) fn protocol_sequences(ds: &Dataset, splits: Splits) -> Result<Vec<String>> {
    let mut names = ds.split(Split::Test);
    if splits == Splits::TestValAgainstAll {
        // FineDance@Genre validates on its test list: each dance once.
        let val: Vec<String> = ds
            .split(Split::Val)
            .into_iter()
            .filter(|n| !names.contains(n))
            .collect();
        names.extend(val);
    }
    names.retain(|n| {
        ds.motion_path(n).is_file() || {
            tracing::warn!(
                "{}: missing, left out of the evaluation",
                ds.motion_path(n).display()
            );
            false
        }
    });
    if names.len() < 2 {
        return Err(Error::Io(qean_io::Error::at(
            &ds.root,
            format!(
                "the test and val splits hold {} motion(s); the metrics need at least 2",
                names.len()
            ),
        )));
    }
    qean_checkpoint::features::ensure_features(ds, &names)?;
    Ok(names)
}

/// One sampler request per pairing: the seed is the motion's frames from its start (see [`SeedStart`]),
/// the music's features from the same frame on. Returns the requests and the starts.
pub(crate) fn sample_requests(
    ds: &Dataset,
    pairs: &[(String, String, String)],
    config: &qean_config::RunConfig,
    seed_start: SeedStart,
) -> Result<(Vec<SampleRequest>, Vec<usize>)> {
    let (layout, seed_frames) = (config.layout(), config.seed_frames());
    let mut motions = Vec::new();
    for (motion, _, _) in pairs {
        let path = ds.motion_path(motion);
        let m = ds.read_motion(motion)?;
        if m.frames < seed_frames {
            return Err(Error::Io(qean_io::Error::at(
                &path,
                format!(
                    "{} frames, shorter than the {seed_frames}-frame seed",
                    m.frames
                ),
            )));
        }
        motions.push(m);
    }
    let lengths: Vec<usize> = motions.iter().map(|m| m.frames).collect();
    let starts = seed_start.starts(&lengths, seed_frames);
    let mut requests = Vec::new();
    for (((_, music, _), m), &s) in pairs.iter().zip(&motions).zip(&starts) {
        let (audio, frames) = feature_cache::load(ds, music)?;
        let dim = qean_aistpp::windows::AUDIO_DIM;
        let audio = audio[s.min(frames) * dim..].to_vec();
        requests.push(SampleRequest {
            seed: m.slice(s, s + seed_frames).to_layout(layout),
            audio: config.recipe.model_audio(audio, dim),
        });
    }
    Ok((requests, starts))
}

/// The sampler's options: the request's overrides, else the run's recipe.
fn sample_options(req: &RunEvalRequest, config: &qean_config::RunConfig) -> Result<SampleOptions> {
    let s = &req.sampling;
    let r = &config.recipe;
    let opts = SampleOptions {
        frames: req.max_frames,
        audio_pad: s.audio_pad,
        feedback_project: s.feedback_project.unwrap_or(r.feedback_project),
        offset_output: r.predict == qean_config::recipe::Predict::Offset,
        ensemble: s.ensemble.unwrap_or(r.ensemble),
        ensemble_decay: s.ensemble_decay.unwrap_or(r.ensemble_decay),
        seam_frames: s.seam_frames.unwrap_or(r.seam_frames),
        layout: config.layout(),
        spec: config.window_spec(),
    };
    qean_config::recipe::check_ensemble(
        ("--ensemble", opts.ensemble),
        ("--ensemble-decay", opts.ensemble_decay),
        config.model.target_len,
    )
    .map_err(Error::Invalid)?;
    Ok(opts)
}

/// Every request sampled in one batch with the checkpoint's model, with a progress bar; TSMT draws
/// with `draw_seed`.
fn sample_dances(
    req: &RunEvalRequest,
    ck: &qean_checkpoint::Checkpoint,
    (requests, genres): (&[SampleRequest], &[Option<usize>]),
    opts: &SampleOptions,
    draw_seed: u64,
) -> Result<Vec<Vec<f32>>> {
    let backend = req.sampling.backend.unwrap_or(ck.config.train.backend);
    let pb = qean_checkpoint::progress::bar(
        req.max_frames as u64,
        &format!("sampling {} sequences", requests.len()),
        "frames",
    );
    let mut progress = |done: usize, total: usize| {
        pb.set_length(total as u64);
        pb.set_position(done as u64);
    };
    let dances = match ck.config.spec() {
        ModelSpec::Tsmt(_) => {
            sample_tsmt(req, ck, requests, opts, draw_seed, backend, &mut progress)?
        }
        ModelSpec::Gpt(_) | ModelSpec::GptGenre(..) | ModelSpec::GptKeyframe(..) => {
            sample_gpt(req, ck, (requests, genres), opts, draw_seed, &mut progress)?
        }
        _ => {
            let device = qean_models::backend::device(backend)?;
            let model = ck.load_model(&device)?;
            qean_models::sampler::sample(&model, &device, requests, opts, progress)?
        }
    };
    pb.finish_and_clear();
    Ok(dances)
}

/// TSMT's rollouts of the requests (seed motions and 35-D music), as vectors in `opts.layout`.
fn sample_tsmt(
    req: &RunEvalRequest,
    ck: &qean_checkpoint::Checkpoint,
    requests: &[SampleRequest],
    opts: &SampleOptions,
    draw_seed: u64,
    backend: qean_models::backend::Backend,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Vec<Vec<f32>>> {
    let dim = qean_aistpp::windows::AUDIO_DIM;
    let seeds = requests
        .iter()
        .map(|r| Motion::from_layout(&r.seed, opts.layout).map_err(Error::Invalid))
        .collect::<Result<Vec<_>>>()?;
    let music: Vec<(&[f32], usize)> = requests
        .iter()
        .map(|r| (r.audio.as_slice(), r.audio.len() / dim))
        .collect();
    let t = ck.config.tsmt();
    let s = &req.sampling;
    let rollouts = crate::tsmt::TsmtRollouts {
        seeds: &seeds,
        music: &music,
        frames: req.max_frames,
        sampling: crate::tsmt::sampling_with(&t, s.temperature, s.top_k, s.decode, draw_seed),
        backend,
        smooth_sigma: s.smooth_sigma.unwrap_or(t.smooth_sigma),
    };
    let motions = crate::tsmt::sample_motions(ck, &rollouts, progress)?;
    Ok(motions.iter().map(|m| m.to_layout(opts.layout)).collect())
}

/// The VQ-VAE + GPT's dances of the requests, as vectors in `opts.layout` (greedy unless the request's
/// sampling overrides say otherwise).
fn sample_gpt(
    req: &RunEvalRequest,
    ck: &qean_checkpoint::Checkpoint,
    (requests, genres): (&[SampleRequest], &[Option<usize>]),
    opts: &SampleOptions,
    draw_seed: u64,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Vec<Vec<f32>>> {
    let dim = qean_aistpp::windows::AUDIO_DIM;
    let g = ck.config.gpt_table();
    let mut run = crate::gpt::GptRun::load(ck)?;
    run.decoding = req.sampling.decoding(run.decoding);
    let picking = crate::gpt::Picking::of(g, &req.sampling.picking(), draw_seed);
    let mut out = Vec::new();
    for (i, r) in requests.iter().enumerate() {
        let seed = Motion::from_layout(&r.seed, opts.layout).map_err(Error::Invalid)?;
        let music = (r.audio.as_slice(), r.audio.len() / dim);
        let choice = genres
            .get(i)
            .copied()
            .flatten()
            .filter(|_| run.genre.is_some())
            .map(|genre| crate::gpt::GenreChoice {
                genre,
                z_seed: i as u64,
            });
        let motion = run
            .dance(
                g,
                &seed,
                music,
                req.max_frames,
                &picking,
                crate::gpt::Controls::genre(choice),
                &mut |_, _| {},
            )?
            .ok_or_else(|| {
                Error::Invalid(format!(
                    "request {i}: the music is shorter than the seed and one token"
                ))
            })?;
        progress((i + 1) * req.max_frames / requests.len(), req.max_frames);
        out.push(motion.to_layout(opts.layout));
    }
    Ok(out)
}

/// S-music-D's further rollouts of a TSMT run (draw seeds after the main one), as joint sequences
/// named like the main set.
fn more_rollouts(
    req: &RunEvalRequest,
    ck: &qean_checkpoint::Checkpoint,
    requests: &[SampleRequest],
    opts: &SampleOptions,
    main: &[Sequence],
) -> Result<Vec<Vec<Sequence>>> {
    let count = req.sampling.music_rollouts.unwrap_or(5);
    let mut sets = Vec::new();
    for k in 1..count as u64 {
        let dances = sample_dances(req, ck, (requests, &[]), opts, req.sampling.sample_seed + k)?;
        let set = dances
            .iter()
            .zip(main)
            .map(|(d, s)| {
                let m = Motion::from_layout(d, opts.layout).map_err(Error::Invalid)?;
                Ok(Sequence {
                    joints: frames_of(m.joints(req.root)),
                    ..s.clone()
                })
            })
            .collect::<Result<Vec<_>>>()?;
        sets.push(set);
    }
    Ok(sets)
}

/// The generated dances as joint positions, written to `out_dir/generated/NAME.joints.npy`, with
/// their pairings.
fn write_generated(
    out_dir: &Path,
    pairs: &[(String, String, String)],
    dances: &[Vec<f32>],
    starts: &[usize],
    (opts, seed_frames): (&SampleOptions, usize),
    root: qean_motion::FkRoot,
) -> Result<(Vec<Sequence>, Vec<Pairing>)> {
    let joints_dir = out_dir.join("generated");
    std::fs::create_dir_all(&joints_dir).map_err(|e| qean_io::Error::io(&joints_dir, e))?;
    let d = opts.layout.dim();
    let mut generated = Vec::new();
    let mut pairings = Vec::new();
    for (((motion, music, name), dance), &start) in pairs.iter().zip(dances).zip(starts) {
        let m = Motion::from_layout(dance, opts.layout)
            .map_err(|e| Error::Invalid(format!("generated {name}: {e}")))?;
        let points = m.joints(root);
        qean_motion::joints_file::write_joints(
            &joints_dir.join(format!("{name}.joints.npy")),
            &points,
        )?;
        generated.push(Sequence {
            name: name.clone(),
            joints: frames_of(points),
            music: Some(music.clone()),
            music_offset: start,
        });
        pairings.push(Pairing {
            name: name.clone(),
            motion: motion.clone(),
            music_id: music.clone(),
            generated: dance.len() / d - seed_frames,
            seed_start: start,
        });
    }
    let lengths: Vec<usize> = pairings.iter().map(|p| p.generated).collect();
    tracing::info!(
        "generated {} sequences, {}..={} frames each",
        lengths.len(),
        lengths.iter().min().unwrap_or(&0),
        lengths.iter().max().unwrap_or(&0)
    );
    Ok((generated, pairings))
}

/// The ground-truth reference set: every non-ignored motion (the test ones under EDGE's splits), full
/// length.
pub(crate) fn reference_set(
    ds: &Dataset,
    root: qean_motion::FkRoot,
    splits: Splits,
) -> Result<Vec<Sequence>> {
    let names = match splits {
        Splits::TestValAgainstAll => ds.all_sequences()?,
        Splits::TestAgainstTest => ds.split(Split::Test),
    };
    let mut reference = Vec::new();
    for name in names {
        let m = ds.read_motion(&name)?;
        reference.push(Sequence {
            music: ds.music_id(&name),
            ..Sequence::new(name.clone(), frames_of(m.joints(root)))
        });
    }
    Ok(reference)
}

/// The chance baselines, scored with `cfg`: the frozen seed pose, and the dances against other music.
/// They repeat the warnings the main evaluation gave (constant reference dimensions; renamed dances have
/// no GT partner), so they run silently.
fn chance_baselines(
    generated: &[Sequence],
    reference: &[Sequence],
    lookup: qean_eval::protocol::BeatLookup,
    cfg: &EvalConfig,
) -> Result<Baselines> {
    let quiet = || tracing::subscriber::NoSubscriber::default();
    let frozen = tracing::subscriber::with_default(quiet(), || {
        evaluate(
            &frozen_dances(generated, cfg.seed_frames),
            reference,
            Some(lookup),
            cfg,
        )
    })?;
    let mut pairings = Vec::new();
    for shift in 1.. {
        let Some(g) = repaired_dances(generated, shift) else {
            break;
        };
        pairings.push(tracing::subscriber::with_default(quiet(), || {
            evaluate(&g, reference, Some(lookup), cfg)
        })?);
    }
    Ok(Baselines {
        frozen,
        random_pairing: average_beat_align(pairings),
    })
}

/// The row label of a checkpoint's reports.
fn label(config: &qean_config::RunConfig, step: u64) -> String {
    let m = &config.model;
    match m.arch {
        qean_config::model::Arch::Fact => format!("FACT step {step}"),
        qean_config::model::Arch::Tsmt => format!("TSMT step {step}"),
        qean_config::model::Arch::Inbetween => format!("in-betweener step {step}"),
        qean_config::model::Arch::Vqvae => format!("VQ-VAE step {step}"),
        qean_config::model::Arch::Gpt => format!("VQ-VAE + GPT step {step}"),
        qean_config::model::Arch::GptGenre => format!("VQ-VAE + GPT + genre control step {step}"),
        qean_config::model::Arch::GptKeyframe => {
            format!("VQ-VAE + GPT + keyframe control step {step}")
        }
        qean_config::model::Arch::GenreClf => format!("genre classifier step {step}"),
        qean_config::model::Arch::Qean => format!(
            "QEAN ({:?} positions, {:?} attention) step {step}",
            m.position, m.attention
        )
        .to_lowercase()
        .replacen("qean", "QEAN", 1),
    }
}

/// Writes `report.json` and `report.md` (the settings in a heading over the table); returns the table.
/// How a token model's dances are drawn, in words (None for the deterministic FACT and QEAN).
fn sampler_label(req: &RunEvalRequest, config: &qean_config::RunConfig) -> Option<String> {
    let s = &req.sampling;
    if let Some(t) = config.tsmt.as_ref() {
        let r = crate::tsmt::sampling_with(t, s.temperature, s.top_k, s.decode, s.sample_seed);
        let smooth = match s.smooth_sigma.unwrap_or(t.smooth_sigma) {
            x if x > 0.0 => format!("; joints smoothed (σ {x} frames)"),
            _ => String::new(),
        };
        return Some(format!(
            "TSMT decoding {}, temperature {}, top-k {}, draw seed {}{smooth}",
            r.decode.name(),
            r.temperature,
            r.top_k,
            r.seed
        ));
    }
    if config.gpt.is_some() {
        let g = config.gpt_table();
        let p = crate::gpt::Picking::of(g, &s.picking(), s.sample_seed);
        let d = s.decoding(crate::gpt::Decoding::of(config));
        let floor = match d.floor_window {
            0 => "floor not pinned".to_string(),
            w => format!("lowest point pinned to the seed's floor over {w} frames"),
        };
        let decoding = match d.slide_window {
            0 => format!("{floor}, feet's glide kept"),
            w => format!("{floor}, feet's glide taken away over {w} frames"),
        };
        let decoding = match d.smooth_sigma {
            s if s > 0.0 => format!("{decoding}, joints smoothed (σ {s} frames)"),
            _ => decoding,
        };
        return Some(format!(
            "GPT picking top-k {}, temperature {}, repetition penalty {} over {} tokens, draw seed {}; {decoding}",
            p.top_k, p.temperature, p.repetition_penalty, p.repetition_window, p.seed
        ));
    }
    None
}

fn write_report(
    out_dir: &Path,
    report: &RunReport,
    label: &str,
    seed_frames: usize,
) -> Result<String> {
    let labels: Vec<String> = report
        .reports
        .iter()
        .map(|r| match report.reports.len() {
            1 => label.to_string(),
            _ => format!("{label} ({})", value_name(r.config.metrics_mode)),
        })
        .collect();
    let mut rows: Vec<(&str, &MetricsReport)> = labels
        .iter()
        .map(String::as_str)
        .zip(&report.reports)
        .collect();
    if let Some(b) = &report.baselines {
        rows.push(("chance: frozen seed pose", &b.frozen));
        if let Some(r) = &b.random_pairing {
            rows.push(("chance: random music pairing", r));
        }
    }
    let table = render_markdown(&rows);
    write_json_atomic(&out_dir.join("report.json"), report)?;
    let sampler = report
        .sampler
        .as_ref()
        .map_or(String::new(), |s| format!("Sampler: {s}.\n\n"));
    let md = format!(
        "# Evaluation of {} ({:?} protocol, {} sequences, seed = {}, up to {} generated frames, {} feedback, {} pass(es) per frame, seed's end eased over {} frames)\n\n{sampler}{table}",
        report.checkpoint.display(),
        report.protocol,
        report.pairings.len(),
        match report.seed_start {
            SeedStart::Zero => format!("first {seed_frames} GT frames"),
            s => format!("{seed_frames} GT frames from a random start ({s})"),
        },
        report.frames,
        if report.feedback_project { "projected" } else { "raw" },
        report.ensemble,
        report.seam_frames
    );
    qean_io::fsutil::atomic_write(&out_dir.join("report.md"), md.as_bytes())?;
    Ok(table)
}
