//! Motion energy: does a generated dance move as much as real dance, and as smoothly? Three
//! numbers against a reference set (issue 17; FACT's best-known failure is motion that freezes
//! after the seed, its second is jitter):
//!
//! - `speed_ratio`: mean joint speed of the generated frames / that of the reference set;
//! - `accel_ratio`: the same for mean joint acceleration (above 1: jitter);
//! - `freeze_fraction`: share of 1-s windows whose mean joint speed is below 20 % of the
//!   reference set's median 1-s-window speed.
//!
//! Joint speed at t = mean over the 24 joints of |p[t+1] − p[t]|·60 (m/s); joint acceleration at
//! t = mean over joints of |p[t+1] − 2p[t] + p[t−1]|·3600 (m/s²). Set means pool every sample of
//! every sequence (a long sequence weighs more). A 1-s window is 60 consecutive speed samples
//! (frames [60k, 60k + 61)); a sequence shorter than that counts as one window of what it has.
//! The same numbers are reported per 5-s span (300 speed samples; the last span may be shorter).
//!
//! `root_drift`: how far the root (joint 0) gets in 10 s, sideways and up or down — what the speed misses
//! when a dance glides or sinks through the floor slowly (docs/control.md, "Feet on the floor").
//! `foot_contact`: the share of frames with a foot on the floor — what the speed misses when a dance
//! floats (docs/control.md: a VQ-VAE whose decoded feet hovered 5–7 cm up passed every speed check).
//! Plain f64, no Burn.

use serde::{Deserialize, Serialize};

use crate::positions::Frame;
use qean_motion::vec3::{norm, sub};

/// Frames per second of every motion here.
pub const FPS: f64 = 60.0;
/// Speed samples in one freeze window (1 s).
pub const WINDOW: usize = 60;
/// Speed samples in one profile span (5 s).
pub const SPAN: usize = 300;
/// A window is frozen below this share of the reference median window speed.
pub const FREEZE_SHARE: f64 = 0.2;

/// Frames of one root-drift window (10 s), and the stride between windows (1 s).
pub const DRIFT_WINDOW: usize = 600;
pub const DRIFT_STRIDE: usize = 60;

/// How far the root (joint 0) moves within 10 s: over every window of `DRIFT_WINDOW` + 1 frames starting
/// each `DRIFT_STRIDE` frames (a shorter sequence is one window of all its frames), the mean horizontal
/// distance and the mean height change between the window's first and last frame, m.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct RootDrift {
    pub horizontal: f64,
    pub vertical: f64,
    pub windows: usize,
}

/// The root drift of a set of sequences (every window of every sequence of at least 2 frames weighs the
/// same).
pub fn root_drift<'a>(sequences: impl IntoIterator<Item = &'a [Frame]>) -> RootDrift {
    let (mut h, mut v, mut n) = (0.0, 0.0, 0usize);
    for joints in sequences {
        if joints.len() < 2 {
            continue;
        }
        let span = DRIFT_WINDOW.min(joints.len() - 1);
        for start in (0..joints.len() - span).step_by(DRIFT_STRIDE) {
            let (a, b) = (joints[start][0], joints[start + span][0]);
            h += (b[0] - a[0]).hypot(b[2] - a[2]);
            v += (b[1] - a[1]).abs();
            n += 1;
        }
    }
    RootDrift {
        horizontal: average(h, n),
        vertical: average(v, n),
        windows: n,
    }
}

/// The foot joints (SMPL: left and right ankle, left and right foot).
pub const FOOT_JOINTS: [usize; 4] = [7, 8, 10, 11];
/// Leading frames of a sequence whose lowest foot joint is its floor (the first second).
pub const FLOOR_FRAMES: usize = 60;
/// A foot within this height of the floor (above or below) is on it, m.
pub const ON_FLOOR: f64 = 0.05;

/// How often a set's dances stand on their floor: the share of frames whose lowest foot joint is
/// within `ON_FLOOR` of the sequence's floor, the lowest foot joint over its first `FLOOR_FRAMES`
/// frames (the seed's first second for a generated dance). Floating and sinking both lower it.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct FootContact {
    pub share: f64,
    pub frames: usize,
}

