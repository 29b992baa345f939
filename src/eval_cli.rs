//! `qean eval` and `qean curves` (also the `qean-eval` binary): their arguments, turned into the typed
//! requests of `qean-eval` (directory mode) and `qean-pipeline` (checkpoint mode, curves).

use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::Parser;
use qean_eval::config::{
    BaSegment, BaVariant, EvalConfig, GeometricVariant, MetricsMode, MusicBeatSource, PositionMode,
};
use qean_eval::curves::CurvesRequest;
use qean_eval::dirs::{evaluate_dirs, DirRequest};
use qean_eval::pfc::PfcVariant;
use qean_eval::preset::ProtocolPreset;
use qean_eval::run_report::{Protocol, SeedStart};
use qean_models::autoregress::AudioPad;
use qean_pipeline::evaluate::{RunEvalRequest, SamplingOverrides};

/// Evaluate generated dance motion against AIST++ ground truth: FID_k, FID_g, Dist_k, Dist_g and
/// BeatAlign, computed as Bailando's and mint's reference code computes them (bugs included by
/// default; see --metrics-mode).
#[derive(Debug, Parser)]
#[command(about = "Score dances: FID_k, FID_g, Dist_k, Dist_g, BeatAlign, motion energy, PFC")]
pub struct Args {
    /// Directory of generated motions, seed frames first: joint positions as .npy (T, 24, 3) or (T, 72), model
    /// vectors .npy (T, 225|219), AIST++ .pkl (forward kinematics applied) or .bvh.
    #[arg(long, required_unless_present_any = ["run", "task"], requires = "reference")]
    pub generated: Option<PathBuf>,
    /// Directory of ground-truth motions (the normalisation and FID reference set), same format.
    #[arg(long, required_unless_present_any = ["run", "task"], requires = "generated")]
    pub reference: Option<PathBuf>,
    /// Checkpoint mode: a training run directory. Samples the test + val sequences of --data with its
    /// checkpoint (seed = first 120 GT frames, --max-frames generated), evaluates them against every
    /// non-ignored sequence of --data, and writes R/eval/step-N/report.{json,md}.
    #[arg(long, conflicts_with_all = ["generated", "reference", "music", "beats"], requires = "data")]
    pub run: Option<PathBuf>,
    /// Checkpoint mode: which checkpoint of --run (step-N, N or a path; default the newest).
    #[arg(long, requires = "run")]
    pub checkpoint: Option<String>,
    /// Checkpoint mode and --task inbetween: the dataset (AIST++, FineDance or a folder of dances; detected).
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// What to score: dances (generated motions; the default) or inbetween (Lin's keyframe benchmark:
    /// each test + val dance of --data rebuilt from N keys per measure, scored against the originals).
    #[arg(long, value_enum, default_value_t = Task::Dances)]
    pub task: Task,
    /// --task inbetween: keys per measure, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "3,5,9")]
    pub keys: Vec<usize>,
    /// --task inbetween: keyframe strategies (even, onset, stems, nmfd, dp); with --methods, every
    /// combination. Default: Lin's rows (even × linear/bezier, dp × bezier_fit/linear, onset/stems/nmfd × linear).
    #[arg(long, value_delimiter = ',')]
    pub strategies: Vec<String>,
    /// --task inbetween: in-betweeners (linear, bezier = training mean θ, bezier_fit = fitted per dance).
    #[arg(long, value_delimiter = ',')]
    pub methods: Vec<String>,
    /// --task inbetween: stems as DIR/<music ID>/{drums,bass,vocals,other}.wav (default DATA/stems).
    #[arg(long)]
    pub stems: Option<PathBuf>,
    /// --task inbetween: keep Ballet Jazz (Lin drops it).
    #[arg(long)]
    pub include_jb: bool,
    /// --task inbetween: a keyframes.* or inbetween.* setting (docs/keyframes.md), e.g.
    /// keyframes.stem_source=hpss or inbetween.mse_space=joints.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// --task inbetween: trained in-betweener runs (qean train --config configs/inbetween/...), comma-separated;
    /// each adds an even-keys row.
    #[arg(long, value_delimiter = ',')]
    pub inbetweeners: Vec<PathBuf>,
    /// --task inbetween: the directory for report.{md,json}.
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Checkpoint mode: paired (each motion with its own music) or unpaired (mint: 10 music draws per motion).
    #[arg(long, value_enum, default_value_t = Protocol::Paired)]
    pub protocol: Protocol,
    /// Checkpoint mode: where each seed starts in its ground-truth motion: zero (mint: the first
    /// frames) or random[:SEED] (QEAN's "random motion seeds": a seeded uniform draw per sequence;
    /// the music starts at the same frame).
    #[arg(long, default_value = "zero", requires = "run")]
    pub seed_start: SeedStart,
    /// Checkpoint mode: when the music ends first, stop (mint) or edge (repeat its last frame).
    #[arg(long, value_enum, default_value_t = AudioPad::Stop)]
    pub audio_pad: AudioPad,
    /// The same as --audio-pad edge (the older spelling).
    #[arg(long, hide = true)]
    pub audio_pad_edge: bool,
    /// Checkpoint mode: project fed-back rotations to SO(3) while sampling (default: the run's
    /// recipe.feedback_project).
    #[arg(long, requires = "run", conflicts_with = "raw_feedback")]
    pub feedback_project: bool,
    /// Checkpoint mode: feed raw outputs back unchanged, as mint does (overrides the run's recipe).
    #[arg(long, requires = "run")]
    pub raw_feedback: bool,
    /// Checkpoint mode: temporal ensembling while sampling, the number of overlapping passes
    /// averaged per frame (default: the run's recipe.ensemble; 1 = mint).
    #[arg(long, requires = "run")]
    pub ensemble: Option<usize>,
    /// Checkpoint mode: the ensembling weights' decay per pass (default: the run's recipe).
    #[arg(long, requires = "run")]
    pub ensemble_decay: Option<f64>,
    /// Checkpoint mode: frames over which the jump at the seed's end fades out while sampling
    /// (default: the run's recipe.seam_frames; 0 = off, mint).
    #[arg(long, requires = "run")]
    pub seam_frames: Option<usize>,
    /// Checkpoint mode, TSMT: sampling temperature (default: the run's tsmt.temperature).
    #[arg(long, requires = "run")]
    pub temperature: Option<f64>,
    /// Checkpoint mode, TSMT: draw from the k most likely bins only (default: the run's tsmt.top_k).
    #[arg(long, requires = "run")]
    pub top_k: Option<usize>,
    /// Checkpoint mode, TSMT: how sampled bins become coordinates: bin (the paper's), subbin, coherent or
    /// mean (default: the run's tsmt.decode; `qean sample --help` says what each does).
    #[arg(long, requires = "run")]
    pub decode: Option<String>,
    /// Checkpoint mode, GPT: the repetition penalty on the codes of the last gpt.repetition_window tokens
    /// (1 = off; default: the run's gpt.repetition_penalty).
    #[arg(long, requires = "run")]
    pub repetition_penalty: Option<f64>,
    /// Checkpoint mode, genre runs: the guidance S of `qean sample --genre-guidance` (default: the run's).
    #[arg(long, requires = "run", value_name = "S")]
    pub genre_guidance: Option<f64>,
    /// Checkpoint mode, GPT: the decoded dance's lowest point pinned to the seed's floor over windows of N
    /// frames (0 = off; default: the run's gpt.floor_window).
    #[arg(long, requires = "run")]
    pub floor_window: Option<usize>,
    /// Checkpoint mode, GPT: the planted feet's slow glide taken away over windows of N frames (0 = off;
    /// default: the run's gpt.slide_window).
    #[arg(long, requires = "run")]
    pub slide_window: Option<usize>,
    /// Checkpoint mode, GPT and TSMT: σ in frames of the decoded joints' temporal filter (0 = off;
    /// default: the run's gpt.smooth_sigma or tsmt.smooth_sigma).
    #[arg(long, requires = "run")]
    pub smooth_sigma: Option<f64>,
    /// Checkpoint mode, TSMT: seed of the draws (S-music-D's extra rollouts use the next seeds).
    #[arg(long, requires = "run", default_value_t = 0)]
    pub sample_seed: u64,
    /// Checkpoint mode, TSMT: rollouts per input for S-music-D (SPEC §11.10: 5; 1 = none).
    #[arg(long, requires = "run")]
    pub music_rollouts: Option<usize>,
    /// Checkpoint mode: write the report under R/eval/step-N-TAG/ instead of R/eval/step-N/
    /// (several sampling settings of one checkpoint side by side).
    #[arg(long, requires = "run")]
    pub tag: Option<String>,
    /// Checkpoint mode: backend for sampling (default: the run's).
    #[arg(long, value_enum)]
    pub backend: Option<qean_models::backend::Backend>,
    /// Checkpoint mode: also score two chance baselines on the same protocol: "frozen" (each seed's
    /// last frame held for the generated length) and "random pairing" (each generated dance scored
    /// against another sequence's music). A trained model should beat both.
    #[arg(long, requires = "run")]
    pub baselines: bool,
    /// Checkpoint mode, genre-control runs: run the genre control test (SPEC §13.10) with this trained
    /// genre classifier run: every paired music × all 10 genres, the classifier's verdicts (accuracy,
    /// confusion) and per-genre FID; writes R/eval/step-N/control.{json,md}.
    #[arg(long, requires = "run")]
    pub classifier: Option<PathBuf>,
    /// Checkpoint mode, GPT runs with a trained T-Base: the text evaluation (SPEC §13.10) on a text–motion
    /// set in the HumanML3D layout (with text_emb/<id>.npy embeddings): each dance with the next caption of
    /// --text-split over --text-interval, fused and as a pure T-Base rollout; writes R/eval/step-N/text.{json,md}.
    #[arg(long, requires = "run", conflicts_with = "classifier")]
    pub text_set: Option<PathBuf>,
    /// With --text-set: the split file whose captions are the prompts.
    #[arg(long, default_value = "test", requires = "text_set")]
    pub text_split: String,
    /// With --text-set: the interval in seconds of the dance (seed included).
    #[arg(long, default_value = "4.0..8.0", requires = "text_set")]
    pub text_interval: String,
    /// Directory of the music, <music ID>.wav (or .ogg/.mp3/.flac); beats tracked from the audio as
    /// --ba-music-beats says. Names without an AIST++ music ID need --pairing (or NAME.music).
    #[arg(long, conflicts_with = "beats")]
    pub music: Option<PathBuf>,
    /// Directory mode: a CSV of `generated,music` rows pairing generated files whose names hold no
    /// AIST++ music ID with their music (an audio file's stem in --music, or a key of --beats). A
    /// `NAME.music` file beside a generated motion does the same for one file.
    #[arg(long, conflicts_with = "run")]
    pub pairing: Option<PathBuf>,
    /// JSON file of precomputed music beats: {"mBR0": [frame, ...], ...} at 60 FPS.
    #[arg(long)]
    pub beats: Option<PathBuf>,
    /// Music beats for BeatAlign: bailando (HPSS-percussive, start BPM 120) or feature35 (column 34 of our
    /// features). With --beats it is only a label recorded in the report.
    #[arg(long, value_enum, default_value_t = MusicBeatSource::Bailando)]
    pub ba_music_beats: MusicBeatSource,
    /// BeatAlign formula: Bailando's (over music beats) or mint PR-41's (over motion beats).
    #[arg(long, value_enum, default_value_t = BaVariant::Bailando)]
    pub ba_variant: BaVariant,
    /// Frames BeatAlign scores: the generated ones, or seed and generated.
    #[arg(long, value_enum, default_value_t = BaSegment::Generated)]
    pub ba_segment: BaSegment,
    /// Metric modes to compute, comma-separated: reference = the reference code's bugs (acceleration
    /// precedence, τ = 1/120), comparable with published tables; corrected = both fixed. The report
    /// holds one entry per mode (SPEC §7.6 keeps both).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        default_value = "reference,corrected"
    )]
    pub metrics_mode: Vec<MetricsMode>,
    /// zero_start = Bailando (subtract the first root position); mint_absolute = mint.
    #[arg(long, value_enum, default_value_t = PositionMode::ZeroStart)]
    pub positions: PositionMode,
    /// Geometric feature extractor: manual_new (fixed joint names) or legacy_fairmotion.
    #[arg(long, value_enum, default_value_t = GeometricVariant::ManualNew)]
    pub geometric: GeometricVariant,
    /// Leading frames of each generated file that are the seed (120 for `qean sample` output).
    #[arg(long, default_value_t = 120)]
    pub seed_frames: usize,
    /// Evaluate at most this many generated frames.
    #[arg(long, default_value_t = 1200)]
    pub max_frames: usize,
    /// Music frame of each generated file's frame 0.
    #[arg(long, default_value_t = 0)]
    pub music_offset: usize,
    /// Beat precision/recall/F1 (Li et al.): motion beats match the paired reference's within this
    /// many frames (SPEC §11.9; 2 = the paper's literal frame count).
    #[arg(long, default_value_t = 5)]
    pub beat_tol: usize,
    /// Named protocols, comma-separated: bailando (our defaults), edge (30 fps, 5-s clips every 2.5 s, PFC)
    /// or lodge (30 fps, 1,024 frames, 22 root-relative joints); the report lists every setting a preset
    /// fixed and its source (docs/protocols.md). Directory mode: one table per preset; checkpoint mode
    /// takes one (it also picks the splits and the dances' length: 1,200, 1,800 or 2,048 frames).
    #[arg(
        long,
        value_enum,
        value_delimiter = ',',
        conflicts_with_all = ["positions", "max_frames", "pfc", "ba_segment"]
    )]
    pub protocol_preset: Vec<ProtocolPreset>,
    /// PFC, EDGE's physical foot-contact score (lower: feet that push the body): scored at ours (60 fps,
    /// every frame) or edge (30 fps, every second frame, as EDGE's tables; 3–5× ours on the same dance).
    #[arg(long, value_enum, default_value_t = PfcVariant::Ours)]
    pub pfc: PfcVariant,
    /// Write the full report (per-sequence values included) here as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Row label of the markdown table.
    #[arg(long, default_value = "generated")]
    pub label: String,
    /// Root convention of forward kinematics for .pkl motions (SMPL parameters): smpl (mint, Bailando) or edge.
    #[arg(long, value_enum, default_value_t = RootArg::Smpl)]
    pub fk_root: RootArg,
}

