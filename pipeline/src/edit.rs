//! `qean edit` (SPEC §12.7): read a dance and edits.json, resolve the kept frames, regenerate the ranges
//! and write the edited dance, its report and (optionally) a preview — all checked before anything is
//! written.

use crate::inbetween::{rebuild, Context, Segment, Trained};
use crate::keyframes::{select_keyframes_of, KeyframesRequest};
use crate::{Error, Result};
use qean_keyframes::bezier::{BezierSettings, MeanTheta, ThetaFile};
use qean_keyframes::edit::{apply, EditSpec, Keep, Method, RangeReport};
use qean_keyframes::even::even_keys;
use qean_keyframes::select::Strategy;
use qean_keyframes::KeyframeOptions;
use qean_motion::motion::{read_motion, Precision};
use qean_motion::{FkRoot, Motion};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// How regenerated frames are drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EditMethod {
    Slerp,
    Bezier,
    /// A trained in-betweener (`--run R`).
    Transformer,
}

#[derive(Debug, Clone)]
pub struct EditRequest {
    pub motion: PathBuf,
    pub music: Option<PathBuf>,
    pub stems: Option<PathBuf>,
    pub edits: PathBuf,
    pub method: EditMethod,
    pub bpm: Option<f64>,
    pub options: KeyframeOptions,
    pub bezier: BezierSettings,
    pub out: PathBuf,
    /// Also write `<out>.png` and `<out>.gif`.
    pub render: bool,
    /// The trained in-betweener of `transformer`.
    pub run: Option<PathBuf>,
    /// The dance's genre code for the genre in-betweener (default: from an AIST++ name).
    pub genre: Option<String>,
    /// A Bézier training mean (`bezier_<strategy>_N<n>.json` of `qean eval --task inbetween`); without
    /// it `bezier` fits θ on the input's own key pairs.
    pub theta: Option<PathBuf>,
}

/// The report written beside the output.
#[derive(Debug, Clone, Serialize)]
pub struct EditReport {
    pub input: String,
    pub output: String,
    pub method: EditMethod,
    /// The checkpoint of a learnt method (none for slerp and bezier).
    pub checkpoint: Option<String>,
    pub keep: String,
    /// Where the Bézier θ came from.
    pub theta_source: Option<String>,
    pub edited_frames: Vec<usize>,
    pub ranges: Vec<RangeReport>,
    pub frames: usize,
}

/// `out.pkl` → `out.report.json` (and `.png`/`.gif` for previews).
pub fn sibling(out: &Path, ext: &str) -> PathBuf {
    out.with_extension(ext)
}

fn keep_label(k: &Keep) -> String {
    match k {
        Keep::Ends => "range ends".into(),
        Keep::Grid(n) => format!("grid:{n}"),
        Keep::Dp(n) => format!("dp:{n}"),
        Keep::Onset(n) => format!("onset:{n}"),
        Keep::Frames(f) => format!("{} frames", f.len()),
    }
}

/// The frames `keep` names, over the whole motion, and the boundaries of the measures they were chosen
/// in, sorted (where the in-betweener's windows end; `measures_wanted` also finds them for frame lists
/// when a tempo is known).
fn kept_frames(
    motion: &Motion,
    req: &EditRequest,
    keep: &Keep,
    measures_wanted: bool,
) -> Result<(Vec<usize>, Vec<usize>)> {
    let rule = |strategy, n| KeyframesRequest {
        motion: req.motion.clone(),
        music: req.music.clone(),
        stems: req.stems.clone(),
        strategy,
        n,
        bpm: req.bpm,
        options: req.options.clone(),
    };
    type Measures = Option<Vec<(usize, usize)>>;
    let selected = |strategy, n| -> Result<(Vec<usize>, Measures)> {
        let s = select_keyframes_of(motion, &rule(strategy, n))?.selection;
        Ok((s.keyframes, Some(s.segments)))
    };
    let measures = || {
        if !measures_wanted {
            return None;
        }
        match select_keyframes_of(motion, &rule(Strategy::Even, 2)) {
            Ok(k) => Some(k.selection.segments),
            Err(e) => {
                tracing::warn!(
                    "{}: no measure grid for the in-betweener's windows ({e}); windows are cut at anchors only",
                    req.motion.display()
                );
                None
            }
        }
    };
    let (kept, measures) = match keep {
        Keep::Ends => (vec![], measures()),
        Keep::Frames(f) => (f.clone(), measures()),
        Keep::Grid(n) => selected(Strategy::Even, *n)?,
        Keep::Dp(n) => selected(Strategy::Dp, *n)?,
        Keep::Onset(n) => selected(Strategy::Onset, *n)?,
    };
    let cuts: std::collections::BTreeSet<usize> = measures
        .iter()
        .flatten()
        .flat_map(|&(a, b)| [a, b])
        .collect();
    Ok((kept, cuts.into_iter().collect()))
}

