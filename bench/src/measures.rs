//! The measures of `qean bench`, their inputs and their sizes.

use std::path::{Path, PathBuf};
use std::time::Instant;

use burn::module::Module;
use burn::tensor::{Device, Tensor, TensorData};
use qean_aistpp::windows::AUDIO_DIM;
use qean_audio::{features_for_file, FeatureOptions};
use qean_config::RunConfig;
use qean_eval::synthetic::SyntheticSet;
use qean_eval::{evaluate, EvalConfig, Sequence};
use qean_models::autoregress::{SampleOptions, SampleRequest};
use qean_models::sampler::sample;
use qean_models::DanceModel;
use qean_train::fact_qean::update;
use qean_train::trainer::adam;
use serde::{Deserialize, Serialize};

use super::report::Entry;

/// One measure.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum MeasureId {
    Features,
    FeaturesDataset,
    Metrics,
    TrainTiny,
    TrainMint,
    SampleTiny,
    SampleMint,
    TrainTsmt,
    SampleTsmt,
}

impl MeasureId {
    pub const ALL: [MeasureId; 9] = [
        MeasureId::Features,
        MeasureId::FeaturesDataset,
        MeasureId::Metrics,
        MeasureId::TrainTiny,
        MeasureId::TrainMint,
        MeasureId::SampleTiny,
        MeasureId::SampleMint,
        MeasureId::TrainTsmt,
        MeasureId::SampleTsmt,
    ];

    pub fn name(self) -> &'static str {
        match self {
            MeasureId::Features => "features",
            MeasureId::FeaturesDataset => "features-dataset",
            MeasureId::Metrics => "metrics",
            MeasureId::TrainTiny => "train-tiny",
            MeasureId::TrainMint => "train-mint",
            MeasureId::SampleTiny => "sample-tiny",
            MeasureId::SampleMint => "sample-mint",
            MeasureId::TrainTsmt => "train-tsmt",
            MeasureId::SampleTsmt => "sample-tsmt",
        }
    }

    pub fn parse(s: &str) -> Option<MeasureId> {
        MeasureId::ALL.into_iter().find(|m| m.name() == s)
    }

    /// Runs a model (and so depends on the backend).
    pub fn uses_model(self) -> bool {
        !matches!(
            self,
            MeasureId::Features | MeasureId::FeaturesDataset | MeasureId::Metrics
        )
    }

    /// Model size of a model measure ("tiny", "mint", or "paper" for TSMT).
    pub fn size(self) -> &'static str {
        match self {
            MeasureId::TrainMint | MeasureId::SampleMint => "mint",
            MeasureId::TrainTsmt | MeasureId::SampleTsmt => "paper",
            _ => "tiny",
        }
    }
}

/// Sizes and repeat counts.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Sizes {
    /// Length of the feature track (seconds) and its sample rate (the embedded song is resampled to
    /// it: 44.1 kHz, the rate of most music files, makes librosa.load downsample as it usually does).
    pub track_seconds: f64,
    #[serde(default = "default_track_rate")]
    pub track_rate: u32,
    pub feature_repeats: usize,
    /// Tracks of the dataset-mode feature measure (copies of the track under AIST++ music names; 2 to 10).
    #[serde(default = "default_dataset_tracks")]
    pub dataset_tracks: usize,
    /// Generated sequences, their frames (seed + generated), reference sequences.
    pub generated: usize,
    pub generated_frames: usize,
    pub reference: usize,
    pub metric_repeats: usize,
    pub batch: usize,
    /// Timed training steps (after one warm-up step).
    pub train_steps_tiny: usize,
    pub train_steps_mint: usize,
    /// Sequences sampled together, and the frames timed (after one warm-up pass).
    pub sequences: usize,
    pub sample_frames_tiny: usize,
    pub sample_frames_mint: usize,
    /// The horizon the frames-per-second figure is converted to (mint: 1200).
    pub horizon: usize,
    /// TSMT (paper size): timed training steps at batch 32, and frames sampled per timing.
    #[serde(default = "default_tsmt_steps")]
    pub train_steps_tsmt: usize,
    #[serde(default = "default_tsmt_frames")]
    pub sample_frames_tsmt: usize,
}

