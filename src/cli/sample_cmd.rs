//! `qean sample`: a dance from any song with a trained checkpoint.

use qean_config::ModelSpec;
use std::path::PathBuf;

use anyhow::bail;
use clap::Args;
use qean_checkpoint::checkpoint;
use qean_models::autoregress::AudioPad;
use qean_pipeline::generate::{self, GenerateOptions, SeedSource};
use qean_pipeline::gpt::{KeyframeRequest, TextRequest};

/// Generate a dance for each song with a trained model (SPEC §6): one model pass per frame, sliding
/// the motion and music windows; each new frame is the first output token (mint) or the mean of what
/// the last N passes predicted for it (the run's `recipe.ensemble`). Prints each dance's speed per
/// 5 s and warns when it froze or jitters.
///
/// Writes, per song, into --out:
///   NAME.pkl         AIST++ format (smpl_poses, smpl_trans, smpl_scaling, seed_frames)
///   NAME.joints.npy  joint positions, frames × 24 × 3, float32, +Y up, 60 fps
///   NAME.bvh         SMPL skeleton at 60 fps (opens in Blender)
///   NAME.png/.gif    with --render: a contact sheet with the music's beats marked, and an
///                    animation
/// Every output starts with the seed frames (the run's `model.motion_len`: 120 for mint's FACT,
/// 30 in the demo; TSMT: `tsmt.seed_frames`, 120).
///
/// TSMT runs draw every joint coordinate from its predicted bins: --temperature, --top-k and
/// --sample-seed choose how (same seed, same dance); FACT and QEAN are deterministic and ignore them.
///
/// Example: qean sample --run runs/full --music song.ogg --out dances --render
#[derive(Args, Debug)]
#[command(verbatim_doc_comment)]
#[command(about = "Generate dances for songs with a trained model")]
pub struct SampleArgs {
    /// Run directory (its newest checkpoint is used unless --checkpoint names one).
    #[arg(long)]
    pub run: PathBuf,
    /// Checkpoint of the run: step-N, N, or a path.
    #[arg(long)]
    pub checkpoint: Option<String>,
    /// Song(s) to dance to (wav, ogg, mp3, flac); several are generated as one batch.
    #[arg(long, required = true)]
    pub music: Vec<PathBuf>,
    /// Seed motion: the first 120 frames of this AIST++ pickle (default: a neutral standing pose).
    #[arg(long, conflicts_with_all = ["data", "sequence"])]
    pub seed_motion: Option<PathBuf>,
    /// Seed from a dataset sequence: the dataset directory (with --sequence).
    #[arg(long, requires = "sequence")]
    pub data: Option<PathBuf>,
    /// Seed from a dataset sequence: its name (with --data).
    #[arg(long, requires = "data")]
    pub sequence: Option<String>,
    /// Where the seed starts in the seed motion: zero (its first frames) or random[:SEED] (a seeded
    /// uniform draw, QEAN's "random motion seeds"). Ignored for the standing pose.
    #[arg(long, default_value = "zero")]
    pub seed_start: qean_eval::run_report::SeedStart,
    /// Frames to generate after the seed (at 60 fps; mint: 1200 = 20 s).
    #[arg(long, default_value_t = 1200)]
    pub frames: usize,
    /// When the music ends first: stop (mint) or edge (repeat the last music frame).
    #[arg(long, value_enum, default_value_t = AudioPad::Stop)]
    pub audio_pad: AudioPad,
    /// Project fed-back rotations to SO(3) and zero the pad dims (default: the run's
    /// recipe.feedback_project; off in mint's reference sampler).
    #[arg(long, conflicts_with = "raw_feedback")]
    pub feedback_project: bool,
    /// Feed the raw outputs back unchanged, as mint does (overrides the run's recipe).
    #[arg(long)]
    pub raw_feedback: bool,
    /// Temporal ensembling: each frame the mean of what the last N passes predicted for it
    /// (default: the run's recipe.ensemble; 1 = mint's first output token only).
    #[arg(long)]
    pub ensemble: Option<usize>,
    /// Weight e^(−X·k) of the pass k frames back when ensembling (default: the run's recipe).
    #[arg(long)]
    pub ensemble_decay: Option<f64>,
    /// Ease the seed's end: the jump from the seed to the first generated frame fades out over
    /// N frames, fed back to the model as generated (GPT runs: the decoded body eased out of the
    /// seed's last pose) (default: the run's recipe.seam_frames; 0 = off, as mint).
    #[arg(long)]
    pub seam_frames: Option<usize>,
    /// Output directory (created if missing).
    #[arg(long)]
    pub out: PathBuf,
    /// Output name (one song only; default: the song's file stem).
    #[arg(long)]
    pub name: Option<String>,
    /// Also write a preview: PNG contact sheet with beats marked, and an animated GIF.
    #[arg(long)]
    pub render: bool,
    /// Also write NAME.view.html per song: the dance in 3-D with its music, in one offline page (`qean view`).
    #[arg(long)]
    pub view: bool,
    /// Backend (default: the run's).
    #[arg(long, value_enum)]
    pub backend: Option<qean_models::backend::Backend>,
    /// TSMT and GPT: sampling temperature (0 = the most likely bin or code; default: the run's
    /// tsmt.temperature / gpt.temperature, 1).
    #[arg(long)]
    pub temperature: Option<f64>,
    /// TSMT and GPT: draw only from the k most likely bins or codes (0 = all; default: the run's top_k;
    /// a GPT's is 1, greedy as Bailando).
    #[arg(long)]
    pub top_k: Option<usize>,
    /// TSMT: how sampled bins become joint coordinates: bin (the paper: every coordinate draws its own
    /// bin, decoded to the bin's centre), subbin (the same draws, each value the mean of its distribution
    /// around the drawn bin), coherent (one smooth quantile per frame shared by every coordinate, read
    /// continuously: no jitter from independent draws or bin steps), mean (each distribution's mean,
    /// deterministic). Default: the run's tsmt.decode. docs/tsmt.md compares them.
    #[arg(long)]
    pub decode: Option<String>,
    /// GPT: divide the logits of codes used in the last gpt.repetition_window tokens (8) by this before
    /// picking (1 = off, Bailando's picking; default: the run's gpt.repetition_penalty).
    #[arg(long)]
    pub repetition_penalty: Option<f64>,
    /// Genre runs: logits = plain + S·(genre − plain), the frozen GPT's without the genre tokens as plain
    /// (1 = the paper's; larger steers harder; default: the run's genre.guidance). docs/control.md.
    #[arg(long, value_name = "S")]
    pub genre_guidance: Option<f64>,
    /// GPT: pin the decoded dance's lowest point to the seed's floor over windows of N frames, so a root
    /// integrated from decoded velocities does not sink through the floor (0 = off, the paper's decoding;
    /// default: the run's gpt.floor_window).
    #[arg(long)]
    pub floor_window: Option<usize>,
    /// GPT: take the slow glide of the planted feet away over windows of N frames (the decoded root's bias
    /// also slides the dance sideways; a dance that travels by stepping keeps its travel) (0 = off, the
    /// paper's decoding; default: the run's gpt.slide_window).
    #[arg(long)]
    pub slide_window: Option<usize>,
    /// GPT and TSMT: smooth the decoded joints over time with a Gaussian of σ frames, taking the token decoder's
    /// frame-to-frame roughness away (0 = off, the paper's decoding; default: the run's gpt.smooth_sigma or tsmt.smooth_sigma).
    #[arg(long)]
    pub smooth_sigma: Option<f64>,
    /// TSMT and GPT: seed of the draws.
    #[arg(long, default_value_t = 0)]
    pub sample_seed: u64,
    /// Genre-control runs (model.arch = "gpt_genre"): dance in this genre. AIST++: BR (break), PO (pop),
    /// LO (lock), MH (middle hip-hop), LH (LA hip-hop), HO (house), WA (waack), KR (krump), JS (street
    /// jazz), JB (ballet jazz); FineDance: its labels (Breaking, Popping, Dai, Kun, …).
    #[arg(long)]
    pub genre: Option<String>,
    /// With --genre: the seed of the genre noise z (another seed, another dance of the same genre).
    #[arg(long, default_value_t = 0, requires = "genre")]
    pub z_seed: u64,
    /// GPT runs with a trained T-Base: put a described move into the dance (text control, SPEC §13.7). A .npy
    /// of gpt.text_dim values (e.g. a CLIP ViT-B/32 text embedding; the encoder is not shipped: compute it
    /// yourself) or genre:XX (the synthetic text set's pseudo-embedding of genre XX). Repeat it, each
    /// with its own --text-interval, for several texts in one dance.
    #[arg(long, requires = "text_interval")]
    pub text_embedding: Vec<String>,
    /// With --text-embedding: where, in seconds of the output dance (seed included), e.g. 4.0..6.5.
    #[arg(long, requires = "text_embedding")]
    pub text_interval: Vec<String>,
    /// Keyframe-control runs (model.arch = "gpt_keyframe", SPEC §13.6): poses the dance must pass through,
    /// {"keyframes": [{"frame": F, "pose_aa": [72 SMPL axis-angle], "trans": [3]}, ...]}, F a frame of the
    /// output dance (60 fps, seed included).
    #[arg(long, conflicts_with = "keyframes_from")]
    pub keyframes: Option<PathBuf>,
    /// Keyframe-control runs: take the keyframes from this motion file (.pkl), at --keyframe-frames.
    #[arg(long, requires = "keyframe_frames")]
    pub keyframes_from: Option<PathBuf>,
    /// With --keyframes-from: frames of the output dance (seed included), e.g. 240,600; each takes that
    /// frame's pose of the motion file.
    #[arg(long, value_delimiter = ',', requires = "keyframes_from")]
    pub keyframe_frames: Vec<usize>,
    /// GPT and genre-control runs: the keyframe module of this keyframe-control run (over the same GPT)
    /// for --keyframes, so genre, text and keyframes go in one dance.
    #[arg(long)]
    pub keyframe_run: Option<PathBuf>,
}

