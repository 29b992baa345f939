//! A model family that is neither FACT nor QEAN — a one-layer regressor from the last pose and the first
//! music frame to the next pose — trained through the trainer's `Family` trait: training, checkpoints with
//! the family's own state, an interrupted run resumed to bit-identical parameters, and sampling, all without
//! touching the loop.

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use burn::module::Module;
use burn::nn::{Linear, LinearConfig};
use burn::tensor::{Device, Tensor, TensorData};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::windows::{Batch, SequenceSet, AUDIO_DIM};
use qean_checkpoint::checkpoint::{self, Checkpoint};
use qean_checkpoint::weights::{read_family_state, FAMILY_STATE_FILE};
use qean_checkpoint::ProgressMode;
use qean_config::RunConfig;
use qean_models::autoregress::{SampleOptions, SampleRequest};
use qean_models::model::DanceGenerator;
use qean_train::family::{self, Family, StepContext};
use qean_train::{train_family, Start, TrainOptions};

#[derive(Module, Debug)]
struct Toy {
    layer: Linear,
}

impl Toy {
    /// motion [B, Lm, D], audio [B, La, 35] → the next pose [B, 1, D]: last pose + a linear step.
    fn predict(&self, motion: Tensor<3>, audio: Tensor<3>) -> Tensor<3> {
        let lm = motion.dims()[1];
        let last = motion.narrow(1, lm - 1, 1);
        let music = audio.narrow(1, 0, 1);
        self.layer
            .forward(Tensor::cat(vec![last.clone(), music], 2))
            + last
    }
}

impl DanceGenerator for Toy {
    fn generate(&self, motion: Tensor<3>, audio: Tensor<3>) -> Tensor<3> {
        self.predict(motion, audio)
    }

    fn generate_tokens(&self, motion: Tensor<3>, audio: Tensor<3>, tokens: usize) -> Tensor<3> {
        let p = self.predict(motion, audio);
        Tensor::cat(vec![p; tokens], 1)
    }
}

/// The toy family. Its checkpoint state is the training split's size, fitted once; `stop_at` raises the
/// stop flag while preparing that update (an interruption from inside a run).
#[derive(Default)]
struct ToyFamily {
    state: Option<serde_json::Value>,
    restored: bool,
    stop_at: Option<(u64, Arc<AtomicBool>)>,
}

fn tensors(batch: &Batch, device: &Device) -> (Tensor<3>, Tensor<3>, Tensor<3>) {
    let (b, sp, d) = (batch.len(), batch.spec, batch.dim);
    let t = |data: &[f32], shape: [usize; 3]| {
        Tensor::from_data(TensorData::new(data.to_vec(), shape), device)
    };
    (
        t(&batch.motion, [b, sp.motion_len, d]),
        t(&batch.audio, [b, sp.audio_len, AUDIO_DIM]),
        t(&batch.target, [b, sp.target_len, d]).narrow(1, 0, 1),
    )
}

fn mse(model: &Toy, (motion, audio, target): (Tensor<3>, Tensor<3>, Tensor<3>)) -> Tensor<1> {
    (model.predict(motion, audio) - target)
        .powf_scalar(2.0)
        .mean()
}

impl Family for ToyFamily {
    type Model = Toy;
    type Inputs = (Tensor<3>, Tensor<3>, Tensor<3>);

    fn init(&self, config: &RunConfig, device: &Device) -> qean_io::Result<Toy> {
        let d = config.layout().dim();
        Ok(Toy {
            layer: LinearConfig::new(d + AUDIO_DIM, d).init(device),
        })
    }

    fn prepare(
        &mut self,
        _config: &mut RunConfig,
        dataset: &Dataset,
        train: Split,
        resume: Option<&Checkpoint>,
    ) -> qean_io::Result<()> {
        match resume.map(read_family_state).transpose()?.flatten() {
            Some(state) => {
                self.state = Some(state);
                self.restored = true;
            }
            None => {
                self.state =
                    Some(serde_json::json!({ "train_sequences": dataset.split(train).len() }))
            }
        }
        Ok(())
    }

