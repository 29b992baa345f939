//! Procedural dances phase-locked to a beat grid. Each 8-beat phrase performs the move that the phrase's chord
//! selects (a genre vocabulary, permuted per choreography), so the music determines the dance; every move is
//! built from periodic joint rotations whose extremes (zero velocity) fall on the beats, so kinematic beats
//! line up with musical beats. Angles are clamped to per-joint limits.

use rand::Rng;
use rand_chacha::ChaCha8Rng;

use crate::music::BEATS_PER_PHRASE;
use qean_motion::motion::{Motion, FPS};
use qean_motion::rotation::{axis_angle_to_matrix, matmul, matrix_to_axis_angle, Mat3};
use qean_motion::skeleton::{rest_joints, NUM_JOINTS, SMPL_MALE_PELVIS};

// Joint indices (SMPL order).
const PELVIS: usize = 0;
const L_HIP: usize = 1;
const R_HIP: usize = 2;
const SPINE1: usize = 3;
const L_KNEE: usize = 4;
const R_KNEE: usize = 5;
const SPINE2: usize = 6;
const L_ANKLE: usize = 7;
const R_ANKLE: usize = 8;
const SPINE3: usize = 9;
const NECK: usize = 12;
const HEAD: usize = 15;
const L_SHOULDER: usize = 16;
const R_SHOULDER: usize = 17;
const L_ELBOW: usize = 18;
const R_ELBOW: usize = 19;
const L_WRIST: usize = 20;
const R_WRIST: usize = 21;

const X: usize = 0;
const Y: usize = 1;
const Z: usize = 2;

/// Joint limits in degrees, [joint][axis] = (min, max). Joints not listed get ±30°.
fn limits() -> [[(f64, f64); 3]; NUM_JOINTS] {
    let mut l = [[(-30.0, 30.0); 3]; NUM_JOINTS];
    l[PELVIS] = [(-40.0, 40.0), (-60.0, 60.0), (-30.0, 30.0)];
    l[L_KNEE] = [(0.0, 140.0), (-5.0, 5.0), (-5.0, 5.0)];
    l[R_KNEE] = [(0.0, 140.0), (-5.0, 5.0), (-5.0, 5.0)];
    l[L_HIP] = [(-110.0, 30.0), (-40.0, 40.0), (-15.0, 60.0)];
    l[R_HIP] = [(-110.0, 30.0), (-40.0, 40.0), (-60.0, 15.0)];
    l[L_ANKLE] = [(-40.0, 40.0), (-15.0, 15.0), (-15.0, 15.0)];
    l[R_ANKLE] = [(-40.0, 40.0), (-15.0, 15.0), (-15.0, 15.0)];
    l[L_ELBOW] = [(-10.0, 10.0), (-145.0, 0.0), (-10.0, 10.0)];
    l[R_ELBOW] = [(-10.0, 10.0), (0.0, 145.0), (-10.0, 10.0)];
    l[L_SHOULDER] = [(-60.0, 60.0), (-90.0, 90.0), (-90.0, 80.0)];
    l[R_SHOULDER] = [(-60.0, 60.0), (-90.0, 90.0), (-80.0, 90.0)];
    for j in [SPINE1, SPINE2, SPINE3] {
        l[j] = [(-25.0, 25.0), (-30.0, 30.0), (-20.0, 20.0)];
    }
    for j in [NECK, HEAD] {
        l[j] = [(-35.0, 35.0), (-45.0, 45.0), (-25.0, 25.0)];
    }
    l
}

/// Relaxed standing pose (degrees): arms down, slight knee and elbow bend.
fn neutral_pose() -> [[f64; 3]; NUM_JOINTS] {
    let mut p = [[0.0; 3]; NUM_JOINTS];
    p[L_SHOULDER][Z] = -65.0;
    p[R_SHOULDER][Z] = 65.0;
    p[L_ELBOW][Y] = -15.0;
    p[R_ELBOW][Y] = 15.0;
    p[L_KNEE][X] = 5.0;
    p[R_KNEE][X] = 5.0;
    p[L_HIP][X] = -3.0;
    p[R_HIP][X] = -3.0;
    p
}

/// The shape of one oscillation over one period, as a function of the phase x ∈ [0, 1).
#[derive(Debug, Clone, Copy)]
enum Shape {
    /// (1 + cos 2πx)/2: 1 on the beat, smooth.
    Cos,
    /// ((1 + cos 2πx)/2)³: a sharp hit on the beat.
    Pulse,
}

