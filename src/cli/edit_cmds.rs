//! `qean keyframes`: keyframes of a dance per measure (Lin 2022, SPEC §12).

use clap::Args;
use qean_keyframes::select::Strategy;
use qean_keyframes::KeyframeOptions;
use qean_pipeline::keyframes::{select_keyframes, KeyframesRequest};
use serde::Deserialize;
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
    /// A [keyframes] setting, e.g. keyframes.kf_edge_guard=3 or keyframes.dp_error=lerp (configs/README.md).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Where to write the keys: {"segments": [[a, b], ...], "keyframes": [...], "strategy", "n", ...}.
    #[arg(long)]
    pub json: PathBuf,
}

/// `[keyframes]` settings from `--set keyframes.key=value` overrides.
pub fn keyframe_options(sets: &[String]) -> anyhow::Result<KeyframeOptions> {
    let mut table = toml::Table::new();
    for spec in sets {
        let (parts, value) = qean_config::run::parse_override(spec).map_err(anyhow::Error::msg)?;
        let [t, key] = parts.as_slice() else {
            anyhow::bail!("--set {spec}: only keyframes.* settings apply here");
        };
        if t != "keyframes" {
            anyhow::bail!("--set {spec}: only keyframes.* settings apply here");
        }
        // Each setting alone first, so that an error names the one at fault.
        let single = toml::Table::from_iter([(key.clone(), value.clone())]);
        if let Err(e) = KeyframeOptions::deserialize(toml::Value::Table(single)) {
            let first = e.to_string();
            anyhow::bail!(
                "--set {spec}: {}",
                first.lines().next().unwrap_or("").trim()
            );
        }
        table.insert(key.clone(), value);
    }
    Ok(KeyframeOptions::deserialize(toml::Value::Table(table))?)
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
        options: keyframe_options(&a.set)?,
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
