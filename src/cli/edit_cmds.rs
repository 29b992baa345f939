//! `qean keyframes`: keyframes of a dance per measure (Lin 2022, SPEC §12).

use clap::Args;
use qean_keyframes::select::Strategy;
use qean_pipeline::keyframes::{select_keyframes, KeyframesRequest};
use std::path::PathBuf;

#[derive(Args, Debug)]
#[command(
    about = "Pick keyframes of a dance per measure (even, onset, stems, nmfd or dp)",
    long_about = "Pick keyframes of a dance, N per measure with both measure ends included (Lin 2022, SPEC §12.2–12.3). \
The measure grid comes from the tempo: --bpm, else the AIST++ music ID in the motion's or the music's name \
(gBR_sBM_cAll_d04_mBR0_ch01 → 80 BPM), else the music's beat tracker.\n\n\
Strategies: even (evenly spaced), onset (the strongest onset-envelope peaks of the music), stems and nmfd \
(peaks of stem-weighted onsets or NMFD drum activations), dp (Roberts's salient poses: the keys whose \
straight-line in-betweens miss the dance least, from the motion alone).",
    after_help = "Examples:\n  qean keyframes --motion dance.pkl --bpm 120 --strategy even --n 3 --json keys.json\n  \
qean keyframes --motion gBR_sBM_cAll_d04_mBR0_ch01.pkl --music mBR0.wav --strategy onset --n 5 --json keys.json\n  \
qean keyframes --motion dance.pkl --bpm 110 --strategy dp --n 5 --set keyframes.dp_combine=sum --json keys.json"
)]
pub struct KeyframesArgs {
    /// The dance: an AIST++ .pkl or a model-layout .npy (frames, 225|219).
    #[arg(long)]
    pub motion: PathBuf,
    /// Its music (needed by onset, stems and nmfd; gives a tempo when the name does not).
    #[arg(long)]
    pub music: Option<PathBuf>,
    /// Stems of the music for `stems` and `nmfd`: a directory with drums.wav, bass.wav, vocals.wav and
    /// other.wav (e.g. OpenUnmix's output). Without stems, --set keyframes.stem_source=hpss uses HPSS.
    #[arg(long)]
    pub stems: Option<PathBuf>,
    /// even, onset, stems, nmfd or dp.
    #[arg(long, default_value = "even")]
    pub strategy: String,
    /// Keyframes per measure, both ends included (3 = half notes, 5 = quarters, 9 = eighths in 4/4).
    #[arg(long, default_value_t = 5)]
    pub n: usize,
    /// Tempo in beats per minute (4/4: a measure is 14400/BPM frames at 60 fps).
    #[arg(long)]
    pub bpm: Option<f64>,
    /// A [keyframes] setting, e.g. keyframes.kf_edge_guard=3 or keyframes.dp_error=lerp (docs/keyframes.md).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Where to write the keys: {"segments": [[a, b], ...], "keyframes": [...], "strategy", "n", ...}.
    #[arg(long)]
    pub json: PathBuf,
}

pub fn keyframes(a: KeyframesArgs) -> anyhow::Result<()> {
    let strategy = Strategy::parse(&a.strategy).map_err(anyhow::Error::msg)?;
    if let Some(dir) = a.json.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.is_dir() {
            anyhow::bail!("{}: the output directory does not exist", a.json.display());
        }
    }
    let result = select_keyframes(&KeyframesRequest {
        motion: a.motion.clone(),
        music: a.music.clone(),
        stems: a.stems.clone(),
        strategy,
        n: a.n,
        bpm: a.bpm,
        options: qean_pipeline::keyframe_settings::parse(&a.set)?.keyframes,
    })?;
    let text = serde_json::to_string_pretty(&result)? + "\n";
    qean_io::fsutil::atomic_write(&a.json, text.as_bytes())?;
    let s = &result.selection;
    println!(
        "{} keyframes ({} per measure, {}) over {} measures of {} frames at {} BPM ({})",
        s.keyframes.len(),
        s.n,
        strategy.name(),
        s.segments.len(),
        result.frames,
        s.bpm,
        result.tempo_source
    );
    let shown: Vec<String> = s.keyframes.iter().take(12).map(|k| k.to_string()).collect();
    println!(
        "keys: {}{}",
        shown.join(", "),
        if s.keyframes.len() > 12 { ", …" } else { "" }
    );
    println!("wrote {}", a.json.display());
    Ok(())
}

