//! `qean demo`: the whole system on embedded data, with nothing to download. A small synthetic
//! AIST++-format dataset whose music includes two real, freely licensed recordings; the tiny FACT
//! and tiny full-QEAN presets trained on it; a 1200-frame dance for a held-out real song (Kevin
//! MacLeod's "Vibe Ace") from each model, with previews; both models scored on the synthetic test
//! + val split next to two chance baselines; a table and the path of every artefact.
//!
//! Every stage is resumable: a second run reuses what the first finished (the dataset, the
//! features, finished or interrupted training runs, dances and reports of the same checkpoint).

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Instant;

pub mod genre;
pub mod inbetween;
pub mod keyframe;

use indicatif::ProgressBar;
use qean_config::run::string_override;
use qean_config::RunConfig;
use qean_eval::motion_energy::{motion_energy, EnergyReference, MotionEnergy};
use qean_eval::report::MetricsReport;
use qean_eval::run_report::RunReport;
use qean_io::fsutil::atomic_write;

use crate::error::{bail, Context};
use crate::evaluate::{evaluate_run, RunEvalRequest};
use crate::generate::{self, GenerateOptions, SeedSource};
use qean_checkpoint::checkpoint::Checkpoint;
use qean_checkpoint::ProgressMode;
use qean_synth::{self as synth, RealTrack, SynthOptions};

/// A file shipped inside the binary.
struct Asset {
    path: &'static str,
    bytes: &'static [u8],
}

macro_rules! asset {
    ($p:literal) => {
        Asset {
            path: $p,
            bytes: include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/../", $p)),
        }
    };
}

/// The real music (with licences) and the presets the demo trains.
const ASSETS: &[Asset] = &[
    asset!("assets/music/Kevin_MacLeod_-_Vibe_Ace.ogg"),
    asset!("assets/music/Kevin_MacLeod_-_Vibe_Ace.LICENSE.txt"),
    asset!("assets/music/Brahms_Hungarian_Dance_5.ogg"),
    asset!("assets/music/Brahms_Hungarian_Dance_5.LICENSE.txt"),
    asset!("assets/music/sorohanro_-_solo-trumpet-06.ogg"),
    asset!("assets/music/sorohanro_-_solo-trumpet-06.LICENSE.txt"),
    asset!("configs/fact.toml"),
    asset!("configs/tiny/fact.toml"),
    asset!("configs/qean/baseline.toml"),
    asset!("configs/tiny/baseline.toml"),
    asset!("configs/tiny/full.toml"),
    asset!("configs/tsmt/paper.toml"),
    asset!("configs/tsmt/tiny.toml"),
    asset!("configs/tsmt/small.toml"),
    asset!("configs/inbetween/paper.toml"),
    asset!("configs/inbetween/tiny.toml"),
    asset!("configs/inbetween/tiny_motion.toml"),
    asset!("configs/inbetween/tiny_motion_smooth.toml"),
    asset!("configs/control/vqvae_paper.toml"),
    asset!("configs/control/vqvae_tiny.toml"),
    asset!("configs/control/gpt_paper.toml"),
    asset!("configs/control/gpt_tiny.toml"),
    asset!("configs/control/genre_clf_paper.toml"),
    asset!("configs/control/genre_clf_tiny.toml"),
    asset!("configs/control/genre_paper.toml"),
    asset!("configs/control/genre_tiny.toml"),
    asset!("configs/control/keyframe_paper.toml"),
    asset!("configs/control/keyframe_tiny.toml"),
];

/// The run names of the demo's motion VQ-VAE (trained beside the dance models), of the GPT over its
/// tokens (trained after it), of the genre classifier (beside the dance models) and of genre control over
/// the GPT (trained after the GPT).
const VQ: &str = "vq";
const GPT: &str = "gpt";
pub(crate) const CLF: &str = "genre_clf";
pub(crate) const GENRE: &str = "genre";
/// Keyframe control over the GPT (trained after genre control, used by [`keyframe`]).
pub(crate) const KEYFRAME: &str = "keyframe";

/// The run name of the demo's in-betweener (trained beside the dance models, used by
/// [`inbetween`]).
const INBETWEENER: &str = "inbetween";

/// The held-out song the demo dances to (not in the dataset).
const HELD_OUT: &str = "assets/music/Kevin_MacLeod_-_Vibe_Ace.ogg";
/// Real recordings standing in for two training music IDs: (file, music ID). The trumpet loop is
/// at 90 BPM, mBR1's tempo.
const TRAIN_TRACKS: [(&str, &str); 2] = [
    ("assets/music/sorohanro_-_solo-trumpet-06.ogg", "mBR1"),
    ("assets/music/Brahms_Hungarian_Dance_5.ogg", "mLO0"),
];

/// How big the demo is.
#[derive(Debug, Clone, PartialEq)]
pub struct Budget {
    /// The smoke-test size (`--quick`): too short for the dances to be trusted.
    pub quick: bool,
    pub sequences: usize,
    pub seconds: f64,
    /// Seed motion and music window lengths (frames): shorter than mint's 120 / 240 so that CPU
    /// training fits the budget (attention cost grows with the square of the window).
    pub motion_len: usize,
    pub audio_len: usize,
    pub steps: u64,
    pub batch_size: usize,
    /// Frames generated for the held-out song.
    pub dance_frames: usize,
    /// Most frames generated per test/val sequence in the evaluation (`qean eval --max-frames`).
    pub eval_frames: usize,
    /// `--set` overrides of the recipe beyond the presets' (empty: the presets' own).
    pub recipe: Vec<String>,
    /// Train on data whose genres show (`--genre-data`): every genre holds its posture and its music plays
    /// its riff (`qean synth --genre-postures --genre-music`; docs/control.md).
    pub genre_data: bool,
}