impl Shape {
    fn eval(self, x: f64) -> f64 {
        let c = 0.5 * (1.0 + (2.0 * std::f64::consts::PI * x).cos());
        match self {
            Shape::Cos => c,
            Shape::Pulse => c * c * c,
        }
    }
}

/// One oscillating degree of freedom: angle += amp · shape(beat/period + phase).
#[derive(Debug, Clone, Copy)]
struct Osc {
    joint: usize,
    axis: usize,
    amp: f64,
    period: f64,
    phase: f64,
    shape: Shape,
}

const fn osc(joint: usize, axis: usize, amp: f64, period: f64, phase: f64, shape: Shape) -> Osc {
    Osc {
        joint,
        axis,
        amp,
        period,
        phase,
        shape,
    }
}

/// A move: joint oscillations plus root motion.
#[derive(Debug, Clone)]
struct Move {
    oscs: Vec<Osc>,
    /// Side step: root x amplitude (m) with a period of 4 beats.
    sway: f64,
    /// Yaw turned per phrase (degrees).
    turn: f64,
}

/// Knee bend with hip and ankle compensation so the feet stay under the hips.
fn bounce(amp: f64, period: f64) -> Vec<Osc> {
    vec![
        osc(L_KNEE, X, amp, period, 0.0, Shape::Cos),
        osc(R_KNEE, X, amp, period, 0.0, Shape::Cos),
        osc(L_HIP, X, -amp / 2.0, period, 0.0, Shape::Cos),
        osc(R_HIP, X, -amp / 2.0, period, 0.0, Shape::Cos),
        osc(L_ANKLE, X, -amp / 2.0, period, 0.0, Shape::Cos),
        osc(R_ANKLE, X, -amp / 2.0, period, 0.0, Shape::Cos),
    ]
}

