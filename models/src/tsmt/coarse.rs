//! TSMT at a coarser frame rate (`tsmt.frame_step`, ours): the model steps every `step` frames of the
//! 60 fps data — 20 fps at step 3, near the paper's 24 fps (SPEC §11.1) — and the sampled frames are
//! interpolated back to 60 fps. A step of the model then moves a joint `step` times as far, so the motion
//! stands out of the bins' and the draws' noise, and the noise left is spread over `step` frames, which
//! divides the acceleration it makes by about step².
//!
//! The grid: real frames `offset + c·step`, c = 0, 1, …; its music row c is the MFCC + Δ row of that real
//! frame, and its beat flag is set when a beat falls within ±step/2 frames of it.

use super::model::MFCC_DIM;
use super::sample::TsmtAudio;
use qean_config::tsmt::TsmtUpsample;

/// The real frames a coarse grid samples.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Grid {
    pub step: usize,
    pub offset: usize,
}

impl Grid {
    /// The grid whose last seed point is the seed's last frame (`seed_frames` ≥ 1).
    pub fn ending_at(seed_frames: usize, step: usize) -> Grid {
        Grid {
            step,
            offset: (seed_frames - 1) % step,
        }
    }

    /// The real frame of coarse frame `c`.
    pub fn frame(&self, c: usize) -> usize {
        self.offset + c * self.step
    }

    /// Coarse frames whose real frame is below `frames`.
    pub fn count(&self, frames: usize) -> usize {
        if frames <= self.offset {
            0
        } else {
            (frames - self.offset).div_ceil(self.step)
        }
    }

    /// Rows `frames × dim` (real frames) sampled at the grid.
    pub fn rows<T: Copy>(&self, rows: &[T], dim: usize) -> Vec<T> {
        let frames = rows.len() / dim;
        (0..self.count(frames))
            .flat_map(|c| {
                let f = self.frame(c);
                rows[f * dim..(f + 1) * dim].iter().copied()
            })
            .collect()
    }

    /// The music as the coarse model hears it: each coarse frame's MFCC + Δ row, and a beat when one falls
    /// within ±step/2 real frames of it.
    pub fn audio(&self, music: &TsmtAudio) -> TsmtAudio {
        let n = self.count(music.frames);
        let half = self.step / 2;
        let mut mfcc = Vec::with_capacity(n * MFCC_DIM);
        let mut beats = Vec::with_capacity(n);
        for c in 0..n {
            let f = self.frame(c);
            mfcc.extend_from_slice(&music.mfcc[f * MFCC_DIM..(f + 1) * MFCC_DIM]);
            let lo = f.saturating_sub(half);
            let hi = (f + self.step - half).min(music.frames);
            beats.push(music.beats[lo..hi].iter().copied().max().unwrap_or(0));
        }
        TsmtAudio {
            mfcc,
            beats,
            frames: n,
        }
    }
}

/// Real-rate rows from coarse ones: `coarse` holds frames × `dim` values at the grid's points; the result
/// has a row for every real frame `from..to`, from the four points around it (the end points repeated past
/// the ends) by `curve`.
pub fn upsample(
    grid: &Grid,
    coarse: &[f64],
    dim: usize,
    (from, to): (usize, usize),
    curve: TsmtUpsample,
) -> Vec<f64> {
    match curve {
        TsmtUpsample::CatmullRom => interpolate(grid, coarse, dim, from, to),
        TsmtUpsample::Bspline => bspline(grid, coarse, dim, from, to),
    }
}

/// The uniform cubic B-spline with the coarse points as control points: twice continuously
/// differentiable, so the acceleration has no jumps at the points, and near rather than through them
/// (a point's value is (p₋ + 4p + p₊)/6 there): frame-to-frame noise of the model's steps is smoothed
/// away with it. A line is kept exactly.
pub fn bspline(grid: &Grid, coarse: &[f64], dim: usize, from: usize, to: usize) -> Vec<f64> {
    let n = coarse.len() / dim;
    assert!(n >= 1, "at least one coarse frame");
    let point = |c: isize, d: usize| coarse[(c.clamp(0, n as isize - 1) as usize) * dim + d];
    let mut out = Vec::with_capacity((to - from) * dim);
    for f in from..to {
        let x = (f as f64 - grid.offset as f64) / grid.step as f64;
        let c = x.floor() as isize;
        let t = x - c as f64;
        let w = [
            (1.0 - t).powi(3) / 6.0,
            (3.0 * t * t * t - 6.0 * t * t + 4.0) / 6.0,
            (-3.0 * t * t * t + 3.0 * t * t + 3.0 * t + 1.0) / 6.0,
            t * t * t / 6.0,
        ];
        for d in 0..dim {
            out.push((0..4).map(|k| w[k] * point(c - 1 + k as isize, d)).sum());
        }
    }
    out
}