impl Budget {
    /// Training steps of one demo model. TSMT gets three quarters (3,000: the small preset's, where it
    /// stops jittering, docs/tsmt.md); so do the VQ-VAE and the GPT (docs/control.md measured these), as
    /// they train one after the other. The in-betweener gets half (2,000 steps: its preset's), genre
    /// control half (it trains after the GPT), the genre classifier a quarter (1,000: its preset's).
    pub fn steps_for(&self, name: &str) -> u64 {
        match name {
            "tsmt" | VQ | GPT => (self.steps * 3 / 4).max(25),
            INBETWEENER | GENRE | KEYFRAME => (self.steps / 2).max(25),
            CLF => (self.steps / 4).max(25),
            _ => self.steps,
        }
    }

    /// About 11 minutes on 2 CPU cores (default) or under one (`--quick`); docs/freezing.md says
    /// why these sizes.
    pub fn new(quick: bool) -> Budget {
        if quick {
            Budget {
                quick: true,
                sequences: 24,
                seconds: 8.0,
                motion_len: 30,
                audio_len: 60,
                steps: 100,
                batch_size: 8,
                dance_frames: 1200,
                eval_frames: 300,
                recipe: Vec::new(),
                genre_data: false,
            }
        } else {
            Budget {
                quick: false,
                sequences: 60,
                seconds: 16.0,
                motion_len: 30,
                audio_len: 60,
                steps: 4000,
                batch_size: 8,
                dance_frames: 1200,
                eval_frames: 600,
                recipe: Vec::new(),
                genre_data: false,
            }
        }
    }
}

impl DemoResult {
    /// Training was interrupted: no table yet.
    fn interrupted(dataset: PathBuf) -> DemoResult {
        DemoResult {
            dataset,
            models: Vec::new(),
            table: String::new(),
            summary: PathBuf::new(),
            inbetween: None,
            finished: false,
        }
    }
}

/// Options of [`run`].
#[derive(Debug, Clone)]
pub struct DemoOptions {
    pub out: PathBuf,
    pub budget: Budget,
    /// Set (e.g. by Ctrl-C) to stop training with a checkpoint; the next run resumes.
    pub stop: Arc<AtomicBool>,
    pub progress: ProgressMode,
    /// The `qean` executable that trains each stage in a process of its own (`qean train`).
    pub exe: PathBuf,
}

/// One dance to the held-out song.
#[derive(Debug, Clone)]
pub struct DanceResult {
    pub label: String,
    /// `dances/<dir>/`: the family's name, or `genre-<G>` for a genre-steered dance.
    pub dir: String,
    pub files: Vec<PathBuf>,
    /// Motion energy of the generated frames against the synthetic ground truth.
    pub energy: MotionEnergy,
    /// Seed frames at its start.
    pub seed_frames: usize,
}

/// One trained model's results.
#[derive(Debug, Clone)]
pub struct ModelResult {
    pub label: String,
    pub run_dir: PathBuf,
    pub checkpoint: PathBuf,
    pub train_seconds: f64,
    pub final_loss: Option<f64>,
    /// Its dances to the held-out song (genre control: one per demonstrated genre).
    pub dances: Vec<DanceResult>,
    pub report_md: PathBuf,
    pub report: RunReport,
}

/// What the demo produced.
#[derive(Debug, Clone)]
pub struct DemoResult {
    pub dataset: PathBuf,
    pub models: Vec<ModelResult>,
    pub table: String,
    pub summary: PathBuf,
    /// The in-betweening section (none when training was interrupted).
    pub inbetween: Option<inbetween::InbetweenDemo>,
    /// False when training was interrupted (the table is then not written).
    pub finished: bool,
}

pub(crate) fn say(msg: impl AsRef<str>) {
    eprintln!("[demo] {}", msg.as_ref());
}

/// Writes the embedded files under `out` (skipping those already there with the same bytes).
pub fn write_assets(out: &Path) -> crate::Result<()> {
    for a in ASSETS {
        let path = out.join(a.path);
        if std::fs::read(&path).ok().as_deref() == Some(a.bytes) {
            continue;
        }
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("{}: cannot create", parent.display()))?;
        }
        atomic_write(&path, a.bytes)?;
    }
    Ok(())
}

fn dataset(out: &Path, budget: &Budget) -> crate::Result<PathBuf> {
    let dir = out.join("data");
    let info = dir.join("synth.json");
    if info.is_file() {
        let v: serde_json::Value = serde_json::from_slice(
            &std::fs::read(&info).with_context(|| format!("{}: cannot read", info.display()))?,
        )
        .with_context(|| format!("{}: not a synth report", info.display()))?;
        let n: usize = v["splits"].as_object().map_or(0, |m| {
            m.values().filter_map(|x| x.as_array()).map(Vec::len).sum()
        });
        if v["varied_music"].as_bool() != Some(true) {
            bail!(
                "{}: made with plain procedural music by an older demo; this one trains on varied \
                 music (docs/freezing.md, section 5); use another --out",
                dir.display()
            );
        }
        if n != budget.sequences || v["seconds"].as_f64() != Some(budget.seconds) {
            bail!(
                "{}: made for another demo size ({n} sequences of {} s, this run wants {} of {} s); \
                 use another --out",
                dir.display(),
                v["seconds"],
                budget.sequences,
                budget.seconds
            );
        }
        let shows = |key: &str| v[key].as_bool().unwrap_or(false);
        if shows("genre_postures") != budget.genre_data || shows("genre_music") != budget.genre_data
        {
            bail!(
                "{}: made {} --genre-data; use another --out",
                dir.display(),
                if budget.genre_data { "without" } else { "with" }
            );
        }
        say(format!("dataset: reusing {}", dir.display()));
        return Ok(dir);
    }
    let spinner = ProgressBar::new_spinner();
    spinner.set_message(format!(
        "dataset: {} synthetic sequences of ~{} s (2 real recordings among the music)",
        budget.sequences, budget.seconds
    ));
    spinner.enable_steady_tick(std::time::Duration::from_millis(200));
    let mut real_music = Vec::new();
    for (file, id) in TRAIN_TRACKS {
        real_music.push(RealTrack::load(&out.join(file), id)?);
    }
    let report = synth::generate(
        &dir,
        &SynthOptions {
            sequences: budget.sequences,
            seconds: budget.seconds,
            seed: 0,
            real_music,
            genre_postures: budget.genre_data,
            genre_music: budget.genre_data,
            ..Default::default()
        },
    )?;
    spinner.finish_and_clear();
    let count = |s: &str| report.splits.get(s).map_or(0, |v| v.len());
    say(format!(
        "dataset: {} ({} train, {} val, {} test sequences, {} music tracks)",
        dir.display(),
        count("train"),
        count("val"),
        count("test"),
        report.music.len()
    ));
    Ok(dir)
}

