//! Cubic Bézier in-betweening (SPEC §12.4b, Lin eq. 2.7): one cubic per key pair and D_euler channel,
//! C(s) = Σ P_i·B_i³(s) with s uniform in time, P0 and P3 the key values. The two free control points are
//! parameterised by θ = (θ1, θ2) so that an average θ learnt on training dances transfers to new ones.

use crate::euler::{euler_to_matrix, motion_to_euler, EulerOrder};
use qean_motion::rotation::matrix_to_axis_angle;
use qean_motion::Motion;
use serde::{Deserialize, Serialize};

/// How θ sets the inner control points P1, P2 (Δ = P3 − P0).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum BezierParam {
    /// P1 = P0 + θ1, P2 = P3 + θ2: θ = (Δ/3, −Δ/3) is the straight line, θ = 0 smoothstep.
    #[default]
    Handles,
    /// P1 = P0 + θ1·Δ, P2 = P0 + θ2·Δ: (⅓, ⅔) is the straight line.
    Chord,
    /// θ = (P1, P2) themselves (what Lin's rows look like).
    Absolute,
}

/// How the training average of θ weighs the fitted pairs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum BezierAverage {
    #[default]
    Plain,
    /// Weighted by Δ², which `chord` needs on flat spans.
    Delta2,
}

fn bernstein(s: f64) -> [f64; 4] {
    let r = 1.0 - s;
    [r * r * r, 3.0 * s * r * r, 3.0 * s * s * r, s * s * s]
}

/// The curve as base(s) + θ1·f1(s) + θ2·f2(s): returns (base, f1, f2).
fn terms(p0: f64, p3: f64, s: f64, param: BezierParam) -> (f64, f64, f64) {
    let b = bernstein(s);
    let delta = p3 - p0;
    match param {
        BezierParam::Handles => (p0 * (b[0] + b[1]) + p3 * (b[2] + b[3]), b[1], b[2]),
        BezierParam::Chord => (
            p0 * (b[0] + b[1] + b[2]) + p3 * b[3],
            delta * b[1],
            delta * b[2],
        ),
        BezierParam::Absolute => (p0 * b[0] + p3 * b[3], b[1], b[2]),
    }
}

/// C(s) for key values p0, p3.
pub fn curve(p0: f64, p3: f64, theta: [f64; 2], s: f64, param: BezierParam) -> f64 {
    let (base, f1, f2) = terms(p0, p3, s, param);
    base + theta[0] * f1 + theta[1] * f2
}

/// The θ that draws the straight line from p0 to p3.
pub fn linear_theta(p0: f64, p3: f64, param: BezierParam) -> [f64; 2] {
    let delta = p3 - p0;
    match param {
        BezierParam::Handles => [delta / 3.0, -delta / 3.0],
        BezierParam::Chord => [1.0 / 3.0, 2.0 / 3.0],
        BezierParam::Absolute => [p0 + delta / 3.0, p0 + 2.0 * delta / 3.0],
    }
}

/// Least-squares θ for one channel (`x` indexed by frame) between keys t1 < t2: the residual is linear in θ,
/// so Levenberg–Marquardt's answer is the 2 × 2 normal equations' solution. `None` when fewer than 2
/// interior frames (or a flat `chord` span) leave θ undetermined.
pub fn fit_pair(x: &[f64], t1: usize, t2: usize, param: BezierParam) -> Option<[f64; 2]> {
    if t2 < t1 + 3 {
        return None;
    }
    let (p0, p3) = (x[t1], x[t2]);
    let span = (t2 - t1) as f64;
    let (mut a11, mut a12, mut a22, mut r1, mut r2) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (t, &xt) in x.iter().enumerate().take(t2).skip(t1 + 1) {
        let (base, f1, f2) = terms(p0, p3, (t - t1) as f64 / span, param);
        let y = xt - base;
        a11 += f1 * f1;
        a12 += f1 * f2;
        a22 += f2 * f2;
        r1 += f1 * y;
        r2 += f2 * y;
    }
    let det = a11 * a22 - a12 * a12;
    if det.is_nan() || det.abs() <= 1e-12 * (a11 * a22).max(f64::MIN_POSITIVE) {
        return None;
    }
    Some([(a22 * r1 - a12 * r2) / det, (a11 * r2 - a12 * r1) / det])
}

/// Sum of squared residuals of θ over the interior of [t1, t2].
pub fn sse(x: &[f64], t1: usize, t2: usize, theta: [f64; 2], param: BezierParam) -> f64 {
    let span = (t2 - t1) as f64;
    (t1 + 1..t2)
        .map(|t| (curve(x[t1], x[t2], theta, (t - t1) as f64 / span, param) - x[t]).powi(2))
        .sum()
}

/// The 75 D_euler channels of a motion, each as its own time series.
fn channels(motion: &Motion, order: EulerOrder, unwrap: bool) -> Vec<Vec<f64>> {
    let x = motion_to_euler(motion, order, unwrap);
    (0..75)
        .map(|c| x.chunks_exact(75).map(|row| row[c]).collect())
        .collect()
}

