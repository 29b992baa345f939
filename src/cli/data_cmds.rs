//! `qean synth`, `qean inspect`, `qean joints`: the data-layer commands.

use std::path::PathBuf;

use clap::Args;
use qean::eval_cli::RootArg;
use qean_motion::Motion;
use qean_synth as synth;

/// Make a synthetic dataset (in the AIST++ layout unless --layout says another): procedural music per
/// music ID (WAV) and procedural dances phase-locked to it (motion pickles), with train/val/test split lists following the AIST++ naming rules.
/// Each track's loudness, mix and drum sections vary (quiet intros, breakdowns) while its dances keep
/// their energy, so a model learns to dance to the beat and the chords, not to a loudness level.
/// Deterministic for a given seed.
#[derive(Args, Debug)]
#[command(about = "Make a synthetic dataset (any layout): procedural music and dances")]
pub struct SynthArgs {
    /// Output directory (must not exist, or be empty). Written atomically.
    #[arg(long)]
    pub out: PathBuf,
    /// Total number of sequences; about 1/6 each go to val and test.
    #[arg(long, default_value_t = 60)]
    pub sequences: usize,
    /// Length of each sequence in seconds (each varies between 85% and 100% of it).
    #[arg(long, default_value_t = 16.0)]
    pub seconds: f64,
    /// Random seed.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Sample rate of the music files (30720 Hz is the feature rate: no resampling needed).
    #[arg(long, default_value_t = 30720)]
    pub sample_rate: u32,
    /// A recording to use as a training music ID's music instead of procedural music, as
    /// FILE=MUSIC_ID (e.g. song.ogg=mLO0; repeatable); its dances follow the recording's tracked
    /// beats. `qean demo` uses two.
    #[arg(long, value_name = "FILE=MUSIC_ID")]
    pub real_music: Vec<String>,
    /// Plain procedural music: every track at full loudness with drums throughout, as datasets
    /// made before varied music (the default varies loudness, mix and drum sections per track,
    /// which the dances ignore; docs/freezing.md, section 5).
    #[arg(long)]
    pub plain_music: bool,
    /// Give every genre its posture (krump's deep stance, waacking's raised arms, …), held through its
    /// dances: genres a classifier can tell apart (0.85–0.95 against 0.40–0.60), at a cost to models that
    /// hear no genre and must guess it from the music (docs/control.md).
    #[arg(long)]
    pub genre_postures: bool,
    /// Give every genre's procedural music its own riff (a pitched pattern of sixteenths, per genre), so
    /// that the music says the genre as AIST++'s does (docs/control.md).
    #[arg(long)]
    pub genre_music: bool,
    /// Also write a synthetic text–motion set in the HumanML3D layout into DIR (SPEC §13.1): --sequences
    /// procedural dances of at most 10 s, 22 joints at 20 fps, two captions each whose embeddings are the
    /// genre's pseudo-embedding (512 values, what `--text-embedding genre:XX` samples with). It trains a
    /// GPT's T-Base (gpt.text_set = DIR) without a text encoder; it is not language.
    #[arg(long, value_name = "DIR")]
    pub text_set: Option<PathBuf>,
    /// The layout to write: `aistpp`; `finedance` (FineDance's release: motion/NNN.npy, [T, 315] 6-D rotations
    /// at 30 fps; music_wav/NNN.wav; label_json/NNN.json; FineDance@Genre's test and training IDs, so its
    /// embedded split lists apply; AIST++'s val dances left out); `folder` (NAME.pkl beside NAME.wav, splits/).
    #[arg(long, default_value = "aistpp", value_name = "aistpp|finedance|folder")]
    pub layout: qean_aistpp::layout::DataLayout,
}

pub fn synth(a: SynthArgs) -> anyhow::Result<()> {
    let mut real_music = Vec::new();
    for spec in &a.real_music {
        let Some((file, id)) = spec.rsplit_once('=') else {
            anyhow::bail!("--real-music {spec}: expected FILE=MUSIC_ID, e.g. song.ogg=mLO0");
        };
        real_music.push(synth::RealTrack::load(std::path::Path::new(file), id)?);
    }
    let opts = synth::SynthOptions {
        sequences: a.sequences,
        seconds: a.seconds,
        seed: a.seed,
        sample_rate: a.sample_rate,
        real_music,
        varied_music: !a.plain_music,
        genre_postures: a.genre_postures,
        genre_music: a.genre_music,
    };
    let report = synth::generate_as(&a.out, &opts, a.layout)?;
    if let Some(dir) = &a.text_set {
        let text = synth::text_set::TextSynthOptions {
            motions: a.sequences,
            seconds: a.seconds.min(10.0),
            seed: a.seed,
            fps: 20.0,
            dim: 512,
        };
        synth::text_set::generate_text_set(dir, &text)?;
        println!(
            "wrote {}: a text–motion set of {} motions",
            dir.display(),
            a.sequences
        );
    }
    let count = |s: &str| report.splits.get(s).map_or(0, |v| v.len());
    println!(
        "wrote {} ({} layout): {} train, {} val, {} test sequences, {} music tracks",
        a.out.display(),
        a.layout.name(),
        count("train"),
        count("val"),
        count("test"),
        report.music.len()
    );
    Ok(())
}