fn default_dataset_tracks() -> usize {
    8
}

fn default_tsmt_steps() -> usize {
    3
}

fn default_tsmt_frames() -> usize {
    30
}

/// The AIST++ music IDs whose tempo prior is 120 BPM (80 + 10k; house 110 + 5k), the peer's prior: the
/// dataset-mode tracks are named after them, so both sides track beats from the same prior.
pub const DATASET_MUSIC: [&str; 10] = [
    "mBR4", "mPO4", "mLO4", "mMH4", "mLH4", "mHO2", "mWA4", "mKR4", "mJS4", "mJB4",
];

/// The music IDs of the dataset-mode measure (2 to 10 of them).
pub fn dataset_music(sizes: &Sizes) -> &'static [&'static str] {
    &DATASET_MUSIC[..sizes.dataset_tracks.clamp(2, DATASET_MUSIC.len())]
}

/// TSMT's training batch (the reference script's).
pub const TSMT_BATCH: usize = 32;

impl Sizes {
    pub fn new(quick: bool) -> Sizes {
        Sizes {
            track_seconds: 60.0,
            track_rate: default_track_rate(),
            feature_repeats: if quick { 1 } else { 3 },
            dataset_tracks: if quick { 4 } else { default_dataset_tracks() },
            generated: 40,
            generated_frames: 1320,
            reference: 1363,
            metric_repeats: if quick { 1 } else { 3 },
            batch: 16,
            train_steps_tiny: if quick { 3 } else { 10 },
            train_steps_mint: 1,
            sequences: 40,
            sample_frames_tiny: if quick { 5 } else { 30 },
            sample_frames_mint: 1,
            horizon: 1200,
            train_steps_tsmt: if quick { 1 } else { default_tsmt_steps() },
            sample_frames_tsmt: if quick { 5 } else { default_tsmt_frames() },
        }
    }
}

fn default_track_rate() -> u32 {
    44_100
}

/// Inputs shared by our measures and the peers'.
pub struct Inputs {
    pub dir: PathBuf,
    /// The 60 s track (16-bit WAV at `Sizes::track_rate`).
    pub track: PathBuf,
    /// An AIST++-layout directory whose `wav/` holds `Sizes::dataset_tracks` copies of the track.
    pub dataset: PathBuf,
    /// The synthetic metric set and its description for the peer.
    pub set: SyntheticSet,
    pub set_json: PathBuf,
    /// Run configs of the tiny and the mint-size FACT, and of TSMT at the paper's size.
    pub tiny_config: PathBuf,
    pub mint_config: PathBuf,
    pub tsmt_config: PathBuf,
}

impl Inputs {
    /// The inputs under `dir`, as [`Inputs::prepare`] wrote them (the metric set is rebuilt from
    /// its seed in memory: cheaper than parsing its JSON). Reads and writes nothing.
    pub fn open(dir: &Path, sizes: &Sizes) -> Inputs {
        Inputs {
            dir: dir.to_path_buf(),
            track: dir.join(format!(
                "track-{}s-{}hz.wav",
                sizes.track_seconds, sizes.track_rate
            )),
            dataset: dir.join(format!("feature-dataset-{}", sizes.dataset_tracks)),
            set: SyntheticSet::aist_sized(
                7,
                sizes.generated,
                sizes.generated_frames,
                sizes.reference,
            ),
            set_json: dir.join("metric-set.json"),
            tiny_config: dir.join("configs/tiny/fact.toml"),
            mint_config: dir.join("configs/fact.toml"),
            tsmt_config: dir.join("configs/tsmt/paper.toml"),
        }
    }