/// The Bézier θ: the mean over the input's own key pairs that lie outside every range (keys from the
/// keep rule when it is one, else every 30 frames); the whole input when no pair is outside.
fn own_theta(
    motion: &Motion,
    spec: &EditSpec,
    kept: &[usize],
    settings: &BezierSettings,
) -> (MeanTheta, String) {
    let keys: Vec<usize> = match spec.keep {
        Keep::Grid(_) | Keep::Dp(_) | Keep::Onset(_) if kept.len() >= 2 => kept.to_vec(),
        _ => even_keys(0, motion.frames - 1, (motion.frames - 1) / 30 + 2),
    };
    let outside = |a: usize, b: usize| spec.regenerate.iter().all(|&(s, e)| b < s || a > e);
    let mut mean = MeanTheta::default();
    let mut pairs = 0;
    // Pairs with at least 2 frames between them (others fix no θ).
    for w in keys
        .windows(2)
        .filter(|w| w[1] >= w[0] + 3 && outside(w[0], w[1]))
    {
        mean.add(motion, w, settings);
        pairs += 1;
    }
    if pairs == 0 {
        mean.add(motion, &keys, settings);
        return (
            mean,
            format!(
                "fitted on all {} key pairs of the input",
                keys.len().saturating_sub(1)
            ),
        );
    }
    (
        mean,
        format!("fitted on {pairs} key pairs of the input outside the ranges"),
    )
}

/// The Bézier θ of an edit: the training mean of `--theta` (SPEC §12.7), else the input's own
/// ([`own_theta`]).
fn bezier_theta(
    req: &EditRequest,
    motion: &Motion,
    spec: &EditSpec,
    kept: &[usize],
) -> Result<(MeanTheta, String)> {
    let Some(path) = &req.theta else {
        let (mean, source) = own_theta(motion, spec, kept, &req.bezier);
        return Ok((mean, source + " (no --theta training mean given)"));
    };
    let bad = |e: String| Error::Invalid(format!("{}: {e}", path.display()));
    let text = std::fs::read_to_string(path).map_err(|e| bad(format!("cannot read: {e}")))?;
    let file: ThetaFile = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
    let mean = file.mean_for(&req.bezier).map_err(bad)?;
    let source = format!(
        "training mean of {} dances ({} keys, N = {}) from {}",
        file.sequences,
        file.strategy,
        file.n,
        path.display()
    );
    Ok((mean, source))
}

/// The fastest joint's largest step between frames (m per frame) in frames [a, b].
fn peak_step(joints: &[[f64; 3]], a: usize, b: usize) -> f64 {
    let mut worst: f64 = 0.0;
    for t in a.max(1)..=b {
        for j in 0..24 {
            let (p, q) = (joints[t * 24 + j], joints[(t - 1) * 24 + j]);
            worst = worst.max(
                ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt(),
            );
        }
    }
    worst
}

/// Bézier curves run per Euler channel; near gimbal lock (in XYZ order: a quarter turn of the body about
/// the vertical axis) a channel swings fast and a cubic through it flails. Say so when a regenerated
/// range moves much faster than the input ever does.
fn warn_if_faster(input: &Motion, out: &Motion, ranges: &[(usize, usize)], edits: &Path) {
    let (ji, jo) = (input.joints(FkRoot::Smpl), out.joints(FkRoot::Smpl));
    let reference = peak_step(&ji, 0, input.frames - 1);
    for &(a, b) in ranges {
        let peak = peak_step(&jo, a, b);
        if peak > 3.0 * reference {
            tracing::warn!(
                "{}: range [{a}, {b}] moves up to {:.2} m per frame, {:.1}× the input's fastest: Bézier curves in \
                 Euler angles flail near gimbal lock; try --set keyframes.euler_order=YXZ (turns about the \
                 vertical axis stay away from it) or --method slerp",
                edits.display(),
                peak,
                peak / reference.max(1e-12)
            );
        }
    }
}