/// The move library. Periods are 1, 2 or 4 beats with phases 0 or ½, so every extreme lands on a beat.
fn library(k: usize) -> Move {
    use Shape::*;
    let mut oscs = Vec::new();
    let (mut sway, mut turn) = (0.0, 0.0);
    match k {
        // bounce + head nod
        0 => {
            oscs.extend(bounce(25.0, 1.0));
            oscs.push(osc(SPINE2, X, 6.0, 1.0, 0.0, Cos));
            oscs.push(osc(NECK, X, 12.0, 1.0, 0.0, Cos));
            oscs.push(osc(L_ELBOW, Y, -30.0, 1.0, 0.0, Cos));
            oscs.push(osc(R_ELBOW, Y, 30.0, 1.0, 0.0, Cos));
        }
        // arm pump: arms forward/back alternately, elbows hit on the beat
        1 => {
            oscs.extend(bounce(12.0, 1.0));
            oscs.push(osc(L_SHOULDER, Y, -50.0, 2.0, 0.0, Cos));
            oscs.push(osc(R_SHOULDER, Y, 50.0, 2.0, 0.5, Cos));
            oscs.push(osc(L_ELBOW, Y, -70.0, 1.0, 0.0, Pulse));
            oscs.push(osc(R_ELBOW, Y, 70.0, 1.0, 0.0, Pulse));
        }
        // side step with hip sway
        2 => {
            oscs.extend(bounce(10.0, 1.0));
            oscs.push(osc(L_HIP, Z, 18.0, 4.0, 0.0, Cos));
            oscs.push(osc(R_HIP, Z, -18.0, 4.0, 0.5, Cos));
            oscs.push(osc(SPINE1, Z, 8.0, 4.0, 0.0, Cos));
            oscs.push(osc(L_SHOULDER, Z, 25.0, 4.0, 0.0, Cos));
            oscs.push(osc(R_SHOULDER, Z, -25.0, 4.0, 0.5, Cos));
            sway = 0.15;
        }
        // twist: torso against pelvis
        3 => {
            oscs.extend(bounce(15.0, 1.0));
            oscs.push(osc(SPINE2, Y, 25.0, 2.0, 0.0, Cos));
            oscs.push(osc(PELVIS, Y, -15.0, 2.0, 0.0, Cos));
            oscs.push(osc(L_ELBOW, Y, -60.0, 2.0, 0.5, Cos));
            oscs.push(osc(R_ELBOW, Y, 60.0, 2.0, 0.0, Cos));
        }
        // arm wave, left and right half a period apart
        4 => {
            oscs.push(osc(L_SHOULDER, Z, 70.0, 2.0, 0.0, Cos));
            oscs.push(osc(R_SHOULDER, Z, -70.0, 2.0, 0.5, Cos));
            oscs.push(osc(L_ELBOW, Y, -50.0, 1.0, 0.5, Cos));
            oscs.push(osc(R_ELBOW, Y, 50.0, 1.0, 0.0, Cos));
            oscs.push(osc(HEAD, Z, 12.0, 2.0, 0.0, Cos));
            oscs.extend(bounce(8.0, 2.0));
        }
        // kicks, alternating legs every two beats
        5 => {
            oscs.push(osc(L_HIP, X, -60.0, 4.0, 0.0, Pulse));
            oscs.push(osc(L_KNEE, X, 30.0, 4.0, 0.0, Pulse));
            oscs.push(osc(R_HIP, X, -60.0, 4.0, 0.5, Pulse));
            oscs.push(osc(R_KNEE, X, 30.0, 4.0, 0.5, Pulse));
            oscs.push(osc(L_SHOULDER, Y, 30.0, 4.0, 0.0, Cos));
            oscs.push(osc(R_SHOULDER, Y, -30.0, 4.0, 0.5, Cos));
        }
        // arms raised overhead and down
        6 => {
            oscs.push(osc(L_SHOULDER, Z, 130.0, 4.0, 0.0, Cos));
            oscs.push(osc(R_SHOULDER, Z, -130.0, 4.0, 0.0, Cos));
            oscs.push(osc(L_ELBOW, Y, -40.0, 2.0, 0.5, Cos));
            oscs.push(osc(R_ELBOW, Y, 40.0, 2.0, 0.5, Cos));
            oscs.push(osc(SPINE3, X, -10.0, 4.0, 0.0, Cos));
            oscs.extend(bounce(15.0, 2.0));
        }
        // turn: a quarter turn per phrase while bouncing
        7 => {
            oscs.extend(bounce(18.0, 1.0));
            oscs.push(osc(L_SHOULDER, Z, 40.0, 2.0, 0.0, Cos));
            oscs.push(osc(R_SHOULDER, Z, -40.0, 2.0, 0.0, Cos));
            turn = 90.0;
        }
        // forward lean and recover
        8 => {
            oscs.push(osc(SPINE1, X, 20.0, 2.0, 0.0, Cos));
            oscs.push(osc(SPINE2, X, 15.0, 2.0, 0.0, Cos));
            oscs.extend(bounce(30.0, 2.0));
            oscs.push(osc(L_SHOULDER, Y, -40.0, 2.0, 0.0, Cos));
            oscs.push(osc(R_SHOULDER, Y, 40.0, 2.0, 0.0, Cos));
            oscs.push(osc(L_ELBOW, Y, -80.0, 2.0, 0.0, Pulse));
            oscs.push(osc(R_ELBOW, Y, 80.0, 2.0, 0.0, Pulse));
        }
        // popping: sharp hits of chest, shoulders, neck and wrists on every beat
        _ => {
            oscs.push(osc(SPINE3, X, -10.0, 1.0, 0.0, Pulse));
            oscs.push(osc(L_SHOULDER, Z, 20.0, 1.0, 0.0, Pulse));
            oscs.push(osc(R_SHOULDER, Z, -20.0, 1.0, 0.0, Pulse));
            oscs.push(osc(NECK, Y, 20.0, 2.0, 0.0, Pulse));
            oscs.push(osc(L_WRIST, Z, 30.0, 1.0, 0.0, Pulse));
            oscs.push(osc(R_WRIST, Z, -30.0, 1.0, 0.0, Pulse));
            oscs.push(osc(L_ELBOW, Y, -40.0, 2.0, 0.5, Pulse));
            oscs.push(osc(R_ELBOW, Y, 40.0, 2.0, 0.0, Pulse));
            oscs.extend(bounce(10.0, 1.0));
        }
    }
    Move { oscs, sway, turn }
}

