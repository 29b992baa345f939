//! BeatAlign (SPEC §7.5): how well motion beats (local minima of joint speed) meet music beats.
//!
//! Two reference formulas that are not interchangeable:
//! - Bailando `utils/beat_align_score.py`: mean joint speed smoothed by scipy `gaussian_filter(σ=5)`,
//!   order-1 minima, score averaged over **music** beats;
//! - mint PR-41 `tools/calculate_beat_scores.py`: summed joint speed, unsmoothed, minima against ±10
//!   neighbours, score averaged over **motion** beats.
//!
//! Beat lists are frame indices (60 FPS) in the coordinates of the motion passed in.

use serde::{Deserialize, Serialize};

use crate::config::BaSegment;
use crate::positions::Frame;

/// `gaussian_filter(kinetic_vel, 5)` in Bailando.
pub const BAILANDO_SIGMA: f64 = 5.0;
/// `argrelextrema(..., order=10)  # 10 for 60FPS` in mint.
pub const MINT_ORDER: usize = 10;
/// Both scores use exp(−d²/(2·3²)).
pub const SCORE_SIGMA: f64 = 3.0;

/// Both variants' scores for one sequence; `None` when the sequence has no music beats in range
/// (the reference would divide by zero or fail; SPEC §7.5 excludes and logs it).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct BeatScores {
    pub bailando: Option<f64>,
    pub mint: Option<f64>,
}

/// scipy.ndimage `gaussian_filter1d(x, sigma)` with its defaults: truncate 4 (radius
/// ⌊4σ + 0.5⌋), normalised weights, "reflect" boundary (d c b a | a b c d | d c b a).
pub fn gaussian_filter1d(x: &[f64], sigma: f64) -> Vec<f64> {
    let n = x.len();
    if n == 0 {
        return Vec::new();
    }
    let radius = (4.0 * sigma + 0.5) as isize;
    let mut w: Vec<f64> = (-radius..=radius)
        .map(|u| (-0.5 * (u * u) as f64 / (sigma * sigma)).exp())
        .collect();
    let s: f64 = w.iter().sum();
    w.iter_mut().for_each(|v| *v /= s);
    let period = 2 * n as isize;
    let reflect = |i: isize| {
        let m = i.rem_euclid(period);
        (if m < n as isize { m } else { period - 1 - m }) as usize
    };
    (0..n as isize)
        .map(|i| {
            if i >= radius && i + radius < n as isize {
                let window = &x[(i - radius) as usize..=(i + radius) as usize];
                w.iter().zip(window).map(|(wu, xu)| wu * xu).sum()
            } else {
                w.iter()
                    .zip(-radius..=radius)
                    .map(|(wu, u)| wu * x[reflect(i + u)])
                    .sum()
            }
        })
        .collect()
}

/// scipy.signal `argrelextrema(x, np.less, order)` with mode "clip": `x[i]` strictly below every
/// neighbour within `order`, out-of-range neighbours clipped to the end value (so the ends never
/// qualify).
pub fn local_minima(x: &[f64], order: usize) -> Vec<usize> {
    let n = x.len();
    (0..n)
        .filter(|&i| {
            (1..=order).all(|s| x[i] < x[(i + s).min(n - 1)] && x[i] < x[i.saturating_sub(s)])
        })
        .collect()
}