/// The `--set` overrides that shrink a preset to the demo's budget, for `steps` steps. The
/// in-betweener keeps its own windows and constant learning rate; the genre classifier and genre
/// control keep their batch sizes and constant learning rates too.
fn overrides(b: &Budget, data: &Path, name: &str, steps: u64) -> Vec<String> {
    let every = (steps / 4).max(1);
    let mut o = vec![
        string_override("data.dir", &data.to_string_lossy()),
        format!("train.steps={steps}"),
        format!("train.checkpoint_every={every}"),
        format!("train.val_every={every}"),
        format!("train.log_every={}", (steps / 30).max(1)),
    ];
    if name != CLF && name != GENRE && name != KEYFRAME {
        o.push(format!("train.batch_size={}", b.batch_size));
    }
    if name != INBETWEENER && name != CLF && name != GENRE && name != KEYFRAME {
        o.extend([
            format!("model.motion_len={}", b.motion_len),
            format!("model.audio_len={}", b.audio_len),
            format!("schedule.boundaries=[{}]", (steps * 3 / 4).max(1)),
        ]);
        o.extend(b.recipe.iter().cloned());
    }
    o
}

/// A finished run: its newest checkpoint, training seconds and last loss.
type Trained = (Checkpoint, f64, Option<f64>);

/// One training run to start: its name, preset, config file, run directory, whether it resumes, its
/// overrides and steps.
struct Plan<'a> {
    name: &'a str,
    preset: &'a str,
    config: PathBuf,
    run_dir: PathBuf,
    resume: bool,
    overrides: Vec<String>,
    steps: u64,
}

/// The runs of `presets`, each checked (its preset loads; an earlier run of the same name was made with
/// the same config) before anything starts.
fn plan<'a>(
    opts: &DemoOptions,
    data: &Path,
    presets: &[(&'a str, &str, &'a str)],
) -> crate::Result<Vec<Plan<'a>>> {
    let mut plans = Vec::new();
    for (name, _, preset) in presets {
        let steps = opts.budget.steps_for(name);
        let mut overrides = overrides(&opts.budget, data, name, steps);
        if *name == VQ {
            // A constant LR 1e-3: the 1e-4 tail left codebooks whose decoded ground truth moved at
            // 0.64–0.85× its speed, and GPTs over them froze (docs/control.md, "Three training seeds").
            overrides.extend([
                "schedule.initial=1e-3".into(),
                "schedule.values=[1e-3]".into(),
            ]);
        }
        if *name == GPT {
            // LR 1e-3 then 1e-4 (the presets' CI-sized 300 steps start lower), over the demo's VQ-VAE.
            let vq = opts.out.join("runs").join(VQ);
            overrides.extend([
                "schedule.initial=1e-3".into(),
                "schedule.values=[1e-4]".into(),
                string_override("gpt.vqvae_run", &vq.to_string_lossy()),
            ]);
        }
        if *name == GENRE || *name == KEYFRAME {
            let gpt = opts.out.join("runs").join(GPT);
            let key = format!("{name}.gpt_run");
            overrides.push(string_override(&key, &gpt.to_string_lossy()));
        }
        let config = opts.out.join(preset);
        let wanted = RunConfig::load(&config, &overrides)?;
        let run_dir = opts.out.join("runs").join(name);
        let resume =
            qean_checkpoint::run_dir::list_checkpoints(&run_dir).is_ok_and(|c| !c.is_empty());
        if resume {
            // The trainer's own check, made here too so that a run of an earlier demo (e.g. before
            // a preset changed) stops the demo before any training starts.
            qean_checkpoint::checkpoint::resolve(&run_dir)?.check_config(&wanted)?;
        }
        plans.push(Plan {
            name,
            preset,
            config,
            run_dir,
            resume,
            overrides,
            steps,
        });
    }
    Ok(plans)
}

/// A started `qean train` process and the thread that forwards its stderr (returning the last line).
type Started = (std::process::Child, std::thread::JoinHandle<String>);

/// Starts the `qean train` process of `p`; its progress lines are printed with its name (unless `quiet`).
fn start(exe: &Path, p: &Plan, quiet: bool) -> crate::Result<Started> {
    use std::io::BufRead;
    use std::process::{Command, Stdio};
    say(format!(
        "train {}: {}, {} steps → {}{}",
        p.name,
        p.preset,
        p.steps,
        p.run_dir.display(),
        if p.resume { " (continuing)" } else { "" }
    ));
    let mut cmd = Command::new(exe);
    cmd.arg("train")
        .arg("--config")
        .arg(&p.config)
        .arg("--plain");
    if p.resume {
        cmd.arg("--resume").arg(&p.run_dir);
    } else {
        cmd.arg("--run-dir").arg(&p.run_dir);
    }
    for o in &p.overrides {
        cmd.arg("--set").arg(o);
    }
    let mut child = cmd
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .with_context(|| format!("cannot start {}", exe.display()))?;
    // Progress lines, prefixed; the last one is the error if the child fails.
    let stderr = child.stderr.take().expect("piped");
    let label = p.name.to_string();
    let reader = std::thread::spawn(move || {
        let mut last = String::new();
        for line in std::io::BufReader::new(stderr)
            .lines()
            .map_while(|l| l.ok())
        {
            if !quiet && !line.trim().is_empty() {
                say(format!("train {label}: {line}"));
            }
            last = line;
        }
        last
    });
    Ok((child, reader))
}