/// Catmull–Rom interpolation through the coarse points (frames on a point get the point exactly); its
/// acceleration jumps at the points.
pub fn interpolate(grid: &Grid, coarse: &[f64], dim: usize, from: usize, to: usize) -> Vec<f64> {
    let n = coarse.len() / dim;
    assert!(n >= 1, "at least one coarse frame");
    let point = |c: isize, d: usize| coarse[(c.clamp(0, n as isize - 1) as usize) * dim + d];
    let mut out = Vec::with_capacity((to - from) * dim);
    for f in from..to {
        let x = (f as f64 - grid.offset as f64) / grid.step as f64;
        let c = x.floor() as isize;
        let t = x - c as f64;
        for d in 0..dim {
            let (p0, p1, p2, p3) = (
                point(c - 1, d),
                point(c, d),
                point(c + 1, d),
                point(c + 2, d),
            );
            // Catmull–Rom: passes through p1 at t = 0 and p2 at t = 1 with tangents (p2 − p0)/2, (p3 − p1)/2.
            let v = 0.5
                * (2.0 * p1
                    + (p2 - p0) * t
                    + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t * t
                    + (3.0 * p1 - p0 - 3.0 * p2 + p3) * t * t * t);
            out.push(v);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_grid_ends_on_the_seed_and_samples_rows() {
        let g = Grid::ending_at(120, 3);
        assert_eq!(g.offset, 2);
        assert_eq!(g.frame(39), 119);
        assert_eq!(g.count(120), 40);
        assert_eq!(g.count(121), 40);
        assert_eq!(g.count(123), 41);
        assert_eq!(Grid::ending_at(120, 1), Grid { step: 1, offset: 0 });
        let rows: Vec<u32> = (0..10 * 2).collect();
        assert_eq!(
            Grid { step: 4, offset: 1 }.rows(&rows, 2),
            vec![2, 3, 10, 11, 18, 19]
        );
    }

    #[test]
    fn coarse_music_keeps_every_beat() {
        let frames = 30;
        let music = TsmtAudio {
            mfcc: (0..frames * MFCC_DIM).map(|i| i as f32).collect(),
            beats: (0..frames).map(|f| u8::from(f % 7 == 0)).collect(),
            frames,
        };
        let g = Grid { step: 3, offset: 0 };
        let a = g.audio(&music);
        assert_eq!(a.frames, 10);
        assert_eq!(
            &a.mfcc[MFCC_DIM..2 * MFCC_DIM],
            &music.mfcc[3 * MFCC_DIM..4 * MFCC_DIM]
        );
        // Beats at frames 0, 7, 14, 21, 28; coarse frame c covers real frames 3c − 1 ..= 3c + 1.
        let hit: Vec<usize> = (0..a.frames).filter(|&c| a.beats[c] == 1).collect();
        assert_eq!(hit, vec![0, 2, 5, 7, 9]);
    }

    #[test]
    fn interpolation_passes_through_the_points_and_is_exact_on_lines_and_smooth() {
        let g = Grid { step: 3, offset: 2 };
        // A line x = 0.5·frame sampled at the grid is reproduced exactly between the inner points.
        let coarse: Vec<f64> = (0..8).map(|c| 0.5 * g.frame(c) as f64).collect();
        let real = interpolate(&g, &coarse, 1, 5, 20);
        for (i, v) in real.iter().enumerate() {
            assert!((v - 0.5 * (5 + i) as f64).abs() < 1e-12, "{i}: {v}");
        }
        // The B-spline keeps a line too, and is smoother than the points: its second differences on a
        // zigzag are far smaller than Catmull–Rom's.
        let b = bspline(&g, &coarse, 1, 5, 20);
        for (i, v) in b.iter().enumerate() {
            assert!((v - 0.5 * (5 + i) as f64).abs() < 1e-12, "{i}: {v}");
        }
        let zigzag: Vec<f64> = (0..12)
            .map(|c| if c % 2 == 0 { 1.0 } else { -1.0 })
            .collect();
        let bend = |v: &[f64]| {
            v.windows(3)
                .map(|w| (w[2] - 2.0 * w[1] + w[0]).abs())
                .sum::<f64>()
        };
        let (cr, bs) = (
            interpolate(&g, &zigzag, 1, 8, 28),
            bspline(&g, &zigzag, 1, 8, 28),
        );
        assert!(bend(&bs) < 0.5 * bend(&cr), "{} {}", bend(&bs), bend(&cr));
        // On a point, the point itself (two dims).
        let two: Vec<f64> = (0..6).flat_map(|c| [c as f64, -(c as f64) * 2.0]).collect();
        let r = interpolate(&g, &two, 2, g.frame(3), g.frame(3) + 1);
        assert_eq!(r, vec![3.0, -6.0]);
    }
}
