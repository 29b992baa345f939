//! Geometric ("manual") features, 32-D (SPEC §7.3), after Bailando `utils/features/manual_new.py`
//! (= aist-api `features/manual.py` after 091f00b) and the predicates of `features/utils.py`.
//! Each feature is a per-frame Boolean over frames 1..T−1; the output is its mean.

use crate::config::{GeometricVariant, MetricsMode};
use crate::error::{Error, Result};
use crate::positions::{Frame, N_JOINTS};
use qean_motion::vec3::{cross, dot, norm, sub};

pub const GEOMETRIC_DIM: usize = 32;
pub const MIN_FRAMES: usize = 2;

/// Joint names in SMPL order, as `manual_new.py` lists them.
pub const SMPL_NAMES: [&str; N_JOINTS] = [
    "root",
    "lhip",
    "rhip",
    "belly",
    "lknee",
    "rknee",
    "spine",
    "lankle",
    "rankle",
    "chest",
    "ltoes",
    "rtoes",
    "neck",
    "linshoulder",
    "rinshoulder",
    "head",
    "lshoulder",
    "rshoulder",
    "lelbow",
    "relbow",
    "lwrist",
    "rwrist",
    "lhand",
    "rhand",
];

/// The fairmotion order that aist-api used before 091f00b, mapped to SMPL indices 0..21: the bug.
pub const LEGACY_NAMES: [&str; 22] = [
    "root",
    "lhip",
    "lknee",
    "lankle",
    "ltoes",
    "rhip",
    "rknee",
    "rankle",
    "rtoes",
    "belly",
    "spine",
    "chest",
    "neck",
    "head",
    "linshoulder",
    "lshoulder",
    "lelbow",
    "lwrist",
    "rinshoulder",
    "rshoulder",
    "relbow",
    "rwrist",
];

/// Rest SMPL-male joints hard-coded in `manual_new.py` for the body constants (the same values come
/// out of the SPEC §3.3 rest pose; tested): lshoulder, lelbow, rshoulder, lhip, rhip.
pub const REST_LSHOULDER: [f64; 3] = [1.99113488e-01, 2.36807942e-01, -1.80702247e-02];
pub const REST_LELBOW: [f64; 3] = [4.54445392e-01, 2.21158922e-01, -4.10167128e-02];
pub const REST_RSHOULDER: [f64; 3] = [-1.91692337e-01, 2.36928746e-01, -1.23055102e-02];
pub const REST_LHIP: [f64; 3] = [5.64076714e-02, -3.23069185e-01, 1.09197125e-02];
pub const REST_RHIP: [f64; 3] = [-6.24834076e-02, -3.31302464e-01, 1.50412619e-02];

/// The mis-named rest joints behind the legacy constants, as Bailando `utils/features/manual.py` keeps
/// them: "lshoulder" is SMPL joint 15 (head), "lelbow" joint 16, "rshoulder" joint 19, "rhip" joint 5.
pub const LEGACY_REST_LSHOULDER: [f64; 3] = [0.00121265, 0.37817603, 0.03681623];
pub const LEGACY_REST_LELBOW: [f64; 3] = [0.19911349, 0.23680794, -0.01807022];
pub const LEGACY_REST_RSHOULDER: [f64; 3] = [-0.45181984, 0.2225595, -0.04357424];
pub const LEGACY_REST_LHIP: [f64; 3] = [0.05640767, -0.32306919, 0.01091971];
pub const LEGACY_REST_RHIP: [f64; 3] = [-0.10574003, -0.7149903, 0.01019822];

/// Humerus length, shoulder width and hip width: the thresholds' units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyConstants {
    pub hl: f64,
    pub sw: f64,
    pub hw: f64,
}

impl BodyConstants {
    pub fn of(variant: GeometricVariant) -> Self {
        let (ls, le, rs, lh, rh) = match variant {
            GeometricVariant::ManualNew => (
                REST_LSHOULDER,
                REST_LELBOW,
                REST_RSHOULDER,
                REST_LHIP,
                REST_RHIP,
            ),
            GeometricVariant::LegacyFairmotion => (
                LEGACY_REST_LSHOULDER,
                LEGACY_REST_LELBOW,
                LEGACY_REST_RSHOULDER,
                LEGACY_REST_LHIP,
                LEGACY_REST_RHIP,
            ),
        };
        BodyConstants {
            hl: norm(sub(ls, le)),
            sw: norm(sub(ls, rs)),
            hw: norm(sub(lh, rh)),
        }
    }
}

/// `time_per_frame=1/120` in the reference although AIST++ is 60 FPS; `corrected` uses 1/60.
pub fn time_step(mode: MetricsMode) -> f64 {
    time_step_at(mode, 60.0)
}

