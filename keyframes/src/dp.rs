//! Keyframes by dynamic programming (SPEC §12.3e): Roberts et al.'s salient poses, as Lin uses them. An
//! error table E[i, j] says how badly the straight line from frame i to frame j misses the frames between;
//! the DP picks the N keys whose worst span error is smallest (minimax, as in Roberts's code).

use serde::{Deserialize, Serialize};

/// How the error of one span is measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum DpError {
    /// Roberts: distance from [t | x_t] to the chord through the span's ends (time is a coordinate).
    #[default]
    Chord,
    /// Lin's wording: distance from x_k to the linear interpolation of the ends at k.
    Lerp,
}

/// How span errors add up over a selection.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum DpCombine {
    /// The worst span (Roberts's code).
    #[default]
    Max,
    /// The sum of spans (Lin's paraphrase).
    Sum,
}

/// Which per-frame vectors the DP sees.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum DpSpace {
    /// 24 Euler triples + root translation (75-D), Lin's choice.
    #[default]
    Euler75,
    /// The 225-D rotation-matrix layout.
    Rotmat225,
    /// 24 joint positions (72-D).
    Joints72,
}

/// Roberts's "infinite" error for a degenerate chord.
const DEGENERATE: f64 = 999_999_999.0;

/// The n × n span-error table of points x (n rows of `dim` values), row-major; E[i, j] for j ≤ i + 1 is 0.
pub fn error_table(x: &[f64], dim: usize, kind: DpError) -> Vec<f64> {
    let n = x.len() / dim;
    let row = |t: usize| &x[t * dim..(t + 1) * dim];
    let mut e = vec![0.0; n * n];
    for i in 0..n {
        for j in i + 2..n {
            let (xi, xj) = (row(i), row(j));
            let mut worst: f64 = 0.0;
            match kind {
                DpError::Chord => {
                    // d = p_j − p_i with time as coordinate 0.
                    let dt = (j - i) as f64;
                    let dd: f64 = dt * dt
                        + xi.iter()
                            .zip(xj)
                            .map(|(a, b)| (b - a) * (b - a))
                            .sum::<f64>();
                    if dd == 0.0 {
                        e[i * n + j] = DEGENERATE;
                        continue;
                    }
                    for k in i + 1..j {
                        let xk = row(k);
                        let vt = (k - i) as f64;
                        let vd: f64 = vt * dt
                            + xk.iter()
                                .zip(xi)
                                .zip(xj)
                                .map(|((c, a), b)| (c - a) * (b - a))
                                .sum::<f64>();
                        let s = vd / dd;
                        let mut r2 = (vt - s * dt).powi(2);
                        for a in 0..dim {
                            let r = (xk[a] - xi[a]) - s * (xj[a] - xi[a]);
                            r2 += r * r;
                        }
                        worst = worst.max(r2.sqrt());
                    }
                }
                DpError::Lerp => {
                    let span = (j - i) as f64;
                    for k in i + 1..j {
                        let xk = row(k);
                        let (wi, wj) = ((j - k) as f64 / span, (k - i) as f64 / span);
                        let r2: f64 = (0..dim)
                            .map(|a| (xk[a] - (wi * xi[a] + wj * xj[a])).powi(2))
                            .sum();
                        worst = worst.max(r2.sqrt());
                    }
                }
            }
            e[i * n + j] = worst;
        }
    }
    e
}

fn combine(kind: DpCombine, a: f64, b: f64) -> f64 {
    match kind {
        DpCombine::Max => a.max(b),
        DpCombine::Sum => a + b,
    }
}

/// The cost of a sorted key selection (relative frames 0..n−1) under table `e`.
pub fn selection_cost(e: &[f64], n: usize, keys: &[usize], kind: DpCombine) -> f64 {
    keys.windows(2)
        .map(|w| e[w[0] * n + w[1]])
        .fold(0.0, |acc, v| combine(kind, acc, v))
}

