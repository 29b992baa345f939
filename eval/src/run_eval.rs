//! Checkpoint mode (`qean-eval --run R --data DIR`, SPEC §1.6): sample the test + val sequences
//! with a trained checkpoint (seed = the first 120 ground-truth frames, 1200 generated frames,
//! batched), then every metric against the ground-truth reference set (all non-ignored
//! sequences, full length), written to `R/eval/step-N/report.{json,md}` with the generated
//! joints beside them.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use anyhow::{bail, Context};
use indicatif::{ProgressBar, ProgressStyle};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::feature_cache;
use qean_aistpp::names::music_id_of;
use qean_models::autoregress::{AudioPad, SampleOptions, SampleRequest};
use qean_motion::motion::Motion;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use crate::cli::{music_beats, Args, EvaluationFile};
use crate::io::write_json_atomic;
use crate::motion_energy::EnergyReference;
use crate::positions::{Frame, Sequence, N_JOINTS};
use crate::protocol::evaluate;
use crate::report::{render_markdown, MetricsReport};

/// Which motion is paired with which music.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Protocol {
    /// Each test/val motion with its own music (Bailando, QEAN; the default).
    Paired,
    /// mint's: 10 draws of music per motion from the same set (seed 42), duplicates dropped.
    Unpaired,
}

/// One generated sequence of the protocol.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Pairing {
    /// Output name; its 5th `_` field is the music ID (AIST++ naming), so BeatAlign finds the music.
    pub name: String,
    /// The ground-truth sequence giving the seed.
    pub motion: String,
    pub music_id: String,
    /// Frames generated after the seed.
    pub generated: usize,
}

/// report.json of checkpoint mode.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunReport {
    pub checkpoint: PathBuf,
    pub step: u64,
    pub protocol: Protocol,
    pub frames: usize,
    /// Whether fed-back frames were projected to SO(3) while sampling.
    #[serde(default)]
    pub feedback_project: bool,
    /// Passes averaged per frame (temporal ensembling; 1 = token 0 only).
    #[serde(default = "one")]
    pub ensemble: usize,
    /// Frames over which the jump at the seed's end faded out (0 = off; reports written before
    /// the option existed were sampled without it).
    #[serde(default)]
    pub seam_frames: usize,
    pub pairings: Vec<Pairing>,
    pub reports: Vec<MetricsReport>,
    /// With `--baselines`: the chance baselines, scored like the first report.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baselines: Option<Baselines>,
}

fn one() -> usize {
    1
}

/// Chance baselines of checkpoint mode (`--baselines`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Baselines {
    /// Every dance replaced by its seed's last frame, held: no motion at all.
    pub frozen: MetricsReport,
    /// The generated dances scored against other music IDs' beats: every rotation of the sorted
    /// music IDs that moves each dance to another song, its BeatAlign values averaged over those
    /// pairings (the expected score of a random mismatched pairing); `None` when all sequences share
    /// one music ID.
    pub random_pairing: Option<MetricsReport>,
}

/// The frozen baseline: seed frames, then the last seed frame held for the rest of each sequence.
pub fn frozen_dances(generated: &[Sequence], seed_frames: usize) -> Vec<Sequence> {
    generated
        .iter()
        .map(|s| {
            let keep = seed_frames.min(s.joints.len());
            let mut joints = s.joints[..keep].to_vec();
            if let Some(&last) = joints.last() {
                joints.resize(s.joints.len(), last);
            }
            Sequence {
                name: s.name.clone(),
                joints,
            }
        })
        .collect()
}

/// One random-pairing set: each name's music ID (5th `_` field) replaced by the distinct music ID
/// `shift` places later in sorted order (1 ≤ shift < number of IDs), so no dance keeps its own music.
/// `None` with fewer than two music IDs or a shift outside that range.
pub fn repaired_dances(generated: &[Sequence], shift: usize) -> Option<Vec<Sequence>> {
    let mut ids: Vec<String> = generated
        .iter()
        .filter_map(|s| music_id_of(&s.name))
        .collect();
    ids.sort();
    ids.dedup();
    if ids.len() < 2 || shift == 0 || shift >= ids.len() {
        return None;
    }
    let out = generated
        .iter()
        .map(|s| {
            let mut fields: Vec<String> = s.name.split('_').map(str::to_string).collect();
            if let Some(pos) = music_id_of(&s.name).and_then(|m| ids.iter().position(|x| *x == m)) {
                fields[4] = ids[(pos + shift) % ids.len()].clone();
            }
            Sequence {
                name: fields.join("_"),
                joints: s.joints.clone(),
            }
        })
        .collect();
    Some(out)
}

