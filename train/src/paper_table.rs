//! A sweep laid out as the QEAN paper's tables (seed 000, section 4): Table 1 (every method's FID_k,
//! FID_g, Dist_k, Dist_g and BeatAlign) and Table 2 (the ablation's FID_k, FID_g and BeatAlign), each
//! cell the mean ± 95 % interval over seeds, plus what the paper does not report — each dance set's own
//! chance levels, speed, frozen share and PFC — the ground truth scored the same way, and, in a separate
//! block, the numbers the paper publishes (AIST++ at paper size: a reference, not a comparison).

use std::path::Path;

use qean_config::sweep::PaperTable;
use qean_eval::config::value_name;
use qean_eval::preset::ProtocolPreset;
use qean_eval::stats::Interval;
use qean_io::error::Result;
use qean_render::canvas::*;
use serde::Serialize;

use crate::sweep::{seeds_table_head, SeedGroup};

/// A column: its heading and the sweep quantity it shows.
struct Column {
    head: &'static str,
    key: &'static str,
}

const fn col(head: &'static str, key: &'static str) -> Column {
    Column { head, key }
}

/// Table 1's columns: the paper's five, then each set's chance levels and our dance measures.
const TABLE1: &[Column] = &[
    col("FID_k ↓", "fid_k"),
    col("FID_g ↓", "fid_g"),
    col("Dist_k →", "dist_k"),
    col("Dist_g →", "dist_g"),
    col("BeatAlign ↑", "beat_align"),
    col("BeatAlign, random pairing", "random_beat_align"),
    col("FID_k, frozen", "frozen_fid_k"),
    col("speed ratio", "speed_ratio"),
    col("frozen share", "freeze_fraction"),
    col("PFC ↓", "pfc"),
];

/// Table 2's columns: the paper's three, then the same extras.
const TABLE2: &[Column] = &[
    col("FID_k ↓", "fid_k"),
    col("FID_g ↓", "fid_g"),
    col("BeatAlign ↑", "beat_align"),
    col("BeatAlign, random pairing", "random_beat_align"),
    col("speed ratio", "speed_ratio"),
    col("PFC ↓", "pfc"),
];

/// The ground truth's own values, by the column they stand in.
const GROUND: &[(&str, &str)] = &[
    ("dist_k", "gt_dist_k"),
    ("dist_g", "gt_dist_g"),
    ("beat_align", "gt_beat_align"),
    ("pfc", "gt_pfc"),
];

/// The QEAN paper's Table 1 (FID_k, FID_g, Dist_k, Dist_g, BeatAlign; "-" where it prints none).
const PUBLISHED1: &[(&str, [Option<f64>; 5])] = &[
    (
        "AIST++",
        [None, None, Some(9.057), Some(7.556), Some(0.292)],
    ),
    ("AIST++ (random)", [None, None, None, None, Some(0.213)]),
    (
        "Li et al.",
        [
            Some(86.43),
            Some(20.58),
            Some(6.85),
            Some(4.93),
            Some(0.232),
        ],
    ),
    (
        "DanceNet",
        [
            Some(69.18),
            Some(17.76),
            Some(2.86),
            Some(2.72),
            Some(0.232),
        ],
    ),
    (
        "DanceRevolution",
        [Some(73.42), Some(31.01), Some(3.52), Some(2.46), Some(0.22)],
    ),
    (
        "FACT (baseline)",
        [Some(48.95), Some(28.1), Some(4.9), Some(6.69), Some(0.232)],
    ),
    (
        "QEAN",
        [Some(30.1), Some(11.5), Some(7.82), Some(9.37), Some(0.239)],
    ),
];

/// The QEAN paper's Table 2 (FID_k, FID_g, BeatAlign).
const PUBLISHED2: &[(&str, [Option<f64>; 3])] = &[
    ("baseline", [Some(48.95), Some(28.1), Some(0.232)]),
    (
        "baseline + Spin Position Embedding",
        [Some(30.1), Some(11.5), Some(0.239)],
    ),
    ("baseline + QRA", [Some(46.33), Some(26.2), Some(0.236)]),
];

/// One row of the table as written to JSON.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    pub label: String,
    pub seeds: Vec<u64>,
    /// Column key → interval over seeds (absent: not measured).
    pub values: Vec<(String, Option<Interval>)>,
}

/// A row of the paper's own table: the method and its values by column key (`None`: not printed).
pub type Published = (String, Vec<(String, Option<f64>)>);