/// What `qean eval` scores.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Task {
    Dances,
    Inbetween,
}

/// Root convention for forward kinematics (SPEC §3.3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum RootArg {
    Smpl,
    Edge,
}

impl RootArg {
    pub fn fk(self) -> qean_motion::FkRoot {
        match self {
            RootArg::Smpl => qean_motion::FkRoot::Smpl,
            RootArg::Edge => qean_motion::FkRoot::Edge,
        }
    }
}

impl Args {
    /// The configuration of each requested metrics mode, for each protocol preset (if any).
    pub fn configs(&self) -> Vec<EvalConfig> {
        let base = self.mode_configs();
        if self.protocol_preset.is_empty() {
            return base;
        }
        self.protocol_preset
            .iter()
            .flat_map(|p| base.iter().map(|c| p.apply(c.clone())))
            .collect()
    }

    /// The configuration of each requested metrics mode, flag by flag.
    fn mode_configs(&self) -> Vec<EvalConfig> {
        self.metrics_mode
            .iter()
            .map(|&metrics_mode| EvalConfig {
                metrics_mode,
                positions: self.positions,
                geometric: self.geometric,
                ba_variant: self.ba_variant,
                ba_music_beats: self.ba_music_beats,
                ba_segment: self.ba_segment,
                seed_frames: self.seed_frames,
                max_frames: self.max_frames,
                music_offset: self.music_offset,
                beat_tol: self.beat_tol,
                pfc: self.pfc,
                ..EvalConfig::default()
            })
            .collect()
    }

