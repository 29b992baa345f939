//! The measure grid (SPEC §12.2, Lin eq. 3.1): AIST music is 4/4 at a constant tempo, so a measure lasts
//! 14400/BPM frames at 60 fps; a dance is cut into one segment per measure.

use serde::{Deserialize, Serialize};

/// How a fractional measure length becomes frame indices.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Rounding {
    /// Measure m starts at ⌊m·14400/BPM + ½⌋: no drift.
    #[default]
    Cumulative,
    /// A fixed length ⌊14400/BPM⌋.
    Floor,
    /// A fixed length round(14400/BPM).
    Round,
}

/// Whether consecutive segments share their boundary frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Boundary {
    /// [b_m, b_{m+1}]: the shared frame is always a keyframe.
    #[default]
    Shared,
    /// [b_m, b_{m+1} − 1].
    Disjoint,
}

/// Frames per measure at `bpm` (4 beats, 60 fps).
pub fn measure_frames(bpm: f64) -> f64 {
    14400.0 / bpm
}

/// Start frame of measure `m` after `offset`.
pub fn measure_start(m: usize, bpm: f64, rounding: Rounding, offset: usize) -> usize {
    let start = match rounding {
        Rounding::Cumulative => {
            if bpm.fract() == 0.0 && bpm > 0.0 && bpm < 1e6 {
                // Exact: ⌊m·14400/B + ½⌋ = (28800·m + B) div 2B.
                let b = bpm as u64;
                ((28800 * m as u64 + b) / (2 * b)) as usize
            } else {
                (m as f64 * measure_frames(bpm) + 0.5).floor() as usize
            }
        }
        Rounding::Floor => m * measure_frames(bpm).floor() as usize,
        Rounding::Round => m * measure_frames(bpm).round() as usize,
    };
    offset + start
}

/// The measure starts that fall inside a motion of `frames` frames.
pub fn measure_starts(frames: usize, bpm: f64, rounding: Rounding, offset: usize) -> Vec<usize> {
    let mut out = Vec::new();
    for m in 0.. {
        let b = measure_start(m, bpm, rounding, offset);
        if b >= frames {
            break;
        }
        out.push(b);
    }
    out
}

/// Inclusive segments [a, b] covering every frame of a motion: one per measure, a tail for the leftover
/// frames, and a head [0, offset] when the grid starts late.
pub fn segments(
    frames: usize,
    bpm: f64,
    rounding: Rounding,
    boundary: Boundary,
    offset: usize,
) -> Vec<(usize, usize)> {
    if frames == 0 {
        return Vec::new();
    }
    let mut cuts = measure_starts(frames, bpm, rounding, offset);
    if cuts.first() != Some(&0) {
        cuts.insert(0, 0);
    }
    let last = frames - 1;
    let mut out = Vec::with_capacity(cuts.len());
    for (i, &a) in cuts.iter().enumerate() {
        let next = cuts.get(i + 1).copied();
        match boundary {
            Boundary::Shared => {
                let b = next.unwrap_or(last);
                // A tail that is only the last shared frame adds nothing.
                if b > a || frames == 1 {
                    out.push((a, b));
                }
            }
            Boundary::Disjoint => out.push((a, next.map_or(last, |n| n - 1))),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cumulative_grid_at_110_bpm() {
        let s = measure_starts(400, 110.0, Rounding::Cumulative, 0);
        assert_eq!(s, vec![0, 131, 262, 393]);
        // Integer arithmetic equals the float formula wherever the float is not on a half.
        for bpm in [80.0, 90.0, 100.0, 110.0, 115.0, 120.0, 125.0, 130.0, 135.0] {
            for m in 0..200 {
                let f = (m as f64 * 14400.0 / bpm + 0.5).floor() as usize;
                assert_eq!(
                    measure_start(m, bpm, Rounding::Cumulative, 0),
                    f,
                    "{bpm} {m}"
                );
            }
        }
    }

    #[test]
    fn measure_lengths_table() {
        let want = [
            (80.0, 180.0),
            (90.0, 160.0),
            (100.0, 144.0),
            (110.0, 130.91),
            (115.0, 125.22),
            (120.0, 120.0),
            (125.0, 115.2),
            (130.0, 110.77),
            (135.0, 106.67),
        ];
        for (bpm, f) in want {
            assert!((measure_frames(bpm) - f).abs() < 0.005, "{bpm}");
        }
        assert_eq!(
            measure_starts(400, 110.0, Rounding::Floor, 0),
            vec![0, 130, 260, 390]
        );
        assert_eq!(
            measure_starts(400, 110.0, Rounding::Round, 0),
            vec![0, 131, 262, 393]
        );
        assert_eq!(
            measure_starts(300, 115.0, Rounding::Round, 0),
            vec![0, 125, 250]
        );
    }

    #[test]
    fn shared_disjoint_and_tail_segments() {
        let s = segments(127, 120.0, Rounding::Cumulative, Boundary::Shared, 0);
        assert_eq!(s, vec![(0, 120), (120, 126)]);
        let d = segments(127, 120.0, Rounding::Cumulative, Boundary::Disjoint, 0);
        assert_eq!(d, vec![(0, 119), (120, 126)]);
        // An exact fit has no tail in shared mode; disjoint keeps the single last frame.
        assert_eq!(
            segments(121, 120.0, Rounding::Cumulative, Boundary::Shared, 0),
            vec![(0, 120)]
        );
        assert_eq!(
            segments(121, 120.0, Rounding::Cumulative, Boundary::Disjoint, 0),
            vec![(0, 119), (120, 120)]
        );
        // A late grid gets a head segment.
        assert_eq!(
            segments(200, 120.0, Rounding::Cumulative, Boundary::Shared, 10),
            vec![(0, 10), (10, 130), (130, 199)]
        );
        // Segments cover every frame.
        for frames in [1, 2, 50, 121, 500] {
            for boundary in [Boundary::Shared, Boundary::Disjoint] {
                let s = segments(frames, 110.0, Rounding::Cumulative, boundary, 0);
                assert_eq!(s.first().unwrap().0, 0);
                assert_eq!(s.last().unwrap().1, frames - 1);
            }
        }
    }
}