#[derive(Args, Debug)]
#[command(
    about = "Edit a dance: keep some poses, set others, regenerate the frames in between",
    long_about = "Edit a dance (SPEC §12.7). edits.json names the ranges to regenerate and what to keep:\n\n  \
{\"regenerate\": [[120, 240]], \"keep\": \"grid:5\", \"edits\": [{\"frame\": 180, \"pose_aa\": [72 values], \"trans\": [x, y, z]}]}\n\n\
\"keep\" is \"grid:N\" (N even keys per measure), \"dp:N\" (the DP's salient poses), \"onset:N\" (music onsets; needs \
--music) or a list of frames; \"edits\" set new poses (axis-angle, 24 joints) and optionally the root translation. \
In each range the anchors are its ends, the kept frames and the edited frames; every other frame of the range is \
regenerated (slerp: straight root path and shortest-arc joint turns; bezier: cubic curves per Euler channel with \
the mean shape of training dances (--theta, written by `qean eval --task inbetween`) or else of the input's own \
key pairs; transformer: a trained in-betweener, --run). Frames outside the ranges are copied bit for bit. Writes OUT.pkl and \
OUT.report.json (anchors and per-range error against the input); --render adds OUT.png and OUT.gif.",
    after_help = "Examples:\n  qean edit --motion dance.pkl --edits edits.json --method slerp --bpm 120 --out edited.pkl\n  \
qean edit --motion dance.pkl --music song.wav --edits edits.json --method bezier --out edited.pkl --render\n  \
qean eval --task inbetween --data data --keys 5 --methods bezier --out bench   # writes bench/bezier_even_N5.json\n  \
qean edit --motion dance.pkl --edits edits.json --method bezier --theta bench/bezier_even_N5.json --out edited.pkl"
)]
pub struct EditArgs {
    /// The dance: an AIST++ .pkl or a model-layout .npy (frames, 225|219).
    #[arg(long)]
    pub motion: PathBuf,
    /// Its music (for keep = "onset:N" and the tempo).
    #[arg(long)]
    pub music: Option<PathBuf>,
    /// Stems directory (keep rules on stems; see `qean keyframes --help`).
    #[arg(long)]
    pub stems: Option<PathBuf>,
    /// The edits: {"regenerate": [[a, b], ...], "keep": ..., "edits": [...]}.
    #[arg(long)]
    pub edits: PathBuf,
    /// slerp, bezier or transformer (a trained in-betweener, --run R).
    #[arg(long, value_enum, default_value_t = MethodArg::Slerp)]
    pub method: MethodArg,
    /// The in-betweener run for --method transformer (qean train --config configs/inbetween/...).
    #[arg(long)]
    pub run: Option<PathBuf>,
    /// The dance's genre (BR, PO, LO, MH, LH, HO, WA, KR, JS) for the genre in-betweener; default: from an
    /// AIST++ name.
    #[arg(long)]
    pub genre: Option<String>,
    /// The Bézier training mean for --method bezier (bezier_<strategy>_N<n>.json from `qean eval --task
    /// inbetween`); default: fitted on the input's own key pairs.
    #[arg(long)]
    pub theta: Option<PathBuf>,
    /// Tempo for the measure grid of keep rules (else from the names or the music).
    #[arg(long)]
    pub bpm: Option<f64>,
    /// A [keyframes] or [inbetween] setting, e.g. keyframes.dp_error=lerp or inbetween.bezier_param=chord.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// The edited dance (.pkl).
    #[arg(long)]
    pub out: PathBuf,
    /// Also draw OUT.png (contact sheet) and OUT.gif.
    #[arg(long)]
    pub render: bool,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug)]
pub enum MethodArg {
    Slerp,
    Bezier,
    Transformer,
}

pub fn edit(a: EditArgs) -> anyhow::Result<()> {
    let settings = qean_pipeline::keyframe_settings::parse(&a.set)?;
    let report = qean_pipeline::edit::edit(&qean_pipeline::edit::EditRequest {
        motion: a.motion.clone(),
        music: a.music.clone(),
        stems: a.stems.clone(),
        edits: a.edits.clone(),
        method: match a.method {
            MethodArg::Slerp => qean_pipeline::edit::EditMethod::Slerp,
            MethodArg::Bezier => qean_pipeline::edit::EditMethod::Bezier,
            MethodArg::Transformer => qean_pipeline::edit::EditMethod::Transformer,
        },
        run: a.run.clone(),
        genre: a.genre.clone(),
        theta: a.theta.clone(),
        bpm: a.bpm,
        options: settings.keyframes,
        bezier: settings.bezier,
        out: a.out.clone(),
        render: a.render,
    })?;
    for r in &report.ranges {
        println!(
            "range {}..{}: {} anchors, {} frames regenerated, MSE vs input {:.4} (rotation matrices)",
            r.range.0,
            r.range.1,
            r.anchors.len(),
            r.range.1 - r.range.0 + 1 - r.anchors.len(),
            r.mse_rotmat
        );
    }
    if let Some(source) = &report.theta_source {
        println!("Bézier θ: {source}");
    }
    println!(
        "wrote {} and {}",
        a.out.display(),
        qean_pipeline::edit::sibling(&a.out, "report.json").display()
    );
    if a.render {
        println!(
            "preview: {} and {}",
            qean_pipeline::edit::sibling(&a.out, "png").display(),
            qean_pipeline::edit::sibling(&a.out, "gif").display()
        );
    }
    Ok(())
}
