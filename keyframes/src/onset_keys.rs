//! Onset-peak keyframes (SPEC §12.3b, Lin §3.4.2): the N − 2 strongest onset peaks inside a segment plus
//! its ends, filled up with midpoints where the segment has too few peaks. The same selection serves the
//! stem-weighted (§12.3c) and NMFD (§12.3d) curves.

use serde::{Deserialize, Serialize};

/// Which frames of the curve count as peaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum PeakPicker {
    /// librosa's onset_detect peak picking (SPEC §2.5) on the curve: for the onset envelope these are
    /// exactly column 33's peaks.
    #[default]
    OnsetDetect,
    /// c[n−1] < c[n] ≥ c[n+1].
    LocalMax,
}

/// Where extra keys go when a segment has fewer than N − 2 usable peaks.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum Fallback {
    /// The midpoint of the neighbouring keys with the largest c[k_i] + c[k_{i+1}] (Lin's wording).
    #[default]
    MaxPairSum,
    /// The midpoint of the widest gap.
    WidestGap,
}

/// Peak frames of a curve sampled at 60 fps (sr 30720, hop 512).
pub fn peaks(curve: &[f64], picker: PeakPicker) -> Vec<usize> {
    match picker {
        PeakPicker::OnsetDetect => qean_audio::onset::onset_detect(curve, 30720.0, 512),
        PeakPicker::LocalMax => (1..curve.len().saturating_sub(1))
            .filter(|&n| curve[n - 1] < curve[n] && curve[n] >= curve[n + 1])
            .collect(),
    }
}

/// Keys of segment [a, b] from a curve (absolute frames; values past its end count as 0) and its peaks.
pub fn onset_keys(
    curve: &[f64],
    peaks: &[usize],
    (a, b): (usize, usize),
    n: usize,
    guard: usize,
    fallback: Fallback,
) -> Vec<usize> {
    assert!(n >= 2 && b >= a, "onset_keys needs n ≥ 2 and a ≤ b");
    let c = |k: usize| curve.get(k).copied().unwrap_or(0.0);
    let mut candidates: Vec<usize> = peaks
        .iter()
        .copied()
        .filter(|&p| p >= a + guard && p + guard <= b)
        .collect();
    // Largest value first, the earlier frame on ties.
    candidates.sort_by(|&p, &q| c(q).total_cmp(&c(p)).then(p.cmp(&q)));
    candidates.truncate(n.saturating_sub(2));
    let mut keys = candidates;
    keys.push(a);
    keys.push(b);
    keys.sort_unstable();
    keys.dedup();
    while keys.len() < n {
        let mut best: Option<(usize, f64)> = None;
        for i in 0..keys.len() - 1 {
            let (k0, k1) = (keys[i], keys[i + 1]);
            if k1 - k0 < 2 {
                continue;
            }
            let score = match fallback {
                Fallback::MaxPairSum => c(k0) + c(k1),
                Fallback::WidestGap => (k1 - k0) as f64,
            };
            if best.is_none_or(|(_, s)| score > s) {
                best = Some((i, score));
            }
        }
        let Some((i, _)) = best else { break };
        keys.insert(i + 1, (keys[i] + keys[i + 1]) / 2);
    }
    keys
}

#[cfg(test)]
mod tests {
    use super::*;

    fn example() -> (Vec<f64>, Vec<usize>) {
        let mut c = vec![0.0; 121];
        let peaks = vec![3, 30, 45, 60, 90, 118];
        for (&p, v) in peaks.iter().zip([9.0, 5.0, 2.0, 7.0, 5.0, 8.0]) {
            c[p] = v;
        }
        (c, peaks)
    }

    #[test]
    fn spec_example() {
        let (c, p) = example();
        let keys = |n, g, f| onset_keys(&c, &p, (0, 120), n, g, f);
        assert_eq!(keys(3, 5, Fallback::MaxPairSum), vec![0, 60, 120]);
        assert_eq!(keys(5, 5, Fallback::MaxPairSum), vec![0, 30, 60, 90, 120]);
        assert_eq!(
            keys(9, 5, Fallback::MaxPairSum),
            vec![0, 30, 37, 45, 52, 60, 75, 90, 120]
        );
        assert_eq!(
            keys(9, 5, Fallback::WidestGap),
            vec![0, 15, 30, 45, 60, 75, 90, 105, 120]
        );
        assert_eq!(keys(3, 0, Fallback::MaxPairSum), vec![0, 3, 120]);
    }

    #[test]
    fn ties_take_the_earlier_frame() {
        let mut c = vec![0.0; 101];
        for p in [20, 40, 60, 80] {
            c[p] = 1.0;
        }
        let keys = onset_keys(&c, &[80, 60, 40, 20], (0, 100), 4, 5, Fallback::MaxPairSum);
        assert_eq!(keys, vec![0, 20, 40, 100]);
        // A segment too short for N keys gets every frame.
        let keys = onset_keys(&c, &[], (10, 13), 9, 5, Fallback::MaxPairSum);
        assert_eq!(keys, vec![10, 11, 12, 13]);
    }

    #[test]
    fn local_max_picker() {
        let c = [0.0, 1.0, 0.5, 0.5, 2.0, 2.0, 1.0, 3.0];
        assert_eq!(peaks(&c, PeakPicker::LocalMax), vec![1, 4]);
    }
}