/// Summarise a motion pickle (.pkl), a .npy array, an audio file (duration, rate, channels, tempo, beats), a
/// model config (.toml: architecture and exact parameter count) or a dataset directory (any layout).
#[derive(Args, Debug)]
#[command(about = "Summarise a motion, array, audio file, model config, run or dataset")]
pub struct InspectArgs {
    /// The file or directory to describe.
    pub path: PathBuf,
}

pub fn inspect(a: InspectArgs) -> anyhow::Result<()> {
    let summary = qean_aistpp::inspect::inspect(&a.path)?;
    print!("{summary}");
    Ok(())
}

/// Check a dataset before training on it: counts, lengths, frame rates, genres, foot sliding, and every
/// defect, one line each — a motion that cannot be read (a NaN frame, a truncated file, a wrong width), a
/// listed sequence without its motion, music missing, unreadable or shorter than its dance, joints out of
/// range, a clip that repeats another. Exits non-zero when it finds one.
#[derive(Args, Debug)]
#[command(
    about = "Check a dataset (AIST++, FineDance or a folder of dances) for defects",
    after_help = "Finds, one line each: motions that cannot be read (a NaN frame, a truncated file, a wrong width), \
listed sequences without a motion, music missing, unreadable or shorter than its dance, joints over 50 m out or \
jumping over 0.5 m in a frame, duplicated clips, unknown genre labels; exits 1 when it finds any.\n\nExamples:\n  \
qean check-data data/FineDance\n  qean check-data my_dances --layout folder"
)]
pub struct CheckDataArgs {
    /// The dataset directory; its layout is detected (motions/: AIST++; motion/: FineDance; else a folder).
    pub dir: PathBuf,
    /// Read it as this layout instead.
    #[arg(long, value_name = "aistpp|finedance|folder")]
    pub layout: Option<qean_aistpp::layout::DataLayout>,
}

pub fn check_data(a: CheckDataArgs) -> anyhow::Result<()> {
    let ds = qean_aistpp::dataset::Dataset::open_with(&a.dir, a.layout)?;
    let pb = qean_checkpoint::progress::bar(0, "", "");
    let check = qean_pipeline::check_data::check_data(&ds, |done, total| {
        pb.set_length(total as u64);
        pb.set_position(done as u64);
    })?;
    pb.finish_and_clear();
    print!("{check}");
    if !check.defects.is_empty() {
        anyhow::bail!(
            "{}: {} defect(s), listed above",
            a.dir.display(),
            check.defects.len()
        );
    }
    Ok(())
}

/// Forward kinematics: an AIST++ motion pickle to joint positions, a (frames, 24, 3) float32 .npy.
#[derive(Args, Debug)]
#[command(about = "Forward kinematics: a motion pickle to joint positions (.npy)")]
pub struct JointsArgs {
    /// AIST++ motion pickle (smpl_poses, smpl_trans, smpl_scaling).
    pub motion: PathBuf,
    /// Output .npy path.
    #[arg(long)]
    pub out: PathBuf,
    /// Root convention: `smpl` adds the SMPL-male rest pelvis (as mint and Bailando); `edge` does not.
    #[arg(long, value_enum, default_value_t = RootArg::Smpl)]
    pub root: RootArg,
}

pub fn joints(a: JointsArgs) -> anyhow::Result<()> {
    let motion = Motion::read_pkl(&a.motion)?;
    qean_motion::joints_file::write_joints(&a.out, &motion.joints(a.root.fk()))?;
    println!(
        "wrote {}: {} frames × 24 joints",
        a.out.display(),
        motion.frames
    );
    Ok(())
}

/// Render a preview of any motion: an animated stick figure (GIF) and a contact sheet of key frames (PNG) with
/// the music's beats marked when known.
#[derive(Args, Debug)]
#[command(about = "Render a motion: a stick-figure GIF and a contact sheet (PNG)")]
pub struct RenderArgs {
    /// Motion file: AIST++ .pkl, .npy of joints (frames, 24, 3) or of model vectors (frames, 225|219), or .bvh.
    pub motion: PathBuf,
    /// Output: FILE.png or FILE.gif (the other is written next to it), or a stem to which both are added.
    #[arg(long)]
    pub out: PathBuf,
    /// Music beats to mark: a 35-D feature .npy (column 34, aligned with the motion's frames).
    #[arg(long)]
    pub features: Option<PathBuf>,
    /// Frames at the start to label as seed (e.g. 120 for generated dances).
    #[arg(long, default_value_t = 0)]
    pub seed_frames: usize,
    /// Root convention for forward kinematics of .pkl/.npy vectors.
    #[arg(long, value_enum, default_value_t = RootArg::Smpl)]
    pub root: RootArg,
}