pub fn sample(a: SampleArgs) -> anyhow::Result<i32> {
    if a.name.is_some() && a.music.len() > 1 {
        bail!("--name works with one --music only");
    }
    if a.frames == 0 {
        bail!("--frames must be at least 1");
    }
    let ck = checkpoint::resolve_in_run(&a.run, a.checkpoint.as_deref())?;
    let genre = genre_choice(&a, &ck)?;
    let decode = decode_choice(a.decode.as_deref(), &ck)?;
    let audio_len = ck.config.min_music_frames();
    let mut songs = Vec::new();
    for path in &a.music {
        songs.push(generate::load_song(path, a.name.as_deref(), audio_len)?);
    }
    let source = match (&a.seed_motion, &a.data, &a.sequence) {
        (Some(p), _, _) => SeedSource::Pickle(p.clone()),
        (None, Some(d), Some(n)) => SeedSource::Sequence {
            data: d.clone(),
            name: n.clone(),
        },
        _ => SeedSource::Standing,
    };
    let seed = generate::seed_motion(&source, a.seed_start, &ck)?;
    let opts = GenerateOptions {
        frames: a.frames,
        audio_pad: a.audio_pad,
        feedback_project: ck
            .config
            .recipe
            .feedback_project_with(a.feedback_project, a.raw_feedback),
        ensemble: a.ensemble.unwrap_or(ck.config.recipe.ensemble),
        ensemble_decay: a.ensemble_decay.unwrap_or(ck.config.recipe.ensemble_decay),
        seam_frames: a.seam_frames.unwrap_or(ck.config.recipe.seam_frames),
        render: a.render,
        backend: a.backend.unwrap_or(ck.config.train.backend),
        temperature: a.temperature,
        top_k: a.top_k,
        decode,
        repetition_penalty: a.repetition_penalty,
        genre_guidance: a.genre_guidance,
        floor_window: a.floor_window,
        slide_window: a.slide_window,
        smooth_sigma: a.smooth_sigma,
        sample_seed: a.sample_seed,
        genre,
        text: TextRequest::list(&a.text_embedding, &a.text_interval)?,
        keyframes: KeyframeRequest::of_args(
            a.keyframes.as_deref(),
            a.keyframes_from
                .as_deref()
                .map(|m| (m, a.keyframe_frames.as_slice())),
        )?,
        keyframe_run: a.keyframe_run.clone(),
    };
    opts.check(&ck)?;
    let pb = qean_checkpoint::progress::bar(a.frames as u64, "", "frames");
    let written = generate::generate(&ck, &songs, &seed, &opts, &a.out, |done, total| {
        pb.set_length(total as u64);
        pb.set_position(done as u64);
    })?;
    pb.finish_and_clear();
    if a.view {
        let marks = qean_pipeline::view::control_marks(&opts);
        write_views(&a, (&ck, &marks), &songs, &written)?;
    }
    println!("checkpoint: {} (step {})", ck.dir.display(), ck.state.step);
    let reference = energy_reference(&a.run, &ck);
    let seed_frames = ck.config.seed_frames();
    for g in &written {
        println!(
            "{}: {} seed + {} generated frames",
            g.name, seed_frames, g.generated
        );
        for p in g.paths.all() {
            println!("  {}", p.display());
        }
        print_motion(&g.name, &g.joints, seed_frames, reference.as_ref());
    }
    Ok(0)
}

