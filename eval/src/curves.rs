//! `qean curves`: metrics against training steps for a set of runs, grouped over seeds. Reads
//! every `R/eval/step-N/report.json` (checkpoint mode writes them; `--evaluate` writes the
//! missing ones first) and draws speed_ratio, accel_ratio, freeze_fraction and FID_k against the
//! step, one colour per group (runs whose names differ only in `-seed<k>`, as a sweep names
//! them), the mean line over seeds and every seed's point. Also writes the points as CSV and a
//! markdown table of each group at its last common step: mean ± sample SD over seeds.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::Error;
use qean_render::canvas::*;

use crate::run_report::RunReport;
use crate::stats::mean_sd;

/// The numbers read from one report (its first metrics mode).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    pub step: u64,
    pub speed_ratio: f64,
    pub accel_ratio: f64,
    pub freeze_fraction: f64,
    /// Lowest speed ratio of any 5-s span, highest acceleration ratio of any span.
    pub min_span_speed_ratio: f64,
    pub max_span_accel_ratio: f64,
    pub fid_k: f64,
    pub fid_g: f64,
    pub beat_align: Option<f64>,
    /// The frozen-seed baseline's FID_k, when the report has baselines.
    pub frozen_fid_k: Option<f64>,
}

impl Point {
    pub fn of(report: &RunReport) -> Option<Point> {
        let r = report.reports.first()?;
        let e = r.motion_energy.as_ref()?;
        Some(Point {
            step: report.step,
            speed_ratio: e.speed_ratio,
            accel_ratio: e.accel_ratio,
            freeze_fraction: e.freeze_fraction,
            min_span_speed_ratio: e
                .spans
                .iter()
                .map(|s| s.speed_ratio)
                .fold(f64::MAX, f64::min),
            max_span_accel_ratio: e.spans.iter().map(|s| s.accel_ratio).fold(0.0, f64::max),
            fid_k: r.fid_k,
            fid_g: r.fid_g,
            beat_align: r.beat_align,
            frozen_fid_k: report.baselines.as_ref().map(|b| b.frozen.fid_k),
        })
    }
}

/// One run's points.
#[derive(Debug, Clone)]
pub struct RunCurve {
    pub dir: PathBuf,
    pub name: String,
    pub group: String,
    pub points: Vec<Point>,
}

/// The group of a run name: the name without its `-seed<k>` part.
pub fn group_of(name: &str) -> String {
    let parts: Vec<&str> = name.split('-').collect();
    let kept: Vec<&str> = parts
        .iter()
        .copied()
        .filter(|p| {
            !(p.len() > 4 && p.starts_with("seed") && p[4..].chars().all(|c| c.is_ascii_digit()))
        })
        .collect();
    if kept.is_empty() {
        name.to_string()
    } else {
        kept.join("-")
    }
}

fn is_run(dir: &Path) -> bool {
    dir.join("config.toml").is_file() && dir.join("checkpoints").is_dir()
}

/// The run directories named: runs themselves, or directories holding runs (a sweep's output).
pub fn find_runs(paths: &[PathBuf]) -> crate::Result<Vec<PathBuf>> {
    let mut runs = Vec::new();
    for p in paths {
        if is_run(p) {
            runs.push(p.clone());
            continue;
        }
        if !p.is_dir() {
            return Err(Error::file(p, "no such run directory"));
        }
        let mut inner: Vec<PathBuf> = std::fs::read_dir(p)
            .map_err(|e| Error::file(p, format!("cannot read: {e}")))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|d| is_run(d))
            .collect();
        if inner.is_empty() {
            return Err(Error::file(
                p,
                "neither a run directory (config.toml, checkpoints/) nor a directory of runs",
            ));
        }
        inner.sort();
        runs.extend(inner);
    }
    Ok(runs)
}

