//! The TSMT paper's diversity measures (SPEC §11.10) on normalised features: A-seq-D across
//! sequences (all pairs: §7.4's Dist), I-seq-D within sequences (non-overlapping chunks, pairs
//! pooled over sequences) and S-music-D across rollouts for the same music.

use crate::dist::average_distance;
use crate::error::Result;

fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// A-seq-D: the mean distance over all pairs of sequences (= Dist).
pub fn a_seq_d(features: &[Vec<f64>]) -> Result<f64> {
    average_distance(features)
}

/// I-seq-D: Σ_s Σ_{k<l} ‖g_{s,k} − g_{s,l}‖ / Σ_s K_s(K_s − 1)/2 over each sequence's chunk
/// features; None when no sequence has two chunks.
pub fn i_seq_d(chunks_per_sequence: &[Vec<Vec<f64>>]) -> Option<f64> {
    let (mut sum, mut pairs) = (0.0, 0usize);
    for chunks in chunks_per_sequence {
        for (k, a) in chunks.iter().enumerate() {
            for b in &chunks[k + 1..] {
                sum += distance(a, b);
                pairs += 1;
            }
        }
    }
    (pairs > 0).then(|| sum / pairs as f64)
}

/// S-music-D: for each music, the mean distance over pairs of its rollouts; then the mean over
/// musics (those with fewer than two rollouts are left out). None when no music has two.
pub fn s_music_d(groups: &[Vec<Vec<f64>>]) -> Option<f64> {
    let per_music: Vec<f64> = groups
        .iter()
        .filter(|g| g.len() >= 2)
        .map(|g| average_distance(g).expect("two or more"))
        .collect();
    (!per_music.is_empty()).then(|| per_music.iter().sum::<f64>() / per_music.len() as f64)
}

/// Starts of the non-overlapping `chunk`-frame chunks of a `frames`-frame segment (the remainder
/// is dropped).
pub fn chunk_starts(frames: usize, chunk: usize) -> Vec<usize> {
    if chunk == 0 {
        return Vec::new();
    }
    (0..frames / chunk).map(|k| k * chunk).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_cases() {
        let f = vec![vec![0.0, 0.0], vec![3.0, 4.0], vec![0.0, 1.0]];
        // A-seq-D = Dist: (5 + 1 + √18)/3.
        let want = (5.0 + 1.0 + 18f64.sqrt()) / 3.0;
        assert!((a_seq_d(&f).unwrap() - want).abs() < 1e-12);
        // I-seq-D pools pairs: sequence 1 has pairs 5 and 1 and √18; sequence 2 one pair of 2; sequence 3
        // one chunk (adds nothing).
        let chunks = vec![
            f.clone(),
            vec![vec![1.0, 1.0], vec![1.0, 3.0]],
            vec![vec![9.0, 9.0]],
        ];
        let want = (5.0 + 1.0 + 18f64.sqrt() + 2.0) / 4.0;
        assert!((i_seq_d(&chunks).unwrap() - want).abs() < 1e-12);
        assert_eq!(i_seq_d(&[vec![vec![1.0]]]), None);
        // S-music-D: mean over musics of each music's mean pair distance.
        let groups = vec![
            f.clone(),
            vec![vec![0.0, 0.0], vec![0.0, 2.0]],
            vec![vec![1.0, 1.0]],
        ];
        let want = ((5.0 + 1.0 + 18f64.sqrt()) / 3.0 + 2.0) / 2.0;
        assert!((s_music_d(&groups).unwrap() - want).abs() < 1e-12);
        assert_eq!(chunk_starts(500, 240), vec![0, 240]);
        assert_eq!(chunk_starts(239, 240), Vec::<usize>::new());
    }
}
