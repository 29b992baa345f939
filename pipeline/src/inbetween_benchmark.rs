//! Lin's reconstruction benchmark (SPEC §12.5–12.6): reduce each test + val dance to N keys per measure,
//! rebuild the frames between them, and score the rebuilt set against the originals with MSE, FID_g and
//! FID_k (Dist and BeatAlign as extras), next to Lin's published numbers.

use crate::inbetween::{measure_segments, rebuild, Context, Trained};
use crate::keyframes::{select_keyframes_cached, CurveCache, KeyframesRequest};
use crate::{Error, Result};
use qean_aistpp::dataset::{Dataset, Split};
use qean_eval::config::{EvalConfig, MusicBeatSource};
use qean_eval::dirs::music_beats;
use qean_eval::positions::Sequence;
use qean_eval::run_report::frames_of;
use qean_keyframes::bezier::{self, BezierSettings, MeanTheta, ThetaFile, ThetaSource};
use qean_keyframes::mse::{mse, MseSpace};
use qean_keyframes::select::Strategy;
use qean_keyframes::{slerp, KeyframeOptions};
use qean_motion::{FkRoot, Motion};
use serde::Serialize;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// How the frames between keys are rebuilt.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum IbMethod {
    /// Straight root path + shortest-arc SLERP (§12.4a).
    Linear,
    /// Bézier with the training split's mean θ (§12.4b, Lin's protocol with even keys).
    Bezier,
    /// Bézier fitted on each test dance itself (Lin's DP protocol, "following Roberts").
    BezierFit,
    /// A trained transformer in-betweener (`--inbetweeners R`).
    Transformer,
}

impl IbMethod {
    pub fn parse(s: &str) -> std::result::Result<IbMethod, String> {
        match s {
            "linear" | "slerp" => Ok(IbMethod::Linear),
            "bezier" => Ok(IbMethod::Bezier),
            "bezier_fit" => Ok(IbMethod::BezierFit),
            other => Err(format!(
                "unknown in-betweening method {other:?} (expected linear, bezier or bezier_fit)"
            )),
        }
    }

    pub fn label(self) -> &'static str {
        match self {
            IbMethod::Linear => "linear+SLERP",
            IbMethod::Bezier => "Bézier (train mean)",
            IbMethod::BezierFit => "Bézier (fit on test)",
            IbMethod::Transformer => "transformer",
        }
    }
}

/// The set FID and Dist compare the rebuilt dances with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FidReference {
    /// The originals of the same test + val sequences (Lin: "how close a set of reconstructed dances is
    /// to a set of original dances").
    #[default]
    Same,
    /// Every non-ignored sequence of the dataset (the 1363 of AIST++).
    All,
}

/// The rows of the strategies and in-betweeners asked for: every combination (the even strategy or the
/// linear in-betweener where one list is empty), or Lin's rows ([`default_rows`]) when both are.
pub fn rows_of(strategies: Vec<Strategy>, methods: Vec<IbMethod>) -> Vec<(Strategy, IbMethod)> {
    if strategies.is_empty() && methods.is_empty() {
        return default_rows();
    }
    let strategies = match strategies.is_empty() {
        true => vec![Strategy::Even],
        false => strategies,
    };
    let methods = match methods.is_empty() {
        true => vec![IbMethod::Linear],
        false => methods,
    };
    strategies
        .iter()
        .flat_map(|&s| methods.iter().map(move |&m| (s, m)))
        .collect()
}

/// Lin's rows without the learnt in-betweeners: Exp. 1 (even × linear/Bézier, DP × Bézier fitted per
/// sequence, plus DP × linear for Tables 4.1–4.3) and Exp. 2 (music keys × linear).
pub fn default_rows() -> Vec<(Strategy, IbMethod)> {
    vec![
        (Strategy::Even, IbMethod::Linear),
        (Strategy::Even, IbMethod::Bezier),
        (Strategy::Dp, IbMethod::BezierFit),
        (Strategy::Dp, IbMethod::Linear),
        (Strategy::Onset, IbMethod::Linear),
        (Strategy::Stems, IbMethod::Linear),
        (Strategy::Nmfd, IbMethod::Linear),
    ]
}

