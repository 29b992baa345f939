//! `qean features`: the 35-D music features of audio files, or of every music ID of a dataset (cached).

use std::path::PathBuf;

use anyhow::bail;
use clap::Args;
use indicatif::ProgressBar;
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::feature_cache;
use qean_audio::{self as audio, FeatureOptions, Resampler};

/// Compute the 35-D FACT music features (librosa 0.8.1 semantics: onset envelope, 20 MFCC, 12 chroma_cens,
/// onset peaks, beats; 60 frames per second) of audio files, writing OUT/<stem>.npy (frames × 35 float32);
/// or, with --dataset, cache the features of every music ID of a dataset directory in DIR/features/
/// (skipping those already cached and up to date).
#[derive(Args, Debug)]
#[command(about = "Compute the 35-D FACT music features of audio files or a dataset")]
pub struct FeaturesArgs {
    /// Audio files (wav, ogg, mp3, flac; any rate and channel count).
    pub audio: Vec<PathBuf>,
    /// Output directory for the .npy files (must exist).
    #[arg(long, required_unless_present = "dataset")]
    pub out: Option<PathBuf>,
    /// A dataset directory (any layout) whose music to cache.
    #[arg(long, conflicts_with_all = ["audio", "out"])]
    pub dataset: Option<PathBuf>,
    /// Beat-tracker tempo prior in BPM. Default: from the AIST++ music ID in the name, else 120.
    #[arg(long)]
    pub start_bpm: Option<f64>,
    /// Resampling filter (resampy 0.2.2's): kaiser_best (librosa.load's default) or kaiser_fast.
    #[arg(long, default_value = "kaiser_best", value_parser = ["kaiser_best", "kaiser_fast"])]
    pub resampler: String,
    /// Write the features of a silent track (flat onset envelope: no onsets, no beats) instead of refusing
    /// it. A silent file in a dance dataset is almost always a decoding or export mistake.
    #[arg(long)]
    pub allow_silent: bool,
}

/// The features of one file, refusing silence unless `--allow-silent`.
fn file_features(
    path: &std::path::Path,
    opts: &FeatureOptions,
    a: &FeaturesArgs,
) -> anyhow::Result<audio::MusicFeatures> {
    let f = audio::features_for_file(path, opts)?;
    if !a.allow_silent && f.is_silent() {
        bail!(
            "{}: the audio is silent (flat onset envelope: no onsets, no beats); pass --allow-silent to \
             write its features anyway",
            path.display()
        );
    }
    Ok(f)
}

/// Options for the track `name` (`--start-bpm` is checked once in [`features`]).
fn options(name: &str, a: &FeaturesArgs) -> FeatureOptions {
    let mut o = FeatureOptions::with_start_bpm(qean_aistpp::names::start_bpm(name));
    if let Some(b) = a.start_bpm {
        o.start_bpm = b;
    }
    o.resampler = if a.resampler == "kaiser_fast" {
        Resampler::KaiserFast
    } else {
        Resampler::KaiserBest
    };
    o
}

fn bar(n: usize) -> ProgressBar {
    qean_checkpoint::progress::bar(n as u64, "", "")
}

pub fn features(a: FeaturesArgs) -> anyhow::Result<()> {
    if let Some(b) = a.start_bpm.filter(|b| !(b.is_finite() && *b > 0.0)) {
        bail!("--start-bpm must be a positive number, got {b}");
    }
    if let Some(dir) = &a.dataset {
        let ds = Dataset::open(dir)?;
        let mut names: Vec<String> = Split::ALL.iter().flat_map(|s| ds.split(*s)).collect();
        names.extend(ds.all_sequences()?);
        let ids = ds.music_ids(&names);
        let pb = bar(ids.len());
        let describe = |id: &str| -> String { options(id, &a).cache_key() };
        let computed = feature_cache::ensure(
            &ds,
            &ids,
            describe,
            |path, id| {
                let f = file_features(path, &options(id, &a), &a)
                    .map_err(|e| qean_io::Error::msg(format!("{e:#}")))?;
                Ok((f.data, f.frames))
            },
            |done, _, id| {
                pb.set_position(done as u64);
                pb.set_message(id.to_string());
            },
        )?;
        pb.finish_and_clear();
        println!(
            "{} music IDs: {computed} computed, {} already cached, in {}",
            ids.len(),
            ids.len() - computed,
            ds.features_dir().display()
        );
        return Ok(());
    }
    let out = a
        .out
        .clone()
        .expect("clap requires --out without --dataset");
    if a.audio.is_empty() {
        bail!("no audio files given (or use --dataset DIR)");
    }
    if !out.is_dir() {
        bail!("{}: output directory does not exist", out.display());
    }
    // Every file is computed before any is written, so a bad file leaves no partial output.
    let pb = bar(a.audio.len());
    let mut done: Vec<(&PathBuf, PathBuf, audio::MusicFeatures)> =
        Vec::with_capacity(a.audio.len());
    for path in &a.audio {
        let stem = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "audio".into());
        pb.set_message(stem.clone());
        let f = file_features(path, &options(&stem, &a), &a)?;
        let dst = out.join(format!("{stem}.npy"));
        if done.iter().any(|(_, d, _)| *d == dst) {
            bail!(
                "{}: two inputs share the stem {stem:?}, so both would write {}",
                path.display(),
                dst.display()
            );
        }
        done.push((path, dst, f));
        pb.inc(1);
    }
    pb.finish_and_clear();
    for (path, dst, f) in &done {
        qean_io::npy::write_f32(dst, &[f.frames, audio::FEATURE_DIM], &f.data)?;
        println!(
            "{}: {} frames, tempo {:.2} BPM, {} beats -> {}",
            path.display(),
            f.frames,
            f.tempo_bpm,
            f.beats.len(),
            dst.display()
        );
    }
    Ok(())
}

/// `qean inspect` on an audio file: duration, rate, channels, tempo and beat count.
pub fn inspect_audio(path: &std::path::Path) -> anyhow::Result<()> {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned());
    let opts =
        FeatureOptions::with_start_bpm(qean_aistpp::names::start_bpm(&stem.unwrap_or_default()));
    print!("{}", audio::features::describe_file(path, &opts)?);
    Ok(())
}