/// The whole table as written to `tableN.json`.
#[derive(Debug, Clone, Serialize)]
pub struct Table {
    pub table: &'static str,
    pub columns: Vec<(String, String)>,
    pub rows: Vec<Row>,
    /// The reference set scored like each group of rows (one row per distinct scoring).
    pub ground_truth: Vec<Row>,
    /// Each variant minus the baseline, seed by seed (Table 2, or any sweep with a baseline).
    pub paired: Vec<Row>,
    /// The paper's numbers, for reference.
    pub published: Vec<Published>,
    /// The named protocol every row was scored under (`None`: ours, Bailando's settings).
    pub protocol: Option<ProtocolPreset>,
}

/// The line that says which protocol scored a sweep's numbers.
pub fn protocol_line(protocol: Option<ProtocolPreset>) -> String {
    match protocol {
        Some(p) => format!(
            "Protocol: preset `{}`, {}: every number here is scored under it (`qean eval --protocol-preset \
             {}` lists each setting it fixes); published numbers are under their paper's own protocol.",
            value_name(p),
            p.title(),
            value_name(p)
        ),
        None => "Protocol: ours (no preset named; Bailando's settings: 60 fps, the generated frames after \
                 the seed, every non-ignored motion as the reference)."
            .to_string(),
    }
}

fn value(list: &[(String, Option<Interval>)], key: &str) -> Option<Interval> {
    list.iter().find(|(k, _)| k == key).and_then(|(_, i)| *i)
}

/// The reference set's rows: one per distinct set of values (the frames scored may differ by family),
/// naming the variants scored that way.
fn ground_rows(columns: &[Column], danced: &[&SeedGroup]) -> Vec<Row> {
    let mut ground: Vec<Row> = Vec::new();
    for g in danced {
        let values: Vec<(String, Option<Interval>)> = GROUND
            .iter()
            .filter(|(k, _)| columns.iter().any(|c| c.key == *k))
            .map(|(k, gt)| (k.to_string(), value(&g.intervals, gt)))
            .chain(
                columns
                    .iter()
                    .any(|c| c.key == "speed_ratio")
                    .then(|| ("speed_ratio".to_string(), Interval::of(&[1.0]))),
            )
            .collect();
        let same = |r: &Row| {
            r.values.iter().zip(&values).all(|((_, a), (_, b))| {
                a.map(|i| format!("{:.6e}", i.mean)) == b.map(|i| format!("{:.6e}", i.mean))
            })
        };
        match ground.iter_mut().find(|r| same(r)) {
            Some(r) => r.label.push_str(&format!(", {}", g.variant)),
            None => ground.push(Row {
                label: format!("ground truth, scored as {}", g.variant),
                seeds: Vec::new(),
                values,
            }),
        }
    }
    ground
}

/// The paper's own rows of `kind`, by column key.
fn published(kind: PaperTable) -> Vec<Published> {
    fn rows<const N: usize>(table: &[(&str, [Option<f64>; N])], keys: [&str; N]) -> Vec<Published> {
        table
            .iter()
            .map(|(name, v)| {
                let values = keys.iter().map(|k| k.to_string()).zip(v.iter().copied());
                (name.to_string(), values.collect())
            })
            .collect()
    }
    match kind {
        PaperTable::Table1 => rows(
            PUBLISHED1,
            ["fid_k", "fid_g", "dist_k", "dist_g", "beat_align"],
        ),
        PaperTable::Table2 => rows(PUBLISHED2, ["fid_k", "fid_g", "beat_align"]),
    }
}

/// Builds the table from a sweep's seed groups (groups without dance metrics, e.g. a VQ-VAE stage, are
/// left out).
pub fn build(kind: PaperTable, groups: &[SeedGroup], protocol: Option<ProtocolPreset>) -> Table {
    let columns = match kind {
        PaperTable::Table1 => TABLE1,
        PaperTable::Table2 => TABLE2,
    };
    let danced: Vec<&SeedGroup> = groups
        .iter()
        .filter(|g| value(&g.intervals, "fid_k").is_some())
        .collect();
    let rows = danced
        .iter()
        .map(|g| Row {
            label: g.label(),
            seeds: g.seeds.clone(),
            values: columns
                .iter()
                .map(|c| (c.key.to_string(), value(&g.intervals, c.key)))
                .collect(),
        })
        .collect();
    let ground = ground_rows(columns, &danced);
    let paired = danced
        .iter()
        .filter_map(|g| {
            let base = g.against.as_ref()?;
            Some(Row {
                label: format!("{} − {base}", g.label()),
                seeds: g.seeds.clone(),
                values: columns
                    .iter()
                    .map(|c| (c.key.to_string(), value(&g.paired, c.key)))
                    .collect(),
            })
        })
        .collect();
    let published = published(kind);
    Table {
        table: kind.name(),
        columns: columns
            .iter()
            .map(|c| (c.key.to_string(), c.head.to_string()))
            .collect(),
        rows,
        ground_truth: ground,
        paired,
        published,
        protocol,
    }
}

