//! The metrics report (serde JSON) and its markdown rendering in the layout of QEAN Table 1
//! (SPEC §8), each number tagged with the variants that produced it.

use serde::{Deserialize, Serialize};

use crate::config::{value_name, EvalConfig};
use crate::error::{Error, Result};
use crate::li_metrics::LiMetrics;
use crate::motion_energy::{DancingCount, EnergyReference, FootContact, MotionEnergy, RootDrift};
use crate::preset::{ProtocolPreset, Source};

/// Per generated sequence: its evaluated length, BeatAlign under both variants and the raw
/// (unnormalised) features.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SequenceMetrics {
    pub name: String,
    pub music_id: Option<String>,
    /// Evaluated generated frames L (after the seed and the max-frames cut).
    pub frames: usize,
    pub beat_align_bailando: Option<f64>,
    pub beat_align_mint: Option<f64>,
    pub kinetic: Vec<f64>,
    pub geometric: Vec<f64>,
    /// Speed, acceleration and frozen share of the evaluated frames against the reference set.
    #[serde(default)]
    pub motion_energy: Option<MotionEnergy>,
}

/// A sequence left out of some average, and why (also logged).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Exclusion {
    /// "generated" or "reference".
    pub set: String,
    pub name: String,
    /// What it is left out of: "all" or "beat_align".
    pub from: String,
    pub reason: String,
}

/// A generated dance that exploded: from `frame` on it was held at its last plausible frame.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Explosion {
    pub name: String,
    pub frame: usize,
    pub reason: String,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MetricsReport {
    pub config: EvalConfig,
    pub label: String,
    pub fid_k: f64,
    pub fid_g: f64,
    /// Dist_k / Dist_g of the generated set (Bailando's Div_k / Div_g).
    pub div_k: f64,
    pub div_g: f64,
    /// BeatAlign under `config.ba_variant`; `None` without music beats.
    pub beat_align: Option<f64>,
    pub beat_align_bailando: Option<f64>,
    pub beat_align_mint: Option<f64>,
    /// Dist of the normalised reference set.
    pub gt_div_k: f64,
    pub gt_div_g: f64,
    /// BeatAlign of the GT sequences paired (by name) with the generated ones, with their own music.
    pub gt_beat_align: Option<f64>,
    pub gt_beat_align_bailando: Option<f64>,
    pub gt_beat_align_mint: Option<f64>,
    pub n_generated: usize,
    pub n_reference: usize,
    pub n_beat_align: usize,
    pub n_gt_beat_align: usize,
    /// Reference dimensions with σ = 0, left out of FID and Dist (the reference code divides by
    /// σ + 1e-10 there).
    pub constant_reference_dims_k: Vec<usize>,
    pub constant_reference_dims_g: Vec<usize>,
    /// The set's motion energy (speed_ratio, accel_ratio, freeze_fraction, 5-s spans) against
    /// `energy_reference`, the reference set's statistics.
    #[serde(default)]
    pub motion_energy: Option<MotionEnergy>,
    #[serde(default)]
    pub energy_reference: Option<EnergyReference>,
    /// How far the generated frames' root gets in 10 s, and the reference set's.
    #[serde(default)]
    pub root_drift: Option<RootDrift>,
    #[serde(default)]
    pub reference_root_drift: Option<RootDrift>,
    /// EDGE's physical foot-contact score of the generated frames (`crate::pfc`; lower is better), and
    /// of the reference set.
    #[serde(default)]
    pub pfc: Option<f64>,
    #[serde(default)]
    pub gt_pfc: Option<f64>,
    /// How often the generated frames have a foot on the floor, and the reference set's frames.
    #[serde(default)]
    pub foot_contact: Option<FootContact>,
    #[serde(default)]
    pub reference_foot_contact: Option<FootContact>,
    /// How many generated dances are within the dancing limits, and how many of the reference set's own
    /// sequences are (from the seed's end on): the limits are against the set's mean, which some genres
    /// exceed.
    #[serde(default)]
    pub dancing: Option<DancingCount>,
    #[serde(default)]
    pub reference_dancing: Option<DancingCount>,
    pub sequences: Vec<SequenceMetrics>,
    pub excluded: Vec<Exclusion>,
    /// Generated dances that exploded (held at their last plausible frame for every metric).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub exploded: Vec<Explosion>,
    /// The TSMT paper's metrics (beat P/R/F1, A-/I-/S-music-D, Authenticity, Coherence), as top-level
    /// keys.
    #[serde(flatten)]
    pub li: LiMetrics,
}