    /// Writes the inputs under `dir`: the embedded configs and music, the track, the set's JSON.
    pub fn prepare(dir: &Path, sizes: &Sizes) -> crate::Result<Inputs> {
        let inputs = Inputs::open(dir, sizes);
        qean_pipeline::demo::write_assets(dir)?;
        let source = dir.join("assets/music/Kevin_MacLeod_-_Vibe_Ace.ogg");
        let decoded = qean_audio::decode::decode_file(&source, 3600.0)?;
        let song: Vec<f64> = decoded.samples.iter().map(|&v| v as f64).collect();
        let song = qean_audio::resample::resample_with(
            &song,
            decoded.rate as f64,
            sizes.track_rate as f64,
            qean_audio::Resampler::KaiserFast,
            false,
            false,
        )?;
        // Loop the song if it is shorter than the track.
        let want = (sizes.track_seconds * sizes.track_rate as f64).round() as usize;
        let samples: Vec<f64> = song.iter().cycle().take(want).copied().collect();
        qean_io::wav::write_pcm16(&inputs.track, &samples, sizes.track_rate)?;
        for dir in ["wav", "motions"] {
            let d = inputs.dataset.join(dir);
            std::fs::create_dir_all(&d).map_err(|e| qean_io::Error::io(&d, e))?;
        }
        for path in inputs.dataset_tracks(sizes) {
            std::fs::copy(&inputs.track, &path).map_err(|e| qean_io::Error::io(&path, e))?;
        }
        let set = serde_json::to_string(&inputs.set)
            .map_err(|e| crate::Error::invalid(format!("the benchmark's metric set: {e}")))?;
        qean_io::fsutil::atomic_write(&inputs.set_json, set.as_bytes())?;
        Ok(inputs)
    }

    /// The dataset-mode tracks: `wav/<id>.wav` for the first `dataset_tracks` of [`DATASET_MUSIC`].
    pub fn dataset_tracks(&self, sizes: &Sizes) -> Vec<PathBuf> {
        dataset_music(sizes)
            .iter()
            .map(|id| self.dataset.join(format!("wav/{id}.wav")))
            .collect()
    }

    pub fn config(&self, id: MeasureId) -> &Path {
        match id.size() {
            "mint" => &self.mint_config,
            "paper" => &self.tsmt_config,
            _ => &self.tiny_config,
        }
    }
}

/// Peak resident memory since the last [`reset_peak_rss`] (MiB; NaN where /proc is missing).
pub fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1)?.parse::<f64>().ok())
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

/// Resets the peak to the current resident size (Linux ≥ 4.0).
pub fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

pub(super) fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Deterministic values in [-1, 1) for benchmark inputs (the timing does not depend on them).
pub(super) fn filler(n: usize, seed: u64) -> Vec<f32> {
    let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 40) as f32 / (1u64 << 23) as f32 - 1.0
        })
        .collect()
}

/// Runs one measure on `backend` ("" for the measures without a model).
pub fn run_measure(
    id: MeasureId,
    backend: &str,
    inputs: &Inputs,
    sizes: &Sizes,
) -> crate::Result<Entry> {
    reset_peak_rss();
    let mut entry = match id {
        MeasureId::Features => features(inputs, sizes)?,
        MeasureId::FeaturesDataset => features_dataset(inputs, sizes)?,
        MeasureId::Metrics => metrics(inputs, sizes)?,
        MeasureId::TrainTiny | MeasureId::TrainMint => train(id, backend, inputs, sizes)?,
        MeasureId::SampleTiny | MeasureId::SampleMint => sampling(id, backend, inputs, sizes)?,
        MeasureId::TrainTsmt => super::tsmt::train(backend, inputs, sizes)?,
        MeasureId::SampleTsmt => super::tsmt::sampling(backend, inputs, sizes)?,
    };
    entry.peak_rss_mb = peak_rss_mb();
    Ok(entry)
}

fn features(inputs: &Inputs, sizes: &Sizes) -> crate::Result<Entry> {
    let opts = FeatureOptions::default();
    let mut times = Vec::new();
    for _ in 0..sizes.feature_repeats.max(1) {
        let t = Instant::now();
        let f = features_for_file(&inputs.track, &opts)?;
        times.push(t.elapsed().as_secs_f64());
        qean_pipeline::ensure!(f.frames > 0, "no feature frames");
    }
    Ok(Entry::time(
        MeasureId::Features,
        "",
        median(times),
        "s per track",
        format!(
            "{} s track at {} Hz, decode + resample + 35-D features, median of {}",
            sizes.track_seconds,
            sizes.track_rate,
            sizes.feature_repeats.max(1)
        ),
    ))
}