fn speed(a: &[f64; 3], b: &[f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Bailando `calc_db`: `v[t]` = mean over joints of `|p[t+1] − p[t]|`, t < T−1, smoothed; minima.
/// Returns (motion beats, length of v).
pub fn motion_beats_bailando(joints: &[Frame]) -> (Vec<usize>, usize) {
    let v: Vec<f64> = joints
        .windows(2)
        .map(|w| {
            w[1].iter()
                .zip(&w[0])
                .map(|(a, b)| speed(a, b))
                .sum::<f64>()
                / w[0].len() as f64
        })
        .collect();
    let smooth = gaussian_filter1d(&v, BAILANDO_SIGMA);
    (local_minima(&smooth, 1), v.len())
}

/// mint `motion_peak_onehot`: `v[0] = 0`, `e[t] = Σ_joints |p[t] − p[t−1]|`, unsmoothed; ±10 minima.
pub fn motion_beats_mint(joints: &[Frame]) -> Vec<usize> {
    let mut e = vec![0.0; joints.len()];
    for t in 1..joints.len() {
        e[t] = joints[t]
            .iter()
            .zip(&joints[t - 1])
            .map(|(a, b)| speed(a, b))
            .sum();
    }
    local_minima(&e, MINT_ORDER)
}

fn gauss(d: f64) -> f64 {
    (-d * d / (2.0 * SCORE_SIGMA * SCORE_SIGMA)).exp()
}

fn nearest(targets: &[usize], x: usize) -> f64 {
    targets
        .iter()
        .map(|&t| t.abs_diff(x))
        .min()
        .expect("callers check for emptiness") as f64
}

/// Bailando `BA`: mean over music beats of exp(−min_m (m − b)²/18); 0 with no motion beats (the
/// reference fails there); `None` with no music beats.
pub fn score_bailando(music_beats: &[usize], motion_beats: &[usize]) -> Option<f64> {
    if music_beats.is_empty() {
        return None;
    }
    if motion_beats.is_empty() {
        return Some(0.0);
    }
    let total: f64 = music_beats
        .iter()
        .map(|&b| gauss(nearest(motion_beats, b)))
        .sum();
    Some(total / music_beats.len() as f64)
}

/// mint `alignment_score`: mean over motion beats of exp(−min_b (b − m)²/18); 0 with no motion
/// beats; `None` with no music beats.
pub fn score_mint(music_beats: &[usize], motion_beats: &[usize]) -> Option<f64> {
    if music_beats.is_empty() {
        return None;
    }
    if motion_beats.is_empty() {
        return Some(0.0);
    }
    let total: f64 = motion_beats
        .iter()
        .map(|&m| gauss(nearest(music_beats, m)))
        .sum();
    Some(total / motion_beats.len() as f64)
}

/// Scores of a generated sequence `joints` = seed (`seed` frames) ++ generated (`len` frames, after
/// any cut), with `music_beats` already in this sequence's frame coordinates.
///
/// - Bailando, `Generated`: the generated frames against the music beats in [seed, seed + len),
///   shifted by −seed (and, as `get_mb(length=T−1)` does, below len − 1).
/// - Bailando, `Full`: all frames against the music beats below seed + len − 1.
/// - mint, `Generated`: minima of the whole envelope, then motion and music beats sliced at `seed`
///   (`[120:]`); the music is not cut at the motion's end.
/// - mint, `Full`: nothing sliced, the music not cut.
pub fn score_generated(
    joints: &[Frame],
    seed: usize,
    len: usize,
    music_beats: &[usize],
    segment: BaSegment,
) -> BeatScores {
    let all = &joints[..(seed + len).min(joints.len())];
    let from = match segment {
        BaSegment::Generated => seed.min(all.len()),
        BaSegment::Full => 0,
    };
    let (db, vlen) = motion_beats_bailando(&all[from..]);
    let music_b: Vec<usize> = music_beats
        .iter()
        .filter(|&&b| b >= from && b - from < vlen)
        .map(|&b| b - from)
        .collect();
    let dm: Vec<usize> = motion_beats_mint(all)
        .into_iter()
        .filter(|&m| m >= from)
        .map(|m| m - from)
        .collect();
    let music_m: Vec<usize> = music_beats
        .iter()
        .filter(|&&b| b >= from)
        .map(|&b| b - from)
        .collect();
    BeatScores {
        bailando: score_bailando(&music_b, &db),
        mint: score_mint(&music_m, &dm),
    }
}

/// Scores of a GT sequence with its own music: full length, music from frame 0, cut below T − 1
/// (Bailando `get_mb(length=T−1)`) or T (mint `audio_feature[:T]`).
pub fn score_ground_truth(joints: &[Frame], music_beats: &[usize]) -> BeatScores {
    let t = joints.len();
    let (db, vlen) = motion_beats_bailando(joints);
    let music_b: Vec<usize> = music_beats.iter().copied().filter(|&b| b < vlen).collect();
    let music_m: Vec<usize> = music_beats.iter().copied().filter(|&b| b < t).collect();
    BeatScores {
        bailando: score_bailando(&music_b, &db),
        mint: score_mint(&music_m, &motion_beats_mint(joints)),
    }
}
