//! `qean view`'s page: one self-contained HTML file that shows dances in 3-D side by side (three.js, vendored
//! in `assets/viewer.bundle.js`, built by `tools/build_viewer.sh` from `viewer/viewer.js`) with their music
//! embedded and played in sync — the audio clock drives the animation — plus seeking, pause, speed, loop, an
//! orbit camera, a floor grid and a timeline of music beats, each dance's motion beats and the seed frames.
//! Works offline from a file: no network, no server.

use std::path::Path;

use qean_io::error::{Error, Result};
use serde_json::json;

/// The viewer script (three.js r187 and ours, minified; MIT licence header inside).
const BUNDLE: &str = include_str!("../assets/viewer.bundle.js");

/// Music embedded above this size makes the page slow to open: `--link-music` links it instead.
pub const EMBED_LIMIT: usize = 20 << 20;

/// One dance of the page.
#[derive(Debug, Clone)]
pub struct ViewDance {
    pub label: String,
    /// Joint positions, frames × 24, metres, +Y up, 60 fps.
    pub joints: Vec<[f64; 3]>,
    /// Motion beats (frames).
    pub motion_beats: Vec<usize>,
    /// Leading frames that are the seed (shaded on the timeline).
    pub seed_frames: usize,
    /// What the dance was asked to follow, marked on its timeline row: keyframes and text intervals.
    pub marks: Vec<ViewMark>,
}

/// A mark on a dance's timeline: frames `from..=to` (one frame for a keyframe) and what it is.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewMark {
    pub from: usize,
    pub to: usize,
    pub label: String,
}

/// The music: embedded bytes or a link relative to the page, with its beats (frames at 60 fps).
#[derive(Debug, Clone)]
pub enum ViewAudio {
    Embedded { bytes: Vec<u8>, mime: String },
    Linked { href: String },
}

#[derive(Debug, Clone)]
pub struct ViewMusic {
    pub audio: ViewAudio,
    pub beats: Vec<usize>,
    pub name: String,
}

/// What the page shows besides the dances.
#[derive(Debug, Clone)]
pub struct ViewOptions {
    pub title: String,
    /// Draw every dance at the same place (compare poses directly) instead of side by side.
    pub overlay: bool,
}

/// The MIME type of an audio file by its extension.
pub fn audio_mime(path: &Path) -> Result<&'static str> {
    Ok(match qean_io::fsutil::extension_lower(path).as_str() {
        "ogg" | "oga" => "audio/ogg",
        "wav" => "audio/wav",
        "mp3" => "audio/mpeg",
        "flac" => "audio/flac",
        "m4a" | "aac" => "audio/mp4",
        "opus" => "audio/ogg; codecs=opus",
        _ => {
            return Err(Error::at(
                path,
                "not an audio file a browser plays (.ogg, .wav, .mp3, .flac, .m4a)",
            ))
        }
    })
}

fn base64(bytes: &[u8]) -> String {
    crate::gltf::base64(bytes)
}

/// HTML-escaped text.
fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// The page.
pub fn page(dances: &[ViewDance], music: Option<&ViewMusic>, opts: &ViewOptions) -> String {
    let data = json!({
        "fps": 60,
        "overlay": opts.overlay,
        "parents": qean_motion::skeleton::PARENTS,
        "music_beats": music.map(|m| m.beats.clone()).unwrap_or_default(),
        "dances": dances.iter().map(|d| {
            let values: Vec<u8> = d.joints.iter().flat_map(|p| p.map(|v| v as f32)).flat_map(|v| v.to_le_bytes()).collect();
            json!({
                "label": d.label,
                "frames": d.joints.len() / 24,
                "joints": base64(&values),
                "motion_beats": d.motion_beats,
                "seed_frames": d.seed_frames,
                "marks": d.marks.iter().map(|m| json!({"from": m.from, "to": m.to, "label": m.label})).collect::<Vec<_>>(),
            })
        }).collect::<Vec<_>>(),
    });
    // `</` inside the JSON would end the script element.
    let data = data.to_string().replace("</", "<\\/");
    let audio = match music.map(|m| &m.audio) {
        Some(ViewAudio::Embedded { bytes, mime }) => format!(
            "<audio id=\"music\" preload=\"auto\" src=\"data:{mime};base64,{}\"></audio>",
            base64(bytes)
        ),
        Some(ViewAudio::Linked { href }) => {
            format!(
                "<audio id=\"music\" preload=\"auto\" src=\"{}\"></audio>",
                escape(href)
            )
        }
        None => String::new(),
    };
    let palette = [
        "#4c8bf5", "#f5a142", "#3fbf6f", "#d9534f", "#9b6fd9", "#2bb5b8", "#c7c739", "#e377c2",
    ];
    let legend: String = dances
        .iter()
        .enumerate()
        .map(|(i, d)| {
            format!(
                "<span><i style=\"background:{}\"></i>{}</span>",
                palette[i % palette.len()],
                escape(&d.label)
            )
        })
        .collect();
    let song = music
        .map(|m| format!(" · music: {}", escape(&m.name)))
        .unwrap_or_else(|| " · no music".into());
    format!(
        r#"<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>qean view: loading</title>
<meta name="viewport" content="width=device-width, initial-scale=1">
<style>
html, body {{ margin: 0; height: 100%; font: 14px system-ui, sans-serif; background: #f4f4f0; color: #222; }}
#wrap {{ display: flex; flex-direction: column; height: 100%; }}
header {{ padding: 6px 10px; display: flex; gap: 14px; align-items: center; flex-wrap: wrap; }}
header h1 {{ font-size: 15px; margin: 0; }}
#legend span {{ margin-right: 12px; }} #legend i {{ display: inline-block; width: 10px; height: 10px; margin-right: 4px; }}
#view {{ flex: 1; min-height: 300px; }} #view canvas {{ width: 100%; height: 100%; display: block; }}
#timeline {{ width: 100%; height: 56px; display: block; cursor: pointer; background: #fff; }}
#bar {{ padding: 6px 10px; display: flex; gap: 12px; align-items: center; }}
#warning {{ color: #b00; padding: 0 10px; }}
</style></head>
<body><div id="wrap">
<header><h1>{title}</h1><span id="legend">{legend}</span><span>{song} · drag to orbit, scroll to zoom</span></header>
<div id="warning"></div>
<div id="view"></div>
<canvas id="timeline" title="music beats (top), each dance's motion beats, the seed shaded; click to seek"></canvas>
<div id="bar"><button id="play">play</button>
<label>speed <select id="speed"><option>0.25</option><option>0.5</option><option selected>1</option><option>1.5</option><option>2</option></select></label>
<label><input type="checkbox" id="loop"> loop</label><span id="status"></span></div>
</div>
{audio}
<script type="application/json" id="qean-data">{data}</script>
<script>{bundle}</script>
</body></html>
"#,
        title = escape(&opts.title),
        legend = legend,
        song = song,
        audio = audio,
        data = data,
        bundle = BUNDLE,
    )
}

/// Writes the page atomically.
pub fn write(
    path: &Path,
    dances: &[ViewDance],
    music: Option<&ViewMusic>,
    opts: &ViewOptions,
) -> Result<()> {
    if dances.is_empty() {
        return Err(Error::at(path, "no dance to show"));
    }
    qean_io::fsutil::atomic_write(path, page(dances, music, opts).as_bytes())
}
