//! The floor under a decoded dance (issue 36). A token model's root is integrated from the velocities its
//! VQ-VAE decodes (SPEC §13.8, `pos72`), and a bias of a millimetre per frame in them adds up: the demo's
//! GPT dances sank 0.6–0.8 m through the floor in 20 s while the speed and acceleration checks passed
//! (docs/control.md, "Feet on the floor").
//!
//! `pin_to_floor` moves the dance up or down, slowly, so that its lowest point comes back to the seed's
//! floor: per frame the height of the lowest joint above the floor, its minimum over a window centred on
//! the frame (a jump shorter than the window keeps its height: the window also holds frames on the
//! ground), that minimum averaged twice over the same window (a smooth correction: a triangle filter),
//! subtracted from every joint.
//!
//! The same bias slides the dance sideways: 0.4–1.2 m in 20 s, all of the demo's GPT dances the same way,
//! the feet gliding with the body. `stop_sliding` takes the slow part of that glide away: per frame t → t + 1
//! the horizontal step of the planted foot (the lower foot, within `CONTACT` of the floor at both frames),
//! averaged over the planted frames of a window centred on the frame and averaged again (a glide slower
//! than the window), summed from the first pinned frame on and subtracted from every joint. A planted foot
//! does not move, so a dance that travels by stepping keeps its travel; a sway faster than the window keeps
//! its sway.
//!
//! Both corrections fade in over `FADE` frames after the seed (the seam's smoothstep), so neither moves
//! the first generated frame nor changes its velocity. A window of N frames spans N/2 frames either side.

/// Joints per frame (SMPL).
const J: usize = 24;
/// SMPL's feet (left, right).
const FEET: [usize; 2] = [10, 11];
/// Frames over which each correction fades in after the seed (1 s).
pub const FADE: usize = 60;
/// A foot within this height (m) above the floor is planted.
pub const CONTACT: f64 = 0.05;

/// The height of a frame's lowest joint.
pub fn lowest(frame: &[[f64; 3]]) -> f64 {
    frame.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min)
}

/// The floor of `joints` (T × 24 points): the lowest height any joint reaches in them.
pub fn floor_of(joints: &[[f64; 3]]) -> f64 {
    lowest(joints)
}

/// Mean of `x` over the window of `half` frames either side of each index (shortened at the ends).
fn box_mean(x: &[f64], half: usize) -> Vec<f64> {
    let mut prefix = Vec::with_capacity(x.len() + 1);
    prefix.push(0.0);
    for v in x {
        prefix.push(prefix.last().copied().unwrap_or(0.0) + v);
    }
    (0..x.len())
        .map(|t| {
            let (a, b) = (t.saturating_sub(half), (t + half + 1).min(x.len()));
            (prefix[b] - prefix[a]) / (b - a) as f64
        })
        .collect()
}

/// The vertical correction of each frame (what `pin_to_floor` subtracts): the lowest joint's height above
/// `floor`, its minimum over `window` frames centred on the frame, averaged twice over the same window.
pub fn floor_offsets(joints: &[[f64; 3]], floor: f64, window: usize) -> Vec<f64> {
    let above: Vec<f64> = joints.chunks(J).map(|f| lowest(f) - floor).collect();
    let half = window / 2;
    let minima: Vec<f64> = (0..above.len())
        .map(|t| {
            let (a, b) = (t.saturating_sub(half), (t + half + 1).min(above.len()));
            above[a..b].iter().copied().fold(f64::INFINITY, f64::min)
        })
        .collect();
    box_mean(&box_mean(&minima, half), half)
}

/// Pins the frames from `from` on (T × 24 points) to `floor` over windows of `window` frames (0 = off).
/// The earlier frames (the seed) take part in the windows but are not moved; the correction fades in over
/// `FADE` frames (where the seed ends it may already be a centimetre: the seed's last window reaches into
/// the dance).
pub fn pin_to_floor(joints: &mut [[f64; 3]], from: usize, floor: f64, window: usize) {
    debug_assert!(joints.len().is_multiple_of(J), "whole frames of {J} joints");
    if window == 0 || joints.len() < (from + 1) * J {
        return;
    }
    let offsets = floor_offsets(joints, floor, window);
    for (k, (frame, dy)) in joints.chunks_mut(J).zip(&offsets).skip(from).enumerate() {
        let dy = dy * (1.0 - crate::seam::weight(k, FADE));
        for p in frame {
            p[1] -= dy;
        }
    }
}