/// A genre's move vocabulary (indices into the library, one per chord) and energy.
pub fn genre_style(genre: &str) -> ([usize; 4], f64) {
    match genre {
        "BR" => ([0, 5, 7, 3], 1.2),
        "PO" => ([9, 1, 4, 0], 1.0),
        "LO" => ([1, 6, 2, 9], 1.0),
        "MH" => ([0, 1, 3, 2], 1.0),
        "LH" => ([2, 0, 4, 3], 1.1),
        "HO" => ([0, 2, 5, 7], 1.0),
        "WA" => ([4, 6, 1, 9], 1.1),
        "KR" => ([8, 1, 3, 0], 1.3),
        "JS" => ([2, 7, 6, 4], 0.9),
        _ => ([6, 5, 7, 2], 0.9),
    }
}

/// A genre's posture: degrees added to the neutral pose, held through the whole dance whatever the move.
/// Real AIST++ genres differ this way while sharing many steps — krump's deep stance with the fists up,
/// waacking's raised arms, ballet jazz's extended arms. Without it the synthetic genres are only a choice
/// among shared moves, and the genre classifier reaches 0.40–0.60 on them; with it 0.85–0.95. A posture
/// moves nothing by itself, but a model that hears no genre must guess one from the music, and the demo's
/// tiny models dance worse for it (docs/control.md): opt-in, `qean synth --genre-postures`.
fn genre_posture(genre: &str) -> Vec<(usize, usize, f64)> {
    match genre {
        // break: low stance
        "BR" => vec![
            (L_KNEE, X, 35.0),
            (R_KNEE, X, 35.0),
            (L_HIP, X, -30.0),
            (R_HIP, X, -30.0),
            (SPINE1, X, 12.0),
        ],
        // pop: arms in front, elbows up
        "PO" => vec![
            (L_ELBOW, Y, -60.0),
            (R_ELBOW, Y, 60.0),
            (L_SHOULDER, Y, -40.0),
            (R_SHOULDER, Y, 40.0),
        ],
        // lock: arms out to the sides, elbows bent
        "LO" => vec![
            (L_SHOULDER, Z, 45.0),
            (R_SHOULDER, Z, -45.0),
            (L_ELBOW, Y, -85.0),
            (R_ELBOW, Y, 85.0),
        ],
        // middle hip-hop: soft knees, chest forward
        "MH" => vec![(L_KNEE, X, 15.0), (R_KNEE, X, 15.0), (SPINE2, X, 8.0)],
        // LA hip-hop: a forward lean
        "LH" => vec![(SPINE1, X, 15.0), (SPINE2, X, 8.0)],
        // house: bent knees
        "HO" => vec![
            (L_KNEE, X, 20.0),
            (R_KNEE, X, 20.0),
            (L_HIP, X, -12.0),
            (R_HIP, X, -12.0),
        ],
        // waack: arms raised high
        "WA" => vec![(L_SHOULDER, Z, 110.0), (R_SHOULDER, Z, -110.0)],
        // krump: deep stance, chest forward, fists up
        "KR" => vec![
            (L_KNEE, X, 30.0),
            (R_KNEE, X, 30.0),
            (L_HIP, X, -20.0),
            (R_HIP, X, -20.0),
            (SPINE2, X, 15.0),
            (L_ELBOW, Y, -95.0),
            (R_ELBOW, Y, 95.0),
        ],
        // street jazz: chest lifted, arms a little out and forward
        "JS" => vec![
            (SPINE2, X, -10.0),
            (SPINE3, X, -8.0),
            (L_SHOULDER, Z, 20.0),
            (R_SHOULDER, Z, -20.0),
            (L_SHOULDER, Y, -20.0),
            (R_SHOULDER, Y, 20.0),
        ],
        // ballet jazz: upright, arms extended forward and out
        _ => vec![
            (L_SHOULDER, Z, 40.0),
            (R_SHOULDER, Z, -40.0),
            (L_SHOULDER, Y, -35.0),
            (R_SHOULDER, Y, 35.0),
            (L_ELBOW, Y, 15.0),
            (R_ELBOW, Y, -15.0),
            (NECK, X, -8.0),
        ],
    }
}

/// What a dance follows: the beat grid and the chord of each phrase.
#[derive(Debug, Clone)]
pub struct BeatGrid {
    /// Beat times in seconds, increasing.
    pub beat_times: Vec<f64>,
    /// Chord label of each phrase of [`BEATS_PER_PHRASE`] beats (cycled).
    pub phrase_chords: Vec<usize>,
}