    /// Checkpoint mode's request for `run` (the flags that only directory mode reads are ignored).
    pub fn run_request(&self, run: &std::path::Path) -> anyhow::Result<RunEvalRequest> {
        let data = self
            .data
            .clone()
            .context("--run needs --data DIR (the dataset)")?;
        let max_frames = match self.protocol_preset.as_slice() {
            [] => self.max_frames,
            [p] => p.sample_frames(),
            _ => {
                bail!("checkpoint mode takes one --protocol-preset (directory mode scores several)")
            }
        };
        Ok(RunEvalRequest {
            run: run.to_path_buf(),
            checkpoint: self.checkpoint.clone(),
            data,
            protocol: self.protocol,
            seed_start: self.seed_start,
            max_frames,
            sampling: SamplingOverrides {
                feedback_project: (self.feedback_project || self.raw_feedback)
                    .then_some(self.feedback_project),
                ensemble: self.ensemble,
                ensemble_decay: self.ensemble_decay,
                seam_frames: self.seam_frames,
                backend: self.backend,
                audio_pad: if self.audio_pad_edge {
                    AudioPad::Edge
                } else {
                    self.audio_pad
                },
                temperature: self.temperature,
                top_k: self.top_k,
                decode: self
                    .decode
                    .as_deref()
                    .map(str::parse)
                    .transpose()
                    .map_err(|e: String| anyhow::anyhow!("--decode: {e}"))?,
                repetition_penalty: self.repetition_penalty,
                genre_guidance: self.genre_guidance,
                floor_window: self.floor_window,
                slide_window: self.slide_window,
                smooth_sigma: self.smooth_sigma,
                sample_seed: self.sample_seed,
                music_rollouts: self.music_rollouts,
            },
            configs: self.configs(),
            ba_music_beats: self.ba_music_beats,
            root: self.fk_root.fk(),
            tag: self.tag.clone(),
            baselines: self.baselines,
            json: self.json.clone(),
        })
    }