impl MetricsReport {
    /// Error if any number is NaN or infinite (the report must never carry one).
    pub fn check_finite(&self) -> Result<()> {
        let mut named: Vec<(String, f64)> = vec![
            ("fid_k".into(), self.fid_k),
            ("fid_g".into(), self.fid_g),
            ("div_k".into(), self.div_k),
            ("div_g".into(), self.div_g),
            ("gt_div_k".into(), self.gt_div_k),
            ("gt_div_g".into(), self.gt_div_g),
        ];
        let opts = [
            ("beat_align", self.beat_align),
            ("beat_align_bailando", self.beat_align_bailando),
            ("beat_align_mint", self.beat_align_mint),
            ("gt_beat_align", self.gt_beat_align),
            ("gt_beat_align_bailando", self.gt_beat_align_bailando),
            ("gt_beat_align_mint", self.gt_beat_align_mint),
            ("pfc", self.pfc),
            ("gt_pfc", self.gt_pfc),
        ];
        named.extend(
            opts.iter()
                .filter_map(|(n, v)| v.map(|v| (n.to_string(), v))),
        );
        let energy = |name: &str, e: &MotionEnergy| -> Vec<(String, f64)> {
            let mut v = vec![
                (format!("{name}speed_ratio"), e.speed_ratio),
                (format!("{name}accel_ratio"), e.accel_ratio),
                (format!("{name}freeze_fraction"), e.freeze_fraction),
            ];
            for s in &e.spans {
                v.push((format!("{name}span speed"), s.speed));
                v.push((format!("{name}span accel"), s.accel));
            }
            v
        };
        if let Some(e) = &self.motion_energy {
            named.extend(energy("", e));
        }
        for (name, d) in [
            ("root_drift", &self.root_drift),
            ("reference_root_drift", &self.reference_root_drift),
        ] {
            if let Some(d) = d {
                named.push((format!("{name} horizontal"), d.horizontal));
                named.push((format!("{name} vertical"), d.vertical));
            }
        }
        for (name, c) in [
            ("foot_contact", &self.foot_contact),
            ("reference_foot_contact", &self.reference_foot_contact),
        ] {
            if let Some(c) = c {
                named.push((name.to_string(), c.share));
            }
        }
        named.extend(self.li.named().into_iter().map(|(k, v)| (k.to_string(), v)));
        for s in &self.sequences {
            if let Some(e) = &s.motion_energy {
                named.extend(energy(&format!("{} ", s.name), e));
            }
            for v in s.beat_align_bailando.iter().chain(&s.beat_align_mint) {
                named.push((format!("{} beat_align", s.name), *v));
            }
            for v in s.kinetic.iter().chain(&s.geometric) {
                named.push((format!("{} features", s.name), *v));
            }
        }
        match named.into_iter().find(|(_, v)| !v.is_finite()) {
            Some((n, v)) => Err(Error::Invalid(format!(
                "internal error: {n} is {v}; refusing to report a non-finite metric"
            ))),
            None => Ok(()),
        }
    }
}

fn opt(v: Option<f64>, digits: usize) -> String {
    v.map_or_else(|| "-".to_string(), |x| format!("{x:.digits$}"))
}

/// A markdown table in the layout of QEAN Table 1: a ground-truth row named after the reference set ("AIST++"
/// in the paper; from the first report) and
/// one row per report, then one line per report naming its variants.
pub fn render_markdown(rows: &[(&str, &MetricsReport)]) -> String {
    let mut out = String::new();
    if let Some(p) = rows.first().and_then(|(_, r)| r.config.preset) {
        out.push_str(&protocol_block(p, rows));
    }
    out.push_str(
        "| Methods | FID_k ↓ | FID_g ↓ | Dist_k ↑ | Dist_g ↑ | BeatAlign ↑ | speed ratio → 1 | accel ratio → 1 | frozen ↓ | PFC ↓ | speed ratio per 5 s |\n",
    );
    out.push_str("|---|---|---|---|---|---|---|---|---|---|---|\n");
    if let Some((_, gt)) = rows.first() {
        out.push_str(&format!(
            "| {} | - | - | {:.3} | {:.3} | {} | 1 | 1 | - | {} | - |\n",
            gt.config.reference_name,
            gt.gt_div_k,
            gt.gt_div_g,
            opt(gt.gt_beat_align, 4),
            opt(gt.gt_pfc, 3)
        ));
    }
    for (name, r) in rows {
        let e = r.motion_energy.as_ref();
        out.push_str(&format!(
            "| {name} | {:.2} | {:.2} | {:.3} | {:.3} | {} | {} | {} | {} | {} | {} |\n",
            r.fid_k,
            r.fid_g,
            r.div_k,
            r.div_g,
            opt(r.beat_align, 4),
            opt(e.map(|e| e.speed_ratio), 2),
            opt(e.map(|e| e.accel_ratio), 2),
            e.map_or_else(
                || "-".into(),
                |e| format!("{:.0} %", 100.0 * e.freeze_fraction)
            ),
            opt(r.pfc, 3),
            e.map_or_else(|| "-".into(), MotionEnergy::span_speed_ratios),
        ));
    }
    out.push('\n');
    for (name, r) in rows {
        out.push_str(&format!(
            "- {name}: {} generated vs {} reference sequences; BeatAlign = {} variant over {} sequences (GT: {}); {}\n",
            r.n_generated,
            r.n_reference,
            value_name(r.config.ba_variant),
            r.n_beat_align,
            r.n_gt_beat_align,
            r.label
        ));
    }
    for (name, r) in rows {
        let notes: Vec<String> = constant_dims_notes(r)
            .into_iter()
            .chain(drift_note(r))
            .chain(contact_note(r))
            .chain(dancing_note(r))
            .collect();
        if !notes.is_empty() {
            out.push_str(&format!("- {name}: {}\n", notes.join("; ")));
        }
        for e in &r.exploded {
            out.push_str(&format!(
                "- {name}: {} EXPLODED at frame {} ({}); every metric sees it held at its last plausible frame from there\n",
                e.name, e.frame, e.reason
            ));
        }
    }
    out.push_str(&li_block(rows));
    if let Some(reference) = rows.first().and_then(|(_, r)| r.energy_reference) {
        out.push_str(&format!(
            "- motion energy: ratios to the reference set's mean joint speed {:.3} m/s and acceleration {:.2} m/s² \
             ({} sequences); a 1-s window is frozen below {:.3} m/s (20 % of the reference's median window)\n",
            reference.speed,
            reference.accel,
            reference.sequences,
            reference.freeze_threshold()
        ));
    }
    out
}