pub fn render(a: RenderArgs) -> anyhow::Result<()> {
    let joints = qean_motion::joints_file::load_joints(&a.motion, a.root.fk())?;
    let beats = match &a.features {
        Some(f) => Some(qean_render::beats_from_features(f)?),
        None => None,
    };
    let title = a
        .motion
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let preview = qean_render::Preview {
        title,
        joints: &joints,
        fps: qean_motion::motion::FPS,
        beats: beats.as_deref(),
        seed_frames: a.seed_frames,
    };
    let (png, gif) = qean_render::preview_paths(&a.out);
    qean_render::write_preview(&preview, &png, &gif)?;
    println!("wrote {} and {}", png.display(), gif.display());
    Ok(())
}

/// Convert a motion between formats: an AIST++ .pkl, a .npy of model vectors (frames, 225|219), or joint
/// positions (a .npy of (frames, 24, 3), e.g. another system's output, or an SMPL-skeleton .bvh) to .bvh (SMPL
/// skeleton, 60 fps, centimetres), .npy (joint positions, frames × 24 × 3) or .pkl (AIST++ format). Joint
/// positions become SMPL rotations by inverse kinematics (SPEC §11.3), with the bones at SMPL's lengths.
#[derive(Args, Debug)]
#[command(
    about = "Convert a motion between .pkl, .npy, .bvh (IK from positions) and glTF .glb",
    after_help = "Examples:\n  qean convert dance.pkl --out dance.bvh\n  qean convert dance.pkl --out dance.glb   (Blender: File > Import > glTF 2.0)\n  qean convert other_system.joints.npy --out dance.pkl\n  qean convert other_system.joints.npy --out dance.bvh --ik hinge"
)]
pub struct ConvertArgs {
    /// Input motion: .pkl (AIST++), .npy (frames, 225|219) or joint positions (.npy (frames, 24, 3), .bvh).
    pub motion: PathBuf,
    /// Output file; the format follows the extension (.bvh, .npy, .pkl; .glb or .gltf: the SMPL skeleton as
    /// animated glTF 2.0 nodes at 60 fps, for Blender, three.js or any glTF viewer).
    #[arg(long)]
    pub out: PathBuf,
    /// Root convention for joint positions and the BVH root channel.
    #[arg(long, value_enum, default_value_t = RootArg::Smpl)]
    pub root: RootArg,
    /// Inverse kinematics for joint-position inputs: `swing` (minimal rotation per bone, stable) or
    /// `hinge` (knees and elbows bend about one axis, twist moved to the hips and shoulders).
    #[arg(long, value_enum, default_value_t = IkArg::Swing)]
    pub ik: IkArg,
}

/// `--ik` values.
#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum IkArg {
    Swing,
    Hinge,
}

impl IkArg {
    pub fn mode(self) -> qean_motion::ik::IkMode {
        match self {
            IkArg::Swing => qean_motion::ik::IkMode::Swing,
            IkArg::Hinge => qean_motion::ik::IkMode::Hinge,
        }
    }
}

pub fn convert(a: ConvertArgs) -> anyhow::Result<()> {
    let root = a.root.fk();
    let (motion, ik_error) = qean_motion::joints_file::read_any(&a.motion, a.ik.mode(), root)?;
    if let Some(mean) = ik_error {
        println!(
            "inverse kinematics ({:?}): mean joint distance after FK {:.2} mm (bones at SMPL lengths)",
            a.ik,
            mean * 1000.0
        );
    }
    let ext = qean_io::fsutil::extension_lower(&a.out);
    match ext.as_str() {
        "bvh" => qean_motion::bvh::write(&a.out, &motion, root)?,
        "npy" => qean_motion::joints_file::write_joints(&a.out, &motion.joints(root))?,
        "pkl" => motion.write_pkl(&a.out, qean_motion::motion::Precision::F64)?,
        "glb" | "gltf" => qean_render::gltf::write(&a.out, &motion, root)?,
        _ => anyhow::bail!(
            "{}: unknown output format (use .bvh, .npy, .pkl, .glb or .gltf)",
            a.out.display()
        ),
    }
    println!("wrote {} ({} frames)", a.out.display(), motion.frames);
    Ok(())
}