    fn inputs(
        &self,
        drawn: Batch,
        _model: &Toy,
        device: &Device,
        ctx: &StepContext,
    ) -> Self::Inputs {
        if let Some((step, flag)) = &self.stop_at {
            if ctx.step == *step {
                flag.store(true, Ordering::SeqCst);
            }
        }
        tensors(&drawn, device)
    }

    fn loss(&self, model: &Toy, inputs: Self::Inputs, _config: &RunConfig) -> Tensor<1> {
        mse(model, inputs)
    }

    fn validation_loss(
        &self,
        model: &Toy,
        set: &SequenceSet,
        _config: &RunConfig,
        device: &Device,
    ) -> f64 {
        mse(model, tensors(&set.first_windows(), device)).into_scalar::<f32>() as f64
    }

    fn checkpoint_state(&self) -> Option<serde_json::Value> {
        self.state.clone()
    }
}

fn options(run_dir: &Path, start: Start, stop: Arc<AtomicBool>) -> TrainOptions {
    TrainOptions {
        start,
        progress: ProgressMode::Quiet,
        stop,
        ..TrainOptions::new(run_dir)
    }
}

fn final_checkpoint(run: &Path) -> Checkpoint {
    checkpoint::resolve(run).unwrap()
}

/// A small synthetic dataset under `dir` and the toy's 6-update config (plus `extra` overrides).
fn setup(dir: &Path, extra: &[&str]) -> (std::path::PathBuf, RunConfig) {
    let data = dir.join("synth");
    let synth = qean_synth::SynthOptions {
        sequences: 12,
        seconds: 6.0,
        seed: 3,
        sample_rate: 8000,
        real_music: Vec::new(),
        varied_music: false,
        genre_postures: false,
        genre_music: false,
    };
    qean_synth::generate(&data, &synth).unwrap();
    let configs = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs");
    let mut overrides = vec![
        qean_config::run::string_override("data.dir", &data.to_string_lossy()),
        "train.steps=6".into(),
        "train.batch_size=2".into(),
        "train.checkpoint_every=2".into(),
        "train.val_every=2".into(),
        "train.log_every=1".into(),
    ];
    overrides.extend(extra.iter().map(|e| e.to_string()));
    let config = RunConfig::load(&configs.join("fact.toml"), &overrides).unwrap();
    (data, config)
}

/// Every parameter's name and bit pattern.
fn bits(m: &Toy) -> Vec<(String, Vec<u32>)> {
    qean_models::params::named_parameters(m)
        .into_iter()
        .map(|p| (p.name, p.values.iter().map(|v| v.to_bits()).collect()))
        .collect()
}

