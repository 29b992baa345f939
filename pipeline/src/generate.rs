//! Dances from a trained checkpoint (`qean sample`): music features of a song, a seed motion
//! (a pickle, a dataset sequence, or a neutral standing pose), the autoregressive sampler
//! (SPEC §6), and the exports of qean-render (pkl, joints .npy, BVH, previews).

use qean_config::ModelSpec;
use std::path::{Path, PathBuf};

use qean_aistpp::dataset::Dataset;
use qean_aistpp::windows::AUDIO_DIM;
use qean_audio::{self as audio, FeatureOptions, MusicFeatures};
use qean_io::error::{Error, Result};
use qean_models::autoregress::{AudioPad, SampleOptions, SampleRequest};
use qean_motion::fk::FkRoot;
use qean_motion::motion::{Layout, Motion};
use qean_render::export::{export_dance, ExportOptions, ExportPaths};

use qean_checkpoint::checkpoint::Checkpoint;
use qean_eval::run_report::SeedStart;

/// Where the seed motion comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum SeedSource {
    /// A neutral standing pose (SPEC's default when nothing is given).
    Standing,
    /// The first frames of a motion pickle.
    Pickle(PathBuf),
    /// The first frames of a dataset sequence.
    Sequence { data: PathBuf, name: String },
}

/// One song to dance to.
#[derive(Debug, Clone)]
pub struct Song {
    pub path: PathBuf,
    /// Output name (default: the file stem).
    pub name: String,
    pub features: MusicFeatures,
}

/// Reads a song and computes its features; a song shorter than the model's music window is
/// an error naming the file.
pub fn load_song(path: &Path, name: Option<&str>, audio_len: usize) -> Result<Song> {
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "song".into());
    let features = audio::features_for_file(
        path,
        &FeatureOptions::with_start_bpm(qean_aistpp::names::start_bpm(&stem)),
    )?;
    if features.is_silent() {
        tracing::warn!(
            "{}: the audio is silent (no onsets, no beats)",
            path.display()
        );
    }
    if features.frames < audio_len {
        return Err(Error::at(
            path,
            format!(
                "the song is {:.2} s long; the model needs at least {:.2} s ({audio_len} frames) of music",
                features.frames as f64 / 60.0,
                audio_len as f64 / 60.0
            ),
        ));
    }
    Ok(Song {
        path: path.to_path_buf(),
        name: name.map(str::to_string).unwrap_or(stem),
        features,
    })
}

/// The seed: the run's seed frames (`model.motion_len`, or `tsmt.seed_frames`) in the model's layout.
pub fn seed_motion(source: &SeedSource, start: SeedStart, ck: &Checkpoint) -> Result<Vec<f32>> {
    Ok(seed_clip(source, start, ck.config.seed_frames())?.to_layout(ck.config.layout()))
}

/// `n` seed frames from `source`, as a motion.
pub fn seed_clip(source: &SeedSource, start: SeedStart, n: usize) -> Result<Motion> {
    let (motion, path) = match source {
        SeedSource::Standing => return Ok(Motion::standing(n, FkRoot::Smpl)),
        SeedSource::Pickle(p) => (Motion::read_pkl(p)?, p.clone()),
        SeedSource::Sequence { data, name } => {
            let ds = Dataset::open(data)?;
            let p = ds.motion_path(name);
            if !p.is_file() {
                return Err(Error::at(&p, format!("no motion for sequence {name}")));
            }
            (ds.read_motion(name)?, p)
        }
    };
    if motion.frames < n {
        return Err(Error::at(
            &path,
            format!(
                "the seed motion has {} frames; {n} are needed",
                motion.frames
            ),
        ));
    }
    let s = start.starts(&[motion.frames], n)[0];
    Ok(motion.slice(s, s + n))
}

/// Sampling settings of `qean sample`.
#[derive(Debug, Clone)]
pub struct GenerateOptions {
    pub frames: usize,
    pub audio_pad: AudioPad,
    pub feedback_project: bool,
    /// Temporal ensembling: passes averaged per frame (1 = token 0 only, mint) and their decay.
    pub ensemble: usize,
    pub ensemble_decay: f64,
    /// Frames over which the jump at the seed's end fades out (0 = off, mint).
    pub seam_frames: usize,
    pub render: bool,
    pub backend: qean_models::backend::Backend,
    /// Categorical sampling (TSMT): temperature, top-k and the seed of the draws (None: the run's).
    pub temperature: Option<f64>,
    pub top_k: Option<usize>,
    /// TSMT: how sampled bins become coordinates (None: the run's `tsmt.decode`).
    pub decode: Option<qean_config::tsmt::TsmtDecode>,
    /// GPT: the repetition penalty (None: the run's `gpt.repetition_penalty`).
    pub repetition_penalty: Option<f64>,
    /// Genre runs: the guidance s (None: the run's `genre.guidance`).
    pub genre_guidance: Option<f64>,
    /// GPT: the floor's window (None: the run's `gpt.floor_window`; 0 = off).
    pub floor_window: Option<usize>,
    /// GPT: the feet's glide window (None: the run's `gpt.slide_window`; 0 = off).
    pub slide_window: Option<usize>,
    /// GPT: σ of the decoded joints' temporal filter (None: the run's `gpt.smooth_sigma`; 0 = off).
    pub smooth_sigma: Option<f64>,
    pub sample_seed: u64,
    /// Genre control (genre-control GPT runs): the genre and the seed of z.
    pub genre: Option<crate::gpt::GenreChoice>,
    /// Text control (GPT runs whose T-Base was trained).
    pub text: Vec<crate::gpt::TextRequest>,
    /// Keyframe control (keyframe-control GPT runs, or any run of the same GPT with `keyframe_run`).
    pub keyframes: Vec<crate::gpt::KeyframeRequest>,
    /// A keyframe-control run whose module joins this GPT run's sampling (unified sampling, SPEC §13.8).
    pub keyframe_run: Option<std::path::PathBuf>,
}