/// Settings shared by fitting and drawing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BezierSettings {
    pub param: BezierParam,
    pub average: BezierAverage,
    pub order: EulerOrder,
    pub unwrap: bool,
}

impl Default for BezierSettings {
    fn default() -> Self {
        BezierSettings {
            param: BezierParam::Handles,
            average: BezierAverage::Plain,
            order: EulerOrder::XYZ,
            unwrap: true,
        }
    }
}

/// The training average of θ per channel (Lin: fit every training segment, apply the mean to the test).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeanTheta {
    /// Per channel: Σ w·θ1, Σ w·θ2, Σ w.
    sums: Vec<[f64; 3]>,
}

impl Default for MeanTheta {
    fn default() -> Self {
        MeanTheta {
            sums: vec![[0.0; 3]; 75],
        }
    }
}

impl MeanTheta {
    /// Fit every key pair of one training motion and add its θ (pairs with an undetermined fit are left out).
    pub fn add(&mut self, motion: &Motion, keys: &[usize], settings: &BezierSettings) {
        for (c, x) in channels(motion, settings.order, settings.unwrap)
            .iter()
            .enumerate()
        {
            for w in keys.windows(2) {
                if let Some(theta) = fit_pair(x, w[0], w[1], settings.param) {
                    let weight = match settings.average {
                        BezierAverage::Plain => 1.0,
                        BezierAverage::Delta2 => (x[w[1]] - x[w[0]]).powi(2),
                    };
                    let s = &mut self.sums[c];
                    s[0] += weight * theta[0];
                    s[1] += weight * theta[1];
                    s[2] += weight;
                }
            }
        }
    }

    /// The mean θ of channel c, or `None` when nothing was fitted there.
    pub fn theta(&self, c: usize) -> Option<[f64; 2]> {
        let s = self.sums[c];
        (s[2] > 0.0).then(|| [s[0] / s[2], s[1] / s[2]])
    }
}

/// A training mean θ on disk (`bezier_<strategy>_N<n>.json`, written by `qean eval --task inbetween`, read
/// by `qean edit --method bezier --theta`): the settings it was fitted under and θ per D_euler channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ThetaFile {
    /// Always "qean-bezier-theta".
    pub format: String,
    pub version: u32,
    /// The keyframe strategy of the training pairs ("even", "dp", …) and keys per measure.
    pub strategy: String,
    pub n: usize,
    pub param: BezierParam,
    pub average: BezierAverage,
    pub euler_order: EulerOrder,
    pub euler_unwrap: bool,
    /// Training dances the mean was taken over.
    pub sequences: usize,
    /// θ = (θ1, θ2) of each of the 75 channels (72 Euler angles, then the translation), or null where no
    /// training pair fixed it (such channels draw straight lines).
    pub theta: Vec<Option<[f64; 2]>>,
}

impl ThetaFile {
    pub const FORMAT: &'static str = "qean-bezier-theta";

    pub fn new(
        mean: &MeanTheta,
        settings: &BezierSettings,
        strategy: &str,
        n: usize,
        sequences: usize,
    ) -> Self {
        ThetaFile {
            format: Self::FORMAT.into(),
            version: 1,
            strategy: strategy.into(),
            n,
            param: settings.param,
            average: settings.average,
            euler_order: settings.order,
            euler_unwrap: settings.unwrap,
            sequences,
            theta: (0..75).map(|c| mean.theta(c)).collect(),
        }
    }

    /// The mean θ for drawing under `settings`, or why this file does not fit them (another
    /// parameterisation, Euler order or unwrapping gives θ another meaning).
    pub fn mean_for(&self, settings: &BezierSettings) -> Result<MeanTheta, String> {
        if self.format != Self::FORMAT || self.version != 1 {
            return Err(format!(
                "not a Bézier θ file (format '{}' version {}; expected '{}' version 1)",
                self.format,
                self.version,
                Self::FORMAT
            ));
        }
        if self.theta.len() != 75 {
            return Err(format!(
                "theta has {} channels; expected 75 (24 Euler triples + translation)",
                self.theta.len()
            ));
        }
        if let Some(c) = self
            .theta
            .iter()
            .position(|t| t.is_some_and(|t| !t.iter().all(|v| v.is_finite())))
        {
            return Err(format!("theta of channel {c} is not finite"));
        }
        let checks = [
            (
                "inbetween.bezier_param",
                serde_name(&self.param),
                serde_name(&settings.param),
            ),
            (
                "keyframes.euler_order",
                serde_name(&self.euler_order),
                serde_name(&settings.order),
            ),
            (
                "keyframes.euler_unwrap",
                self.euler_unwrap.to_string(),
                settings.unwrap.to_string(),
            ),
        ];
        if let Some((key, file, now)) = checks.into_iter().find(|(_, a, b)| a != b) {
            return Err(format!(
                "fitted with {key} = {file} but this edit uses {now}; pass --set {key}={file} or refit"
            ));
        }
        let sums = self
            .theta
            .iter()
            .map(|t| t.map_or([0.0; 3], |t| [t[0], t[1], 1.0]))
            .collect();
        Ok(MeanTheta { sums })
    }
}