#[derive(Debug, Clone)]
pub struct InbetweenRequest {
    pub data: PathBuf,
    /// Keys per measure, e.g. 3, 5, 9.
    pub keys: Vec<usize>,
    pub rows: Vec<(Strategy, IbMethod)>,
    pub out: PathBuf,
    pub options: KeyframeOptions,
    pub bezier: BezierSettings,
    pub mse_space: MseSpace,
    pub fid_reference: FidReference,
    /// Keep Ballet Jazz (Lin drops it: its drums stem is silent).
    pub include_jb: bool,
    /// Stems as `<stems>/<music ID>/{drums,bass,vocals,other}.wav` (`stem_source = "files"`); default
    /// `<data>/stems`.
    pub stems: Option<PathBuf>,
    pub root: FkRoot,
    /// Trained in-betweener runs: each adds an even-keys row (Lin's Exp. 3).
    pub inbetweeners: Vec<PathBuf>,
}

/// One (strategy, method, N) cell.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// "even / linear+SLERP", "even / motion (runs/ib, params_hash …)", …
    pub label: String,
    pub strategy: Strategy,
    pub method: IbMethod,
    pub n: usize,
    pub mse: f64,
    pub fid_k: f64,
    pub fid_g: f64,
    pub dist_k: f64,
    pub dist_g: f64,
    pub beat_align: Option<f64>,
    /// Mean keyframes per sequence.
    pub keyframes: f64,
    pub seconds: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct InbetweenReport {
    pub data: String,
    pub sequences: Vec<String>,
    pub mse_space: MseSpace,
    pub fid_reference: FidReference,
    pub rows: Vec<Row>,
    pub gt_dist_k: f64,
    pub gt_dist_g: f64,
    pub gt_beat_align: Option<f64>,
    /// Lin's expected orderings (§12.6), each "holds" or what violates it.
    pub checks: Vec<String>,
    pub seconds: f64,
}

struct Loaded {
    names: Vec<String>,
    motions: Vec<Motion>,
}

fn load(ds: &Dataset, splits: &[Split], include_jb: bool) -> Result<Loaded> {
    let mut names: Vec<String> = splits.iter().flat_map(|s| ds.split(*s)).collect();
    names.retain(|n| (include_jb || !n.starts_with("gJB")) && ds.motion_path(n).is_file());
    names.sort();
    let motions = names
        .iter()
        .map(|n| ds.read_motion(n).map_err(Error::from))
        .collect::<Result<Vec<_>>>()?;
    Ok(Loaded { names, motions })
}

/// Keys of one dataset sequence under a strategy (tempo from its AIST++ name).
fn keys_of(
    ds: &Dataset,
    curves: &CurveCache,
    req: &InbetweenRequest,
    name: &str,
    motion: &Motion,
    strategy: Strategy,
    n: usize,
) -> Result<Vec<usize>> {
    Ok(selection_of(ds, curves, req, name, motion, strategy, n)?.keyframes)
}

/// The measures and keys of one dataset sequence under a strategy.
fn selection_of(
    ds: &Dataset,
    curves: &CurveCache,
    req: &InbetweenRequest,
    name: &str,
    motion: &Motion,
    strategy: Strategy,
    n: usize,
) -> Result<qean_keyframes::select::Selection> {
    let music_id = ds.music_id(name);
    let music = music_id.as_deref().and_then(|m| ds.audio_path(m));
    let stems_root = req.stems.clone().unwrap_or_else(|| ds.root.join("stems"));
    let k = KeyframesRequest {
        motion: ds.motion_path(name),
        music,
        stems: music_id.map(|m| stems_root.join(m)),
        strategy,
        n,
        bpm: None,
        options: req.options.clone(),
    };
    Ok(select_keyframes_cached(motion, &k, Some(curves))?.selection)
}

/// The music the trained in-betweeners read: (full-mix features, drums-stem features) per music ID, each
/// empty when no model needs it.
type MusicMaps = (HashMap<String, Vec<f32>>, HashMap<String, Vec<f32>>);

