//! Even keyframes (SPEC §12.3a, Lin §3.4.1): N keys spread evenly over a segment, both ends included.

/// k_i = a + ⌊i·L/(N−1) + ½⌋, i = 0..N−1, in integers as (2iL + N − 1) div 2(N − 1); duplicates removed.
/// A segment with fewer than N frames keys every frame. `n` must be at least 2.
pub fn even_keys(a: usize, b: usize, n: usize) -> Vec<usize> {
    assert!(n >= 2 && b >= a, "even_keys needs n ≥ 2 and a ≤ b");
    let len = b - a;
    if len + 1 < n {
        return (a..=b).collect();
    }
    let mut keys: Vec<usize> = (0..n)
        .map(|i| a + (2 * i * len + n - 1) / (2 * (n - 1)))
        .collect();
    keys.dedup();
    keys
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_measure_at_120_bpm() {
        assert_eq!(even_keys(0, 120, 3), vec![0, 60, 120]);
        assert_eq!(even_keys(0, 120, 5), vec![0, 30, 60, 90, 120]);
        assert_eq!(
            even_keys(0, 120, 9),
            vec![0, 15, 30, 45, 60, 75, 90, 105, 120]
        );
        assert_eq!(even_keys(120, 240, 3), vec![120, 180, 240]);
    }

    #[test]
    fn rounding_and_short_segments() {
        // L = 131 (110 BPM): 131/4 = 32.75 → 33, 65.5 → 66 (half up), 98.25 → 98.
        assert_eq!(even_keys(0, 131, 5), vec![0, 33, 66, 98, 131]);
        assert_eq!(even_keys(10, 13, 9), vec![10, 11, 12, 13]);
        assert_eq!(even_keys(5, 5, 3), vec![5]);
        // Exactly N frames: every frame.
        assert_eq!(even_keys(0, 4, 5), vec![0, 1, 2, 3, 4]);
    }
}