    /// Directory mode's request.
    pub fn dir_request(&self) -> anyhow::Result<DirRequest> {
        let (Some(generated), Some(reference)) = (&self.generated, &self.reference) else {
            bail!("give --generated DIR and --reference DIR, or --run R --data DIR");
        };
        Ok(DirRequest {
            generated: generated.clone(),
            reference: reference.clone(),
            music: self.music.clone(),
            beats: self.beats.clone(),
            ba_music_beats: self.ba_music_beats,
            configs: self.configs(),
            json: self.json.clone(),
            label: self.label.clone(),
            root: self.fk_root.fk(),
            pairing: self.pairing.clone(),
        })
    }
}

/// Runs `qean eval`; returns the markdown table to print.
pub fn run_eval(args: &Args) -> anyhow::Result<String> {
    if args.task == Task::Inbetween {
        return run_inbetween(args);
    }
    if args.data.is_some() && args.run.is_none() {
        bail!("--data goes with --run R (checkpoint mode) or --task inbetween");
    }
    match &args.run {
        Some(run) => {
            let req = args.run_request(run)?;
            let text = match &args.text_set {
                Some(dir) => {
                    let (from_s, to_s) =
                        qean_pipeline::gpt::TextRequest::interval(&args.text_interval)
                            .map_err(|e| anyhow::anyhow!("--text-interval {e}"))?;
                    Some(qean_pipeline::text_quality::TextEvalOptions {
                        text_set: dir.clone(),
                        split: args.text_split.clone(),
                        from_s,
                        to_s,
                    })
                }
                None => None,
            };
            let tests = qean_pipeline::evaluate::FamilyTests {
                classifier: args.classifier.clone(),
                text,
            };
            Ok(qean_pipeline::evaluate::evaluate_family(&req, &tests)?)
        }
        None => Ok(evaluate_dirs(&args.dir_request()?)?.1),
    }
}