/// The step of an evaluation directory named `step-N` (or `step-N-TAG` when `tag` is given).
fn eval_step(name: &str, tag: Option<&str>) -> Option<u64> {
    let rest = name.strip_prefix("step-")?;
    let digits = match tag {
        None => rest,
        Some(t) => rest.strip_suffix(t)?.strip_suffix('-')?,
    };
    digits.parse().ok()
}

/// Reads the evaluation reports of a run (`eval/step-N/`, or `eval/step-N-TAG/`), by step.
pub fn read_run(dir: &Path, tag: Option<&str>) -> crate::Result<RunCurve> {
    let name = dir
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| dir.display().to_string());
    let mut points = Vec::new();
    let eval = dir.join("eval");
    if eval.is_dir() {
        let cannot_read = |e: std::io::Error| Error::file(&eval, format!("cannot read: {e}"));
        for e in std::fs::read_dir(&eval).map_err(cannot_read)? {
            let e = e.map_err(cannot_read)?;
            if eval_step(&e.file_name().to_string_lossy(), tag).is_none() {
                continue;
            }
            let path = e.path().join("report.json");
            if !path.is_file() {
                continue;
            }
            let text = std::fs::read_to_string(&path)
                .map_err(|e| Error::file(&path, format!("cannot read: {e}")))?;
            let report: RunReport = serde_json::from_str(&text)
                .map_err(|e| Error::file(&path, format!("not a checkpoint-mode report: {e}")))?;
            if let Some(p) = Point::of(&report) {
                points.push(p);
            }
        }
    }
    points.sort_by_key(|p| p.step);
    Ok(RunCurve {
        dir: dir.to_path_buf(),
        group: group_of(&name),
        name,
        points,
    })
}

type Getter = fn(&Point) -> Option<f64>;

/// The columns of the table and the CSV.
pub const COLUMNS: [(&str, Getter); 9] = [
    ("speed_ratio", |p| Some(p.speed_ratio)),
    ("min_span_speed_ratio", |p| Some(p.min_span_speed_ratio)),
    ("accel_ratio", |p| Some(p.accel_ratio)),
    ("max_span_accel_ratio", |p| Some(p.max_span_accel_ratio)),
    ("freeze_fraction", |p| Some(p.freeze_fraction)),
    ("fid_k", |p| Some(p.fid_k)),
    ("fid_g", |p| Some(p.fid_g)),
    ("beat_align", |p| p.beat_align),
    ("frozen_fid_k", |p| p.frozen_fid_k),
];

/// Groups in first-seen order.
fn groups(runs: &[RunCurve]) -> Vec<(String, Vec<&RunCurve>)> {
    let mut out: Vec<(String, Vec<&RunCurve>)> = Vec::new();
    for r in runs {
        match out.iter_mut().find(|(g, _)| *g == r.group) {
            Some((_, v)) => v.push(r),
            None => out.push((r.group.clone(), vec![r])),
        }
    }
    out
}

/// The table: each group at the last step every one of its runs reached, mean ± SD over runs.
pub fn table(runs: &[RunCurve]) -> String {
    let mut t = String::from("| group | step | runs |");
    for (name, _) in COLUMNS {
        t += &format!(" {name} |");
    }
    t += "\n|---|---|---|";
    t += &"---|".repeat(COLUMNS.len());
    t += "\n";
    for (group, members) in groups(runs) {
        let Some(step) = members
            .iter()
            .map(|r| r.points.last().map_or(0, |p| p.step))
            .min()
            .filter(|&s| s > 0)
        else {
            continue;
        };
        let at: Vec<&Point> = members
            .iter()
            .filter_map(|r| r.points.iter().find(|p| p.step == step))
            .collect();
        if at.len() != members.len() {
            continue;
        }
        t += &format!("| {group} | {step} | {} |", at.len());
        for (_, get) in COLUMNS {
            let v: Vec<f64> = at.iter().filter_map(|p| get(p)).collect();
            if v.is_empty() {
                t += " - |";
            } else {
                let (m, sd) = mean_sd(&v);
                t += &format!(" {m:.3} ± {sd:.3} |");
            }
        }
        t += "\n";
    }
    t
}