impl GenerateOptions {
    /// Warns about options this run ignores; an option out of range, or text control asked of a run that
    /// is not a GPT, is an error.
    pub fn check(&self, ck: &Checkpoint) -> Result<()> {
        let spec = ck.config.spec();
        let token_model = matches!(
            spec,
            ModelSpec::Gpt(_) | ModelSpec::GptGenre(..) | ModelSpec::GptKeyframe(..)
        );
        let draws = token_model || matches!(spec, ModelSpec::Tsmt(_));
        crate::gpt::check_guidance(self.genre_guidance, self.genre.is_some())?;
        if !draws && (self.temperature.is_some() || self.top_k.is_some() || self.sample_seed != 0) {
            tracing::warn!(
                "--temperature, --top-k and --sample-seed are for TSMT and GPT runs; this {:?} run is deterministic and ignores them",
                ck.config.model.arch
            );
        }
        if !draws && self.smooth_sigma.is_some() {
            tracing::warn!(
                "--smooth-sigma is for GPT and TSMT runs (decoded joints); this {:?} run ignores it",
                ck.config.model.arch
            );
        }
        if !token_model && (self.floor_window.is_some() || self.slide_window.is_some()) {
            tracing::warn!(
                "--floor-window and --slide-window are for GPT runs (a root integrated from decoded velocities); this {:?} run ignores them",
                ck.config.model.arch
            );
        }
        if let Some(s) = self
            .smooth_sigma
            .filter(|s| !(s.is_finite() && (0.0..=10.0).contains(s)))
        {
            return Err(Error::msg(format!(
                "--smooth-sigma must be in [0, 10] frames (0 = off), got {s}"
            )));
        }
        if let Some(t) = self.temperature.filter(|t| !(t.is_finite() && *t >= 0.0)) {
            return Err(Error::msg(format!("--temperature must be ≥ 0, got {t}")));
        }
        if let Some(r) = self
            .repetition_penalty
            .filter(|r| !(r.is_finite() && *r >= 1.0))
        {
            return Err(Error::msg(format!(
                "--repetition-penalty must be ≥ 1 (1 = off), got {r}"
            )));
        }
        if !self.text.is_empty() && !token_model {
            return Err(Error::msg(format!(
                "--text-embedding needs a GPT run with a trained T-Base (configs/control/gpt_tiny.toml with gpt.text_set, gpt.text_dir or gpt.synthetic_text); {} is a {:?} run",
                ck.dir.display(),
                ck.config.model.arch
            )));
        }
        for t in &self.text {
            t.check(ck.config.gpt_table(), ck.config.seed_frames())?;
        }
        if self.keyframe_run.is_some() && !token_model {
            return Err(Error::msg(format!(
                "--keyframe-run plugs a keyframe module into a GPT run; {} is a {:?} run",
                ck.dir.display(),
                ck.config.model.arch
            )));
        }
        let module = matches!(spec, ModelSpec::GptKeyframe(..)) || self.keyframe_run.is_some();
        if !self.keyframes.is_empty() && !module {
            return Err(Error::msg(format!(
                "--keyframe needs a keyframe-control run (model.arch = \"gpt_keyframe\", configs/control/keyframe_tiny.toml); {} is a {:?} run",
                ck.dir.display(),
                ck.config.model.arch
            )));
        }
        for k in &self.keyframes {
            k.check(ck.config.seed_frames(), self.frames)?;
        }
        Ok(())
    }
}

/// What was written for one song.
#[derive(Debug, Clone)]
pub struct Generated {
    pub name: String,
    /// Frames generated after the seed.
    pub generated: usize,
    pub paths: ExportPaths,
    /// Joint positions of seed and generated frames, frames × 24 (SMPL root), metres.
    pub joints: Vec<[f64; 3]>,
}

