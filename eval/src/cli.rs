//! The `qean-eval` command line: parse, load, evaluate, print. All logic is reachable from tests.

use std::collections::HashMap;
use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::Parser;

use serde::{Deserialize, Serialize};

use crate::config::{
    value_name, BaSegment, BaVariant, EvalConfig, GeometricVariant, MetricsMode, MusicBeatSource,
    PositionMode,
};
use crate::io::{load_joints_dir, read_beats_json, write_json_atomic};
use crate::protocol::evaluate;
use crate::report::{render_markdown, MetricsReport};

/// Evaluate generated dance motion against AIST++ ground truth: FID_k, FID_g, Dist_k, Dist_g and
/// BeatAlign, computed as Bailando's and mint's reference code computes them (bugs included by
/// default; see --metrics-mode).
#[derive(Debug, Parser)]
#[command(name = "qean-eval", version)]
pub struct Args {
    /// Directory of generated motions, seed frames first: joint positions as .npy (T, 24, 3) or (T, 72), model
    /// vectors .npy (T, 225|219), AIST++ .pkl (forward kinematics applied) or .bvh.
    #[arg(long, required_unless_present = "run", requires = "reference")]
    pub generated: Option<PathBuf>,
    /// Directory of ground-truth motions (the normalisation and FID reference set), same format.
    #[arg(long, required_unless_present = "run", requires = "generated")]
    pub reference: Option<PathBuf>,
    /// Checkpoint mode: a training run directory. Samples the test + val sequences of --data with its
    /// checkpoint (seed = first 120 GT frames, --max-frames generated), evaluates them against every
    /// non-ignored sequence of --data, and writes R/eval/step-N/report.{json,md}.
    #[arg(long, conflicts_with_all = ["generated", "reference", "music", "beats"], requires = "data")]
    pub run: Option<PathBuf>,
    /// Checkpoint mode: which checkpoint of --run (step-N, N or a path; default the newest).
    #[arg(long, requires = "run")]
    pub checkpoint: Option<String>,
    /// Checkpoint mode: the AIST++-layout dataset (motions/, wav/, splits).
    #[arg(long, requires = "run")]
    pub data: Option<PathBuf>,
    /// Checkpoint mode: paired (each motion with its own music) or unpaired (mint: 10 music draws per motion).
    #[arg(long, value_enum, default_value_t = crate::run_eval::Protocol::Paired)]
    pub protocol: crate::run_eval::Protocol,
    /// Checkpoint mode: keep generating past the end of the music by repeating its last frame.
    #[arg(long)]
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
    /// Checkpoint mode: write the report under R/eval/step-N-TAG/ instead of R/eval/step-N/
    /// (several sampling settings of one checkpoint side by side).
    #[arg(long, requires = "run")]
    pub tag: Option<String>,
    /// Checkpoint mode: backend for sampling (default: the run's).
    #[arg(long)]
    pub backend: Option<String>,
    /// Checkpoint mode: also score two chance baselines on the same protocol: "frozen" (each seed's
    /// last frame held for the generated length) and "random pairing" (each generated dance scored
    /// against another sequence's music). A trained model should beat both.
    #[arg(long, requires = "run")]
    pub baselines: bool,
    /// Directory of the music, <music ID>.wav (or .ogg/.mp3/.flac); beats tracked from the audio as
    /// --ba-music-beats says. Non-AIST music IDs are not recognised.
    #[arg(long, conflicts_with = "beats")]
    pub music: Option<PathBuf>,
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
    /// The configuration of each requested metrics mode.
    pub fn configs(&self) -> Vec<EvalConfig> {
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
            })
            .collect()
    }
}

/// What `--json` writes: one report per metrics mode.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EvaluationFile {
    pub reports: Vec<MetricsReport>,
}