fn music_for(trained: &[Trained], ds: &Dataset, names: &[String]) -> Result<MusicMaps> {
    let full = if trained
        .iter()
        .any(|t| t.config.variant.has_audio() && !t.config.variant.drums())
    {
        test_features(ds, names, None)?
    } else {
        HashMap::new()
    };
    let drums = match trained.iter().find(|t| t.config.variant.drums()) {
        Some(t) => test_features(ds, names, Some(t.config.drums))?,
        None => HashMap::new(),
    };
    Ok((full, drums))
}

/// The FID/Dist reference: the test dances' originals, or every sequence (`fid_reference = all`).
fn reference_set(req: &InbetweenRequest, ds: &Dataset, test: &Loaded) -> Result<Vec<Sequence>> {
    let set = match req.fid_reference {
        FidReference::Same => None,
        FidReference::All => Some(load(ds, &[Split::Train, Split::Val, Split::Test], true)?),
    };
    let from = set.as_ref().unwrap_or(test);
    Ok(from
        .names
        .iter()
        .zip(&from.motions)
        .map(|(n, m)| joints_sequence(n, m, req.root))
        .collect())
}

/// The 35-D features of the test sequences' music IDs: the full mix's (the dataset's feature cache), or
/// their drums stems' (`drums`).
fn test_features(
    ds: &Dataset,
    names: &[String],
    drums: Option<qean_config::inbetween::DrumSource>,
) -> Result<HashMap<String, Vec<f32>>> {
    qean_checkpoint::features::ensure_features(ds, names)?;
    let mut out = HashMap::new();
    for id in ds.music_ids(names) {
        let data = match drums {
            None => qean_aistpp::feature_cache::load(ds, &id)?.0,
            Some(source) => qean_checkpoint::inbetween::drums_features(
                ds.audio_path(&id).as_deref(),
                Some(&ds.root.join("stems").join(&id)),
                source,
                qean_aistpp::names::start_bpm(&id),
            )?,
        };
        out.insert(id, data);
    }
    Ok(out)
}

fn joints_sequence(name: &str, m: &Motion, root: FkRoot) -> Sequence {
    Sequence::new(name.to_string(), frames_of(m.joints(root)))
}

/// The mean Bézier θ of the training split's key pairs under one strategy and N.
fn train_mean(
    ds: &Dataset,
    curves: &CurveCache,
    req: &InbetweenRequest,
    train: &Loaded,
    strategy: Strategy,
    n: usize,
) -> Result<MeanTheta> {
    let mut m = MeanTheta::default();
    for (name, motion) in train.names.iter().zip(&train.motions) {
        let keys = keys_of(ds, curves, req, name, motion, strategy, n)?;
        m.add(motion, &keys, &req.bezier);
    }
    Ok(m)
}

/// One cell of the table to compute.
struct Cell<'a> {
    strategy: Strategy,
    method: IbMethod,
    n: usize,
    mean: Option<&'a MeanTheta>,
    trained: Option<&'a Trained>,
    /// 35-D features per music ID (for music-reading in-betweeners).
    features: &'a HashMap<String, Vec<f32>>,
}

impl Cell<'_> {
    fn label(&self) -> String {
        match self.trained {
            Some(t) => format!("{} / {}", self.strategy.name(), t.label()),
            None => format!("{} / {}", self.strategy.name(), self.method.label()),
        }
    }
}