/// [`time_step`] for motion at `fps`: the reference keeps 1/120 whatever the rate (Lodge's code too).
pub fn time_step_at(mode: MetricsMode, fps: f64) -> f64 {
    match mode {
        MetricsMode::Reference => 1.0 / 120.0,
        MetricsMode::Corrected => 1.0 / fps,
    }
}

/// A point a predicate reads: a joint or one of the reference's virtual points.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Point {
    Joint(usize),
    YUnit,
    MinusYUnit,
    Zero,
    /// (0, min_j y_j(t), 0) over all 24 joints of the current frame.
    YMin,
}

/// The six predicates of `features/utils.py`, with SPEC §7.3's argument names.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Predicate {
    /// Velocity of c relative to a, along b − a (`f_move`'s fourth joint is unused).
    Move {
        a: usize,
        b: usize,
        c: usize,
        th: f64,
    },
    /// Velocity of d relative to a, along the normal (c − a) × (b − a).
    NMove {
        a: usize,
        b: usize,
        c: usize,
        d: usize,
        th: f64,
    },
    /// Signed distance of q from the plane through a, b, c.
    Plane {
        a: Point,
        b: Point,
        c: Point,
        q: Point,
        th: f64,
    },
    /// Distance of q from the plane through c with normal b − a.
    NPlane {
        a: Point,
        b: Point,
        c: Point,
        q: Point,
        th: f64,
    },
    /// Angle in degrees between b − a and d − c, strictly inside (lo, hi).
    Angle {
        a: Point,
        b: Point,
        c: Point,
        d: Point,
        lo: f64,
        hi: f64,
    },
    /// Speed of a.
    Fast { a: usize, th: f64 },
}

/// The 32 predicates in the reference's order, joints resolved for `variant`.
pub fn feature_table(variant: GeometricVariant) -> Vec<Predicate> {
    let k = BodyConstants::of(variant);
    let names: &[&str] = match variant {
        GeometricVariant::ManualNew => &SMPL_NAMES,
        GeometricVariant::LegacyFairmotion => &LEGACY_NAMES,
    };
    let j = |n: &str| {
        names
            .iter()
            .position(|m| *m == n)
            .expect("every feature joint is in both name lists")
    };
    let pt = |n: &str| match n {
        "y_unit" => Point::YUnit,
        "minus_y_unit" => Point::MinusYUnit,
        "zero" => Point::Zero,
        "y_min" => Point::YMin,
        _ => Point::Joint(j(n)),
    };
    // f_move passes its third joint as the moving point and ignores the fourth (a reference quirk:
    // features 5-6 measure the chest, not the wrists).
    let mv = |a, b, c, _d: &str, th| Predicate::Move {
        a: j(a),
        b: j(b),
        c: j(c),
        th,
    };
    let nmv = |a, b, c, d, th| Predicate::NMove {
        a: j(a),
        b: j(b),
        c: j(c),
        d: j(d),
        th,
    };
    let pl = |a, b, c, q, th| Predicate::Plane {
        a: pt(a),
        b: pt(b),
        c: pt(c),
        q: pt(q),
        th,
    };
    let npl = |a, b, c, q, th| Predicate::NPlane {
        a: pt(a),
        b: pt(b),
        c: pt(c),
        q: pt(q),
        th,
    };
    let ang = |a, b, c, d, lo, hi| Predicate::Angle {
        a: pt(a),
        b: pt(b),
        c: pt(c),
        d: pt(d),
        lo,
        hi,
    };
    let fast = |a, th| Predicate::Fast { a: j(a), th };
    let (hl, sw, hw) = (k.hl, k.sw, k.hw);
    vec![
        nmv("neck", "rhip", "lhip", "rwrist", 1.8 * hl),
        nmv("neck", "lhip", "rhip", "lwrist", 1.8 * hl),
        npl("chest", "neck", "neck", "rwrist", 0.2 * hl),
        npl("chest", "neck", "neck", "lwrist", 0.2 * hl),
        mv("belly", "chest", "chest", "rwrist", 1.8 * hl),
        mv("belly", "chest", "chest", "lwrist", 1.8 * hl),
        ang("relbow", "rshoulder", "relbow", "rwrist", 0.0, 110.0),
        ang("lelbow", "lshoulder", "lelbow", "lwrist", 0.0, 110.0),
        npl("lshoulder", "rshoulder", "lwrist", "rwrist", 2.5 * sw),
        mv("lwrist", "rwrist", "rwrist", "lwrist", 1.4 * hl),
        mv("rwrist", "root", "lwrist", "root", 1.4 * hl),
        mv("lwrist", "root", "rwrist", "root", 1.4 * hl),
        fast("rwrist", 2.5 * hl),
        fast("lwrist", 2.5 * hl),
        pl("root", "lhip", "ltoes", "rankle", 0.38 * hl),
        pl("root", "rhip", "rtoes", "lankle", 0.38 * hl),
        npl("zero", "y_unit", "y_min", "rankle", 1.2 * hl),
        npl("zero", "y_unit", "y_min", "lankle", 1.2 * hl),
        npl("lhip", "rhip", "lankle", "rankle", 2.1 * hw),
        ang("rknee", "rhip", "rknee", "rankle", 0.0, 110.0),
        ang("lknee", "lhip", "lknee", "lankle", 0.0, 110.0),
        fast("rankle", 2.5 * hl),
        fast("lankle", 2.5 * hl),
        ang("neck", "root", "rshoulder", "relbow", 25.0, 180.0),
        ang("neck", "root", "lshoulder", "lelbow", 25.0, 180.0),
        ang("neck", "root", "rhip", "rknee", 50.0, 180.0),
        ang("neck", "root", "lhip", "lknee", 50.0, 180.0),
        pl("rankle", "neck", "lankle", "root", 0.5 * hl),
        ang("neck", "root", "zero", "y_unit", 70.0, 110.0),
        npl("zero", "minus_y_unit", "y_min", "rwrist", -1.2 * hl),
        npl("zero", "minus_y_unit", "y_min", "lwrist", -1.2 * hl),
        fast("root", 2.3 * hl),
    ]
}