/// The output directory must be writable before minutes of sampling are spent.
pub fn prepare_out(out: &Path) -> Result<()> {
    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let probe = qean_io::fsutil::temp_sibling(&out.join("probe"));
    std::fs::write(&probe, b"")
        .map_err(|e| Error::at(out, format!("output directory is not writable: {e}")))?;
    let _ = std::fs::remove_file(&probe);
    Ok(())
}

/// Generates a dance for every song (one batch) from the same seed and writes the exports to
/// `out` (all files of a song or none).
pub fn generate(
    ck: &Checkpoint,
    songs: &[Song],
    seed: &[f32],
    opts: &GenerateOptions,
    out: &Path,
    mut progress: impl FnMut(usize, usize),
) -> Result<Vec<Generated>> {
    prepare_out(out)?;
    match ck.config.spec() {
        ModelSpec::Tsmt(_) => {
            let seed = Motion::from_layout(seed, ck.config.layout()).map_err(Error::msg)?;
            return crate::tsmt::generate(ck, songs, &seed, opts, out, &mut progress);
        }
        ModelSpec::Gpt(_) | ModelSpec::GptGenre(..) | ModelSpec::GptKeyframe(..) => {
            let seed = Motion::from_layout(seed, ck.config.layout()).map_err(Error::msg)?;
            return crate::gpt::generate(ck, songs, &seed, opts, out, &mut progress);
        }
        // FACT and QEAN below; another family's checkpoint is refused by `load_model`.
        _ => {}
    }
    qean_config::recipe::check_ensemble(
        ("ensemble", opts.ensemble),
        ("ensemble decay", opts.ensemble_decay),
        ck.config.model.target_len,
    )
    .map_err(Error::msg)?;
    let device =
        qean_models::backend::device(opts.backend).map_err(|e| Error::msg(e.to_string()))?;
    let model = ck.load_model(&device)?;
    let sample_opts = SampleOptions {
        frames: opts.frames,
        audio_pad: opts.audio_pad,
        feedback_project: opts.feedback_project,
        offset_output: ck.config.recipe.predict == qean_config::recipe::Predict::Offset,
        ensemble: opts.ensemble,
        ensemble_decay: opts.ensemble_decay,
        seam_frames: opts.seam_frames,
        layout: ck.config.layout(),
        spec: ck.config.window_spec(),
    };
    let requests: Vec<SampleRequest> = songs
        .iter()
        .map(|s| SampleRequest {
            seed: seed.to_vec(),
            audio: ck
                .config
                .recipe
                .model_audio(s.features.data.clone(), AUDIO_DIM),
        })
        .collect();
    for s in songs {
        let l = sample_opts.generated_len(s.features.frames);
        if l < opts.frames {
            tracing::warn!(
                "{}: the music ends after {} frames: generating {l} frames instead of {}",
                s.path.display(),
                s.features.frames,
                opts.frames
            );
        }
        debug_assert_eq!(s.features.data.len(), s.features.frames * AUDIO_DIM);
    }
    let dances =
        qean_models::sampler::sample(&model, &device, &requests, &sample_opts, &mut progress)
            .map_err(|e| Error::msg(e.to_string()))?;
    let seed_frames = ck.config.model.motion_len;
    let mut written = Vec::new();
    for (song, dance) in songs.iter().zip(&dances) {
        let joints = Motion::from_layout(dance, sample_opts.layout)
            .map_err(|e| Error::msg(format!("generated {}: {e}", song.name)))?
            .joints(FkRoot::Smpl);
        let vectors = (dance.as_slice(), sample_opts.layout);
        written.push(export_generated(
            out,
            song,
            vectors,
            joints,
            seed_frames,
            opts.render,
        )?);
    }
    Ok(written)
}

/// [`export_generated`] for a dance held as a [`Motion`] (TSMT, the GPT): written in the 219-D layout.
pub(crate) fn export_motion(
    out: &Path,
    song: &Song,
    motion: &Motion,
    seed_frames: usize,
    render: bool,
) -> Result<Generated> {
    export_generated(
        out,
        song,
        (&motion.to_layout(Layout::L219), Layout::L219),
        motion.joints(FkRoot::Smpl),
        seed_frames,
        render,
    )
}

/// Every export of one generated dance (`vectors` in `layout`, seed frames first) to `out`, named after
/// the song, and its record; `joints` are the dance's joint positions (SMPL root). Each family's sampler
/// ends here.
pub(crate) fn export_generated(
    out: &Path,
    song: &Song,
    (vectors, layout): (&[f32], Layout),
    joints: Vec<[f64; 3]>,
    seed_frames: usize,
    render: bool,
) -> Result<Generated> {
    let paths = export_dance(
        out,
        &song.name,
        vectors,
        layout,
        &ExportOptions {
            seed_frames,
            beats: Some(song.features.beats.clone()),
            render,
            root: FkRoot::Smpl,
        },
    )?;
    Ok(Generated {
        name: song.name.clone(),
        generated: vectors.len() / layout.dim() - seed_frames,
        paths,
        joints,
    })
}