/// Rebuild every test dance for one cell and score the set (the row's `seconds` is left 0).
fn score(
    ds: &Dataset,
    curves: &CurveCache,
    req: &InbetweenRequest,
    test: &Loaded,
    reference: &[Sequence],
    lookup: qean_eval::protocol::BeatLookup,
    cell: &Cell,
) -> Result<(Row, qean_eval::report::MetricsReport)> {
    let mut generated = Vec::new();
    let (mut total_mse, mut total_keys) = (0.0, 0usize);
    for (name, motion) in test.names.iter().zip(&test.motions) {
        let selection = selection_of(ds, curves, req, name, motion, cell.strategy, cell.n)?;
        let keys = selection.keyframes;
        total_keys += keys.len();
        let rebuilt = match (cell.method, cell.mean) {
            (IbMethod::Transformer, _) => {
                let trained = cell.trained.expect("transformer cells carry their model");
                let music =
                    qean_aistpp::names::music_id_of(name).and_then(|m| cell.features.get(&m));
                let ctx = Context {
                    features: music.map(Vec::as_slice),
                    genre: name.get(1..3),
                };
                rebuild(
                    &trained.model,
                    &trained.config,
                    motion,
                    &measure_segments(&selection.segments, &keys),
                    &ctx,
                )
                .map_err(|e| Error::Invalid(format!("{name}: {e}")))?
            }
            (IbMethod::Linear, _) => slerp::inbetween(motion, &keys),
            (IbMethod::Bezier, Some(m)) => {
                bezier::inbetween(motion, &keys, ThetaSource::Mean(m), &req.bezier)
            }
            (IbMethod::BezierFit, _) | (IbMethod::Bezier, None) => {
                bezier::inbetween(motion, &keys, ThetaSource::FitEach, &req.bezier)
            }
        };
        total_mse += mse(motion, &rebuilt, req.mse_space);
        generated.push(joints_sequence(name, &rebuilt, req.root));
    }
    let cfg = EvalConfig {
        seed_frames: 0,
        ..EvalConfig::default()
    };
    let report =
        tracing::subscriber::with_default(tracing::subscriber::NoSubscriber::default(), || {
            qean_eval::protocol::evaluate(&generated, reference, Some(lookup), &cfg)
        })?;
    let count = test.names.len() as f64;
    let row = Row {
        label: cell.label(),
        strategy: cell.strategy,
        method: cell.method,
        n: cell.n,
        mse: total_mse / count,
        fid_k: report.fid_k,
        fid_g: report.fid_g,
        dist_k: report.div_k,
        dist_g: report.div_g,
        beat_align: report.beat_align,
        keyframes: total_keys as f64 / count,
        seconds: 0.0,
    };
    Ok((row, report))
}

/// Run the benchmark; returns the report and its markdown (both also written to `req.out`).
pub fn run(req: &InbetweenRequest) -> Result<(InbetweenReport, String)> {
    let start = Instant::now();
    validate(req)?;
    let ds = Dataset::open(&req.data)?;
    let test = load(&ds, &[Split::Test, Split::Val], req.include_jb)?;
    if test.names.len() < 2 {
        return Err(Error::Invalid(format!(
            "{}: the test and val splits hold {} usable sequences; the benchmark needs 2",
            req.data.display(),
            test.names.len()
        )));
    }
    let needs_train = req.rows.iter().any(|r| r.1 == IbMethod::Bezier);
    let train = if needs_train {
        Some(load(&ds, &[Split::Train], req.include_jb)?)
    } else {
        None
    };
    let reference = reference_set(req, &ds, &test)?;
    let wav = ds.audio_dir();
    let beats = music_beats(
        &wav,
        test.names.iter().filter_map(|n| ds.music_id(n)),
        MusicBeatSource::Bailando,
    )?;
    let lookup = |id: &str| qean_eval::dirs::beats_of(&beats, &wav, id);
    let trained = req
        .inbetweeners
        .iter()
        .map(|r| Trained::load(r))
        .collect::<Result<Vec<_>>>()?;
    let (features, drum_features) = music_for(&trained, &ds, &test.names)?;
    let mut cells: Vec<(Strategy, IbMethod, Option<&Trained>)> =
        req.rows.iter().map(|&(s, m)| (s, m, None)).collect();
    cells.extend(
        trained
            .iter()
            .map(|t| (Strategy::Even, IbMethod::Transformer, Some(t))),
    );
    let mut rows = Vec::new();
    let mut gt = None;
    let mut means: HashMap<(Strategy, usize), MeanTheta> = HashMap::new();
    let curves = CurveCache::default();
    for &n in &req.keys {
        for &(strategy, method, trained) in &cells {
            let t0 = Instant::now();
            let mean = if method == IbMethod::Bezier {
                let train = train.as_ref().expect("loaded when a row needs it");
                if let std::collections::hash_map::Entry::Vacant(slot) = means.entry((strategy, n))
                {
                    slot.insert(train_mean(&ds, &curves, req, train, strategy, n)?);
                }
                means.get(&(strategy, n))
            } else {
                None
            };
            let cell = Cell {
                strategy,
                method,
                n,
                mean,
                trained,
                features: match trained {
                    Some(t) if t.config.variant.drums() => &drum_features,
                    _ => &features,
                },
            };
            let (row, report) = score(&ds, &curves, req, &test, &reference, &lookup, &cell)?;
            gt.get_or_insert((report.gt_div_k, report.gt_div_g, report.gt_beat_align));
            rows.push(Row {
                seconds: t0.elapsed().as_secs_f64(),
                ..row
            });
            tracing::info!("{} at {n} keys: done", cell.label());
        }
    }
    let (gt_dist_k, gt_dist_g, gt_beat_align) = gt.expect("at least one row");
    let report = InbetweenReport {
        data: req.data.display().to_string(),
        sequences: test.names.clone(),
        mse_space: req.mse_space,
        fid_reference: req.fid_reference,
        checks: checks(&rows),
        rows,
        gt_dist_k,
        gt_dist_g,
        gt_beat_align,
        seconds: start.elapsed().as_secs_f64(),
    };
    let md = write(req, &report, &means, train.as_ref())?;
    Ok((report, md))
}