fn lowest_foot(frame: &Frame) -> f64 {
    FOOT_JOINTS
        .iter()
        .map(|&j| frame[j][1])
        .fold(f64::INFINITY, f64::min)
}

/// The foot contact of a set: each item is a whole sequence (its floor taken from its first frames)
/// and the range of frames scored; frames pool over sequences.
pub fn foot_contact<'a>(
    sequences: impl IntoIterator<Item = (&'a [Frame], std::ops::Range<usize>)>,
) -> FootContact {
    let (mut on, mut n) = (0usize, 0usize);
    for (joints, scored) in sequences {
        let floor = joints[..FLOOR_FRAMES.min(joints.len())]
            .iter()
            .map(lowest_foot)
            .fold(f64::INFINITY, f64::min);
        for frame in &joints[scored] {
            on += usize::from((lowest_foot(frame) - floor).abs() <= ON_FLOOR);
            n += 1;
        }
    }
    FootContact {
        share: average(on as f64, n),
        frames: n,
    }
}

/// Mean joint speed (m/s) between consecutive frames: T − 1 values.
pub fn joint_speeds(joints: &[Frame]) -> Vec<f64> {
    joints
        .windows(2)
        .map(|w| {
            let s: f64 = (0..w[0].len()).map(|j| norm(sub(w[1][j], w[0][j]))).sum();
            s / w[0].len() as f64 * FPS
        })
        .collect()
}

/// Mean joint acceleration (m/s²) at frames 1..T−1: T − 2 values.
pub fn joint_accels(joints: &[Frame]) -> Vec<f64> {
    joints
        .windows(3)
        .map(|w| {
            let s: f64 = (0..w[0].len())
                .map(|j| {
                    let a: [f64; 3] =
                        std::array::from_fn(|k| w[2][j][k] - 2.0 * w[1][j][k] + w[0][j][k]);
                    norm(a)
                })
                .sum();
            s / w[0].len() as f64 * FPS * FPS
        })
        .collect()
}

/// Mean speed of each 1-s window of a speed series (a short series is one window).
pub fn window_speeds(speeds: &[f64]) -> Vec<f64> {
    if speeds.is_empty() {
        return Vec::new();
    }
    if speeds.len() < WINDOW {
        return vec![average(speeds.iter().sum(), speeds.len())];
    }
    speeds
        .chunks_exact(WINDOW)
        .map(|c| c.iter().sum::<f64>() / WINDOW as f64)
        .collect()
}

fn median(v: &[f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

/// What the generated motion is compared with: the reference set's pooled means and its median
/// 1-s-window speed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EnergyReference {
    /// Mean joint speed, m/s.
    pub speed: f64,
    /// Mean joint acceleration, m/s².
    pub accel: f64,
    /// Median over every 1-s window of every sequence of the window's mean speed, m/s.
    pub median_window_speed: f64,
    /// Sequences and speed samples it was computed from.
    pub sequences: usize,
    pub samples: usize,
}

impl EnergyReference {
    /// Statistics of a reference set (sequences of at least 3 frames count; others are skipped).
    pub fn fit<'a>(sequences: impl IntoIterator<Item = &'a [Frame]>) -> EnergyReference {
        let mut pooled = Acc::default();
        let mut windows = Vec::new();
        let mut n = 0;
        for joints in sequences {
            if joints.len() < 3 {
                continue;
            }
            let s = joint_speeds(joints);
            pooled.add_samples(&s, &joint_accels(joints));
            windows.extend(window_speeds(&s));
            n += 1;
        }
        EnergyReference {
            speed: pooled.speed(),
            accel: pooled.accel(),
            median_window_speed: median(&windows),
            sequences: n,
            samples: pooled.speed_n,
        }
    }

    /// The speed below which a 1-s window counts as frozen.
    pub fn freeze_threshold(&self) -> f64 {
        FREEZE_SHARE * self.median_window_speed
    }
}