/// A named protocol's own table (its main columns only), the settings it fixed and their sources,
/// above the full table.
fn protocol_block(p: ProtocolPreset, rows: &[(&str, &MetricsReport)]) -> String {
    let cols = p.columns();
    let mut out = format!(
        "**Protocol preset `{}`**: {}. Its main table's columns:\n\n| Methods | {} |\n|---|{}\n",
        value_name(p),
        p.title(),
        cols.iter()
            .map(|c| format!("{c} {}", arrow(c)))
            .collect::<Vec<_>>()
            .join(" | "),
        "---|".repeat(cols.len())
    );
    if let Some((_, gt)) = rows.first() {
        let cells: Vec<String> = cols.iter().map(|c| column(gt, c, true)).collect();
        out.push_str(&format!(
            "| {} | {} |\n",
            gt.config.reference_name,
            cells.join(" | ")
        ));
    }
    for (name, r) in rows {
        let cells: Vec<String> = cols.iter().map(|c| column(r, c, false)).collect();
        out.push_str(&format!("| {name} | {} |\n", cells.join(" | ")));
    }
    out.push_str("\nWhat the preset fixed (code: read in the group's code; inferred: their code is silent; deviation: where we differ, and why; docs/protocols.md has the evidence):\n\n| setting | value | source |\n|---|---|---|\n");
    for s in p.settings() {
        out.push_str(&format!(
            "| {} | {} | {} |\n",
            s.name,
            s.value,
            match s.source {
                Source::Code => "code",
                Source::Inferred => "inferred",
                Source::Deviation => "deviation",
            }
        ));
    }
    let ours = match p {
        ProtocolPreset::Bailando => "the 1,200 scored frames after the seed",
        _ => "every frame after the seed, at 60 fps",
    };
    out.push_str(&format!(
        "\nDirectory mode scores the directories it is given as the generated and reference sets; \
         checkpoint mode picks them as listed. Every metric under protocol `{}` (speed, acceleration, \
         frozen share, drift, foot contact, the dancing limits and the TSMT paper's metrics are no \
         protocol's: they describe {ours}):\n\n",
        value_name(p)
    ));
    out
}

fn arrow(column: &str) -> &'static str {
    match column {
        "FID_k" | "FID_g" | "PFC" => "↓",
        _ => "↑",
    }
}

/// One cell of a preset's table: the dances' value, or with `gt` the reference set's ("-" for FID).
fn column(r: &MetricsReport, name: &str, gt: bool) -> String {
    match (name, gt) {
        ("FID_k", false) => format!("{:.2}", r.fid_k),
        ("FID_g", false) => format!("{:.2}", r.fid_g),
        ("Dist_k", false) => format!("{:.3}", r.div_k),
        ("Dist_g", false) => format!("{:.3}", r.div_g),
        ("Dist_k", true) => format!("{:.3}", r.gt_div_k),
        ("Dist_g", true) => format!("{:.3}", r.gt_div_g),
        ("BeatAlign", false) => opt(r.beat_align, 4),
        ("BeatAlign", true) => opt(r.gt_beat_align, 4),
        ("PFC", false) => opt(r.pfc, 3),
        ("PFC", true) => opt(r.gt_pfc, 3),
        _ => "-".into(),
    }
}