/// The request's own checks, before anything is read.
fn validate(req: &InbetweenRequest) -> Result<()> {
    if req.keys.is_empty() || req.keys.iter().any(|&n| n < 2) {
        return Err(Error::Invalid("--keys: every N must be at least 2".into()));
    }
    req.options
        .validate()
        .map_err(|e| Error::Invalid(format!("keyframe options: {e}")))
}

/// `req.out/`: report.json, report.md and the Bézier means, all or nothing; returns the markdown.
fn write(
    req: &InbetweenRequest,
    report: &InbetweenReport,
    means: &HashMap<(Strategy, usize), MeanTheta>,
    train: Option<&Loaded>,
) -> Result<String> {
    let md = markdown(report);
    let json = serde_json::to_string_pretty(report).expect("plain data") + "\n";
    qean_io::fsutil::atomic_dir(&req.out, |dir| {
        qean_io::fsutil::atomic_write(&dir.join("report.json"), json.as_bytes())?;
        qean_io::fsutil::atomic_write(&dir.join("report.md"), md.as_bytes())?;
        theta_files(dir, means, req, train)
    })?;
    Ok(md)
}

/// Each Bézier training mean as `bezier_<strategy>_N<n>.json`, for `qean edit --method bezier --theta`.
fn theta_files(
    dir: &Path,
    means: &HashMap<(Strategy, usize), MeanTheta>,
    req: &InbetweenRequest,
    train: Option<&Loaded>,
) -> qean_io::Result<()> {
    let sequences = train.map_or(0, |t| t.names.len());
    for (&(strategy, n), mean) in means {
        let file = ThetaFile::new(mean, &req.bezier, strategy.name(), n, sequences);
        let json = serde_json::to_string_pretty(&file).expect("plain data") + "\n";
        let name = format!("bezier_{}_N{n}.json", strategy.name());
        qean_io::fsutil::atomic_write(&dir.join(name), json.as_bytes())?;
    }
    Ok(())
}

/// The distinct row labels, in order of first appearance.
fn row_labels(rows: &[Row]) -> Vec<String> {
    let mut labels: Vec<String> = Vec::new();
    for r in rows {
        if !labels.contains(&r.label) {
            labels.push(r.label.clone());
        }
    }
    labels
}