/// Every point as CSV: group, run, step, then [`COLUMNS`].
pub fn csv(runs: &[RunCurve]) -> String {
    let mut s = String::from("group,run,step");
    for (name, _) in COLUMNS {
        s += &format!(",{name}");
    }
    s += "\n";
    for r in runs {
        for p in &r.points {
            s += &format!("{},{},{}", r.group, r.name, p.step);
            for (_, get) in COLUMNS {
                s += &get(p)
                    .map(|v| format!(",{v}"))
                    .unwrap_or_else(|| ",".into());
            }
            s += "\n";
        }
    }
    s
}

/// One panel: `get` against step (log x when the steps span more than a factor 4).
#[allow(clippy::too_many_arguments)]
fn panel(
    c: &mut Canvas,
    (x0, y0, w, h): (f64, f64, f64, f64),
    title: &str,
    runs: &[RunCurve],
    get: fn(&Point) -> f64,
    band: Option<(f64, f64)>,
    ymax_cap: Option<f64>,
) {
    let all: Vec<&Point> = runs.iter().flat_map(|r| &r.points).collect();
    c.text(x0 as i64, y0 as i64 - 18, title, 2, INK);
    if all.is_empty() {
        c.text(x0 as i64 + 10, (y0 + h / 2.0) as i64, "NO POINTS", 2, GREY);
        return;
    }
    let smin = all.iter().map(|p| p.step).min().unwrap_or(1).max(1) as f64;
    let smax = all.iter().map(|p| p.step).max().unwrap_or(1).max(1) as f64;
    let log = smax / smin > 4.0;
    let fx = |s: f64| if log { s.max(1.0).ln() } else { s };
    let (xa, xb) = if smax > smin {
        (fx(smin), fx(smax))
    } else {
        (fx(smin) - 1.0, fx(smin) + 1.0)
    };
    let mut ymax = all.iter().map(|p| get(p)).fold(0.0f64, f64::max);
    if let Some((_, hi)) = band {
        ymax = ymax.max(hi);
    }
    if let Some(cap) = ymax_cap {
        ymax = ymax.min(cap);
    }
    let ymax = if ymax > 0.0 { ymax * 1.08 } else { 1.0 };
    let to = |s: f64, v: f64| {
        (
            x0 + w * (fx(s) - xa) / (xb - xa),
            y0 + h * (1.0 - (v.min(ymax) / ymax)),
        )
    };
    if let Some((lo, hi)) = band {
        let (_, ya) = to(smin, hi);
        let (_, yb) = to(smin, lo);
        c.fill_rect(x0 as i64, ya as i64, w as i64, (yb - ya) as i64, HIGHLIGHT);
    }
    for k in 0..=4 {
        let v = ymax * k as f64 / 4.0;
        let (_, y) = to(smin, v);
        c.line((x0, y), (x0 + w, y), 1.0, LIGHT);
        c.text(x0 as i64 - 52, y as i64 - 3, &format!("{v:.2}"), 1, GREY);
    }
    let mut ticks: Vec<f64> = all.iter().map(|p| p.step as f64).collect();
    ticks.sort_by(f64::total_cmp);
    ticks.dedup();
    let mut last_x = f64::MIN;
    for s in ticks {
        let (x, _) = to(s, 0.0);
        let label = format!("{}", s as u64);
        if x - last_x < Canvas::text_width(&label, 1) as f64 + 6.0 {
            continue;
        }
        last_x = x;
        c.line((x, y0 + h), (x, y0 + h + 4.0), 1.0, GREY);
        c.text(
            x as i64 - Canvas::text_width(&label, 1) / 2,
            (y0 + h + 8.0) as i64,
            &label,
            1,
            GREY,
        );
    }
    c.line((x0, y0 + h), (x0 + w, y0 + h), 1.0, GREY);
    c.line((x0, y0), (x0, y0 + h), 1.0, GREY);
    for (gi, (_, members)) in groups(runs).iter().enumerate() {
        let color = SERIES[gi % SERIES.len()];
        let mut by_step: BTreeMap<u64, Vec<f64>> = BTreeMap::new();
        for r in members {
            for p in &r.points {
                by_step.entry(p.step).or_default().push(get(p));
                c.disc(to(p.step as f64, get(p)), 2.0, color);
            }
        }
        let means: Vec<(f64, f64)> = by_step
            .iter()
            .map(|(s, v)| to(*s as f64, v.iter().sum::<f64>() / v.len() as f64))
            .collect();
        for seg in means.windows(2) {
            c.line(seg[0], seg[1], 2.0, color);
        }
    }
}