/// Trains every model at once, each in its own `qean train` process: a tiny model keeps one
/// core busy, so on two cores two runs take the time of one. Each child resumes its run when it
/// has checkpoints (an interrupted demo continues). Ctrl-C reaches the children too (same
/// process group): each checkpoints and exits, and this returns `None`.
fn train_all(
    opts: &DemoOptions,
    data: &Path,
    presets: &[(&str, &str, &str)],
) -> crate::Result<Option<Vec<Trained>>> {
    // Every preset and earlier run is checked before anything starts.
    let plans = plan(opts, data, presets)?;
    let quiet = opts.progress == ProgressMode::Quiet;
    let mut children = Vec::new();
    for p in &plans {
        children.push((p, start(&opts.exe, p, quiet)?));
    }
    let mut results = Vec::new();
    let mut interrupted = false;
    let mut failure = None;
    for (p, (mut child, reader)) in children {
        let name = p.name;
        let status = child.wait().context("waiting for a training process")?;
        let last = reader.join().unwrap_or_default();
        match status.code() {
            Some(0) => {
                let ck = qean_checkpoint::checkpoint::resolve(&p.run_dir)?;
                let (seconds, loss) = (ck.state.elapsed_seconds, ck.state.last_loss);
                results.push((ck, seconds, loss));
            }
            Some(130) | None => {
                interrupted = true;
                say(format!(
                    "interrupted: {name} checkpointed; run the demo again to continue"
                ));
            }
            Some(_) => {
                failure.get_or_insert(format!(
                    "training {name} failed: {}",
                    last.trim_start_matches("error: ")
                ));
            }
        }
    }
    if let Some(f) = failure {
        bail!("{f}");
    }
    if interrupted || opts.stop.load(std::sync::atomic::Ordering::SeqCst) {
        return Ok(None);
    }
    Ok(Some(results))
}

/// A stage marker: the stage's output is current if the marker names the same checkpoint (its step, the
/// hash of its weights, and which weights sample: a retrained run at the same step is another model).
fn marker_matches(path: &Path, ck: &Checkpoint) -> bool {
    std::fs::read_to_string(path).ok().as_deref() == Some(&marker_text(ck))
}

fn marker_text(ck: &Checkpoint) -> String {
    let weights = ck.weights_file();
    format!(
        "step {}\nparams_hash {}\nweights {}\n",
        ck.state.step,
        ck.sampled_hash(),
        weights.file_name().unwrap_or_default().to_string_lossy()
    )
}

/// The dance of run `ck` to the held-out song under `out/dances/<dir_name>/` (a genre-control run dances
/// in `genre`, a keyframe-control run through `keyframes`), with its files and joints; reused when the
/// marker names the same checkpoint.
pub(crate) fn dance(
    out: &Path,
    data: &Path,
    dir_name: &str,
    ck: &Checkpoint,
    frames: usize,
    (genre, keyframes): (
        Option<crate::gpt::GenreChoice>,
        Vec<crate::keyframe_control::KeyframeRequest>,
    ),
) -> crate::Result<(Vec<PathBuf>, Vec<qean_eval::Frame>)> {
    let name = dir_name;
    let dir = out.join("dances").join(dir_name);
    let stem = "Vibe_Ace";
    let marker = dir.join(".done");
    let expected: Vec<PathBuf> = ["pkl", "joints.npy", "bvh", "png", "gif"]
        .iter()
        .map(|e| dir.join(format!("{stem}.{e}")))
        .collect();
    if marker_matches(&marker, ck) && expected.iter().all(|p| p.is_file()) {
        if let Ok(joints) = qean_eval::io::read_joints(&expected[1], qean_motion::FkRoot::Smpl) {
            say(format!("dance {name}: reusing {}", dir.display()));
            return Ok((expected, joints));
        }
    }
    let song = generate::load_song(
        &out.join(HELD_OUT),
        Some(stem),
        ck.config.min_music_frames(),
    )?;
    // Seed: the opening of the first test sequence (a pose the models know, unlike a T-pose).
    let ds = qean_aistpp::dataset::Dataset::open(data)?;
    let first = first_test(&ds)?;
    let seed = generate::seed_motion(
        &SeedSource::Sequence {
            data: data.to_path_buf(),
            name: first,
        },
        qean_eval::run_report::SeedStart::Zero,
        ck,
    )?;
    let pb =
        qean_checkpoint::progress::bar(frames as u64, &format!("[demo] dance {name}"), "frames");
    let written = generate::generate(
        ck,
        &[song],
        &seed,
        &GenerateOptions {
            frames,
            audio_pad: qean_models::autoregress::AudioPad::Stop,
            feedback_project: ck.config.recipe.feedback_project,
            ensemble: ck.config.recipe.ensemble,
            ensemble_decay: ck.config.recipe.ensemble_decay,
            seam_frames: ck.config.recipe.seam_frames,
            render: true,
            backend: ck.config.train.backend,
            temperature: None,
            top_k: None,
            decode: None,
            repetition_penalty: None,
            genre_guidance: None,
            floor_window: None,
            slide_window: None,
            smooth_sigma: None,
            sample_seed: 0,
            genre,
            text: Vec::new(),
            keyframes,
            keyframe_run: None,
        },
        &dir,
        |done, total| {
            pb.set_length(total as u64);
            pb.set_position(done as u64);
        },
    )?;
    pb.finish_and_clear();
    atomic_write(&marker, marker_text(ck).as_bytes())?;
    let g = &written[0];
    say(format!(
        "dance {name}: {} seed + {} generated frames → {}",
        ck.config.seed_frames(),
        g.generated,
        dir.display()
    ));
    Ok((
        g.paths.all().iter().map(|p| p.to_path_buf()).collect(),
        qean_eval::run_report::frames_of(g.joints.clone()),
    ))
}

/// The demo dataset's first test sequence: the held-out dances' seed, the ground truth beside them, the
/// dance the in-betweening section rebuilds.
pub(crate) fn first_test(ds: &qean_aistpp::dataset::Dataset) -> crate::Result<String> {
    ds.split(qean_aistpp::dataset::Split::Test)
        .into_iter()
        .next()
        .context("the demo dataset has no test sequence")
}