/// The first report with every BeatAlign value replaced by its mean over `reports` (the motions,
/// hence every other metric, are the same in each). `None` for no reports.
pub fn average_beat_align(reports: Vec<MetricsReport>) -> Option<MetricsReport> {
    let mean = |get: fn(&MetricsReport) -> Option<f64>| -> Option<f64> {
        let v: Vec<f64> = reports.iter().filter_map(get).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let beat_align = mean(|r| r.beat_align);
    let bailando = mean(|r| r.beat_align_bailando);
    let mint = mean(|r| r.beat_align_mint);
    let n = reports.len();
    let mut first = reports.into_iter().next()?;
    first.beat_align = beat_align;
    first.beat_align_bailando = bailando;
    first.beat_align_mint = mint;
    first.label = format!("{} (mean of {n} pairings)", first.label);
    Some(first)
}

/// The pairs of a protocol over the test + val sequences.
pub fn pairings(names: &[String], protocol: Protocol) -> Vec<(String, String, String)> {
    match protocol {
        Protocol::Paired => names
            .iter()
            .filter_map(|n| music_id_of(n).map(|m| (n.clone(), m, n.clone())))
            .collect(),
        Protocol::Unpaired => {
            let musics: Vec<String> = names.iter().filter_map(|n| music_id_of(n)).collect();
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(42);
            let mut seen = HashSet::new();
            let mut out = Vec::new();
            for n in names {
                for _ in 0..10 {
                    let m = musics[rng.random_range(0..musics.len())].clone();
                    if seen.insert((n.clone(), m.clone())) {
                        // The music field replaced, the source motion's music kept as a suffix.
                        let fields: Vec<&str> = n.split('_').collect();
                        let name = if fields.len() >= 6 {
                            let mut f: Vec<String> = fields.iter().map(|s| s.to_string()).collect();
                            let own = f[4].clone();
                            f[4] = m.clone();
                            format!("{}_from-{own}", f.join("_"))
                        } else {
                            format!("{n}_{m}")
                        };
                        out.push((n.clone(), m, name));
                    }
                }
            }
            out
        }
    }
}

/// The motion-energy statistics of a dataset's reference set: every non-ignored sequence, full
/// length, as the metrics' reference set (SPEC §1.6).
pub fn dataset_energy_reference(
    data: &Path,
    root: qean_motion::FkRoot,
) -> anyhow::Result<EnergyReference> {
    let ds = Dataset::open(data)?;
    let mut sequences = Vec::new();
    for name in ds.all_sequences()? {
        let m = Motion::read_pkl(&ds.motion_path(&name))?;
        sequences.push(frames_of(m.joints(root)));
    }
    if sequences.is_empty() {
        bail!(
            "{}: no motions to take the reference speed from",
            data.display()
        );
    }
    Ok(EnergyReference::fit(sequences.iter().map(Vec::as_slice)))
}

/// The reference of [`dataset_energy_reference`], cached in `cache` (a JSON file naming the
/// dataset; recomputed when it names another or cannot be read or written).
pub fn cached_energy_reference(data: &Path, cache: &Path) -> anyhow::Result<EnergyReference> {
    #[derive(Serialize, Deserialize)]
    struct Cached {
        data: PathBuf,
        reference: EnergyReference,
    }
    let data_abs = std::fs::canonicalize(data).unwrap_or_else(|_| data.to_path_buf());
    if let Some(c) = std::fs::read_to_string(cache)
        .ok()
        .and_then(|t| serde_json::from_str::<Cached>(&t).ok())
        .filter(|c| c.data == data_abs)
    {
        return Ok(c.reference);
    }
    let reference = dataset_energy_reference(data, qean_motion::FkRoot::Smpl)?;
    let _ = write_json_atomic(
        cache,
        &Cached {
            data: data_abs,
            reference,
        },
    );
    Ok(reference)
}

/// Joint positions (frames × 24 points) as metric frames.
pub fn frames_of(points: Vec<[f64; 3]>) -> Vec<Frame> {
    points
        .chunks_exact(N_JOINTS)
        .map(|c| {
            let mut f = [[0.0; 3]; N_JOINTS];
            f.copy_from_slice(c);
            f
        })
        .collect()
}

/// Runs checkpoint mode; returns the report file's content and the markdown table.
pub fn evaluate_run(args: &Args, run: &Path) -> anyhow::Result<(EvaluationFile, String)> {
    evaluate_run_full(args, run).map(|(file, table, _)| (file, table))
}

/// [`evaluate_run`], also returning the whole `report.json` (baselines included).
pub fn evaluate_run_full(
    args: &Args,
    run: &Path,
) -> anyhow::Result<(EvaluationFile, String, RunReport)> {
    let data = args
        .data
        .as_ref()
        .context("--run needs --data DIR (the AIST++-layout dataset)")?;
    let ck = qean_train::checkpoint::resolve_in_run(run, args.checkpoint.as_deref())?;
    let ds = Dataset::open(data)?;
    let mut names = ds.split(Split::Test);
    names.extend(ds.split(Split::Val));
    names.retain(|n| {
        ds.motion_path(n).is_file() || {
            tracing::warn!(
                "{}: missing, left out of the evaluation",
                ds.motion_path(n).display()
            );
            false
        }
    });
    if names.len() < 2 {
        bail!(
            "{}: the test and val splits hold {} motion(s); the metrics need at least 2",
            data.display(),
            names.len()
        );
    }
    qean_train::data::ensure_features(&ds, &names)?;
    let config = &ck.config;
    let layout = config.layout();
    let seed_frames = config.model.motion_len;
    let root = args.fk_root.fk();

    let pairs = pairings(&names, args.protocol);
    let mut requests = Vec::new();
    for (motion, music, _) in &pairs {
        let path = ds.motion_path(motion);
        let m = Motion::read_pkl(&path)?;
        if m.frames < seed_frames {
            bail!(
                "{}: {} frames, shorter than the {seed_frames}-frame seed",
                path.display(),
                m.frames
            );
        }
        let (audio, _) = feature_cache::load(&ds, music)?;
        let audio = config
            .recipe
            .model_audio(audio, qean_aistpp::windows::AUDIO_DIM);
        requests.push(SampleRequest {
            seed: m.slice(0, seed_frames).to_layout(layout),
            audio,
        });
    }
    let opts = SampleOptions {
        frames: args.max_frames,
        audio_pad: if args.audio_pad_edge {
            AudioPad::Edge
        } else {
            AudioPad::Stop
        },
        feedback_project: config
            .recipe
            .feedback_project_with(args.feedback_project, args.raw_feedback),
        offset_output: config.recipe.predict == qean_config::recipe::Predict::Offset,
        ensemble: args.ensemble.unwrap_or(config.recipe.ensemble),
        ensemble_decay: args.ensemble_decay.unwrap_or(config.recipe.ensemble_decay),
        seam_frames: args.seam_frames.unwrap_or(config.recipe.seam_frames),
        layout,
        spec: config.window_spec(),
    };
    qean_config::recipe::check_ensemble(
        ("--ensemble", opts.ensemble),
        ("--ensemble-decay", opts.ensemble_decay),
        config.model.target_len,
    )
    .map_err(anyhow::Error::msg)?;
    let backend = args
        .backend
        .clone()
        .unwrap_or_else(|| config.train.backend.clone());
    let device = qean_models::backend::device(&backend).map_err(anyhow::Error::msg)?;
    let model = ck.load_model(&device)?;
    let pb = ProgressBar::new(args.max_frames as u64);
    pb.set_style(
        ProgressStyle::with_template(&format!(
            "sampling {} sequences {{bar:30}} {{pos}}/{{len}} frames {{per_sec}} [eta {{eta}}]",
            requests.len()
        ))
        .expect("valid template"),
    );
    let dances = qean_models::sampler::sample(&model, &device, &requests, &opts, |done, total| {
        pb.set_length(total as u64);
        pb.set_position(done as u64);
    });
    pb.finish_and_clear();

    let mut dir_name = qean_train::run_dir::checkpoint_name(ck.state.step);
    if let Some(tag) = &args.tag {
        if tag.is_empty()
            || !tag
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c))
        {
            bail!("--tag {tag:?}: use letters, digits, '-', '_' or '.'");
        }
        dir_name = format!("{dir_name}-{tag}");
    }
    let out_dir = run.join("eval").join(dir_name);
    let joints_dir = out_dir.join("generated");
    std::fs::create_dir_all(&joints_dir)
        .with_context(|| format!("{}: cannot create", joints_dir.display()))?;
    let d = layout.dim();
    let mut generated = Vec::new();
    let mut pairings_out = Vec::new();
    for ((motion, music, name), dance) in pairs.iter().zip(&dances) {
        let m = Motion::from_layout(dance, layout)
            .map_err(|e| anyhow::anyhow!("generated {name}: {e}"))?;
        let points = m.joints(root);
        qean_motion::joints_file::write_joints(
            &joints_dir.join(format!("{name}.joints.npy")),
            &points,
        )?;
        generated.push(Sequence {
            name: name.clone(),
            joints: frames_of(points),
        });
        pairings_out.push(Pairing {
            name: name.clone(),
            motion: motion.clone(),
            music_id: music.clone(),
            generated: dance.len() / d - seed_frames,
        });
    }
    let lengths: Vec<usize> = pairings_out.iter().map(|p| p.generated).collect();
    tracing::info!(
        "generated {} sequences, {}..={} frames each",
        lengths.len(),
        lengths.iter().min().unwrap_or(&0),
        lengths.iter().max().unwrap_or(&0)
    );

    // The GT reference set: every non-ignored motion, full length.
    let mut reference = Vec::new();
    for name in ds.all_sequences()? {
        let m = Motion::read_pkl(&ds.motion_path(&name))?;
        reference.push(Sequence {
            name: name.clone(),
            joints: frames_of(m.joints(root)),
        });
    }
    let mut ba_names: Vec<&str> = generated.iter().map(|s| s.name.as_str()).collect();
    ba_names.extend(names.iter().map(String::as_str));
    let beats = music_beats(&data.join("wav"), ba_names.into_iter(), args.ba_music_beats)?;
    let lookup = |id: &str| -> crate::Result<Vec<usize>> {
        beats.get(id).cloned().ok_or_else(|| {
            crate::Error::file(data.join("wav"), format!("no audio for music ID '{id}'"))
        })
    };
    let mut reports = Vec::new();
    for mut cfg in args.configs() {
        cfg.seed_frames = seed_frames;
        cfg.music_offset = 0;
        reports.push(evaluate(&generated, &reference, Some(&lookup), &cfg)?);
    }
    let m = &config.model;
    let label = match m.arch {
        qean_models::config::Arch::Fact => format!("FACT step {}", ck.state.step),
        qean_models::config::Arch::Qean => format!(
            "QEAN ({:?} positions, {:?} attention) step {}",
            m.position, m.attention, ck.state.step
        )
        .to_lowercase()
        .replacen("qean", "QEAN", 1),
    };
    let labels: Vec<String> = reports
        .iter()
        .map(|r| match reports.len() {
            1 => label.clone(),
            _ => format!(
                "{label} ({})",
                crate::config::value_name(r.config.metrics_mode)
            ),
        })
        .collect();
    let baselines = match (args.baselines, args.configs().into_iter().next()) {
        (true, Some(mut cfg)) => {
            cfg.seed_frames = seed_frames;
            cfg.music_offset = 0;
            // The baselines repeat the warnings the main evaluation gave (constant reference
            // dimensions; renamed dances have no GT partner): run them silently.
            let quiet = || tracing::subscriber::NoSubscriber::default();
            let frozen = tracing::subscriber::with_default(quiet(), || {
                evaluate(
                    &frozen_dances(&generated, seed_frames),
                    &reference,
                    Some(&lookup),
                    &cfg,
                )
            })?;
            let mut pairings = Vec::new();
            for shift in 1.. {
                let Some(g) = repaired_dances(&generated, shift) else {
                    break;
                };
                pairings.push(tracing::subscriber::with_default(quiet(), || {
                    evaluate(&g, &reference, Some(&lookup), &cfg)
                })?);
            }
            let random_pairing = average_beat_align(pairings);
            Some(Baselines {
                frozen,
                random_pairing,
            })
        }
        _ => None,
    };
    let mut rows: Vec<(&str, &MetricsReport)> =
        labels.iter().map(String::as_str).zip(&reports).collect();
    if let Some(b) = &baselines {
        rows.push(("chance: frozen seed pose", &b.frozen));
        if let Some(r) = &b.random_pairing {
            rows.push(("chance: random music pairing", r));
        }
    }
    let table = render_markdown(&rows);
    let report = RunReport {
        checkpoint: ck.dir.clone(),
        step: ck.state.step,
        protocol: args.protocol,
        frames: args.max_frames,
        feedback_project: opts.feedback_project,
        ensemble: opts.ensemble,
        seam_frames: opts.seam_frames,
        pairings: pairings_out,
        reports: reports.clone(),
        baselines,
    };
    write_json_atomic(&out_dir.join("report.json"), &report)?;
    let md = format!(
        "# Evaluation of {} ({:?} protocol, {} sequences, seed = first {seed_frames} GT frames, up to {} generated frames, {} feedback, {} pass(es) per frame, seed's end eased over {} frames)\n\n{table}",
        ck.dir.display(),
        args.protocol,
        report.pairings.len(),
        args.max_frames,
        if opts.feedback_project { "projected" } else { "raw" },
        opts.ensemble,
        opts.seam_frames
    );
    qean_io::fsutil::atomic_write(&out_dir.join("report.md"), md.as_bytes())?;
    let file = EvaluationFile { reports };
    if let Some(path) = &args.json {
        write_json_atomic(path, &file)?;
    }
    Ok((
        file,
        format!("{table}\nreport: {}\n", out_dir.join("report.md").display()),
        report,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seq(name: &str, frames: usize) -> Sequence {
        let joints = (0..frames)
            .map(|t| [[t as f64, 0.0, 0.0]; N_JOINTS])
            .collect();
        Sequence {
            name: name.to_string(),
            joints,
        }
    }

    #[test]
    fn frozen_dances_hold_the_last_seed_frame() {
        let g = vec![seq("gBR_sBM_cAll_d04_mBR0_ch02", 10)];
        let f = frozen_dances(&g, 4);
        assert_eq!(f[0].joints.len(), 10);
        assert_eq!(f[0].name, g[0].name);
        for t in 0..4 {
            assert_eq!(f[0].joints[t], g[0].joints[t]);
        }
        for t in 4..10 {
            assert_eq!(f[0].joints[t], g[0].joints[3]);
        }
    }

    #[test]
    fn repairing_gives_every_dance_another_music_id() {
        let g = vec![
            seq("gBR_sBM_cAll_d04_mBR0_ch02", 3),
            seq("gPO_sBM_cAll_d10_mPO1_ch02", 3),
            seq("gLO_sBM_cAll_d13_mLO2_ch02", 3),
            seq("gBR_sBM_cAll_d05_mBR0_ch01", 3),
        ];
        let r = repaired_dances(&g, 1).unwrap();
        let ids: Vec<String> = r.iter().map(|s| music_id_of(&s.name).unwrap()).collect();
        assert_eq!(ids, ["mLO2", "mBR0", "mPO1", "mLO2"]);
        let r2 = repaired_dances(&g, 2).unwrap();
        let ids2: Vec<String> = r2.iter().map(|s| music_id_of(&s.name).unwrap()).collect();
        assert_eq!(ids2, ["mPO1", "mLO2", "mBR0", "mPO1"]);
        for (a, b) in g.iter().zip(r.iter().chain(&r2)) {
            assert_ne!(music_id_of(&a.name), music_id_of(&b.name));
            assert_eq!(a.joints, b.joints);
        }
        // Three music IDs: shifts 1 and 2 only.
        assert!(repaired_dances(&g, 3).is_none());
        assert!(repaired_dances(&g, 0).is_none());
        assert!(repaired_dances(&g[..1], 1).is_none());
    }
}