/// `qean features --dataset`'s work on a dataset of `dataset_tracks` tracks: every track's features
/// computed (side by side) and cached, from an empty cache, with the options of training's feature cache
/// (`qean_checkpoint::features::ensure_features`: the AIST++ tempo prior of each music ID, here 120 BPM).
fn features_dataset(inputs: &Inputs, sizes: &Sizes) -> crate::Result<Entry> {
    let ds = qean_aistpp::dataset::Dataset::open(&inputs.dataset)?;
    let ids: Vec<String> = dataset_music(sizes).iter().map(|s| s.to_string()).collect();
    let mut times = Vec::new();
    for _ in 0..sizes.feature_repeats.max(1) {
        let cache = ds.features_dir();
        if cache.exists() {
            std::fs::remove_dir_all(&cache).map_err(|e| qean_io::Error::io(&cache, e))?;
        }
        let t = Instant::now();
        let computed = qean_aistpp::feature_cache::ensure(
            &ds,
            &ids,
            |id| FeatureOptions::with_start_bpm(qean_aistpp::names::start_bpm(id)).cache_key(),
            |path, id| {
                let opts = FeatureOptions::with_start_bpm(qean_aistpp::names::start_bpm(id));
                let f = features_for_file(path, &opts)?;
                Ok((f.data, f.frames))
            },
            |_, _, _| {},
        )?;
        times.push(t.elapsed().as_secs_f64() / ids.len() as f64);
        qean_pipeline::ensure!(
            computed == ids.len(),
            "computed {computed} of {} tracks",
            ids.len()
        );
    }
    let per_track = median(times);
    Ok(Entry::time(
        MeasureId::FeaturesDataset,
        "",
        per_track,
        "s per track",
        format!(
            "{} tracks of {} s at {} Hz into a dataset's feature cache (tracks side by side, each written to disk), {:.2} tracks/s, median of {}",
            ids.len(),
            sizes.track_seconds,
            sizes.track_rate,
            1.0 / per_track,
            sizes.feature_repeats.max(1)
        ),
    ))
}

fn metrics(inputs: &Inputs, sizes: &Sizes) -> crate::Result<Entry> {
    let set = &inputs.set;
    let reference: Vec<Sequence> = set.reference.iter().map(|s| s.sequence()).collect();
    let generated: Vec<Sequence> = set.generated.iter().map(|s| s.sequence()).collect();
    let longest = reference.iter().map(|s| s.joints.len()).max().unwrap_or(0);
    let music = set.beats(longest.max(sizes.generated_frames) + 1);
    let beats = |_: &str| -> qean_eval::Result<Vec<usize>> { Ok(music.clone()) };
    let cfg = EvalConfig::default();
    let mut times = Vec::new();
    for _ in 0..sizes.metric_repeats.max(1) {
        let t = Instant::now();
        let report = evaluate(&generated, &reference, Some(&beats), &cfg)?;
        times.push(t.elapsed().as_secs_f64());
        qean_pipeline::ensure!(report.fid_k.is_finite(), "FID_k is not finite");
    }
    Ok(Entry::time(
        MeasureId::Metrics,
        "",
        median(times),
        "s per evaluation",
        format!(
            "{} generated × {} frames vs {} reference ({} frames), all five metrics, median of {}",
            sizes.generated,
            sizes.generated_frames,
            sizes.reference,
            set.reference_frames(),
            sizes.metric_repeats.max(1)
        ),
    ))
}

pub(super) fn load_config(path: &Path) -> crate::Result<RunConfig> {
    Ok(RunConfig::load(path, &[])?)
}

pub(super) fn device(backend: &str) -> crate::Result<Device> {
    Ok(qean_models::backend::device_named(backend)?)
}