/// A cell: "m ± h" with three decimals (FID: one), "m (1 seed)", or "-"; "(n of N)" where fewer than
/// the row's `seeds` gave a value.
fn cell(key: &str, i: Option<Interval>, seeds: usize) -> String {
    let decimals = if key.contains("fid") { 1 } else { 3 };
    i.map(|i| i.display_of(decimals, seeds))
        .unwrap_or_else(|| "-".into())
}

/// How a row's cells are written.
#[derive(Clone, Copy)]
enum RowKind {
    /// The reference set: one value.
    Ground,
    /// A variant over seeds.
    Run,
    /// A paired difference, starred when its interval excludes 0.
    Paired,
}

/// The table as markdown, with how to read it.
pub fn markdown(t: &Table) -> String {
    let title = match t.table {
        "table1" => "Table 1: every method",
        _ => "Table 2: the ablation",
    };
    let mut md = format!(
        "# {title}\n\nEach cell: the mean over training seeds ± the half-width of its 95 % confidence \
         interval (Student's t, n − 1 degrees of freedom); \"(1 seed)\" where one seed ran, which is a \
         number, not a result. Two rows whose intervals overlap are not shown apart by these seeds. \
         ↓ lower is better, ↑ higher, → closer to the ground truth's. \"random pairing\" scores each \
         dance against other songs' beats and \"frozen\" holds the seed's last pose: the chance levels \
         of that row's own dances.\n\n{}\n\n",
        protocol_line(t.protocol)
    );
    let head = |first: &str| seeds_table_head(first, t.columns.iter().map(|(_, c)| c.as_str()));
    let line = |r: &Row, kind: RowKind| {
        let seeds = if r.seeds.is_empty() {
            String::new()
        } else {
            r.seeds.len().to_string()
        };
        let mut l = format!("| {} | {seeds} |", r.label);
        for (key, _) in &t.columns {
            let v = r
                .values
                .iter()
                .find(|(k, _)| k == key)
                .and_then(|(_, i)| *i);
            let c = match kind {
                RowKind::Ground => v
                    .map(|i| format!("{:.3}", i.mean))
                    .unwrap_or_else(|| "-".into()),
                RowKind::Run => cell(key, v, r.seeds.len()),
                RowKind::Paired if v.is_some_and(|i| i.excludes_zero()) => {
                    format!("{} *", cell(key, v, r.seeds.len()))
                }
                RowKind::Paired => cell(key, v, r.seeds.len()),
            };
            l.push_str(&format!(" {c} |"));
        }
        l.push('\n');
        l
    };
    md.push_str(&head("method"));
    for r in &t.ground_truth {
        md.push_str(&line(r, RowKind::Ground));
    }
    for r in &t.rows {
        md.push_str(&line(r, RowKind::Run));
    }
    if !t.paired.is_empty() {
        md.push_str(
            "\n## Paired differences\n\nEach variant minus the baseline, seed by seed (what the seeds share \
             cancels), mean ± 95 % interval; * marks an interval that excludes 0: a difference these seeds \
             do not explain. Without *, the data do not say which is better.\n\n",
        );
        md.push_str(&head("difference"));
        for r in &t.paired {
            md.push_str(&line(r, RowKind::Paired));
        }
    }
    md.push_str(&published_markdown(t));
    md
}

/// A panel's axis: every whisker of column `key` and the ground truth, from 0 when all are positive.
fn axis_range(t: &Table, key: &str, ground: Option<f64>) -> (f64, f64) {
    let mut lo = f64::INFINITY;
    let mut hi = f64::NEG_INFINITY;
    for r in &t.rows {
        if let Some(i) = value(&r.values, key) {
            let h = i.half_width.unwrap_or(0.0);
            lo = lo.min(i.mean - h);
            hi = hi.max(i.mean + h);
        }
    }
    if let Some(g) = ground {
        lo = lo.min(g);
        hi = hi.max(g);
    }
    if lo >= 0.0 {
        lo = 0.0;
    }
    if hi - lo < 1e-12 {
        hi = lo + 1.0;
    }
    (lo, hi)
}