/// A range's anchors as in-betweener windows, each as close to a training window (one measure) as the
/// anchors allow: a window ends at the first anchor that starts a measure (`cuts`, the measure
/// boundaries; SPEC §12.7 runs the measures that overlap the range), or before it would exceed `max_len`
/// frames. Windows end at anchors, so consecutive windows share one.
pub fn anchor_windows(
    anchors: &[usize],
    max_len: usize,
    cuts: &[usize],
) -> std::result::Result<Vec<Segment>, String> {
    let mut out = Vec::new();
    let mut start = 0;
    while start + 1 < anchors.len() {
        let mut end = start + 1;
        if anchors[end] - anchors[start] + 1 > max_len {
            return Err(format!(
                "anchors {} and {} are {} frames apart, more than the in-betweener's {max_len}: keep a frame between them",
                anchors[start],
                anchors[end],
                anchors[end] - anchors[start]
            ));
        }
        while end + 1 < anchors.len()
            && anchors[end + 1] - anchors[start] < max_len
            && cuts.binary_search(&anchors[end]).is_err()
        {
            end += 1;
        }
        out.push(Segment {
            a: anchors[start],
            b: anchors[end],
            keys: anchors[start..=end].to_vec(),
        });
        start = end;
    }
    Ok(out)
}

/// The 35-D rows a music-reading in-betweener needs: the full mix's, or its drums stem's.
fn model_music(trained: Option<&Trained>, req: &EditRequest) -> Result<Option<Vec<f32>>> {
    Ok(match (trained, &req.music) {
        (Some(t), music) if t.config.variant.drums() => {
            Some(qean_checkpoint::inbetween::drums_features(
                music.as_deref(),
                req.stems.as_deref(),
                t.config.drums,
                120.0,
            )?)
        }
        (Some(t), Some(music)) if t.config.variant.has_audio() => {
            Some(qean_audio::features::features_for_file(music, &Default::default())?.data)
        }
        _ => None,
    })
}

/// The output must be a .pkl in an existing directory.
fn check_output(out: &Path) -> Result<()> {
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !dir.is_dir() {
            return Err(Error::Invalid(format!(
                "{}: the output directory does not exist",
                out.display()
            )));
        }
    }
    if qean_io::fsutil::extension_lower(out) != "pkl" {
        return Err(Error::Invalid(format!(
            "{}: the edited dance is written as .pkl",
            out.display()
        )));
    }
    Ok(())
}