/// Speed and acceleration of one 5-s span (or of a whole sequence or set).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct SpanEnergy {
    /// Seconds from the start of the evaluated segment.
    pub start_s: f64,
    pub end_s: f64,
    /// Mean joint speed (m/s) and acceleration (m/s²).
    pub speed: f64,
    pub accel: f64,
    /// Divided by the reference set's (0 when the reference does not move).
    pub speed_ratio: f64,
    pub accel_ratio: f64,
    /// Share of this span's 1-s windows below the freeze threshold.
    pub freeze_fraction: f64,
}

/// The motion energy of one sequence or of a set.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MotionEnergy {
    pub speed: f64,
    pub accel: f64,
    pub speed_ratio: f64,
    pub accel_ratio: f64,
    pub freeze_fraction: f64,
    /// 1-s windows counted, and how many were frozen.
    pub windows: usize,
    pub frozen_windows: usize,
    /// Per 5-s span from the start of the evaluated segment.
    pub spans: Vec<SpanEnergy>,
}

/// Sums that pool over sequences.
#[derive(Default, Clone)]
struct Acc {
    speed_sum: f64,
    speed_n: usize,
    accel_sum: f64,
    accel_n: usize,
    windows: usize,
    frozen: usize,
}

impl Acc {
    /// Adds the speed and acceleration samples only.
    fn add_samples(&mut self, speeds: &[f64], accels: &[f64]) {
        self.speed_sum += speeds.iter().sum::<f64>();
        self.speed_n += speeds.len();
        self.accel_sum += accels.iter().sum::<f64>();
        self.accel_n += accels.len();
    }

    /// Adds the samples and counts the 1-s windows below `threshold`.
    fn add(&mut self, speeds: &[f64], accels: &[f64], threshold: f64) {
        self.add_samples(speeds, accels);
        for w in window_speeds(speeds) {
            self.windows += 1;
            if w < threshold {
                self.frozen += 1;
            }
        }
    }

    /// Pools another's sums into this one.
    fn merge(&mut self, other: &Acc) {
        self.speed_sum += other.speed_sum;
        self.speed_n += other.speed_n;
        self.accel_sum += other.accel_sum;
        self.accel_n += other.accel_n;
        self.windows += other.windows;
        self.frozen += other.frozen;
    }

    fn speed(&self) -> f64 {
        average(self.speed_sum, self.speed_n)
    }

    fn accel(&self) -> f64 {
        average(self.accel_sum, self.accel_n)
    }

    fn freeze(&self) -> f64 {
        average(self.frozen as f64, self.windows)
    }
}

/// sum / n, or 0 for no samples.
fn average(sum: f64, n: usize) -> f64 {
    if n > 0 {
        sum / n as f64
    } else {
        0.0
    }
}

fn ratio(x: f64, reference: f64) -> f64 {
    if reference > 0.0 {
        x / reference
    } else {
        0.0
    }
}

/// Per-span sums of one sequence: span k holds speed samples [300k, 300k + 300) (sample i runs
/// from frame i to i + 1) and the accelerations at frames [300k, 300k + 300).
fn span_accs(speeds: &[f64], accels: &[f64], threshold: f64) -> Vec<Acc> {
    let n = speeds.len().div_ceil(SPAN);
    (0..n)
        .map(|k| {
            let s = &speeds[k * SPAN..((k + 1) * SPAN).min(speeds.len())];
            // accels[i] is at frame i + 1.
            let a0 = (k * SPAN).saturating_sub(1).min(accels.len());
            let a1 = if k + 1 == n {
                accels.len()
            } else {
                ((k + 1) * SPAN - 1).min(accels.len())
            };
            let mut acc = Acc::default();
            acc.add(s, &accels[a0..a1], threshold);
            acc
        })
        .collect()
}