/// The 2 × 2 figure plus a legend.
pub fn figure(runs: &[RunCurve], title: &str) -> Canvas {
    let gs = groups(runs);
    let legend_rows = gs.len().div_ceil(2);
    let (w, h) = (1200usize, 860 + 18 * legend_rows);
    let mut c = Canvas::new(w, h, WHITE);
    c.text(12, 10, title, 2, INK);
    let (pw, ph) = (470.0, 300.0);
    // Title, value, target band and y-axis cap of each panel, left to right, top to bottom.
    type Panel = (
        &'static str,
        fn(&Point) -> f64,
        Option<(f64, f64)>,
        Option<f64>,
    );
    let panels: [Panel; 4] = [
        (
            "SPEED RATIO (TARGET 0.6-1.6)",
            |p| p.speed_ratio,
            Some((0.6, 1.6)),
            Some(5.0),
        ),
        (
            "ACCEL RATIO (TARGET 2 OR LESS)",
            |p| p.accel_ratio,
            Some((0.0, 2.0)),
            Some(25.0),
        ),
        (
            "FREEZE FRACTION (TARGET 0.1 OR LESS)",
            |p| p.freeze_fraction,
            Some((0.0, 0.1)),
            Some(1.0),
        ),
        ("FID_K", |p| p.fid_k, None, None),
    ];
    for (k, (title, get, band, cap)) in panels.into_iter().enumerate() {
        let (x0, y0) = (90.0 + 590.0 * (k % 2) as f64, 70.0 + 390.0 * (k / 2) as f64);
        panel(&mut c, (x0, y0, pw, ph), title, runs, get, band, cap);
    }
    c.text(
        12,
        808,
        "STEP (LOG SCALE WHEN THE STEPS SPAN A FACTOR 4)",
        1,
        GREY,
    );
    for (gi, (g, members)) in gs.iter().enumerate() {
        let (x, y) = (12 + 590 * (gi % 2) as i64, 830 + 18 * (gi / 2) as i64);
        let color = SERIES[gi % SERIES.len()];
        c.fill_rect(x, y, 24, 6, color);
        c.text(
            x + 32,
            y - 1,
            &format!(
                "{g} ({} RUN{})",
                members.len(),
                if members.len() == 1 { "" } else { "S" }
            ),
            1,
            INK,
        );
    }
    c
}

/// What `qean curves` draws.
#[derive(Debug, Clone)]
pub struct CurvesRequest {
    /// Run directories, or directories of runs (e.g. a sweep's S-runs/).
    pub runs: Vec<PathBuf>,
    /// Output directory: curves.png, curves.csv, table.md.
    pub out: PathBuf,
    /// Only these steps (empty: every evaluated checkpoint).
    pub steps: Vec<u64>,
    /// Figure title.
    pub title: String,
    /// Read the reports tagged TAG: eval/step-N-TAG/.
    pub tag: Option<String>,
}

/// The evaluation directory name of a checkpoint step (`step-N`, or `step-N-TAG`).
pub fn eval_dir_name(step: u64, tag: Option<&str>) -> String {
    match tag {
        Some(t) => format!("step-{step}-{t}"),
        None => format!("step-{step}"),
    }
}