#[test]
fn a_toy_family_trains_resumes_exactly_and_samples_through_the_trainer() {
    let tmp = tempfile::tempdir().unwrap();
    let (data, config) = setup(tmp.path(), &[]);

    // Uninterrupted.
    let straight = tmp.path().join("straight");
    let mut toy = ToyFamily::default();
    let out = train_family(
        &mut toy,
        config.clone(),
        &options(&straight, Start::Fresh, Arc::default()),
    )
    .unwrap();
    assert_eq!((out.step, out.interrupted), (6, false));
    assert!(out.val_loss.is_some_and(f64::is_finite));
    let a = final_checkpoint(&straight);
    let state = std::fs::read_to_string(a.dir.join(FAMILY_STATE_FILE)).unwrap();
    assert!(state.contains("\"train_sequences\""), "{state}");

    // Stopped from inside after the 4th update, then resumed.
    let resumed = tmp.path().join("resumed");
    let flag = Arc::new(AtomicBool::new(false));
    let mut toy = ToyFamily {
        stop_at: Some((3, flag.clone())),
        ..ToyFamily::default()
    };
    let out = train_family(
        &mut toy,
        config.clone(),
        &options(&resumed, Start::Fresh, flag),
    )
    .unwrap();
    assert_eq!((out.step, out.interrupted), (4, true));
    let mut toy = ToyFamily::default();
    let out = train_family(
        &mut toy,
        config.clone(),
        &options(&resumed, Start::Auto, Arc::default()),
    )
    .unwrap();
    assert_eq!((out.step, out.interrupted), (6, false));
    assert!(
        toy.restored,
        "the family state comes from the checkpoint on resume"
    );
    let b = final_checkpoint(&resumed);
    assert_eq!(a.state.params_hash, b.state.params_hash);
    // The weights themselves (the hash is of the names and values; the files also hold run-time ids).
    let device = Device::flex();
    let values = |c: &Checkpoint| {
        bits(&family::load_checkpoint_model(&ToyFamily::default(), c, &device).unwrap())
    };
    assert!(values(&a) == values(&b), "bit-identical parameters");
    assert_eq!(a.state.sampler, b.state.sampler);

    // Sampling through the family's checkpoint.
    let model = family::load_checkpoint_model(&toy, &b, &device).unwrap();
    let ds = Dataset::open(&data).unwrap();
    let name = &ds.split(Split::Test)[0];
    let motion = qean_motion::Motion::read_pkl(&ds.motion_path(name)).unwrap();
    let music = qean_aistpp::names::music_id_of(name).unwrap();
    qean_checkpoint::features::ensure_features(&ds, std::slice::from_ref(name)).unwrap();
    let (audio, _) = qean_aistpp::feature_cache::load(&ds, &music).unwrap();
    let (layout, spec) = (config.layout(), config.window_spec());
    let request = SampleRequest {
        seed: motion.slice(0, spec.motion_len).to_layout(layout),
        audio,
    };
    let opts = SampleOptions {
        frames: 30,
        layout,
        spec,
        ..SampleOptions::default()
    };
    let out = qean_models::sampler::sample(
        &model,
        &device,
        std::slice::from_ref(&request),
        &opts,
        |_, _| {},
    )
    .unwrap();
    let d = layout.dim();
    assert_eq!(out[0].len(), (spec.motion_len + 30) * d);
    assert_eq!(&out[0][..spec.motion_len * d], &request.seed[..]);
    assert!(out[0].iter().all(|x| x.is_finite()));
    let generated = &out[0][spec.motion_len * d..];
    assert_ne!(&generated[..d], &request.seed[(spec.motion_len - 1) * d..]);
}

#[test]
fn the_weight_average_resumes_exactly_and_leaves_training_unchanged() {
    let tmp = tempfile::tempdir().unwrap();
    let (_, plain) = setup(tmp.path(), &[]);
    let averaged = RunConfig {
        train: qean_config::run::TrainConfig {
            ema_decay: 0.9,
            ..plain.train.clone()
        },
        ..plain.clone()
    };
    let run = |name: &str, config: &RunConfig, stop_at: Option<u64>| {
        let dir = tmp.path().join(name);
        let flag = Arc::new(AtomicBool::new(false));
        let mut toy = ToyFamily {
            stop_at: stop_at.map(|s| (s, flag.clone())),
            ..ToyFamily::default()
        };
        train_family(&mut toy, config.clone(), &options(&dir, Start::Fresh, flag)).unwrap();
        if stop_at.is_some() {
            let mut toy = ToyFamily::default();
            let out = train_family(
                &mut toy,
                config.clone(),
                &options(&dir, Start::Auto, Arc::default()),
            )
            .unwrap();
            assert_eq!(out.step, 6);
        }
        final_checkpoint(&dir)
    };
    let device = Device::flex();
    let trained = |c: &Checkpoint| {
        let _rng = qean_models::backend::rng_guard();
        let m = ToyFamily::default().init(&c.config, &device).unwrap();
        let path = c.dir.join(checkpoint::MODEL_FILE);
        bits(&qean_checkpoint::weights::load_weights(m, &path).unwrap())
    };
    let sampled = |c: &Checkpoint| {
        bits(&family::load_checkpoint_model(&ToyFamily::default(), c, &device).unwrap())
    };
    let without = run("without", &plain, None);
    let straight = run("straight", &averaged, None);
    let resumed = run("resumed", &averaged, Some(3));
    assert!(!without.dir.join(checkpoint::EMA_FILE).exists());
    assert!(straight.dir.join(checkpoint::EMA_FILE).is_file());
    assert!(
        trained(&without) == trained(&straight),
        "the average does not change training"
    );
    assert!(sampled(&without) == trained(&without));
    assert!(
        sampled(&straight) != trained(&straight),
        "samplers load the average"
    );
    assert!(
        sampled(&straight) == sampled(&resumed),
        "the average resumes bit-exactly"
    );
    assert!(trained(&straight) == trained(&resumed));
}