fn finish(total: &Acc, spans: &[Acc], reference: &EnergyReference) -> MotionEnergy {
    MotionEnergy {
        speed: total.speed(),
        accel: total.accel(),
        speed_ratio: ratio(total.speed(), reference.speed),
        accel_ratio: ratio(total.accel(), reference.accel),
        freeze_fraction: total.freeze(),
        windows: total.windows,
        frozen_windows: total.frozen,
        spans: spans
            .iter()
            .enumerate()
            .map(|(k, a)| SpanEnergy {
                start_s: (k * SPAN) as f64 / FPS,
                end_s: (k * SPAN + a.speed_n) as f64 / FPS,
                speed: a.speed(),
                accel: a.accel(),
                speed_ratio: ratio(a.speed(), reference.speed),
                accel_ratio: ratio(a.accel(), reference.accel),
                freeze_fraction: a.freeze(),
            })
            .collect(),
    }
}

/// The motion energy of each sequence and of the set (samples pooled; span k of the set pools
/// span k of every sequence that reaches it).
pub fn motion_energy<'a>(
    generated: impl IntoIterator<Item = &'a [Frame]>,
    reference: &EnergyReference,
) -> (Vec<MotionEnergy>, MotionEnergy) {
    let threshold = reference.freeze_threshold();
    let mut per_sequence = Vec::new();
    let mut total = Acc::default();
    let mut set_spans: Vec<Acc> = Vec::new();
    for joints in generated {
        let s = joint_speeds(joints);
        let a = joint_accels(joints);
        let mut own = Acc::default();
        own.add(&s, &a, threshold);
        let spans = span_accs(&s, &a, threshold);
        for (k, sp) in spans.iter().enumerate() {
            if set_spans.len() <= k {
                set_spans.push(Acc::default());
            }
            set_spans[k].merge(sp);
        }
        total.merge(&own);
        per_sequence.push(finish(&own, &spans, reference));
    }
    let mut set = finish(&total, &set_spans, reference);
    // A set span's end is the longest sequence's, not the sum of the sequences' samples.
    for (k, span) in set.spans.iter_mut().enumerate() {
        let longest = per_sequence
            .iter()
            .filter_map(|e| e.spans.get(k))
            .map(|s| s.end_s)
            .fold(span.start_s, f64::max);
        span.end_s = longest;
    }
    (per_sequence, set)
}

/// How many dances of a set are within the dancing limits ([`MotionEnergy::dances`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct DancingCount {
    pub dancing: usize,
    pub of: usize,
}

impl DancingCount {
    pub fn of(energies: &[MotionEnergy]) -> DancingCount {
        DancingCount {
            dancing: energies.iter().filter(|e| e.dances()).count(),
            of: energies.len(),
        }
    }
}

/// Whether a dance froze or jitters, by the thresholds `qean sample` and the demo warn at.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Verdict {
    /// More than 10 % of the 1-s windows frozen, or a 5-s span below 0.6 × the reference speed.
    pub froze: bool,
    /// Mean acceleration above 2 × the reference's in the whole or in a 5-s span.
    pub jitters: bool,
}

/// Limits of a dancing dance (issue 17's targets): every 5-s span between 0.6 and 1.6 × the
/// reference speed with at most 2 × its acceleration, and at most 10 % frozen windows.
pub const MIN_SPEED_RATIO: f64 = 0.6;
pub const MAX_SPEED_RATIO: f64 = 1.6;
pub const MAX_ACCEL_RATIO: f64 = 2.0;
pub const MAX_FREEZE_FRACTION: f64 = 0.1;

impl MotionEnergy {
    pub fn verdict(&self) -> Verdict {
        let froze = self.freeze_fraction > MAX_FREEZE_FRACTION
            || self.spans.iter().any(|s| s.speed_ratio < MIN_SPEED_RATIO);
        let jitters = self.accel_ratio > MAX_ACCEL_RATIO
            || self.spans.iter().any(|s| s.accel_ratio > MAX_ACCEL_RATIO);
        Verdict { froze, jitters }
    }

    /// Every 5-s span inside the dancing limits and the freeze fraction at most 10 %.
    pub fn dances(&self) -> bool {
        self.freeze_fraction <= MAX_FREEZE_FRACTION
            && !self.spans.is_empty()
            && self.spans.iter().all(|s| {
                (MIN_SPEED_RATIO..=MAX_SPEED_RATIO).contains(&s.speed_ratio)
                    && s.accel_ratio <= MAX_ACCEL_RATIO
            })
    }