/// Whether `run` holds a usable report for `step`: `eval/<eval_dir_name>/report.json` readable, made for
/// `max_frames` generated frames under `protocol` (a named preset or none), with motion energy.
pub fn has_report(
    run: &Path,
    step: u64,
    tag: Option<&str>,
    max_frames: usize,
    protocol: Option<crate::preset::ProtocolPreset>,
) -> bool {
    let report = run
        .join("eval")
        .join(eval_dir_name(step, tag))
        .join("report.json");
    std::fs::read_to_string(report)
        .ok()
        .and_then(|t| serde_json::from_str::<RunReport>(&t).ok())
        .is_some_and(|r| {
            r.frames == max_frames
                && r.reports.first().map(|m| m.config.preset) == Some(protocol)
                && Point::of(&r).is_some()
        })
}

/// Reads the runs' reports and writes curves.png, curves.csv and table.md; returns the table.
pub fn write_curves(a: &CurvesRequest) -> crate::Result<String> {
    let dirs = find_runs(&a.runs)?;
    let mut runs = Vec::new();
    for d in &dirs {
        let mut r = read_run(d, a.tag.as_deref())?;
        if !a.steps.is_empty() {
            r.points.retain(|p| a.steps.contains(&p.step));
        }
        runs.push(r);
    }
    if runs.iter().all(|r| r.points.is_empty()) {
        return Err(Error::Invalid(format!(
            "no evaluation reports under {} run(s): evaluate checkpoints first (qean eval --run R ..., or --evaluate --data DIR)",
            runs.len()
        )));
    }
    std::fs::create_dir_all(&a.out)
        .map_err(|e| Error::file(&a.out, format!("cannot create: {e}")))?;
    let table = table(&runs);
    qean_io::fsutil::atomic_write(&a.out.join("curves.png"), &figure(&runs, &a.title).to_png())?;
    qean_io::fsutil::atomic_write(&a.out.join("curves.csv"), csv(&runs).as_bytes())?;
    qean_io::fsutil::atomic_write(&a.out.join("table.md"), table.as_bytes())?;
    Ok(table)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(step: u64, speed: f64) -> Point {
        Point {
            step,
            speed_ratio: speed,
            accel_ratio: 1.0,
            freeze_fraction: 0.0,
            min_span_speed_ratio: speed,
            max_span_accel_ratio: 1.0,
            fid_k: 10.0,
            fid_g: 5.0,
            beat_align: Some(0.2),
            frozen_fid_k: None,
        }
    }

    #[test]
    fn evaluation_directories_by_tag() {
        assert_eq!(eval_step("step-500", None), Some(500));
        assert_eq!(eval_step("step-500-ens4", None), None);
        assert_eq!(eval_step("step-500-ens4", Some("ens4")), Some(500));
        assert_eq!(eval_step("step-500", Some("ens4")), None);
        assert_eq!(eval_step("stepx", None), None);
    }

    #[test]
    fn groups_drop_the_seed_part() {
        assert_eq!(group_of("noise-seed3"), "noise");
        assert_eq!(group_of("noise-seed12-steps=400"), "noise-steps=400");
        assert_eq!(group_of("seedling"), "seedling");
        assert_eq!(group_of("a-seedx"), "a-seedx");
    }

    #[test]
    fn table_averages_seeds_at_the_last_common_step() {
        let runs = vec![
            RunCurve {
                dir: "a".into(),
                name: "x-seed0".into(),
                group: "x".into(),
                points: vec![point(100, 0.1), point(200, 0.8)],
            },
            RunCurve {
                dir: "b".into(),
                name: "x-seed1".into(),
                group: "x".into(),
                points: vec![point(100, 0.3), point(200, 1.2), point(300, 9.0)],
            },
        ];
        let t = table(&runs);
        assert!(t.contains("| x | 200 | 2 | 1.000 ± 0.283 |"), "{t}");
        let c = csv(&runs);
        assert_eq!(c.lines().count(), 6);
        let fig = figure(&runs, "T");
        assert!(fig.pixels.iter().any(|&p| p == SERIES[0]));
    }
}