/// The best `count` keys of frames 0..n−1 (first and last included) and their cost. S₂(e) = E[0, e];
/// S_m(e) = min over k ∈ [m−2, e−1] of combine(S_{m−1}(k), E[k, e]); the smallest k wins ties.
pub fn select(e: &[f64], n: usize, count: usize, kind: DpCombine) -> (Vec<usize>, f64) {
    assert!(count >= 2 && n >= 1 && e.len() == n * n);
    if n <= count {
        let keys: Vec<usize> = (0..n).collect();
        let cost = selection_cost(e, n, &keys, kind);
        return (keys, cost);
    }
    let mut s = vec![f64::INFINITY; count * n];
    let mut from = vec![usize::MAX; count * n];
    s[n + 1..2 * n].copy_from_slice(&e[1..n]);
    for m in 3..=count {
        let row = m - 1;
        for end in m - 1..n {
            let mut best = f64::INFINITY;
            let mut arg = usize::MAX;
            for k in m - 2..end {
                let v = combine(kind, s[(row - 1) * n + k], e[k * n + end]);
                if v < best {
                    best = v;
                    arg = k;
                }
            }
            s[row * n + end] = best;
            from[row * n + end] = arg;
        }
    }
    let mut keys = vec![n - 1];
    let mut end = n - 1;
    for row in (2..count).rev() {
        end = from[row * n + end];
        keys.push(end);
    }
    keys.push(0);
    keys.reverse();
    (keys, s[(count - 1) * n + n - 1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn random_points(n: usize, dim: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        (0..n * dim).map(|_| rng.random_range(-1.0..1.0)).collect()
    }

    /// Every selection of `count` keys from 0..n−1 with both ends.
    fn brute_force(e: &[f64], n: usize, count: usize, kind: DpCombine) -> f64 {
        fn walk(
            e: &[f64],
            n: usize,
            left: usize,
            keys: &mut Vec<usize>,
            kind: DpCombine,
            best: &mut f64,
        ) {
            let last = *keys.last().unwrap();
            if left == 0 {
                keys.push(n - 1);
                *best = best.min(selection_cost(e, n, keys, kind));
                keys.pop();
                return;
            }
            for k in last + 1..n - 1 {
                keys.push(k);
                walk(e, n, left - 1, keys, kind, best);
                keys.pop();
            }
        }
        let mut best = f64::INFINITY;
        walk(e, n, count - 2, &mut vec![0], kind, &mut best);
        best
    }

    #[test]
    fn dp_equals_brute_force() {
        for seed in 0..6 {
            let x = random_points(12, 4, seed);
            for error in [DpError::Chord, DpError::Lerp] {
                let e = error_table(&x, 4, error);
                for kind in [DpCombine::Max, DpCombine::Sum] {
                    for count in [3, 4, 5] {
                        let (keys, cost) = select(&e, 12, count, kind);
                        let bf = brute_force(&e, 12, count, kind);
                        assert!(
                            (cost - bf).abs() <= 1e-12,
                            "{error:?} {kind:?} {count}: {cost} vs {bf}"
                        );
                        assert_eq!(keys.len(), count);
                        assert_eq!((keys[0], keys[count - 1]), (0, 11));
                        assert!((selection_cost(&e, 12, &keys, kind) - cost).abs() <= 1e-12);
                    }
                }
            }
        }
    }

    #[test]
    fn table_basics_and_tie_break() {
        let x = random_points(8, 3, 9);
        let e = error_table(&x, 3, DpError::Chord);
        for i in 0..7 {
            assert_eq!(e[i * 8 + i + 1], 0.0);
        }
        // Collinear points in time and space: every span is exact (to rounding).
        let line: Vec<f64> = (0..10).map(|t| t as f64 * 0.5).collect();
        for kind in [DpError::Chord, DpError::Lerp] {
            let e = error_table(&line, 1, kind);
            assert!(e.iter().all(|&v| v.abs() < 1e-12));
        }
        // A constant under the lerp error: every span is exactly 0, so every selection ties and the
        // smallest k wins each step.
        let e = error_table(&[0.25; 10], 1, DpError::Lerp);
        for kind in [DpCombine::Max, DpCombine::Sum] {
            let (keys, cost) = select(&e, 10, 4, kind);
            assert_eq!(keys, vec![0, 1, 2, 9]);
            assert_eq!(cost, 0.0);
        }
    }

    #[test]
    fn chord_error_hand_case() {
        // Points (t, x): (0, 0), (1, 1), (2, 0): the chord is the t axis; the middle point is 1 away.
        let e = error_table(&[0.0, 1.0, 0.0], 1, DpError::Chord);
        assert!((e[2] - 1.0).abs() < 1e-15);
        // Lerp error: |1 − 0| = 1 too; with a sloped chord they differ.
        let x = [0.0, 0.0, 2.0];
        let chord = error_table(&x, 1, DpError::Chord)[2];
        let lerp = error_table(&x, 1, DpError::Lerp)[2];
        assert!((lerp - 1.0).abs() < 1e-15);
        // Distance from (1, 0) to the line through (0, 0) and (2, 2): 1/√2.
        assert!((chord - 0.5f64.sqrt()).abs() < 1e-15);
    }
}