/// Plot metrics against training steps for runs grouped over seeds (`-seed<k>` in the name).
///
/// Examples:
///   qean curves sweeps/freezing-runs --out docs/freezing/steps
///   qean curves runs/a runs/b --evaluate --data synth --max-frames 600 --out curves
#[derive(Debug, Parser)]
#[command(about = "Plot metrics against training steps for runs grouped over seeds")]
pub struct CurvesArgs {
    /// Run directories, or directories of runs (e.g. a sweep's S-runs/).
    #[arg(required = true)]
    pub runs: Vec<PathBuf>,
    /// Output directory: curves.png, curves.csv, table.md.
    #[arg(long)]
    pub out: PathBuf,
    /// First evaluate every checkpoint without a report (checkpoint mode with --baselines).
    #[arg(long, requires = "data")]
    pub evaluate: bool,
    /// The dataset the runs were trained on (with --evaluate).
    #[arg(long)]
    pub data: Option<PathBuf>,
    /// Generated frames per sequence when evaluating.
    #[arg(long, default_value_t = 1200)]
    pub max_frames: usize,
    /// Only these steps (comma-separated; default every checkpoint).
    #[arg(long, value_delimiter = ',')]
    pub steps: Vec<u64>,
    /// Figure title.
    #[arg(long, default_value = "METRICS AGAINST TRAINING STEPS")]
    pub title: String,
    /// Read (and with --evaluate, write) the reports tagged TAG: eval/step-N-TAG/.
    #[arg(long)]
    pub tag: Option<String>,
    /// With --evaluate: sampling overrides passed to checkpoint mode (e.g. "--ensemble 4").
    #[arg(long, allow_hyphen_values = true, value_delimiter = ' ')]
    pub eval_args: Vec<String>,
}