/// `dances/compare.html`: the first test sequence's ground truth (to its own music) beside every model's
/// dance to the held-out song, with that song playing.
fn compare_page(
    out: &Path,
    data: &Path,
    models: &[ModelResult],
    more: &[&DanceResult],
) -> crate::Result<PathBuf> {
    use crate::view::{write_page, PageDance, PageMusic};
    let root = qean_motion::FkRoot::Smpl;
    let ds = qean_aistpp::dataset::Dataset::open(data)?;
    let first = first_test(&ds)?;
    let gt = ds.read_motion(&first)?;
    let mut dances = vec![PageDance {
        label: format!("ground truth ({first}, to its own music)"),
        joints: gt.joints(root),
        seed_frames: 0,
        marks: Vec::new(),
    }];
    for d in models
        .iter()
        .flat_map(|m| &m.dances)
        .chain(more.iter().copied())
    {
        let npy = d
            .files
            .iter()
            .find(|p| p.to_string_lossy().ends_with(".joints.npy"))
            .context("a demo dance without joints")?;
        dances.push(PageDance {
            label: d.label.clone(),
            joints: qean_motion::joints_file::load_joints(npy, root)?,
            seed_frames: d.seed_frames,
            marks: Vec::new(),
        });
    }
    let page = out.join("dances").join("compare.html");
    let music = PageMusic {
        path: out.join(HELD_OUT),
        link: false,
    };
    write_page(
        &page,
        &dances,
        Some(&music),
        "qean demo: the held-out song",
        false,
    )?;
    Ok(page)
}

fn evaluate(
    run_dir: &Path,
    data: &Path,
    ck: &Checkpoint,
    max_frames: usize,
) -> crate::Result<(RunReport, PathBuf)> {
    let dir = run_dir
        .join("eval")
        .join(qean_checkpoint::run_dir::checkpoint_name(ck.state.step));
    let json = dir.join("report.json");
    let md = dir.join("report.md");
    if json.is_file() && md.is_file() {
        if let Ok(report) = read_report(&json) {
            if report.baselines.is_some()
                && report.step == ck.state.step
                && report.frames == max_frames
            {
                say(format!("evaluate: reusing {}", md.display()));
                return Ok((report, md));
            }
        }
    }
    say(format!(
        "evaluate: {} on the test + val split",
        run_dir.display()
    ));
    let req = RunEvalRequest {
        checkpoint: Some(ck.dir.to_string_lossy().into_owned()),
        max_frames,
        baselines: true,
        ..RunEvalRequest::new(run_dir, data)
    };
    let evaluation = evaluate_run(&req)?;
    Ok((evaluation.report, md))
}

fn read_report(path: &Path) -> crate::Result<RunReport> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("{}: cannot read", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{}: not a report", path.display()))
}

fn num(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), |x| format!("{x:.4}"))
}

/// The final tables: the evaluation (ground truth, each model, the chance baselines), the
/// held-out dance's motion energy, Li et al.'s metrics; then the checks, in words.
pub fn table(models: &[ModelResult], reference: &EnergyReference) -> String {
    eval_table(models)
        + &held_out_table(models, reference)
        + &li_table(models)
        + "\n"
        + &checks(models)
}

/// The evaluation on the test + val split: the ground truth, each model, the chance baselines.
fn eval_table(models: &[ModelResult]) -> String {
    let mut t = String::from(
        "| | FID_k ↓ | FID_g ↓ | Dist_k → | Dist_g → | BeatAlign ↑ | speed ratio → 1 | accel ratio → 1 | frozen ↓ | PFC ↓ | train time |\n\
         |---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    if let Some(first) = models.first().and_then(|m| m.report.reports.first()) {
        t += &format!(
            "| ground truth (synthetic test + val) | - | - | {} | {} | {} | 1 | 1 | 0 % | {} | - |\n",
            num(Some(first.gt_div_k)),
            num(Some(first.gt_div_g)),
            num(first.gt_beat_align),
            // A reused report from before PFC has none; another model's has the same reference's.
            num(models
                .iter()
                .find_map(|m| m.report.reports.first()?.gt_pfc))
        );
    }
    let row = |label: &str, r: &MetricsReport, time: &str| {
        let e = r.motion_energy.as_ref();
        format!(
            "| {label} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {time} |\n",
            num(Some(r.fid_k)),
            num(Some(r.fid_g)),
            num(Some(r.div_k)),
            num(Some(r.div_g)),
            num(r.beat_align),
            e.map_or("-".into(), |e| format!("{:.2}", e.speed_ratio)),
            e.map_or("-".into(), |e| format!("{:.2}", e.accel_ratio)),
            e.map_or("-".into(), |e| format!(
                "{:.0} %",
                100.0 * e.freeze_fraction
            )),
            num(r.pfc),
        )
    };
    for m in models {
        if let Some(r) = m.report.reports.first() {
            t += &row(&m.label, r, &format!("{:.0} s", m.train_seconds));
        }
    }
    if let Some(b) = models.first().and_then(|m| m.report.baselines.as_ref()) {
        t += &row("chance: frozen seed pose", &b.frozen, "-");
    }
    for m in models {
        if let Some(r) = m
            .report
            .baselines
            .as_ref()
            .and_then(|b| b.random_pairing.as_ref())
        {
            // Same motions as the model's row, so only BeatAlign differs.
            t += &format!(
                "| chance: {} with random music (all pairings) | | | | | {} | | | | | - |\n",
                m.label,
                num(r.beat_align)
            );
        }
    }
    t
}