    /// "0.93/0.88/0.91/0.95" style list of the span speed ratios.
    pub fn span_speed_ratios(&self) -> String {
        self.spans
            .iter()
            .map(|s| format!("{:.2}", s.speed_ratio))
            .collect::<Vec<_>>()
            .join("/")
    }

    /// The same for the acceleration ratios.
    pub fn span_accel_ratios(&self) -> String {
        self.spans
            .iter()
            .map(|s| format!("{:.2}", s.accel_ratio))
            .collect::<Vec<_>>()
            .join("/")
    }

    /// "dances", "FROZE", "JITTERS", "FROZE and JITTERS", or "too fast" (a 5-s span above
    /// 1.6 × the reference speed with neither failure).
    pub fn verdict_word(&self) -> &'static str {
        if self.dances() {
            return "dances";
        }
        let v = self.verdict();
        match (v.froze, v.jitters) {
            (true, true) => "FROZE and JITTERS",
            (true, false) => "FROZE",
            (false, true) => "JITTERS",
            (false, false) => "too fast",
        }
    }

    /// What is wrong with the dance, a sentence each (none when it dances): froze, too fast, jitters.
    pub fn warnings(&self, reference: &EnergyReference) -> Vec<String> {
        let v = self.verdict();
        let mut out = Vec::new();
        if v.froze {
            out.push(format!(
                "the dance froze (speed ratio per 5 s {}, {:.0} % of 1-s windows below {:.3} m/s)",
                self.span_speed_ratios(),
                100.0 * self.freeze_fraction,
                reference.freeze_threshold()
            ));
        }
        if !self.dances() && !v.froze && !v.jitters {
            out.push(format!(
                "the dance moves too fast (speed ratio per 5 s {}, above 1.6 in a span)",
                self.span_speed_ratios()
            ));
        }
        if v.jitters {
            out.push(format!(
                "the dance jitters (acceleration ratio per 5 s {}, reference {:.2} m/s²)",
                self.span_accel_ratios(),
                reference.accel
            ));
        }
        out
    }

    /// One line a person reads: speed per 5-s span, acceleration, frozen share, and the verdict.
    pub fn describe(&self, reference: &EnergyReference) -> String {
        let spans: Vec<String> = self
            .spans
            .iter()
            .map(|s| format!("{:.2}", s.speed))
            .collect();
        let verdict = self.verdict_word();
        format!(
            "speed per 5 s {} m/s (reference {:.2}; ratio {:.2}), acceleration {:.1} m/s² (ratio {:.2}), \
             {:.0} % of 1-s windows frozen: {verdict}",
            spans.join(", "),
            reference.speed,
            self.speed_ratio,
            self.accel,
            self.accel_ratio,
            100.0 * self.freeze_fraction
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every joint at x = f(t), y = z = 0.
    fn line(frames: usize, f: impl Fn(usize) -> f64) -> Vec<Frame> {
        (0..frames).map(|t| [[f(t), 0.0, 0.0]; 24]).collect()
    }

    /// A dance-like reference: each joint on its own circle, speeds varying per sequence.
    fn reference_set() -> Vec<Vec<Frame>> {
        (0..5)
            .map(|k| {
                (0..400 + 37 * k)
                    .map(|t| {
                        std::array::from_fn(|j| {
                            let w = 0.05 + 0.01 * j as f64 + 0.002 * k as f64;
                            let r = 0.1 + 0.02 * (j % 5) as f64;
                            let a = w * t as f64 + j as f64;
                            [r * a.cos(), 1.0 + 0.1 * (0.5 * a).sin(), r * a.sin()]
                        })
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn a_constant_sequence_has_speed_ratio_zero_and_is_all_frozen() {
        let refs = reference_set();
        let reference = EnergyReference::fit(refs.iter().map(Vec::as_slice));
        assert!(reference.speed > 0.0 && reference.accel > 0.0);
        let still = vec![[[0.3, 0.9, -0.2]; 24]; 700];
        let (per, set) = motion_energy([still.as_slice()], &reference);
        assert_eq!(set.speed_ratio, 0.0);
        assert_eq!(set.accel_ratio, 0.0);
        assert_eq!(set.freeze_fraction, 1.0);
        assert_eq!(set.windows, 11);
        assert_eq!(per[0], set);
        let v = set.verdict();
        assert!(v.froze && !v.jitters && !set.dances());
    }

    #[test]
    fn the_reference_against_itself_is_one_one_zero() {
        let refs = reference_set();
        let reference = EnergyReference::fit(refs.iter().map(Vec::as_slice));
        let (_, set) = motion_energy(refs.iter().map(Vec::as_slice), &reference);
        assert!((set.speed_ratio - 1.0).abs() < 1e-12, "{}", set.speed_ratio);
        assert!((set.accel_ratio - 1.0).abs() < 1e-12, "{}", set.accel_ratio);
        assert_eq!(set.freeze_fraction, 0.0);
        assert_eq!(
            reference.samples,
            refs.iter().map(|r| r.len() - 1).sum::<usize>()
        );
        assert_eq!(reference.sequences, 5);
    }

    #[test]
    fn five_second_profile_of_a_hand_built_sequence() {
        // 0–5 s still, 5–10 s at 0.5 m/s, 10–12.5 s at 2 m/s: every joint moves along x.
        let v = |t: usize| -> f64 {
            match t {
                0..300 => 0.0,
                300..600 => 0.5,
                _ => 2.0,
            }
        };
        let mut x = vec![0.0];
        for t in 0..749 {
            let last = *x.last().unwrap();
            x.push(last + v(t) / FPS);
        }
        let joints = line(750, |t| x[t]);
        let speeds = joint_speeds(&joints);
        assert_eq!(speeds.len(), 749);
        assert!((speeds[10]).abs() < 1e-12 && (speeds[400] - 0.5).abs() < 1e-12);
        // Reference: 1 m/s constant speed, so ratios are speeds and the threshold is 0.2 m/s.
        let reference = EnergyReference {
            speed: 1.0,
            accel: 10.0,
            median_window_speed: 1.0,
            sequences: 1,
            samples: 1000,
        };
        let (_, e) = motion_energy([joints.as_slice()], &reference);
        assert_eq!(e.spans.len(), 3);
        let sp: Vec<f64> = e.spans.iter().map(|s| s.speed).collect();
        assert!(sp[0].abs() < 1e-12 && (sp[1] - 0.5).abs() < 1e-12 && (sp[2] - 2.0).abs() < 1e-12);
        assert_eq!((e.spans[2].start_s, e.spans[2].end_s), (10.0, 749.0 / 60.0));
        // Acceleration: only at the two speed changes, frame 300 (span 1: 0.5 m/s in one frame)
        // and frame 600 (span 2: 1.5 m/s); spans hold 299, 300 and 149 acceleration samples.
        let dv1 = 0.5 * FPS;
        let dv2 = 1.5 * FPS;
        assert!((e.spans[0].accel).abs() < 1e-9);
        assert!(
            (e.spans[1].accel - dv1 / 300.0).abs() < 1e-9,
            "{}",
            e.spans[1].accel
        );
        assert!(
            (e.spans[2].accel - dv2 / 149.0).abs() < 1e-9,
            "{}",
            e.spans[2].accel
        );
        assert!((e.accel - (dv1 + dv2) / 748.0).abs() < 1e-9);
        // Windows: 12 complete 1-s windows; the first 5 are still (frozen below 0.2 m/s).
        assert_eq!(e.windows, 12);
        assert_eq!(e.frozen_windows, 5);
        assert_eq!(e.spans[0].freeze_fraction, 1.0);
        assert_eq!(e.spans[1].freeze_fraction, 0.0);
        let mean_speed = (300.0 * 0.5 + 149.0 * 2.0) / 749.0;
        assert!((e.speed - mean_speed).abs() < 1e-12);
        assert!(e.verdict().froze);
    }

    #[test]
    fn jitter_is_reported() {
        // A sway with ±1 cm frame-to-frame noise added: the acceleration explodes, the speed less.
        let sway = |t: usize| 0.2 * (std::f64::consts::TAU * t as f64 / FPS).sin();
        let clean = line(600, sway);
        let noisy = line(600, |t| sway(t) + if t % 2 == 0 { 0.01 } else { -0.01 });
        let reference = EnergyReference::fit([clean.as_slice()]);
        let (_, e) = motion_energy([noisy.as_slice()], &reference);
        assert!(e.verdict().jitters);
        assert!(e.accel_ratio > 2.0);
    }

    #[test]
    fn root_drift_sees_a_glide_and_a_sink_but_not_a_sway() {
        // 20 s: swaying ±5 cm at 1 Hz in place; gliding 6 cm/s sideways; sinking 4 cm/s.
        let frames = 1200;
        let sway = |t: usize| 0.05 * (t as f64 / 60.0 * std::f64::consts::TAU).sin();
        let seq = |f: &dyn Fn(usize) -> [f64; 3]| -> Vec<Frame> {
            (0..frames).map(|t| [f(t); 24]).collect()
        };
        let still = root_drift([seq(&|t| [sway(t), 1.0, 0.0]).as_slice()]);
        assert!(
            still.horizontal < 1e-9 && still.vertical < 1e-9,
            "{still:?}"
        );
        assert_eq!(still.windows, 10);
        let glide = root_drift([seq(&|t| [sway(t), 1.0, 0.001 * t as f64]).as_slice()]);
        assert!((glide.horizontal - 0.6).abs() < 1e-9, "{glide:?}");
        let sink = root_drift([seq(&|t| [0.0, 1.0 - 0.04 * t as f64 / 60.0, 0.0]).as_slice()]);
        assert!(
            (sink.vertical - 0.4).abs() < 1e-9 && sink.horizontal == 0.0,
            "{sink:?}"
        );
        // A 5-s sequence is one window of all its frames.
        let short = root_drift([seq(&|t| [0.001 * t as f64, 1.0, 0.0])[..300].as_ref()]);
        assert_eq!(short.windows, 1);
        assert!((short.horizontal - 0.299).abs() < 1e-9);
    }

    #[test]
    fn foot_contact_sees_floating_and_sinking_but_not_stepping() {
        // 10 s after a 1-s seed standing at height 0: feet stepping (one foot lifts 20 cm at a time);
        // the whole body floating 6 cm up every other half second; sinking 2 cm/s.
        let frames = 660;
        let body = |t: usize, lift: f64, drop: f64| -> Frame {
            let mut f = [[0.0, 1.0 - drop, 0.0]; 24];
            for (k, &j) in FOOT_JOINTS.iter().enumerate() {
                let up = if (t / 30) % 2 == k % 2 && t >= 60 {
                    0.2
                } else {
                    0.0
                };
                f[j] = [0.0, up + lift - drop, 0.0];
            }
            f
        };
        let seq = |f: &dyn Fn(usize) -> Frame| -> Vec<Frame> { (0..frames).map(f).collect() };
        let stepping = seq(&|t| body(t, 0.0, 0.0));
        let floating = seq(&|t| {
            body(
                t,
                if t >= 60 && (t / 30) % 2 == 0 {
                    0.06
                } else {
                    0.0
                },
                0.0,
            )
        });
        let sinking = seq(&|t| body(t, 0.0, 0.02 * t.saturating_sub(60) as f64 / 60.0));
        let score = |s: &Vec<Frame>| foot_contact([(s.as_slice(), 60..frames)]);
        assert_eq!(score(&stepping).share, 1.0);
        assert_eq!(score(&stepping).frames, 600);
        assert_eq!(score(&floating).share, 0.5);
        // On the floor for the first 2.5 s (within 5 cm), then under it.
        let sunk = score(&sinking).share;
        assert!((sunk - 151.0 / 600.0).abs() < 1e-12, "{sunk}");
    }
}