/// How a setting's value is written in TOML / `--set`.
fn serde_name<T: Serialize>(v: &T) -> String {
    match serde_json::to_value(v) {
        Ok(serde_json::Value::String(s)) => s,
        other => format!("{other:?}"),
    }
}

/// Where each pair's θ comes from.
pub enum ThetaSource<'a> {
    /// The training mean (channels without one draw straight lines).
    Mean(&'a MeanTheta),
    /// A fit on the motion itself (Lin's DP protocol, "following Roberts").
    FitEach,
}

/// Rebuild the frames between keys with Bézier curves per D_euler channel. Keys are copied exactly; frames
/// outside the first and last key hold them.
pub fn inbetween(
    motion: &Motion,
    keys: &[usize],
    source: ThetaSource,
    settings: &BezierSettings,
) -> Motion {
    assert!(!keys.is_empty() && keys.windows(2).all(|w| w[0] < w[1]));
    // Keys exact and the frames outside them held; every interior frame is drawn below.
    let mut out = crate::slerp::inbetween(motion, keys);
    let chans = channels(motion, settings.order, settings.unwrap);
    let mut row = [0.0; 75];
    for w in keys.windows(2) {
        let (t1, t2) = (w[0], w[1]);
        let thetas: Vec<[f64; 2]> = chans
            .iter()
            .enumerate()
            .map(|(c, x)| {
                let fitted = match &source {
                    ThetaSource::Mean(mean) => mean.theta(c),
                    ThetaSource::FitEach => fit_pair(x, t1, t2, settings.param),
                };
                fitted.unwrap_or_else(|| linear_theta(x[t1], x[t2], settings.param))
            })
            .collect();
        for t in t1 + 1..t2 {
            let s = (t - t1) as f64 / (t2 - t1) as f64;
            for (c, x) in chans.iter().enumerate() {
                row[c] = curve(x[t1], x[t2], thetas[c], s, settings.param);
            }
            for j in 0..24 {
                let m =
                    euler_to_matrix([row[3 * j], row[3 * j + 1], row[3 * j + 2]], settings.order);
                out.poses[t * 72 + 3 * j..t * 72 + 3 * j + 3]
                    .copy_from_slice(&matrix_to_axis_angle(&m));
            }
            for a in 0..3 {
                out.trans[t * 3 + a] = row[72 + a] * motion.scaling;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn wiggly(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let (a, b, c) = (
            rng.random_range(-1.0..1.0),
            rng.random_range(1.0..4.0),
            rng.random_range(0.0..3.0),
        );
        (0..n)
            .map(|t| a + (b * t as f64 / n as f64 + c).sin() + 0.05 * rng.random_range(-1.0..1.0))
            .collect()
    }

    #[test]
    fn linear_theta_is_the_straight_line_and_zero_handles_smoothstep() {
        for param in [
            BezierParam::Handles,
            BezierParam::Chord,
            BezierParam::Absolute,
        ] {
            let th = linear_theta(0.3, -1.1, param);
            for i in 0..=20 {
                let s = i as f64 / 20.0;
                let want = 0.3 + s * (-1.1 - 0.3);
                assert!(
                    (curve(0.3, -1.1, th, s, param) - want).abs() < 1e-14,
                    "{param:?}"
                );
            }
        }
        for i in 0..=20 {
            let s = i as f64 / 20.0;
            let smooth = 3.0 * s * s - 2.0 * s * s * s;
            assert!(
                (curve(1.0, 3.0, [0.0, 0.0], s, BezierParam::Handles) - (1.0 + 2.0 * smooth)).abs()
                    < 1e-14
            );
        }
    }

    #[test]
    fn fit_beats_the_line_and_reproduces_a_cubic() {
        for seed in 0..20 {
            let x = wiggly(40, seed);
            for param in [
                BezierParam::Handles,
                BezierParam::Chord,
                BezierParam::Absolute,
            ] {
                let th = fit_pair(&x, 5, 31, param).unwrap();
                let lin = linear_theta(x[5], x[31], param);
                assert!(sse(&x, 5, 31, th, param) <= sse(&x, 5, 31, lin, param) + 1e-15);
            }
        }
        // A curve drawn from θ is fitted back exactly.
        let th = [0.7, -0.2];
        let x: Vec<f64> = (0..=12)
            .map(|t| curve(1.0, 2.0, th, t as f64 / 12.0, BezierParam::Handles))
            .collect();
        let back = fit_pair(&x, 0, 12, BezierParam::Handles).unwrap();
        assert!((back[0] - 0.7).abs() < 1e-12 && (back[1] + 0.2).abs() < 1e-12);
        // Fewer than 2 interior frames: undetermined.
        assert!(fit_pair(&x, 0, 2, BezierParam::Handles).is_none());
        // A flat chord span: undetermined.
        assert!(fit_pair(&[1.0, 2.0, 0.0, 1.0], 0, 3, BezierParam::Chord).is_none());
    }
}