/// The held-out song's dances per 5-s span, with their verdicts.
fn held_out_table(models: &[ModelResult], reference: &EnergyReference) -> String {
    let mut t = format!(
        "\nThe held-out song's dance (generated frames only), against the synthetic ground truth's mean joint speed \
         {:.3} m/s and acceleration {:.2} m/s² (a 1-s window is frozen below {:.3} m/s):\n\n\
         | | speed per 5 s (m/s) | speed ratio per 5 s (0.6–1.6) | accel ratio per 5 s (≤ 2) | frozen (≤ 10 %) | verdict |\n\
         |---|---|---|---|---|---|\n",
        reference.speed,
        reference.accel,
        reference.freeze_threshold()
    );
    for d in models.iter().flat_map(|m| &m.dances) {
        let e = &d.energy;
        let speeds: Vec<String> = e.spans.iter().map(|s| format!("{:.2}", s.speed)).collect();
        t += &format!(
            "| {} | {} | {} | {} | {:.0} % | {} |\n",
            d.label,
            speeds.join("/"),
            e.span_speed_ratios(),
            e.span_accel_ratios(),
            100.0 * e.freeze_fraction,
            e.verdict_word()
        );
    }
    t
}

/// One line per model: its held-out dances in words, FID_k against 0.7 × the frozen baseline's, BeatAlign
/// against random pairing's.
fn checks(models: &[ModelResult]) -> String {
    let mut t = String::new();
    for m in models {
        let (Some(r), Some(b)) = (m.report.reports.first(), m.report.baselines.as_ref()) else {
            continue;
        };
        let dances: Vec<String> = m
            .dances
            .iter()
            .map(|d| {
                if m.dances.len() == 1 {
                    format!("the held-out dance {}", dance_sentence(&d.energy))
                } else {
                    format!(
                        "the held-out dance as {} {}",
                        d.dir,
                        dance_sentence(&d.energy)
                    )
                }
            })
            .collect();
        t += &format!("- {}: {}", m.label, dances.join("; "));
        let bound = 0.7 * b.frozen.fid_k;
        let fid = if r.fid_k <= bound { "met" } else { "NOT met" };
        t += &format!(
            "; FID_k {:.2} vs 0.7 × the frozen baseline's {:.2} = {bound:.2}: {fid}",
            r.fid_k, b.frozen.fid_k
        );
        if let (Some(d), Some(g)) = (r.dancing, r.reference_dancing) {
            t += &format!(
                "; {} of {} test + val dances within the dancing limits (the ground truth's own: {} of {})",
                d.dancing, d.of, g.dancing, g.of
            );
        }
        if let (Some(c), Some(g)) = (r.foot_contact, r.reference_foot_contact) {
            t += &format!(
                "; feet on the floor in {:.0} % of the frames (ground truth {:.0} %)",
                100.0 * c.share,
                100.0 * g.share
            );
        }
        match (
            r.beat_align,
            b.random_pairing.as_ref().and_then(|x| x.beat_align),
        ) {
            (Some(ours), Some(chance)) => {
                let ba = if ours > chance { "above" } else { "NOT above" };
                t += &format!("; BeatAlign {ours:.4} is {ba} random pairing's {chance:.4}\n");
            }
            _ => t += "; BeatAlign: no music beats\n",
        }
    }
    t
}

/// Li et al.'s metrics (SPEC §11.9–11.11) of every model, with the ground truth's.
fn li_table(models: &[ModelResult]) -> String {
    let mut t = String::from(
        "\nLi et al.'s metrics (motion beats vs the ground truth's, diversity within and across dances, joint \
         limits and speeds):\n\n\
         | | beat F1 ↑ | A-seq-D → | I-seq-D → | S-music-D ↑ | Authenticity ↑ | Coherence ↑ |\n\
         |---|---|---|---|---|---|---|\n",
    );
    if let Some(first) = models.first().and_then(|m| m.report.reports.first()) {
        let l = &first.li;
        t += &format!(
            "| ground truth | - | {} | {} | - | {} | {} |\n",
            num(Some(l.gt_a_seq_d)),
            num(l.gt_i_seq_d),
            num(Some(l.gt_authenticity)),
            num(Some(l.gt_coherence))
        );
    }
    for m in models {
        if let Some(r) = m.report.reports.first() {
            let l = &r.li;
            t += &format!(
                "| {} | {} | {} | {} | {} | {} | {} |\n",
                m.label,
                num(l.beat_f1),
                num(Some(l.a_seq_d)),
                num(l.i_seq_d),
                num(l.s_music_d),
                num(Some(l.authenticity)),
                num(Some(l.coherence))
            );
        }
    }
    t
}

/// "keeps dancing (…)" or "FROZE (…)", with the numbers that decide it.
fn dance_sentence(e: &MotionEnergy) -> String {
    let detail = format!(
        "speed ratio per 5 s {}, accel ratio per 5 s {}, {:.0} % of 1-s windows frozen",
        e.span_speed_ratios(),
        e.span_accel_ratios(),
        100.0 * e.freeze_fraction
    );
    if e.dances() {
        format!("keeps dancing ({detail})")
    } else {
        format!("does NOT dance: {} ({detail})", e.verdict_word())
    }
}

/// What the table needs said under it: `--quick` is a smoke test; a held-out dance that froze.
fn table_note(budget: &Budget, models: &[ModelResult]) -> String {
    if budget.quick {
        return format!(
            "\nThis was `qean demo --quick`, a smoke test of every stage: {} training steps are far too few, so its \
             dances may freeze or jitter. `qean demo` trains long enough for dances that dance.\n",
            budget.steps
        );
    }
    if models
        .iter()
        .flat_map(|m| &m.dances)
        .any(|d| !d.energy.dances())
    {
        return format!(
            "\nA held-out dance that froze or jitters is not a dance, whatever its metrics. The table above scores \
             up to {:.0} s per test and validation sequence; the held-out dance is {:.0} s of a real song. At this \
             budget tiny FACT and tiny QEAN each kept dancing to it in two training seeds of three (this demo is seed \
             0); docs/freezing.md (sections 5 and 6) has the measurements and what was tried.\n",
            budget.eval_frames as f64 / 60.0,
            budget.dance_frames as f64 / 60.0
        );
    }
    String::new()
}