/// Which feature dimensions FID and Dist left out (constant over the reference set), if any.
fn constant_dims_notes(r: &MetricsReport) -> Vec<String> {
    let dims = |d: &[usize], of: usize, what: &str| {
        (!d.is_empty()).then(|| {
            format!(
                "{what} over {} of {of} dimensions ({d:?} are constant over the reference set)",
                of - d.len()
            )
        })
    };
    let kinetic_dim = match r.config.joints {
        crate::preset::JointSet::Smpl24 => crate::kinetic::KINETIC_DIM,
        crate::preset::JointSet::Body22 => 3 * 22,
    };
    [
        dims(&r.constant_reference_dims_k, kinetic_dim, "FID_k/Dist_k"),
        dims(
            &r.constant_reference_dims_g,
            crate::geometric::GEOMETRIC_DIM,
            "FID_g/Dist_g",
        ),
    ]
    .into_iter()
    .flatten()
    .collect()
}

/// "root drift in 10 s: …" for a report that has it.
fn drift_note(r: &MetricsReport) -> Option<String> {
    let (d, g) = (r.root_drift?, r.reference_root_drift?);
    Some(format!(
        "root drift in 10 s: {:.2} m sideways, {:.2} m up or down (reference {:.2} m, {:.2} m; a glide or a \
         sink through the floor the speed ratios miss)",
        d.horizontal, d.vertical, g.horizontal, g.vertical
    ))
}

/// "feet on the floor in …" for a report that has it.
fn contact_note(r: &MetricsReport) -> Option<String> {
    let (c, g) = (r.foot_contact?, r.reference_foot_contact?);
    Some(format!(
        "feet on the floor (a foot within {:.0} cm of the first second's floor) in {:.0} % of the frames \
         (reference {:.0} %; a dance that floats or sinks)",
        100.0 * crate::motion_energy::ON_FLOOR,
        100.0 * c.share,
        100.0 * g.share
    ))
}

/// "… of … dances within the dancing limits" for a report that has it.
fn dancing_note(r: &MetricsReport) -> Option<String> {
    use crate::motion_energy::{
        MAX_ACCEL_RATIO, MAX_FREEZE_FRACTION, MAX_SPEED_RATIO, MIN_SPEED_RATIO,
    };
    let (d, g) = (r.dancing?, r.reference_dancing?);
    Some(format!(
        "{} of {} dances within the dancing limits (every 5-s span at {MIN_SPEED_RATIO}–{MAX_SPEED_RATIO}× the \
         reference's mean speed and ≤ {MAX_ACCEL_RATIO}× its acceleration, ≤ {:.0} % frozen); the reference set's \
         own sequences after the seed: {} of {}",
        d.dancing,
        d.of,
        100.0 * MAX_FREEZE_FRACTION,
        g.dancing,
        g.of
    ))
}

/// The second block: the TSMT paper's metrics (SPEC §11.9–11.11).
fn li_block(rows: &[(&str, &MetricsReport)]) -> String {
    let mut out = String::from(
        "\n| Methods (Li et al. 2020 metrics) | beat P ↑ | beat R ↑ | beat F1 ↑ | A-seq-D ↑ | I-seq-D ↑ | S-music-D ↑ | Authenticity ↑ | Coherence ↑ |\n|---|---|---|---|---|---|---|---|---|\n",
    );
    if let Some((_, gt)) = rows.first() {
        let l = &gt.li;
        out.push_str(&format!(
            "| {} | - | - | - | {:.3} | {} | - | {:.3} | {:.3} |\n",
            gt.config.reference_name,
            l.gt_a_seq_d,
            opt(l.gt_i_seq_d, 3),
            l.gt_authenticity,
            l.gt_coherence
        ));
    }
    for (name, r) in rows {
        let l = &r.li;
        out.push_str(&format!(
            "| {name} | {} | {} | {} | {:.3} | {} | {} | {:.3} | {:.3} |\n",
            opt(l.beat_precision, 3),
            opt(l.beat_recall, 3),
            opt(l.beat_f1, 3),
            l.a_seq_d,
            opt(l.i_seq_d, 3),
            opt(l.s_music_d, 3),
            l.authenticity,
            l.coherence
        ));
    }
    if let Some((_, r)) = rows.first() {
        let c = &r.config;
        out.push_str(&format!(
            "\n- Li et al. metrics: motion beats (Kim-style, σ {}) vs the same-named reference's within ±{} frames over {} sequences; \
             A-seq-D = Dist_k; I-seq-D over {}-frame chunks; S-music-D needs several rollouts per music (checkpoint mode); \
             Authenticity with {}° slack (hinge IK), Coherence below {}°/s (swing IK)\n",
            c.kim_sigma, c.beat_tol, r.li.n_beat_prf, c.chunk, c.limit_slack_deg, c.omega_max_deg_s
        ));
    }
    out
}