impl BeatGrid {
    /// The musical position (in beats) of time `t`: piecewise linear between beats, extrapolated at the ends.
    pub fn beat_position(&self, t: f64) -> f64 {
        let b = &self.beat_times;
        match b.len() {
            0 => 0.0,
            1 => t - b[0],
            n => {
                let i = b.partition_point(|&x| x <= t);
                let (lo, hi) = if i == 0 {
                    (0, 1)
                } else if i >= n {
                    (n - 2, n - 1)
                } else {
                    (i - 1, i)
                };
                lo as f64 + (t - b[lo]) / (b[hi] - b[lo])
            }
        }
    }

    fn chord_of_phrase(&self, phrase: i64) -> usize {
        let n = self.phrase_chords.len().max(1) as i64;
        self.phrase_chords
            .get(phrase.rem_euclid(n) as usize)
            .copied()
            .unwrap_or(0)
    }
}

/// Per-sequence variation: who dances and which choreography.
#[derive(Debug, Clone)]
pub struct DanceStyle {
    pub genre: String,
    /// Permutes the chord → move mapping.
    pub choreo: usize,
    /// Amplitude scale of this dancer.
    pub energy: f64,
    /// Smooth per-dancer pose offsets and drift.
    pub seed: u64,
    /// `smpl_scaling` to store (AIST++ translations are scaled; consumers divide).
    pub scaling: f64,
    /// Hold the genre's posture ([`genre_posture`]).
    pub posture: bool,
}

/// One dancer's own pose, before the moves: the neutral pose with the genre's posture and small offsets,
/// a low-frequency wobble of the upper body, a starting yaw and a slow drift.
struct Dancer {
    base: [[f64; 3]; NUM_JOINTS],
    /// (joint, axis, amplitude in degrees, frequency in Hz, phase).
    wobble: Vec<(usize, usize, f64, f64, f64)>,
    yaw0: f64,
    drift: [f64; 2],
}

/// Draws a [`Dancer`] from `rng` (in a fixed order: the data stay the same for the same seed).
fn dancer(style: &DanceStyle, rng: &mut ChaCha8Rng) -> Dancer {
    let mut base = neutral_pose();
    let posture = if style.posture {
        genre_posture(&style.genre)
    } else {
        Vec::new()
    };
    for &(j, a, deg) in &posture {
        base[j][a] += deg;
    }
    for j in [
        SPINE1, SPINE2, NECK, L_SHOULDER, R_SHOULDER, L_ELBOW, R_ELBOW,
    ] {
        for v in base[j].iter_mut() {
            *v += rng.random_range(-4.0..4.0);
        }
    }
    // Low-frequency wobble (two sines per degree of freedom of the upper body), a few degrees.
    let wobble: Vec<(usize, usize, f64, f64, f64)> = [SPINE2, NECK, HEAD, L_SHOULDER, R_SHOULDER]
        .iter()
        .flat_map(|&j| (0..3).map(move |a| (j, a)))
        .map(|(j, a)| {
            (
                j,
                a,
                rng.random_range(1.0..3.0),
                rng.random_range(0.1..0.6),
                rng.random_range(0.0..std::f64::consts::TAU),
            )
        })
        .collect();
    let yaw0: f64 = rng.random_range(-10.0..10.0);
    let drift = [rng.random_range(-0.1..0.1), rng.random_range(-0.1..0.1)];
    Dancer {
        base,
        wobble,
        yaw0,
        drift,
    }
}