/// The chart beside the table (`tableN.png`): one panel per measured column, each row's mean as a dot
/// with its 95 % interval as a whisker (a ring where one seed gives no interval), the ground truth as an
/// orange line where it has a value.
pub fn chart(t: &Table) -> Canvas {
    let columns: Vec<&(String, String)> = t
        .columns
        .iter()
        .filter(|(k, _)| t.rows.iter().any(|r| value(&r.values, k).is_some()))
        .collect();
    let (panel_w, row_h, head, label_w) = (330i64, 18i64, 34i64, 110i64);
    let per_row = 3usize;
    let panel_h = head + row_h * t.rows.len().max(1) as i64 + 24;
    let grid_rows = columns.len().div_ceil(per_row).max(1) as i64;
    let width = (label_w + panel_w * per_row as i64 + 20) as usize;
    let height = (40 + panel_h * grid_rows) as usize;
    let mut c = Canvas::new(width, height, WHITE);
    let title = match t.table {
        "table1" => "TABLE 1: MEAN AND 95% INTERVAL OVER SEEDS",
        _ => "TABLE 2: MEAN AND 95% INTERVAL OVER SEEDS",
    };
    c.text(10, 10, title, 2, INK);
    for (n, (key, headline)) in columns.iter().enumerate() {
        let x0 = label_w + panel_w * (n % per_row) as i64;
        let y0 = 40 + panel_h * (n / per_row) as i64;
        let ground = t
            .ground_truth
            .iter()
            .filter_map(|r| value(&r.values, key).map(|i| i.mean))
            .next();
        let (lo, hi) = axis_range(t, key, ground);
        let (px0, px1) = ((x0 + 10) as f64, (x0 + panel_w - 20) as f64);
        let to_x = |v: f64| px0 + (px1 - px0) * (v - lo) / (hi - lo);
        let label: String = headline
            .chars()
            .filter(|ch| ch.is_ascii())
            .collect::<String>()
            .trim()
            .to_uppercase();
        c.text(x0 + 10, y0 + 4, &label, 1, INK);
        let axis_y = y0 + head + row_h * t.rows.len() as i64;
        c.line((px0, axis_y as f64), (px1, axis_y as f64), 1.0, GREY);
        // The ends of the axis: the low one left-aligned, the high one right-aligned.
        let short = |v: f64| {
            let a = v.abs();
            if a >= 1e4 {
                format!("{v:.2e}").to_uppercase()
            } else if a >= 100.0 {
                format!("{v:.0}")
            } else if a >= 1.0 {
                format!("{v:.2}")
            } else {
                format!("{v:.3}")
            }
        };
        c.text(px0 as i64, axis_y + 6, &short(lo), 1, GREY);
        let high = short(hi);
        c.text(
            px1 as i64 - Canvas::text_width(&high, 1),
            axis_y + 6,
            &high,
            1,
            GREY,
        );
        if let Some(g) = ground {
            let x = to_x(g);
            c.line((x, (y0 + head - 6) as f64), (x, axis_y as f64), 1.0, ORANGE);
        }
        for (k, r) in t.rows.iter().enumerate() {
            let y = (y0 + head + row_h * k as i64 + row_h / 2) as f64;
            if n % per_row == 0 {
                let name: String = r.label.to_uppercase().chars().take(16).collect();
                c.text(8, y as i64 - 3, &name, 1, INK);
            }
            c.line((px0, y), (px1, y), 1.0, LIGHT);
            let Some(i) = value(&r.values, key) else {
                continue;
            };
            let colour = SERIES[k % SERIES.len()];
            match i.half_width {
                Some(h) => {
                    let (a, b) = (to_x(i.mean - h), to_x(i.mean + h));
                    c.line((a, y), (b, y), 2.0, colour);
                    c.line((a, y - 4.0), (a, y + 4.0), 1.5, colour);
                    c.line((b, y - 4.0), (b, y + 4.0), 1.5, colour);
                    c.disc((to_x(i.mean), y), 3.5, colour);
                }
                None => {
                    c.disc((to_x(i.mean), y), 4.0, colour);
                    c.disc((to_x(i.mean), y), 2.0, WHITE);
                }
            }
        }
    }
    c
}

