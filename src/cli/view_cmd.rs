//! `qean view`: dances in 3-D with their music, in one self-contained HTML page.

use std::path::PathBuf;

use anyhow::bail;
use clap::Args;
use qean::eval_cli::RootArg;
use qean_pipeline::view::{write_page, PageDance, PageMusic};

/// Show dances in 3-D, side by side, with their music: one HTML file that works offline (open it in any
/// browser; no server, no network). The music plays and drives the animation (seek, pause, speed, loop);
/// drag to orbit, scroll to zoom; the timeline marks the music's beats, each dance's motion beats and the
/// seed frames. A dance and a song of different lengths play for the shorter, and the page says so.
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
    /// Leading frames of each dance that are its seed (marked on the timeline).
    #[arg(long, default_value_t = 0)]
    pub seed_frames: usize,
    /// Draw the dances at one place, overlaid (pose against pose), instead of side by side.
    #[arg(long)]
    pub overlay: bool,
    /// Link the music (a path relative to the page) instead of embedding it: for large files.
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
        let label = a.label.get(i).cloned().unwrap_or_else(|| {
            path.file_name()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default()
        });
        dances.push(PageDance {
            label,
            joints,
            seed_frames: a.seed_frames,
            marks: Vec::new(),
        });
    }
    let music = a.music.as_ref().map(|path| PageMusic {
        path: path.clone(),
        link: a.link_music,
    });
    let title = match dances.len() {
        1 => dances[0].label.clone(),
        n => format!("{n} dances"),
    };
    write_page(&a.out, &dances, music.as_ref(), &title, a.overlay)?;
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