/// Generate `frames` frames of dance at 60 fps following `grid`.
pub fn generate(grid: &BeatGrid, style: &DanceStyle, frames: usize) -> Motion {
    use rand::SeedableRng;
    let mut rng = ChaCha8Rng::seed_from_u64(style.seed);
    let (vocab, genre_energy) = genre_style(&style.genre);
    let energy = genre_energy * style.energy;
    let moves: Vec<Move> = (0..4)
        .map(|c| library(vocab[(c + style.choreo) % 4]))
        .collect();
    let lim = limits();
    let Dancer {
        base,
        wobble,
        yaw0,
        drift,
    } = dancer(style, &mut rng);

    // Standing height: pelvis above the lowest rest joint, plus a sole.
    let rest = rest_joints([0.0; 3]);
    let lowest = rest.iter().map(|p| p[1]).fold(f64::MAX, f64::min);
    let pelvis_height = -lowest + 0.05;
    let leg = 0.82;

    let mut poses = Vec::with_capacity(frames * 72);
    let mut trans = Vec::with_capacity(frames * 3);
    let mut yaw_acc = 0.0;
    let mut last_phrase = i64::MIN;
    for f in 0..frames {
        let t = f as f64 / FPS;
        let beat = grid.beat_position(t);
        let phrase = (beat / BEATS_PER_PHRASE as f64).floor() as i64;
        if phrase != last_phrase {
            if last_phrase != i64::MIN {
                yaw_acc += moves[grid.chord_of_phrase(last_phrase)].turn;
            }
            last_phrase = phrase;
        }
        let cur = &moves[grid.chord_of_phrase(phrase)];
        let prev = &moves[grid.chord_of_phrase(phrase - 1)];
        // Cross-fade over the first half beat of a phrase.
        let into = beat - phrase as f64 * BEATS_PER_PHRASE as f64;
        let w = smoothstep((into / 0.5).clamp(0.0, 1.0));
        let phrase_frac = (into / BEATS_PER_PHRASE as f64).clamp(0.0, 1.0);

        let mut ang = base;
        let mut sway = 0.0;
        for (mv, weight) in [(prev, 1.0 - w), (cur, w)] {
            if weight == 0.0 {
                continue;
            }
            for o in &mv.oscs {
                let x = (beat / o.period + o.phase).rem_euclid(1.0);
                ang[o.joint][o.axis] += weight * energy * o.amp * o.shape.eval(x);
            }
            sway += weight * mv.sway * energy * (2.0 * std::f64::consts::PI * beat / 4.0).sin();
        }
        for &(j, a, amp, freq, ph) in &wobble {
            ang[j][a] += amp * (std::f64::consts::TAU * freq * t + ph).sin();
        }
        for j in 0..NUM_JOINTS {
            for a in 0..3 {
                ang[j][a] = ang[j][a].clamp(lim[j][a].0, lim[j][a].1);
            }
        }
        let yaw = yaw0 + yaw_acc + cur.turn * smoothstep(phrase_frac) * w;

        let knee = 0.5 * (ang[L_KNEE][X] + ang[R_KNEE][X]).to_radians();
        let drop = leg * (1.0 - (knee / 2.0).cos());
        let pelvis = [
            sway + drift[0] * (t / 10.0).min(1.0),
            pelvis_height - drop,
            drift[1] * (t / 10.0).min(1.0),
        ];
        for a in 0..3 {
            trans.push((pelvis[a] - SMPL_MALE_PELVIS[a]) * style.scaling);
        }
        for (j, a) in ang.iter().enumerate() {
            let mut r = euler_deg(*a);
            if j == PELVIS {
                r = matmul(&axis_angle_to_matrix([0.0, yaw.to_radians(), 0.0]), &r);
            }
            poses.extend(matrix_to_axis_angle(&r));
        }
    }
    Motion::new(poses, trans, style.scaling).expect("generated motion is finite")
}

fn smoothstep(x: f64) -> f64 {
    x * x * (3.0 - 2.0 * x)
}

/// R = Rz·Ry·Rx from degrees.
fn euler_deg(a: [f64; 3]) -> Mat3 {
    let rx = axis_angle_to_matrix([a[0].to_radians(), 0.0, 0.0]);
    let ry = axis_angle_to_matrix([0.0, a[1].to_radians(), 0.0]);
    let rz = axis_angle_to_matrix([0.0, 0.0, a[2].to_radians()]);
    matmul(&matmul(&rz, &ry), &rx)
}

#[cfg(test)]
mod tests {
    use super::*;
    use qean_motion::fk::FkRoot;

    fn grid(bpm: f64, seconds: f64) -> BeatGrid {
        let p = 60.0 / bpm;
        BeatGrid {
            beat_times: (0..)
                .map(|b| b as f64 * p)
                .take_while(|&t| t < seconds)
                .collect(),
            phrase_chords: vec![0, 2, 1, 3],
        }
    }

    fn style(genre: &str) -> DanceStyle {
        DanceStyle {
            genre: genre.into(),
            choreo: 1,
            energy: 1.0,
            seed: 3,
            scaling: 93.0,
            posture: true,
        }
    }