/// summary.md: the setting, the table, the artefacts and the time taken.
fn summary_text(
    budget: &Budget,
    data: &Path,
    table: &str,
    models: &[ModelResult],
    inbetween: &inbetween::InbetweenDemo,
    seconds: f64,
) -> String {
    let mut summary = format!(
        "# qean demo\n\nDataset: {} ({} sequences of ~{} s{}). FACT and QEAN trained {} steps, TSMT {}, the VQ-VAE and \
         the GPT {} one after the other, genre control {} after them (batch {}, FACT/QEAN windows of {} motion / {} \
         music frames) on CPU; scored on the test + val split (seed = the first {} ground-truth frames, TSMT's and \
         the GPT's 120, then up to {} generated frames), Bailando's metrics and Li et al.'s.\n\n{table}\n## Artefacts\n\n",
        data.display(),
        budget.sequences,
        budget.seconds,
        if budget.genre_data {
            "; --genre-data: each genre holds its posture, its music plays its riff"
        } else {
            ""
        },
        budget.steps,
        budget.steps_for("tsmt"),
        budget.steps_for(GPT),
        budget.steps_for(GENRE),
        budget.batch_size,
        budget.motion_len,
        budget.audio_len,
        budget.motion_len,
        budget.eval_frames
    );
    for m in models {
        summary += &format!(
            "- {}: run {}, checkpoint {}, report {}\n",
            m.label,
            m.run_dir.display(),
            m.checkpoint.display(),
            m.report_md.display()
        );
        for p in m.dances.iter().flat_map(|d| &d.files) {
            summary += &format!("  - {}\n", p.display());
        }
    }
    summary += &format!(
        "- in-betweening: {} (checkpoint {})\n",
        inbetween
            .checkpoint
            .parent()
            .and_then(Path::parent)
            .unwrap_or(&inbetween.checkpoint)
            .display(),
        inbetween.checkpoint.display()
    );
    for r in &inbetween.rows {
        for p in &r.files {
            summary += &format!("  - {}: {}\n", r.label, p.display());
        }
    }
    summary += &format!("\nTotal time of this demo run: {seconds:.0} s\n");
    summary
}

/// The models trained side by side: (run name, label, preset).
const PRESETS: [(&str, &str, &str); 5] = [
    ("fact", "tiny FACT", "configs/tiny/fact.toml"),
    (
        "qean",
        "tiny QEAN (full: SPE + QRA)",
        "configs/tiny/full.toml",
    ),
    (
        "tsmt",
        "small TSMT (Li et al.; mean decoding)",
        "configs/tsmt/small.toml",
    ),
    (
        CLF,
        "tiny genre classifier",
        "configs/control/genre_clf_tiny.toml",
    ),
    (
        INBETWEENER,
        "tiny motion in-betweener (Lin + sin² taper, velocity loss)",
        "configs/inbetween/tiny_motion_smooth.toml",
    ),
];

/// The VQ-VAE, the GPT over its tokens and genre control over the GPT: one after the other, beside the
/// others.
const CHAIN: [(&str, &str, &str); 4] = [
    (VQ, "tiny motion VQ-VAE", "configs/control/vqvae_tiny.toml"),
    (
        GPT,
        "tiny VQ-VAE + GPT (multi-modal control)",
        "configs/control/gpt_tiny.toml",
    ),
    (
        GENRE,
        "tiny GPT + genre control (each track in its genre)",
        "configs/control/genre_tiny.toml",
    ),
    (
        KEYFRAME,
        "tiny GPT + keyframe control",
        "configs/control/keyframe_tiny.toml",
    ),
];

/// A finished stage: its run name, its label and what training left.
type TrainedStage = (&'static str, &'static str, Trained);

/// Trains every stage (side by side, the VQ-VAE → GPT → genre chain in its own thread); `None` when
/// interrupted. Each finished run with its name and label.
fn train_stages(opts: &DemoOptions, data: &Path) -> crate::Result<Option<Vec<TrainedStage>>> {
    let (side, chained) = std::thread::scope(|scope| {
        let chained = scope.spawn(|| -> crate::Result<Option<Vec<Trained>>> {
            let mut done = Vec::new();
            for stage in &CHAIN {
                match train_all(opts, data, std::slice::from_ref(stage))? {
                    Some(mut t) => done.push(t.remove(0)),
                    None => return Ok(None),
                }
            }
            Ok(Some(done))
        });
        let side = train_all(opts, data, &PRESETS);
        (side, chained.join())
    });
    let chained = chained
        .map_err(|_| crate::Error::invalid("internal: the VQ-VAE → GPT → genre thread panicked"))?;
    let (Some(side), Some(chained)) = (side?, chained?) else {
        return Ok(None);
    };
    let trained: Vec<_> = PRESETS
        .iter()
        .chain(&CHAIN)
        .zip(side.into_iter().chain(chained))
        .map(|((name, label, _), t)| (*name, *label, t))
        .collect();
    Ok(Some(trained))
}

/// The run's dances to the held-out song (genre control: one per shown genre), each with its motion
/// energy against the dataset's.
fn held_out_dances(
    out: &Path,
    data: &Path,
    name: &str,
    label: &str,
    ck: &Checkpoint,
    budget: &Budget,
    reference: &EnergyReference,
) -> crate::Result<Vec<DanceResult>> {
    let steered: Vec<(String, String, Option<crate::gpt::GenreChoice>)> = if name == GENRE {
        genre::SHOWN
            .iter()
            .map(|g| {
                let choice =
                    crate::gpt::GenreChoice::parse(g, qean_aistpp::layout::GenreSet::Aistpp, 0)?;
                Ok((
                    format!("genre-{g}"),
                    format!("tiny GPT + genre control, --genre {g}"),
                    Some(choice),
                ))
            })
            .collect::<crate::Result<_>>()?
    } else {
        vec![(name.to_string(), label.to_string(), None)]
    };
    let mut dances = Vec::new();
    for (dir, dance_label, genre) in steered {
        let (files, joints) = dance(
            out,
            data,
            &dir,
            ck,
            budget.dance_frames,
            (genre, Vec::new()),
        )?;
        let seed_frames = ck.config.seed_frames().min(joints.len());
        let (_, energy) = motion_energy([&joints[seed_frames..]], reference);
        say(format!("dance {dir}: {}", energy.describe(reference)));
        dances.push(DanceResult {
            label: dance_label,
            dir,
            files,
            energy,
            seed_frames,
        });
    }
    Ok(dances)
}