/// Runs `qean curves`; returns the table.
pub fn run_curves(a: &CurvesArgs) -> anyhow::Result<String> {
    if a.evaluate {
        let data = a.data.as_ref().context("--evaluate needs --data")?;
        // The sampling overrides of --eval-args, read as `qean eval --run` flags.
        let fixed = [
            "qean eval",
            "--metrics-mode",
            "reference",
            "--run",
            "R",
            "--data",
        ];
        let argv = fixed
            .iter()
            .map(std::ffi::OsString::from)
            .chain([data.as_os_str().to_owned()])
            .chain(a.eval_args.iter().filter(|x| !x.is_empty()).map(Into::into));
        let eval = Args::try_parse_from(argv).context("--eval-args")?;
        let mut template = eval.run_request(std::path::Path::new("R"))?;
        if eval.protocol_preset.is_empty() {
            template.max_frames = a.max_frames; // a preset's dances are as long as it says
        }
        template.tag = a.tag.clone();
        template.baselines = true;
        for d in qean_eval::curves::find_runs(&a.runs)? {
            qean_pipeline::curves::evaluate_missing(&d, &a.steps, &template)?;
        }
    }
    Ok(qean_eval::curves::write_curves(&CurvesRequest {
        runs: a.runs.clone(),
        out: a.out.clone(),
        steps: a.steps.clone(),
        title: a.title.clone(),
        tag: a.tag.clone(),
    })?)
}

/// `qean eval --task inbetween`: Lin's reconstruction benchmark.
fn run_inbetween(args: &Args) -> anyhow::Result<String> {
    use qean_keyframes::select::Strategy;
    use qean_pipeline::inbetween_benchmark::{rows_of, run, IbMethod, InbetweenRequest};
    let data = args
        .data
        .clone()
        .context("--task inbetween needs --data DIR (the dataset)")?;
    let out = args
        .out
        .clone()
        .context("--task inbetween needs --out DIR (for report.md and report.json)")?;
    if args.run.is_some() || args.generated.is_some() {
        bail!("--task inbetween scores the dataset's own dances: drop --run/--generated");
    }
    let strategies = args
        .strategies
        .iter()
        .map(|s| Strategy::parse(s.trim()))
        .collect::<Result<Vec<_>, _>>()
        .map_err(anyhow::Error::msg)?;
    let methods = args
        .methods
        .iter()
        .map(|m| IbMethod::parse(m.trim()))
        .collect::<Result<Vec<_>, _>>()
        .map_err(anyhow::Error::msg)?;
    let rows = rows_of(strategies, methods);
    let settings = qean_pipeline::keyframe_settings::parse(&args.set)?;
    let (_, md) = run(&InbetweenRequest {
        data,
        keys: args.keys.clone(),
        rows,
        out: out.clone(),
        options: settings.keyframes,
        bezier: settings.bezier,
        mse_space: settings.mse_space,
        fid_reference: settings.fid_reference,
        include_jb: args.include_jb,
        stems: args.stems.clone(),
        root: args.fk_root.fk(),
        inbetweeners: args.inbetweeners.clone(),
    })?;
    Ok(format!("{md}\nwrote {}\n", out.join("report.md").display()))
}