/// The paper's own numbers as a markdown block.
fn published_markdown(t: &Table) -> String {
    let mut md = String::new();
    md.push_str(
        "\n## Published (QEAN paper, AIST++ at paper size: for reference, not comparable with the rows \
         above)\n\n",
    );
    let keys: Vec<&String> = t
        .published
        .first()
        .map(|(_, v)| v.iter().map(|(k, _)| k).collect())
        .unwrap_or_default();
    md.push_str("| method |");
    for k in &keys {
        let head = t
            .columns
            .iter()
            .find(|(c, _)| c == *k)
            .map(|(_, h)| h.as_str())
            .unwrap_or(k);
        md.push_str(&format!(" {head} |"));
    }
    md.push('\n');
    md.push_str(&"|---".repeat(keys.len() + 1));
    md.push_str("|\n");
    for (name, values) in &t.published {
        md.push_str(&format!("| {name} |"));
        for (_, v) in values {
            md.push_str(&format!(
                " {} |",
                v.map(|v| v.to_string()).unwrap_or_else(|| "-".into())
            ));
        }
        md.push('\n');
    }
    md
}

/// Writes `tableN.md`, `tableN.json` and the chart `tableN.png` into `out_dir` (atomically).
pub fn write(
    out_dir: &Path,
    kind: PaperTable,
    groups: &[SeedGroup],
    protocol: Option<ProtocolPreset>,
) -> Result<()> {
    let t = build(kind, groups, protocol);
    let json = serde_json::to_string_pretty(&t).expect("table serialises");
    qean_io::fsutil::atomic_write(
        &out_dir.join(format!("{}.png", kind.name())),
        &chart(&t).to_png(),
    )?;
    qean_io::fsutil::atomic_write(
        &out_dir.join(format!("{}.md", kind.name())),
        markdown(&t).as_bytes(),
    )?;
    qean_io::fsutil::atomic_write(
        &out_dir.join(format!("{}.json", kind.name())),
        json.as_bytes(),
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn group(variant: &str, fid: &[f64], gt_dist_k: f64, against: Option<&str>) -> SeedGroup {
        let i = |v: &[f64]| Interval::of(v);
        let seeds: Vec<u64> = (0..fid.len() as u64).collect();
        SeedGroup {
            variant: variant.into(),
            grid: Vec::new(),
            seeds,
            intervals: vec![
                ("fid_k".into(), i(fid)),
                ("beat_align".into(), i(&vec![0.25; fid.len()])),
                ("dist_k".into(), i(&vec![7.0; fid.len()])),
                ("gt_dist_k".into(), i(&vec![gt_dist_k; fid.len()])),
            ],
            against: against.map(Into::into),
            paired: against
                .map(|_| vec![("fid_k".into(), i(&[-1.0, -2.0, -3.0]))])
                .unwrap_or_default(),
        }
    }

    #[test]
    fn rows_ground_truth_paired_differences_and_the_published_block() {
        let vq = SeedGroup {
            intervals: vec![("train_loss".into(), Interval::of(&[1.0]))],
            ..group("vqvae", &[1.0], 0.0, None)
        };
        let groups = [
            group("fact", &[60.1, 55.5, 71.3], 9.1, None),
            vq,
            group("qean", &[50.0, 52.0, 54.0], 9.1, Some("fact")),
            group("gpt", &[40.0, 41.0, 42.0], 8.7, None),
        ];
        let t = build(PaperTable::Table1, &groups, None);
        let labels: Vec<&str> = t.rows.iter().map(|r| r.label.as_str()).collect();
        assert_eq!(
            labels,
            ["fact", "qean", "gpt"],
            "the VQ-VAE stage has no dances"
        );
        let gt: Vec<&str> = t.ground_truth.iter().map(|r| r.label.as_str()).collect();
        assert_eq!(
            gt,
            [
                "ground truth, scored as fact, qean",
                "ground truth, scored as gpt"
            ]
        );
        assert_eq!(t.paired.len(), 1);
        let md = markdown(&t);
        assert!(
            md.contains("| fact | 3 | 62.3 ± 20.2 | - | 7.000 ± 0.000 | - | 0.250 ± 0.000 |"),
            "{md}"
        );
        assert!(
            md.contains(
                "| ground truth, scored as gpt |  | - | - | 8.700 | - | - | - | - | 1.000 |"
            ),
            "{md}"
        );
        assert!(md.contains("| qean − fact | 3 | -2.0 ± 2.5 |"), "{md}");
        assert!(
            md.contains("| QEAN | 30.1 | 11.5 | 7.82 | 9.37 | 0.239 |"),
            "{md}"
        );
        let png = chart(&t);
        assert!(png.width > 600 && png.height > 100);
        assert!(png.pixels.contains(&ORANGE), "the ground truth's line");
        let t2 = build(PaperTable::Table2, &groups, None);
        assert_eq!(t2.columns[2].0, "beat_align");
        assert!(markdown(&t2).contains("| baseline + QRA | 46.33 | 26.2 | 0.236 |"));
    }
}