/// The 32 feature means over frames 1..T−1.
pub fn geometric_features(
    joints: &[Frame],
    variant: GeometricVariant,
    mode: MetricsMode,
) -> Result<Vec<f64>> {
    geometric_features_at(joints, variant, mode, 60.0)
}

/// [`geometric_features`] of motion at `fps` (it sets the corrected mode's time step).
pub fn geometric_features_at(
    joints: &[Frame],
    variant: GeometricVariant,
    mode: MetricsMode,
    fps: f64,
) -> Result<Vec<f64>> {
    let t = joints.len();
    if t < MIN_FRAMES {
        return Err(Error::Invalid(format!(
            "geometric features need at least {MIN_FRAMES} frames, got {t}"
        )));
    }
    let table = feature_table(variant);
    let tau = time_step_at(mode, fps);
    let mut counts = [0usize; GEOMETRIC_DIM];
    for f in 1..t {
        let (cur, prev) = (&joints[f], &joints[f - 1]);
        for (count, pred) in counts.iter_mut().zip(&table) {
            if evaluate(pred, cur, prev, tau) {
                *count += 1;
            }
        }
    }
    let n = (t - 1) as f64;
    Ok(counts.iter().map(|&c| c as f64 / n).collect())
}

/// One predicate on one frame. Written like the reference, so a zero-length direction gives 0/0 = NaN
/// and every comparison with NaN is false, as in numpy.
pub fn evaluate(pred: &Predicate, cur: &Frame, prev: &Frame, tau: f64) -> bool {
    let at = |p: Point| -> [f64; 3] {
        match p {
            Point::Joint(i) => cur[i],
            Point::YUnit => [0.0, 1.0, 0.0],
            Point::MinusYUnit => [0.0, -1.0, 0.0],
            Point::Zero => [0.0; 3],
            Point::YMin => [
                0.0,
                cur.iter().map(|q| q[1]).fold(f64::INFINITY, f64::min),
                0.0,
            ],
        }
    };
    match *pred {
        Predicate::Move { a, b, c, th } => {
            let vel = sub(sub(cur[c], cur[a]), sub(prev[c], prev[a]));
            let dir = sub(cur[b], cur[a]);
            dot(vel, dir) / norm(dir) / tau > th
        }
        Predicate::NMove { a, b, c, d, th } => {
            let vel = sub(sub(cur[d], cur[a]), sub(prev[d], prev[a]));
            let n = cross(sub(cur[c], cur[a]), sub(cur[b], cur[a]));
            dot(vel, n) / norm(n) / tau > th
        }
        Predicate::Plane { a, b, c, q, th } => {
            let pa = at(a);
            let n = cross(sub(at(c), pa), sub(at(b), pa));
            dot(n, sub(at(q), pa)) / norm(n) > th
        }
        Predicate::NPlane { a, b, c, q, th } => {
            let n = sub(at(b), at(a));
            dot(n, sub(at(q), at(c))) / norm(n) > th
        }
        Predicate::Angle { a, b, c, d, lo, hi } => {
            let u = sub(at(b), at(a));
            let v = sub(at(d), at(c));
            let angle = (dot(u, v) / (norm(u) * norm(v))).acos().to_degrees();
            angle > lo && angle < hi
        }
        Predicate::Fast { a, th } => norm(sub(cur[a], prev[a])) / tau > th,
    }
}