/// Load, evaluate each mode, write the JSON (if asked) and return the reports with their markdown table.
pub fn run(args: &Args) -> anyhow::Result<(EvaluationFile, String)> {
    if let Some(run) = &args.run {
        return crate::run_eval::evaluate_run(args, run);
    }
    let root = args.fk_root.fk();
    let (Some(generated), Some(reference)) = (&args.generated, &args.reference) else {
        bail!("give --generated DIR and --reference DIR, or --run R --data DIR");
    };
    let generated = load_joints_dir(generated, root).context("loading generated motions")?;
    let reference = load_joints_dir(reference, root).context("loading reference motions")?;
    let beats: Option<(PathBuf, HashMap<String, Vec<usize>>)> = match (&args.beats, &args.music) {
        (Some(p), _) => Some((p.clone(), read_beats_json(p)?)),
        (None, Some(dir)) => {
            let names = generated.iter().chain(&reference).map(|s| s.name.as_str());
            Some((dir.clone(), music_beats(dir, names, args.ba_music_beats)?))
        }
        (None, None) => None,
    };
    let lookup = |id: &str| -> crate::Result<Vec<usize>> {
        let (path, map) = beats.as_ref().expect("lookup only passed with beats");
        map.get(id)
            .cloned()
            .ok_or_else(|| crate::Error::file(path, format!("no beats for music ID '{id}'")))
    };
    let lookup_ref = beats
        .as_ref()
        .map(|_| &lookup as crate::protocol::BeatLookup);
    let reports = args
        .configs()
        .iter()
        .map(|cfg| evaluate(&generated, &reference, lookup_ref, cfg))
        .collect::<crate::Result<Vec<_>>>()?;
    let file = EvaluationFile { reports };
    if let Some(path) = &args.json {
        write_json_atomic(path, &file)?;
    }
    let labels: Vec<String> = file
        .reports
        .iter()
        .map(|r| match file.reports.len() {
            1 => args.label.clone(),
            _ => format!("{} ({})", args.label, value_name(r.config.metrics_mode)),
        })
        .collect();
    let rows: Vec<(&str, &MetricsReport)> = labels
        .iter()
        .map(String::as_str)
        .zip(&file.reports)
        .collect();
    let table = render_markdown(&rows);
    Ok((file, table))
}

/// Music beats of every AIST++ music ID among `names`, from `dir/<music ID>.(wav|ogg|mp3|flac)`:
/// Bailando's HPSS-percussive beats (start BPM 120), or column 34 of our 35-D features (start BPM from the
/// music ID's tempo prior). IDs without an audio file are left out (their sequences are then excluded from
/// BeatAlign with a logged reason).
pub fn music_beats<'a>(
    dir: &std::path::Path,
    names: impl Iterator<Item = &'a str>,
    source: MusicBeatSource,
) -> anyhow::Result<HashMap<String, Vec<usize>>> {
    use qean_audio as audio;
    if !dir.is_dir() {
        bail!("{}: music directory does not exist", dir.display());
    }
    let mut ids: Vec<String> = names.filter_map(qean_aistpp::names::music_id_of).collect();
    ids.sort();
    ids.dedup();
    let mut out = HashMap::new();
    for id in ids {
        let Some(path) = qean_aistpp::dataset::AUDIO_EXTENSIONS
            .iter()
            .map(|e| dir.join(format!("{id}.{e}")))
            .find(|p| p.is_file())
        else {
            tracing::warn!("no audio for music {id} in {}", dir.display());
            continue;
        };
        let beats = match source {
            MusicBeatSource::Bailando => {
                let a = audio::load_audio(&path, &audio::LoadOptions::default())?;
                audio::hpss::bailando_beats(&a.samples, audio::SR as f64).beats
            }
            MusicBeatSource::Feature35 => {
                audio::features_for_file(
                    &path,
                    &audio::FeatureOptions::with_start_bpm(qean_aistpp::names::start_bpm(&id)),
                )?
                .beats
            }
        };
        out.insert(id, beats);
    }
    Ok(out)
}

/// Logging to stderr; RUST_LOG overrides the -v level.
pub fn init_logging(verbose: u8) {
    let level = match verbose {
        0 => "warn",
        1 => "info",
        _ => "debug",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(format!("{level},symphonia=off")));
    let _ = tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .try_init();
}