/// A named column of a row.
type Metric = (&'static str, fn(&Row) -> f64);

/// Lin's expectations (§12.6): (i) every metric falls as N grows for even, dp and onset keys; (ii) DP keys
/// with Bézier fitted per sequence have the lowest MSE.
pub fn checks(rows: &[Row]) -> Vec<String> {
    let mut out = Vec::new();
    for label in row_labels(rows) {
        let mut cells: Vec<&Row> = rows.iter().filter(|r| r.label == label).collect();
        if !matches!(
            cells[0].strategy,
            Strategy::Even | Strategy::Dp | Strategy::Onset
        ) {
            continue;
        }
        cells.sort_by_key(|r| r.n);
        if cells.len() < 2 {
            continue;
        }
        let metrics: [Metric; 3] = [
            ("MSE", |r| r.mse),
            ("FID_g", |r| r.fid_g),
            ("FID_k", |r| r.fid_k),
        ];
        for (metric, get) in metrics {
            let rises: Vec<String> = cells
                .windows(2)
                .filter(|w| get(w[1]) >= get(w[0]))
                .map(|w| {
                    format!(
                        "{:.4} at N = {} → {:.4} at N = {}",
                        get(w[0]),
                        w[0].n,
                        get(w[1]),
                        w[1].n
                    )
                })
                .collect();
            let what = format!("(i) {label}: {metric} falls as N grows");
            out.push(if rises.is_empty() {
                format!("{what}: holds")
            } else {
                format!("{what}: VIOLATED ({})", rises.join("; "))
            });
        }
    }
    let mut ns: Vec<usize> = rows.iter().map(|r| r.n).collect();
    ns.sort_unstable();
    ns.dedup();
    for n in ns {
        let at: Vec<&Row> = rows.iter().filter(|r| r.n == n).collect();
        let Some(dp) = at
            .iter()
            .find(|r| r.strategy == Strategy::Dp && r.method == IbMethod::BezierFit)
        else {
            continue;
        };
        let best = at
            .iter()
            .min_by(|a, b| a.mse.total_cmp(&b.mse))
            .expect("non-empty");
        let what = format!("(ii) dp / Bézier (fit on test) has the lowest MSE at N = {n}");
        out.push(if best.mse >= dp.mse {
            format!("{what}: holds ({:.4})", dp.mse)
        } else {
            format!(
                "{what}: VIOLATED ({} has {:.4} < {:.4})",
                best.label, best.mse, dp.mse
            )
        });
    }
    out
}

/// Lin's Tables 4.1–4.13 (AIST++ test ∪ val without JB; MSE space and FID code unknown), rows at 9 and 3
/// keys: (label, [MSE, FID_g, FID_k] at 9, the same at 3; `None` where Lin prints no value).
pub const LIN_TABLE: [(&str, [Option<f64>; 6]); 12] = [
    (
        "even / linear+SLERP",
        [
            Some(0.25),
            Some(16.75),
            Some(51.48),
            Some(0.83),
            Some(42.73),
            Some(86.70),
        ],
    ),
    (
        "even / Bézier (train mean)",
        [
            Some(0.91),
            Some(34.37),
            Some(198.08),
            Some(1.07),
            Some(29.74),
            Some(76.01),
        ],
    ),
    (
        "even / motion",
        [
            Some(0.26),
            Some(11.02),
            Some(37.90),
            Some(0.90),
            Some(16.57),
            Some(33.76),
        ],
    ),
    (
        "dp / Bézier (fit on test)",
        [
            Some(0.12),
            Some(13.82),
            Some(33.16),
            Some(0.47),
            Some(18.30),
            Some(54.40),
        ],
    ),
    (
        "onset / linear+SLERP",
        [
            Some(0.31),
            Some(17.46),
            Some(54.62),
            Some(0.90),
            Some(48.12),
            Some(84.26),
        ],
    ),
    (
        "stems / linear+SLERP",
        [
            Some(0.31),
            Some(17.08),
            Some(54.63),
            Some(0.89),
            Some(48.10),
            Some(84.92),
        ],
    ),
    (
        "nmfd / linear+SLERP",
        [
            Some(0.35),
            Some(17.53),
            Some(55.27),
            Some(0.87),
            Some(48.81),
            Some(86.65),
        ],
    ),
    (
        "even / cross_full",
        [
            Some(0.34),
            Some(12.84),
            Some(35.75),
            Some(0.96),
            Some(19.09),
            Some(39.10),
        ],
    ),
    (
        "even / cross_drum",
        [
            Some(0.30),
            Some(11.10),
            Some(38.47),
            Some(0.95),
            Some(18.81),
            Some(37.17),
        ],
    ),
    (
        "even / merged_full",
        [Some(0.36), Some(15.04), Some(29.35), None, None, None],
    ),
    (
        "even / merged_drum",
        [
            Some(0.37),
            Some(15.14),
            Some(28.53),
            Some(0.95),
            Some(17.65),
            Some(36.34),
        ],
    ),
    (
        "even / genre",
        [
            Some(0.27),
            Some(11.38),
            Some(36.88),
            Some(0.88),
            Some(15.16),
            Some(30.24),
        ],
    ),
];

fn cell(v: Option<f64>) -> String {
    v.map_or("–".into(), |x| format!("{x:.2}"))
}

/// The thesis's layout: one row per keys / in-between, MSE, FID_g, FID_k per N.
pub fn markdown(r: &InbetweenReport) -> String {
    let mut ns: Vec<usize> = r.rows.iter().map(|x| x.n).collect();
    ns.sort_unstable();
    ns.dedup();
    let mut s = format!(
        "# In-betweening benchmark (Lin 2022, SPEC §12.5)\n\nData: {} — {} test + val sequences at full length, \
         reconstructed from N keys per measure and scored against {}. MSE in `{}` space \
         (per sequence, then averaged); FID and Dist as §7 (reference mode).\n\n",
        r.data,
        r.sequences.len(),
        match r.fid_reference {
            FidReference::Same => "the same originals",
            FidReference::All => "every sequence of the dataset (fid_reference = all)",
        },
        serde_json::to_value(r.mse_space).ok().and_then(|v| v.as_str().map(String::from)).unwrap_or_default()
    );
    s += "| keys / in-between |";
    for n in &ns {
        s += &format!(" {n}: MSE | FID_g | FID_k |");
    }
    s += "\n|---|";
    s += &"---|---|---|".repeat(ns.len());
    s += "\n";
    for label in row_labels(&r.rows) {
        s += &format!("| {label} |");
        for n in &ns {
            match r.rows.iter().find(|x| x.label == label && x.n == *n) {
                Some(x) => s += &format!(" {:.4} | {:.2} | {:.2} |", x.mse, x.fid_g, x.fid_k),
                None => s += " | | |",
            }
        }
        s += "\n";
    }
    s += "\nExtras (Dist_k, Dist_g, BeatAlign; mean keyframes per sequence; seconds):\n\n| keys / in-between | N | Dist_k | Dist_g | BeatAlign | keys | s |\n|---|---|---|---|---|---|---|\n";
    for x in &r.rows {
        s += &format!(
            "| {} | {} | {:.3} | {:.3} | {} | {:.1} | {:.1} |\n",
            x.label,
            x.n,
            x.dist_k,
            x.dist_g,
            x.beat_align.map_or("–".into(), |b| format!("{b:.4}")),
            x.keyframes,
            x.seconds
        );
    }
    s += &format!(
        "| ground truth | | {:.3} | {:.3} | {} | | |\n\nChecks of Lin's orderings (§12.6; logged, not asserted):\n\n",
        r.gt_dist_k,
        r.gt_dist_g,
        r.gt_beat_align.map_or("–".into(), |b| format!("{b:.4}"))
    );
    for c in &r.checks {
        s += &format!("- {c}\n");
    }
    s += "\nLin's published numbers (AIST++ test ∪ val without Ballet Jazz; his MSE space and FID code are unknown, \
          so compare orderings, not values):\n\n| keys / in-between | 9: MSE | FID_g | FID_k | 3: MSE | FID_g | FID_k |\n|---|---|---|---|---|---|---|\n";
    for (label, v) in LIN_TABLE {
        s += &format!(
            "| {label} | {} |\n",
            v.iter().map(|x| cell(*x)).collect::<Vec<_>>().join(" | ")
        );
    }
    s += &format!("\nRuntime: {:.1} s.\n", r.seconds);
    s
}