    #[test]
    fn feet_near_floor_and_limits_hold() {
        for g in qean_aistpp::names::GENRES {
            let m = generate(&grid(100.0, 10.0), &style(g), 600);
            assert_eq!(m.frames, 600);
            let j = m.joints(FkRoot::Smpl);
            let min_y = j.iter().map(|p| p[1]).fold(f64::MAX, f64::min);
            assert!(
                min_y > -0.15 && min_y < 0.25,
                "{g}: lowest joint at {min_y}"
            );
            let max_y = j.iter().map(|p| p[1]).fold(f64::MIN, f64::max);
            assert!(max_y < 2.3, "{g}: highest joint at {max_y}");
        }
    }

    /// With postures every genre holds its own mean pose (no two within 5 cm of each other in the
    /// root-relative wrists and knees); without, the genres share the neutral one.
    #[test]
    fn postures_set_the_genres_apart_and_are_optional() {
        let mean_pose = |g: &str, posture: bool| -> Vec<f64> {
            let m = generate(
                &grid(100.0, 10.0),
                &DanceStyle {
                    posture,
                    ..style(g)
                },
                600,
            );
            let j = m.joints(FkRoot::Smpl);
            let mut acc = vec![0.0; 12];
            for f in j.chunks_exact(NUM_JOINTS) {
                for (k, joint) in [L_WRIST, R_WRIST, L_KNEE, R_KNEE].iter().enumerate() {
                    for a in 0..3 {
                        acc[3 * k + a] += (f[*joint][a] - f[PELVIS][a]) / 600.0;
                    }
                }
            }
            acc
        };
        let dist = |a: &[f64], b: &[f64]| {
            a.iter()
                .zip(b)
                .map(|(x, y)| (x - y).powi(2))
                .sum::<f64>()
                .sqrt()
        };
        let genres = qean_aistpp::names::GENRES;
        let with: Vec<Vec<f64>> = genres.iter().map(|g| mean_pose(g, true)).collect();
        let without: Vec<Vec<f64>> = genres.iter().map(|g| mean_pose(g, false)).collect();
        for i in 0..genres.len() {
            for k in i + 1..genres.len() {
                let d = dist(&with[i], &with[k]);
                assert!(d > 0.05, "{} and {}: {d}", genres[i], genres[k]);
            }
        }
        let spread = |p: &[Vec<f64>]| {
            let mut worst: f64 = 0.0;
            for a in p {
                for b in p {
                    worst = worst.max(dist(a, b));
                }
            }
            worst
        };
        assert!(
            spread(&without) < spread(&with),
            "{} {}",
            spread(&without),
            spread(&with)
        );
    }

    /// Kinematic beats (minima of mean joint speed) fall close to music beats.
    #[test]
    fn motion_is_phase_locked_to_beats() {
        let bpm = 120.0;
        let m = generate(&grid(bpm, 12.0), &style("HO"), 720);
        let j = m.joints(FkRoot::Smpl);
        let speed: Vec<f64> = (0..m.frames - 1)
            .map(|t| {
                (0..NUM_JOINTS)
                    .map(|k| {
                        let a = j[t * NUM_JOINTS + k];
                        let b = j[(t + 1) * NUM_JOINTS + k];
                        ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2))
                            .sqrt()
                    })
                    .sum::<f64>()
            })
            .collect();
        let minima: Vec<usize> = (1..speed.len() - 1)
            .filter(|&t| speed[t] < speed[t - 1] && speed[t] < speed[t + 1])
            .collect();
        let beat_frames: Vec<f64> = (1..23).map(|b| b as f64 * 60.0 * 60.0 / bpm).collect();
        let near = beat_frames
            .iter()
            .filter(|&&b| minima.iter().any(|&m| (m as f64 - b).abs() <= 3.0))
            .count();
        assert!(
            near as f64 >= 0.8 * beat_frames.len() as f64,
            "{near} of {}",
            beat_frames.len()
        );
    }

    #[test]
    fn beat_position_interpolates() {
        let g = BeatGrid {
            beat_times: vec![1.0, 2.0, 2.5],
            phrase_chords: vec![0],
        };
        assert_eq!(g.beat_position(1.5), 0.5);
        assert_eq!(g.beat_position(2.25), 1.5);
        assert_eq!(g.beat_position(3.0), 3.0);
        assert_eq!(g.beat_position(0.0), -1.0);
    }
}
