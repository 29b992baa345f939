//! `qean view` pages from joint positions and a song file: motion beats of each dance (Kim-style, σ 5) and the
//! song's beats computed here, the page written by `qean_render::view`. Shared by `qean view`, `qean sample
//! --view` and the demo.

use std::path::{Path, PathBuf};

pub use qean_render::view::ViewMark;
use qean_render::view::{ViewAudio, ViewDance, ViewMusic, ViewOptions, EMBED_LIMIT};

use crate::{Error, Result};

/// One dance of a page: label, joint positions (frames × 24, 60 fps) and its seed frames.
#[derive(Debug, Clone)]
pub struct PageDance {
    pub label: String,
    pub joints: Vec<[f64; 3]>,
    pub seed_frames: usize,
    /// Keyframes and text intervals to mark on its timeline.
    pub marks: Vec<ViewMark>,
}

/// The marks of a dance sampled with `opts`: each keyframe at its frame, each text interval over its
/// frames (60 fps).
pub fn control_marks(opts: &crate::generate::GenerateOptions) -> Vec<ViewMark> {
    let keys = opts.keyframes.iter().map(|k| ViewMark {
        from: k.frame,
        to: k.frame,
        label: "keyframe".into(),
    });
    let texts = opts.text.iter().map(|t| ViewMark {
        from: (t.from_s * 60.0).round() as usize,
        to: (t.to_s * 60.0).round() as usize,
        label: format!("text {}", t.embedding),
    });
    keys.chain(texts).collect()
}

/// The music of a page: a song file, embedded or linked (relative to the page).
#[derive(Debug, Clone)]
pub struct PageMusic {
    pub path: PathBuf,
    pub link: bool,
}

/// Writes the page `out` (atomically); `overlay` draws the dances at one place instead of side by side.
pub fn write_page(
    out: &Path,
    dances: &[PageDance],
    music: Option<&PageMusic>,
    title: &str,
    overlay: bool,
) -> Result<()> {
    let view: Vec<ViewDance> = dances
        .iter()
        .map(|d| ViewDance {
            label: d.label.clone(),
            motion_beats: qean_eval::motion_beats::motion_beats(
                &qean_eval::run_report::frames_of(d.joints.clone()),
                5.0,
            ),
            joints: d.joints.clone(),
            seed_frames: d.seed_frames,
            marks: d.marks.clone(),
        })
        .collect();
    let music = music.map(|m| page_music(out, m)).transpose()?;
    qean_render::view::write(
        out,
        &view,
        music.as_ref(),
        &ViewOptions {
            title: title.to_string(),
            overlay,
        },
    )?;
    Ok(())
}

fn page_music(out: &Path, m: &PageMusic) -> Result<ViewMusic> {
    let mime = qean_render::view::audio_mime(&m.path)?;
    let song = crate::generate::load_song(&m.path, None, 1)?;
    let audio = if m.link {
        let abs = std::fs::canonicalize(&m.path).map_err(|e| qean_io::Error::io(&m.path, e))?;
        let dir = out
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        let dir = std::fs::canonicalize(dir)
            .map_err(|_| Error::Io(qean_io::Error::at(dir, "output directory does not exist")))?;
        ViewAudio::Linked {
            href: relative(&dir, &abs),
        }
    } else {
        let bytes = std::fs::read(&m.path).map_err(|e| qean_io::Error::io(&m.path, e))?;
        if bytes.len() > EMBED_LIMIT {
            tracing::warn!(
                "{}: {} MB embedded in the page; --link-music links it instead",
                m.path.display(),
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
pub fn relative(from: &Path, to: &Path) -> String {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths_climb_then_descend() {
        assert_eq!(
            relative(Path::new("/a/b/pages"), Path::new("/a/music/x.ogg")),
            "../../music/x.ogg"
        );
        assert_eq!(relative(Path::new("/a"), Path::new("/a/x.ogg")), "x.ogg");
    }
}
