//! `qean view`: dances in 3-D with their music, in one self-contained HTML page.

use std::path::PathBuf;

use anyhow::{bail, Context};
use clap::Args;
use qean_render::view::{ViewAudio, ViewDance, ViewMusic, ViewOptions, EMBED_LIMIT};

use qean::eval_cli::RootArg;

/// Show dances in 3-D, side by side, with their music: one HTML file that works offline (open it in any
/// browser; no server, no network). The music plays and drives the animation (seek, pause, speed, loop);
/// drag to orbit, scroll to zoom; the timeline marks the music's beats, each dance's motion beats and the
/// seed frames.
///
/// Examples:
///   qean view gt.pkl dances/fact/Vibe_Ace.pkl dances/qean/Vibe_Ace.pkl --label "ground truth" --label FACT
///       --label QEAN --music Vibe_Ace.ogg --seed-frames 120 --out compare.html
///   qean view dance.joints.npy --out dance.html
#[derive(Args, Debug)]
#[command(verbatim_doc_comment)]
#[command(about = "Show dances in 3-D with their music in one offline HTML page")]
pub struct ViewArgs {
    /// Dances: .pkl (AIST++), .npy (frames × 225|219 or joint positions (frames, 24, 3)) or .bvh.
    #[arg(required = true)]
    pub dances: Vec<PathBuf>,
    /// The music, embedded in the page (.ogg, .wav, .mp3, .flac).
    #[arg(long)]
    pub music: Option<PathBuf>,
    /// A label per dance, in order (default: the file names).
    #[arg(long)]
    pub label: Vec<String>,
    /// Leading frames that are the seed (marked on the timeline).
    #[arg(long, default_value_t = 0)]
    pub seed_frames: usize,
    /// Link the music (a path relative to the page) instead of embedding it.
    #[arg(long, requires = "music")]
    pub link_music: bool,
    /// Root convention of the joint positions.
    #[arg(long, value_enum, default_value_t = RootArg::Smpl)]
    pub root: RootArg,
    /// The page to write (.html).
    #[arg(long)]
    pub out: PathBuf,
}

pub fn view(a: ViewArgs) -> anyhow::Result<()> {
    if a.label.len() > a.dances.len() {
        bail!("{} labels for {} dances", a.label.len(), a.dances.len());
    }
    let mut dances = Vec::new();
    for (i, path) in a.dances.iter().enumerate() {
        let joints = qean_motion::joints_file::load_joints(path, a.root.fk())?;
        if joints.len() < 24 {
            bail!("{}: no frames", path.display());
        }
        let frames = qean_eval::run_report::frames_of(joints.clone());
        let label = a.label.get(i).cloned().unwrap_or_else(|| {
            path.file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default()
        });
        dances.push(ViewDance {
            label,
            motion_beats: qean_eval::motion_beats::motion_beats(&frames, 5.0),
            joints,
        });
    }
    let music = match &a.music {
        None => None,
        Some(path) => Some(music(path, &a)?),
    };
    let title = match dances.len() {
        1 => dances[0].label.clone(),
        n => format!("{n} dances"),
    };
    qean_render::view::write(
        &a.out,
        &dances,
        music.as_ref(),
        &ViewOptions {
            title,
            seed_frames: a.seed_frames,
        },
    )?;
    let frames: Vec<String> = dances
        .iter()
        .map(|d| (d.joints.len() / 24).to_string())
        .collect();
    println!(
        "wrote {} ({} dance(s), {} frames{})",
        a.out.display(),
        dances.len(),
        frames.join("/"),
        if music.is_some() { ", with music" } else { "" }
    );
    Ok(())
}

/// The music, embedded (or linked), with its beats.
fn music(path: &std::path::Path, a: &ViewArgs) -> anyhow::Result<ViewMusic> {
    let mime = qean_render::view::audio_mime(path)?;
    let song = qean_pipeline::generate::load_song(path, None, 1)?;
    let audio = if a.link_music {
        let page_dir = a.out.parent().filter(|p| !p.as_os_str().is_empty());
        let abs = std::fs::canonicalize(path)
            .with_context(|| format!("{}: cannot resolve", path.display()))?;
        let dir = match page_dir {
            Some(d) => std::fs::canonicalize(d)
                .with_context(|| format!("{}: output directory does not exist", d.display()))?,
            None => std::env::current_dir()?,
        };
        ViewAudio::Linked {
            href: relative(&dir, &abs),
        }
    } else {
        let bytes =
            std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))?;
        if bytes.len() > EMBED_LIMIT {
            tracing::warn!(
                "{}: {} MB embedded in the page; --link-music links it instead",
                path.display(),
                bytes.len() >> 20
            );
        }
        ViewAudio::Embedded {
            bytes,
            mime: mime.to_string(),
        }
    };
    Ok(ViewMusic {
        audio,
        beats: song.features.beats.clone(),
        name: song.name,
    })
}

/// `to` relative to the directory `from`, with '/' separators (both absolute).
fn relative(from: &std::path::Path, to: &std::path::Path) -> String {
    let a: Vec<_> = from.components().collect();
    let b: Vec<_> = to.components().collect();
    let common = a.iter().zip(&b).take_while(|(x, y)| x == y).count();
    let mut parts: Vec<String> = vec!["..".into(); a.len() - common];
    parts.extend(
        b[common..]
            .iter()
            .map(|c| c.as_os_str().to_string_lossy().into_owned()),
    );
    parts.join("/")
}