fn train(id: MeasureId, backend: &str, inputs: &Inputs, sizes: &Sizes) -> crate::Result<Entry> {
    let config = load_config(inputs.config(id))?;
    let device = device(backend)?.autodiff();
    device.seed(0);
    let mut model = DanceModel::new(&config.model, &device)?;
    let params = model.num_params();
    let mut optim = adam(&config);
    let spec = config.window_spec();
    let d = config.layout().dim();
    let b = sizes.batch;
    let tensor = |shape: [usize; 3], seed| {
        Tensor::<3>::from_data(
            TensorData::new(filler(shape.iter().product(), seed), shape),
            &device,
        )
    };
    let steps = match id {
        MeasureId::TrainMint => sizes.train_steps_mint,
        _ => sizes.train_steps_tiny,
    }
    .max(1);
    let mut times = Vec::new();
    for k in 0..=steps {
        let m = tensor([b, spec.motion_len, d], 1);
        let a = tensor([b, spec.audio_len, AUDIO_DIM], 2);
        let target = tensor([b, spec.target_len, d], 3);
        let t = Instant::now();
        let (next, loss) = update(
            model,
            &mut optim,
            (m, a, target),
            Default::default(),
            1e-4,
            0.0,
        );
        model = next;
        qean_pipeline::ensure!(loss.is_finite(), "the benchmark loss is not finite");
        if k > 0 {
            times.push(t.elapsed().as_secs_f64());
        }
    }
    Ok(Entry::time(
        id,
        backend,
        median(times),
        "s per step",
        format!(
            "FACT {} ({params} parameters), batch {b}, forward + backward + Adam, median of {steps} after a warm-up",
            id.size()
        ),
    ))
}

fn sampling(id: MeasureId, backend: &str, inputs: &Inputs, sizes: &Sizes) -> crate::Result<Entry> {
    let config = load_config(inputs.config(id))?;
    let device = device(backend)?;
    device.seed(0);
    let model = DanceModel::new(&config.model, &device)?;
    let params = model.num_params();
    let spec = config.window_spec();
    let layout = config.layout();
    let frames = match id {
        MeasureId::SampleMint => sizes.sample_frames_mint,
        _ => sizes.sample_frames_tiny,
    }
    .max(1);
    let requests: Vec<SampleRequest> = (0..sizes.sequences)
        .map(|k| SampleRequest {
            seed: filler(spec.motion_len * layout.dim(), 10 + k as u64),
            audio: filler((spec.audio_len + frames) * AUDIO_DIM, 100 + k as u64),
        })
        .collect();
    let opts = |frames| SampleOptions {
        frames,
        layout,
        spec,
        ..SampleOptions::default()
    };
    // Warm-up: one pass (allocator and thread pools), not timed.
    if id == MeasureId::SampleTiny {
        sample(&model, &device, &requests, &opts(1), |_, _| {})?;
    }
    let t = Instant::now();
    let out = sample(&model, &device, &requests, &opts(frames), |_, _| {})?;
    let seconds = t.elapsed().as_secs_f64();
    qean_pipeline::ensure!(
        out.len() == sizes.sequences,
        "sampler returned {} sequences",
        out.len()
    );
    let fps = (sizes.sequences * frames) as f64 / seconds;
    let full = (sizes.sequences * sizes.horizon) as f64 / fps;
    Ok(Entry::rate(
        id,
        backend,
        fps,
        "frames/s",
        format!(
            "FACT {} ({params} parameters), {} sequences in one batch, {frames} frame(s) timed; {} × {} frames ≈ {}",
            id.size(),
            sizes.sequences,
            sizes.sequences,
            sizes.horizon,
            super::report::duration_text(full)
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filler_is_deterministic_and_bounded() {
        let a = filler(1000, 3);
        assert_eq!(a, filler(1000, 3));
        assert_ne!(a, filler(1000, 4));
        assert!(a.iter().all(|v| (-1.0..1.0).contains(v)));
        let mean = a.iter().sum::<f32>() / 1000.0;
        assert!(mean.abs() < 0.1, "{mean}");
    }

    #[test]
    fn measure_names_round_trip() {
        for m in MeasureId::ALL {
            assert_eq!(MeasureId::parse(m.name()), Some(m));
        }
        assert_eq!(MeasureId::parse("nope"), None);
    }
}