/// Prints a dance's motion profile and warns when it froze, races or jitters.
fn print_motion(
    name: &str,
    joints: &[[f64; 3]],
    seed_frames: usize,
    reference: Option<&qean_eval::motion_energy::EnergyReference>,
) {
    let frames = qean_eval::run_report::frames_of(joints.to_vec());
    let generated = &frames[seed_frames.min(frames.len())..];
    match reference {
        Some(r) if generated.len() >= 3 => {
            let (_, e) = qean_eval::motion_energy::motion_energy([generated], r);
            println!("  motion: {}", e.describe(r));
            println!(
                "  per 5 s: speed ratio {}, acceleration ratio {} (dances: 0.6–1.6 and ≤ 2)",
                e.span_speed_ratios(),
                e.span_accel_ratios()
            );
            for w in e.warnings(r) {
                tracing::warn!("{name}: {w}");
            }
        }
        _ => {
            let speeds = qean_eval::motion_energy::joint_speeds(generated);
            let per_span: Vec<String> = speeds
                .chunks(qean_eval::motion_energy::SPAN)
                .map(|c| format!("{:.2}", c.iter().sum::<f64>() / c.len() as f64))
                .collect();
            println!(
                "  motion: speed per 5 s {} m/s (no reference: the run's dataset is not here, so no freeze check)",
                per_span.join(", ")
            );
        }
    }
}