/// The horizontal step (x, z) of the planted foot from frame t to t + 1, or `None` when the lower foot is not
/// within `CONTACT` of the floor (above or below it) at both frames.
fn planted_steps(joints: &[[f64; 3]], floor: f64) -> Vec<Option<[f64; 2]>> {
    let frames: Vec<&[[f64; 3]]> = joints.chunks_exact(J).collect();
    frames
        .windows(2)
        .map(|w| {
            let foot = FEET
                .into_iter()
                .min_by(|&a, &b| w[0][a][1].total_cmp(&w[0][b][1]))
                .unwrap_or(FEET[0]);
            let planted = |f: &[[f64; 3]]| (f[foot][1] - floor).abs() <= CONTACT;
            (planted(w[0]) && planted(w[1]))
                .then(|| [w[1][foot][0] - w[0][foot][0], w[1][foot][2] - w[0][foot][2]])
        })
        .collect()
}

/// Takes the slow glide of the planted feet away from the frames from `from` on (T × 24 points, heights
/// already on `floor`), over windows of `window` frames (0 = off), faded in over `FADE` frames.
pub fn stop_sliding(joints: &mut [[f64; 3]], from: usize, floor: f64, window: usize) {
    debug_assert!(joints.len().is_multiple_of(J), "whole frames of {J} joints");
    if window == 0 || joints.len() < (from + 2) * J {
        return;
    }
    let steps = planted_steps(joints, floor);
    let half = window / 2;
    let mut glide = [Vec::new(), Vec::new()];
    for (axis, g) in glide.iter_mut().enumerate() {
        let values: Vec<f64> = steps.iter().map(|s| s.map_or(0.0, |s| s[axis])).collect();
        let planted: Vec<f64> = steps
            .iter()
            .map(|s| f64::from(u8::from(s.is_some())))
            .collect();
        let (sum, count) = (box_mean(&values, half), box_mean(&planted, half));
        let mean: Vec<f64> = sum
            .iter()
            .zip(&count)
            .map(|(s, c)| if *c > 0.0 { s / c } else { 0.0 })
            .collect();
        *g = box_mean(&mean, half);
    }
    let mut offset = [0.0; 2];
    for (t, frame) in joints.chunks_mut(J).enumerate().skip(from) {
        for p in frame.iter_mut() {
            p[0] -= offset[0];
            p[2] -= offset[1];
        }
        if t < glide[0].len() {
            let fade = 1.0 - crate::seam::weight(t - from, FADE);
            offset[0] += glide[0][t] * fade;
            offset[1] += glide[1][t] * fade;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A dancing figure: 24 joints around a pelvis at `root(t)`, the feet (joints 10, 11) stepping and
    /// touching y = foot(t) in turn.
    fn figure(
        frames: usize,
        root: impl Fn(usize) -> f64,
        lift: impl Fn(usize) -> f64,
    ) -> Vec<[f64; 3]> {
        let mut out = Vec::new();
        for t in 0..frames {
            let phase = (t as f64 / 30.0 * std::f64::consts::PI).sin();
            let y = root(t) + lift(t);
            for j in 0..J {
                let p = match j {
                    10 => [0.1, y - 0.95 + 0.05 * phase.max(0.0), 0.0],
                    11 => [-0.1, y - 0.95 + 0.05 * (-phase).max(0.0), 0.0],
                    _ => [0.02 * j as f64, y - 0.5 + 0.04 * j as f64, 0.01 * phase],
                };
                out.push(p);
            }
        }
        out
    }

    fn heights(joints: &[[f64; 3]]) -> Vec<f64> {
        joints.chunks(J).map(lowest).collect()
    }

    /// |x[t+1] − 2x[t] + x[t−1]| · 60² (m/s² at 60 fps) for t = 1..len − 1.
    fn accelerations(x: &[f64]) -> Vec<f64> {
        x.windows(3)
            .map(|w| ((w[2] - 2.0 * w[1] + w[0]) * 3600.0).abs())
            .collect()
    }

    /// The largest acceleration a correction (before − after, per frame) adds around the seam at frame 120.
    /// The largest change of any point's `axis` coordinate between `before` and `after`.
    fn largest_shift(after: &[[f64; 3]], before: &[[f64; 3]], axis: usize) -> f64 {
        after
            .iter()
            .zip(before)
            .map(|(a, b)| (a[axis] - b[axis]).abs())
            .fold(0.0, f64::max)
    }

    fn seam_kink(correction: &[f64]) -> f64 {
        accelerations(correction)[117..129]
            .iter()
            .copied()
            .fold(0.0, f64::max)
    }

    #[test]
    fn a_sinking_dance_comes_back_to_the_floor() {
        // 10 s sinking at 4 cm/s after a 2-s seed on the floor (pelvis at 1 m, feet at 0.05 m).
        let sink = |t: usize| 1.0 - 0.04 * (t.saturating_sub(120) as f64 / 60.0);
        let mut joints = figure(720, sink, |_| 0.0);
        let before = joints.clone();
        let floor = floor_of(&joints[..120 * J]);
        assert!((floor - 0.05).abs() < 1e-9);
        assert!(heights(&joints)[719] < floor - 0.35);
        pin_to_floor(&mut joints, 120, floor, 60);
        let h = heights(&joints);
        // No jump where the seed ends (the sink itself is 0.7 mm per frame), and the correction does not
        // change the velocity there: its acceleration at the seam stays under 0.3 m/s².
        assert!(
            (h[120] - h[119]).abs() < 1e-3,
            "seam step {}",
            h[120] - h[119]
        );
        let dy: Vec<f64> = (0..720)
            .map(|t| before[t * J][1] - joints[t * J][1])
            .collect();
        let kink = seam_kink(&dy);
        assert!(
            kink < 0.3,
            "correction acceleration at the seam {kink} m/s²"
        );
        // After the seam's fade every 1-s window touches the floor again, up to the half window's lead of
        // the running minimum (the sink over 30 frames: 2 cm) where the sinking was 38 cm.
        let lead = 0.04 / 60.0 * 30.0;
        for w in h[180..690].chunks(60) {
            let m = w.iter().copied().fold(f64::INFINITY, f64::min);
            assert!(
                m > floor - 2e-3 && m < floor + lead + 2e-3,
                "window minimum {m} vs floor {floor}"
            );
        }
    }

    #[test]
    fn a_jump_keeps_its_height_and_the_seed_is_not_moved() {
        // On the floor, with a 0.4-s jump of 30 cm at 5 s.
        let jump = |t: usize| {
            if (300..324).contains(&t) {
                0.3 * ((t - 300) as f64 / 24.0 * std::f64::consts::PI).sin()
            } else {
                0.0
            }
        };
        let before = figure(720, |_| 1.0, jump);
        let mut joints = before.clone();
        let floor = floor_of(&joints[..120 * J]);
        pin_to_floor(&mut joints, 120, floor, 60);
        let most = largest_shift(&joints, &before, 1);
        assert!(most < 1e-9, "a dance on the floor moved by {most} m");
        let mut sunk = figure(720, |t| 1.0 - 0.002 * t as f64, jump);
        let seed = sunk[..120 * J].to_vec();
        pin_to_floor(&mut sunk, 120, floor, 60);
        assert_eq!(&sunk[..120 * J], &seed[..], "the seed moved");
        let h = heights(&sunk);
        let peak = h[300..324].iter().copied().fold(f64::MIN, f64::max);
        assert!(peak > floor + 0.25, "the jump lost its height: {peak}");
    }

    #[test]
    fn the_correction_is_smooth_and_off_at_window_zero() {
        // A dance sinking at 4 cm/s: inside it the correction adds no acceleration; within 1.5 windows of
        // either end, where the windows are shortened, under half of the data's mean joint acceleration
        // (2.35 m/s²) to one frame.
        let joints = figure(720, |t| 1.0 - 0.0007 * t as f64, |_| 0.0);
        let c = floor_offsets(&joints, 0.05, 60);
        let accel = accelerations(&c);
        let most = |a: &[f64]| a.iter().copied().fold(0.0, f64::max);
        assert!(
            most(&accel[90..620]) < 1e-6,
            "inside: {} m/s²",
            most(&accel[90..620])
        );
        assert!(most(&accel) < 1.0, "at the ends: {} m/s²", most(&accel));
        let mut off = joints.clone();
        pin_to_floor(&mut off, 120, 0.05, 0);
        assert_eq!(off, joints);
    }

    /// Root x of each frame.
    fn root_x(joints: &[[f64; 3]]) -> Vec<f64> {
        joints.chunks(J).map(|f| f[0][0]).collect()
    }

    #[test]
    fn a_gliding_dance_stops_gliding() {
        // Everything glides along x at 6 cm/s after a 2-s seed, swaying ±5 cm at 1 Hz.
        let mut joints = figure(1320, |_| 1.0, |_| 0.0);
        for (t, f) in joints.chunks_mut(J).enumerate() {
            let x = 0.001 * t.saturating_sub(120) as f64
                + 0.05 * (t as f64 / 60.0 * 2.0 * std::f64::consts::PI).sin();
            for p in f {
                p[0] += x;
            }
        }
        let floor = floor_of(&joints[..120 * J]);
        let seed = joints[..120 * J].to_vec();
        let before = root_x(&joints);
        stop_sliding(&mut joints, 120, floor, 240);
        assert_eq!(&joints[..120 * J], &seed[..], "the seed moved");
        let x = root_x(&joints);
        // The correction fades in: under 0.3 m/s² of acceleration at the seam.
        let dx: Vec<f64> = before.iter().zip(&x).map(|(b, a)| b - a).collect();
        let kink = seam_kink(&dx);
        assert!(
            kink < 0.3,
            "correction acceleration at the seam {kink} m/s²"
        );
        // Glided 1.2 m; now within 15 cm of where it was when the seed ended (the fade-in and the windows
        // that still hold the still seed let the first seconds glide a little).
        let far = x[120..]
            .iter()
            .map(|v| (v - x[120]).abs())
            .fold(0.0, f64::max);
        assert!(far < 0.15, "still glides: {far} m");
        // The 1-Hz sway is kept (at least 80 % of its ±5 cm).
        let sway = x[600..660].iter().copied().fold(f64::MIN, f64::max)
            - x[600..660].iter().copied().fold(f64::MAX, f64::min);
        assert!(sway > 0.08, "sway {sway} m");
        let mut off = joints.clone();
        stop_sliding(&mut off, 120, floor, 0);
        assert_eq!(off, joints);
    }

    #[test]
    fn a_dance_that_steps_keeps_its_travel() {
        // Walks along x at 0.25 m/s, a step of 12.5 cm every 0.5 s: in step n one foot is planted at
        // 0.125 n while the other swings from 0.125 (n − 1) to 0.125 (n + 1), lifted up to 10 cm.
        let mut joints = Vec::new();
        for t in 0..1200usize {
            let root = 0.25 * t as f64 / 60.0;
            let (n, k) = ((t / 30) as f64, (t % 30) as f64);
            let planted = [0.125 * n, 0.05, 0.0];
            let swing = [
                0.125 * (n - 1.0) + 0.25 * k / 30.0,
                0.05 + 0.1 * ((k + 0.5) / 30.0 * std::f64::consts::PI).sin(),
                0.0,
            ];
            for j in 0..J {
                let p = match (j, (t / 30) % 2) {
                    (10, 0) | (11, 1) => planted,
                    (10, _) | (11, _) => swing,
                    _ => [root + 0.01 * j as f64, 0.5 + 0.04 * j as f64, 0.0],
                };
                joints.push(p);
            }
        }
        let before = joints.clone();
        stop_sliding(&mut joints, 120, 0.05, 240);
        let moved = largest_shift(&joints, &before, 0);
        assert!(moved < 1e-9, "a stepping dance moved by {moved} m");
    }
}