/// Run an edit; returns the report (already written beside the output).
pub fn edit(req: &EditRequest) -> Result<EditReport> {
    req.options
        .validate()
        .map_err(|e| Error::Invalid(format!("keyframe options: {e}")))?;
    if req.theta.is_some() && req.method != EditMethod::Bezier {
        return Err(Error::Invalid(
            "--theta (a Bézier training mean) goes with --method bezier".into(),
        ));
    }
    let motion = read_motion(&req.motion)?;
    let text = std::fs::read_to_string(&req.edits)
        .map_err(|e| Error::Invalid(format!("{}: cannot read: {e}", req.edits.display())))?;
    let spec = EditSpec::parse(&text, motion.frames)
        .map_err(|e| Error::Invalid(format!("{}: {e}", req.edits.display())))?;
    check_output(&req.out)?;
    let (kept, cuts) = kept_frames(
        &motion,
        req,
        &spec.keep,
        req.method == EditMethod::Transformer,
    )?;
    let (theta, theta_source) = match req.method {
        EditMethod::Slerp | EditMethod::Transformer => (None, None),
        EditMethod::Bezier => {
            let (t, s) = bezier_theta(req, &motion, &spec, &kept)?;
            (Some(t), Some(s))
        }
    };
    let trained = match (req.method, &req.run) {
        (EditMethod::Transformer, Some(run)) => Some(Trained::load(run)?),
        (EditMethod::Transformer, None) => {
            return Err(Error::Invalid(
                "--method transformer needs --run R (a trained in-betweener)".into(),
            ))
        }
        _ => None,
    };
    let features = model_music(trained.as_ref(), req)?;
    let genre = req.genre.clone().or_else(|| {
        req.motion
            .file_stem()
            .and_then(|s| s.to_str())
            .and_then(|s| s.strip_prefix('g'))
            .map(|s| s.chars().take(2).collect())
    });
    let learnt = |edited: &Motion, anchors: &[usize]| -> std::result::Result<Motion, String> {
        let t = trained.as_ref().expect("only with a trained model");
        let ctx = Context {
            features: features.as_deref(),
            genre: genre.as_deref(),
        };
        rebuild(
            &t.model,
            &t.config,
            edited,
            &anchor_windows(anchors, t.config.max_len, &cuts)?,
            &ctx,
        )
        .map_err(|e| e.to_string())
    };
    let method = match (&theta, &trained) {
        (_, Some(_)) => Method::Learnt(&learnt),
        (None, None) => Method::Slerp,
        (Some(t), None) => Method::Bezier(t, req.bezier),
    };
    let (out, ranges) = apply(&motion, &spec, &kept, &method)
        .map_err(|e| Error::Invalid(format!("{}: {e}", req.edits.display())))?;
    if req.method == EditMethod::Bezier {
        warn_if_faster(&motion, &out, &spec.regenerate, &req.edits);
    }
    // The input's smpl_scaling is kept (SPEC §12.7 writes 1.0) so that untouched frames stay bit-identical
    // in smpl_trans too.
    let mut written = out;
    written.extra.clear();
    let report = EditReport {
        input: req.motion.display().to_string(),
        output: req.out.display().to_string(),
        method: req.method,
        checkpoint: trained.as_ref().map(|t| t.label()),
        keep: keep_label(&spec.keep),
        theta_source,
        edited_frames: spec.edits.iter().map(|e| e.frame).collect(),
        ranges,
        frames: motion.frames,
    };
    write(req, &written, &report)?;
    Ok(report)
}

/// The edited dance, its report beside it and (with `req.render`) its previews.
fn write(req: &EditRequest, written: &Motion, report: &EditReport) -> Result<()> {
    let json = serde_json::to_string_pretty(report).expect("plain data") + "\n";
    written.write_pkl(&req.out, Precision::F64)?;
    qean_io::fsutil::atomic_write(&sibling(&req.out, "report.json"), json.as_bytes())?;
    if req.render {
        let joints = written.joints(FkRoot::Smpl);
        let preview = qean_render::Preview {
            title: req
                .out
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            joints: &joints,
            fps: qean_motion::motion::FPS,
            beats: None,
            seed_frames: 0,
        };
        qean_render::write_preview(
            &preview,
            &sibling(&req.out, "png"),
            &sibling(&req.out, "gif"),
        )?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::anchor_windows;

    fn spans(w: &[crate::inbetween::Segment]) -> Vec<(usize, usize, usize)> {
        w.iter().map(|s| (s.a, s.b, s.keys.len())).collect()
    }

    #[test]
    fn windows_end_at_measure_boundaries_and_respect_max_len() {
        // 5 keys per 180-frame measure: one window per measure, as in training.
        let anchors: Vec<usize> = (0..=8).map(|i| i * 45).collect();
        let w = anchor_windows(&anchors, 240, &[0, 180, 360]).unwrap();
        assert_eq!(spans(&w), vec![(0, 180, 5), (180, 360, 5)]);
        // Without a grid the same anchors pack greedily under max_len.
        let w = anchor_windows(&anchors, 240, &[]).unwrap();
        assert_eq!(spans(&w), vec![(0, 225, 6), (225, 360, 4)]);
        // A boundary that is not an anchor does not cut; max_len still does.
        let w = anchor_windows(&[0, 100, 200, 300], 240, &[150]).unwrap();
        assert_eq!(spans(&w), vec![(0, 200, 3), (200, 300, 2)]);
        assert!(anchor_windows(&[0, 300], 240, &[])
            .unwrap_err()
            .contains("300 frames apart"));
    }
}