/// `--decode NAME` for a TSMT run: the decoding, or one line saying what is wrong.
pub fn decode_choice(
    name: Option<&str>,
    ck: &checkpoint::Checkpoint,
) -> anyhow::Result<Option<qean_config::tsmt::TsmtDecode>> {
    let Some(name) = name else {
        return Ok(None);
    };
    let decode = name
        .parse::<qean_config::tsmt::TsmtDecode>()
        .map_err(|e| anyhow::anyhow!("--decode: {e}"))?;
    if ck.config.tsmt.is_none() {
        bail!(
            "--decode is for TSMT runs (binned coordinates); {} is a {:?} run",
            ck.dir.display(),
            ck.config.model.arch
        );
    }
    Ok(Some(decode))
}

/// `--view`: one page per song with its dance and music.
fn write_views(
    a: &SampleArgs,
    (ck, marks): (&checkpoint::Checkpoint, &[qean_pipeline::view::ViewMark]),
    songs: &[generate::Song],
    written: &[generate::Generated],
) -> anyhow::Result<()> {
    let label = a
        .run
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "dance".into());
    for (song, g) in songs.iter().zip(written) {
        let page = a.out.join(format!("{}.view.html", g.name));
        let dance = qean_pipeline::view::PageDance {
            label: label.clone(),
            joints: g.joints.clone(),
            seed_frames: ck.config.seed_frames(),
            marks: marks.to_vec(),
        };
        let music = qean_pipeline::view::PageMusic {
            path: song.path.clone(),
            link: false,
        };
        qean_pipeline::view::write_page(&page, &[dance], Some(&music), &g.name, false)?;
        println!("  {}", page.display());
    }
    Ok(())
}

/// `--genre CODE --z-seed S`, for a genre-control run only.
fn genre_choice(
    a: &SampleArgs,
    ck: &checkpoint::Checkpoint,
) -> anyhow::Result<Option<qean_pipeline::gpt::GenreChoice>> {
    let Some(code) = &a.genre else {
        return Ok(None);
    };
    if !matches!(ck.config.spec(), ModelSpec::GptGenre(..)) {
        bail!(
            "--genre needs a genre-control run (model.arch = \"gpt_genre\", trained with configs/control/genre_tiny.toml); {} is a {:?} run",
            ck.dir.display(),
            ck.config.model.arch
        );
    }
    let set = ck.config.genre_table().genres;
    Ok(Some(qean_pipeline::gpt::GenreChoice::parse(
        code, set, a.z_seed,
    )?))
}

/// The training dataset's motion energy (cached in the run directory), if the dataset is here.
fn energy_reference(
    run: &std::path::Path,
    ck: &checkpoint::Checkpoint,
) -> Option<qean_eval::EnergyReference> {
    let data = ck.config.data.dir.as_ref().filter(|d| d.is_dir())?;
    match qean_eval::run_report::cached_energy_reference(data, &run.join("energy_reference.json")) {
        Ok(r) => Some(r),
        Err(e) => {
            tracing::warn!("no reference motion energy from {}: {e:#}", data.display());
            None
        }
    }
}