/// Runs the demo.
pub fn run(opts: &DemoOptions) -> crate::Result<DemoResult> {
    let started = Instant::now();
    let out = &opts.out;
    std::fs::create_dir_all(out).with_context(|| format!("{}: cannot create", out.display()))?;
    write_assets(out)?;
    if opts.budget.quick {
        say(format!(
            "--quick: a smoke test of every stage ({} training steps): its dances may freeze or jitter",
            opts.budget.steps
        ));
    }
    let data = dataset(out, &opts.budget)?;
    // The music features, once, before the training processes start: three processes filling the
    // same cache at once would replace each other's files under each other's reads.
    let ds = qean_aistpp::dataset::Dataset::open(&data)?;
    let computed = qean_checkpoint::features::ensure_features(&ds, &ds.all_sequences()?)?;
    if computed > 0 {
        say(format!(
            "features: computed the music features of {computed} music IDs"
        ));
    }
    let Some(mut trained) = train_stages(opts, &data)? else {
        return Ok(DemoResult::interrupted(data));
    };
    let take = |trained: &mut Vec<(&str, &str, Trained)>, name: &str| {
        let i = trained.iter().position(|t| t.0 == name).expect("trained");
        trained.remove(i).2
    };
    let (ib_ck, _, _) = take(&mut trained, INBETWEENER);
    let (clf_ck, _, _) = take(&mut trained, CLF);
    let (kf_ck, _, _) = take(&mut trained, KEYFRAME);
    take(&mut trained, VQ);
    let reference =
        qean_eval::run_report::dataset_energy_reference(&data, qean_motion::FkRoot::Smpl)?;
    let mut models = Vec::new();
    for (name, label, (ck, seconds, loss)) in trained {
        let run_dir = out.join("runs").join(name);
        let dances = held_out_dances(out, &data, name, label, &ck, &opts.budget, &reference)?;
        let (report, report_md) = evaluate(&run_dir, &data, &ck, opts.budget.eval_frames)?;
        models.push(ModelResult {
            label: label.to_string(),
            run_dir,
            checkpoint: ck.dir.clone(),
            train_seconds: seconds,
            final_loss: loss,
            dances,
            report_md,
            report,
        });
    }
    say("genre control: the classifier on the ground truth, then every test + val music in each of the 10 genres");
    let genre = genre::run(
        &data,
        &clf_ck,
        &out.join("runs").join(GENRE),
        opts.budget.eval_frames,
    )?;
    say("keyframe control: the held-out dance through two poses of a test dance, then the fidelity test");
    let keyframe = keyframe::run(out, &data, &kf_ck, &opts.budget, &reference)?;
    let page = compare_page(out, &data, &models, &[&keyframe.dance])?;
    say(format!(
        "view: {} (every model's dance to the held-out song in 3-D with the music; open it in a browser)",
        page.display()
    ));
    say(format!(
        "in-betweening: rebuilding a test dance from {} keys per measure",
        inbetween::KEYS
    ));
    let inbetween = inbetween::run(out, &data, &out.join("runs").join(INBETWEENER), &ib_ck)?;
    let table = table(&models, &reference)
        + &table_note(&opts.budget, &models)
        + &genre::table(&genre)
        + &keyframe::table(&keyframe)
        + &inbetween::table(&inbetween);
    let summary = summary_text(
        &opts.budget,
        &data,
        &table,
        &models,
        &inbetween,
        started.elapsed().as_secs_f64(),
    );
    let path = out.join("summary.md");
    atomic_write(&path, summary.as_bytes())?;
    if models.is_empty() {
        bail!("internal: no model trained");
    }
    Ok(DemoResult {
        dataset: data,
        models,
        table,
        summary: path,
        inbetween: Some(inbetween),
        finished: true,
    })
}

#[cfg(test)]
mod tests {
    //! The demo's stages are library code: called here without a process.

    use super::*;

    fn options(out: &Path, genre_data: bool) -> DemoOptions {
        DemoOptions {
            out: out.to_path_buf(),
            budget: Budget {
                genre_data,
                ..Budget::new(true)
            },
            stop: Arc::new(AtomicBool::new(false)),
            progress: ProgressMode::Quiet,
            // Never started: the checks below stop the demo before any training.
            exe: PathBuf::from("/nonexistent/qean"),
        }
    }

    /// A dataset left by a demo of the other kind (with or without --genre-data) is refused before anything
    /// trains, with one line that names it and says what to do.
    #[test]
    fn demo_refuses_a_dataset_of_the_other_kind() {
        for (made_with, wanted) in [(true, false), (false, true)] {
            let dir = tempfile::tempdir().unwrap();
            let data = dir.path().join("data");
            std::fs::create_dir_all(&data).unwrap();
            let names: Vec<String> = (0..24).map(|i| format!("\"s{i}\"")).collect();
            let report = format!(
                "{{\"varied_music\": true, \"seconds\": 8.0, \"genre_postures\": {made_with}, \
                 \"genre_music\": {made_with}, \"splits\": {{\"train\": [{}]}}}}",
                names.join(", ")
            );
            std::fs::write(data.join("synth.json"), report).unwrap();
            let e = run(&options(dir.path(), wanted)).unwrap_err().to_string();
            assert!(e.contains("--genre-data") && e.contains("data"), "{e}");
            assert!(!e.contains('\n'), "one line: {e}");
            assert!(!dir.path().join("runs").exists(), "nothing trained");
        }
    }

    /// Each stage's share of the budget (the docs quote these).
    #[test]
    fn stage_budgets() {
        let b = Budget::new(false);
        assert_eq!(b.steps_for("fact"), 4000);
        assert_eq!(b.steps_for("tsmt"), 3000);
        assert_eq!(b.steps_for("gpt"), 3000);
        assert_eq!(b.steps_for("genre"), 2000);
        assert_eq!(b.steps_for("genre_clf"), 1000);
        assert!(!b.genre_data);
    }
}
