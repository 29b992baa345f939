//! SPEC §9 item 14: FID and Dist identities.

use qean_eval::dist::average_distance;
use qean_eval::fid::{fid, frechet_distance, Gaussian};

fn lcg(seed: &mut u64) -> f64 {
    *seed = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    ((*seed >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0
}

fn random_set(n: usize, d: usize, seed: u64, scale: f64, shift: f64) -> Vec<Vec<f64>> {
    let mut s = seed;
    (0..n)
        .map(|_| {
            (0..d)
                .map(|j| shift + scale * (1.0 + j as f64 * 0.1) * lcg(&mut s))
                .collect()
        })
        .collect()
}

#[test]
fn fid_of_a_set_with_itself_is_zero() {
    for (n, d) in [(40, 72), (100, 32), (10, 5)] {
        let x = random_set(n, d, 7, 1.5, 0.2);
        let v = fid(&x, &x).unwrap();
        assert!(v.abs() < 1e-8, "n={n} d={d}: {v}");
    }
}

#[test]
fn fid_is_symmetric() {
    let x = random_set(40, 72, 1, 1.0, 0.0);
    let y = random_set(100, 72, 2, 2.0, 0.5);
    let (a, b) = (fid(&x, &y).unwrap(), fid(&y, &x).unwrap());
    assert!((a - b).abs() < 1e-9 * a.abs().max(1.0), "{a} vs {b}");
    assert!(a > 1.0);
}

/// μ ± s_i e_i: sample mean μ, sample covariance diag(2 s_i² / (2d − 1)).
fn plus_minus(mu: &[f64], s: &[f64]) -> Vec<Vec<f64>> {
    let d = mu.len();
    let mut out = Vec::new();
    for i in 0..d {
        for sign in [1.0, -1.0] {
            let mut v = mu.to_vec();
            v[i] += sign * s[i];
            out.push(v);
        }
    }
    out
}

#[test]
fn fid_matches_the_diagonal_gaussian_closed_form() {
    let d = 6;
    let mu1: Vec<f64> = (0..d).map(|i| 0.1 * i as f64).collect();
    let mu2: Vec<f64> = (0..d).map(|i| -0.2 + 0.05 * i as f64).collect();
    let s1: Vec<f64> = (0..d).map(|i| 0.5 + 0.3 * i as f64).collect();
    let s2: Vec<f64> = (0..d).map(|i| 2.0 - 0.25 * i as f64).collect();
    let got = fid(&plus_minus(&mu1, &s1), &plus_minus(&mu2, &s2)).unwrap();
    let k = 2.0 / (2 * d - 1) as f64;
    let expected: f64 = (0..d)
        .map(|i| {
            let (a, b) = (k * s1[i] * s1[i], k * s2[i] * s2[i]);
            (mu1[i] - mu2[i]).powi(2) + (a.sqrt() - b.sqrt()).powi(2)
        })
        .sum();
    assert!((got - expected).abs() < 1e-10, "{got} vs {expected}");
}

#[test]
fn fid_is_rotation_invariant_and_finite_for_rank_deficient_covariances() {
    // 8 samples in 20-D: both covariances have rank ≤ 7.
    let x = random_set(8, 20, 3, 1.0, 0.0);
    let y = random_set(8, 20, 4, 1.3, 0.1);
    let v = fid(&x, &y).unwrap();
    assert!(v.is_finite() && v > 0.0, "{v}");
    // Rotate every sample by the same Givens rotation in dims (0, 1) and (2, 5).
    let rot = |s: &Vec<Vec<f64>>| -> Vec<Vec<f64>> {
        s.iter()
            .map(|r| {
                let mut r = r.clone();
                for (i, j, t) in [(0usize, 1usize, 0.7f64), (2, 5, -1.1)] {
                    let (a, b) = (r[i], r[j]);
                    r[i] = t.cos() * a - t.sin() * b;
                    r[j] = t.sin() * a + t.cos() * b;
                }
                r
            })
            .collect()
    };
    let w = fid(&rot(&x), &rot(&y)).unwrap();
    assert!((v - w).abs() < 1e-9 * v, "{v} vs {w}");
}

#[test]
fn fid_needs_two_samples_per_set() {
    let x = random_set(1, 4, 1, 1.0, 0.0);
    let y = random_set(5, 4, 2, 1.0, 0.0);
    assert!(fid(&x, &y).is_err());
    assert!(Gaussian::fit(&y).is_ok());
    let g = Gaussian::fit(&y).unwrap();
    assert!(frechet_distance(&g, &g).unwrap().abs() < 1e-12);
}

#[test]
fn dist_identities() {
    assert!((average_distance(&[vec![0.0, 0.0], vec![3.0, 4.0]]).unwrap() - 5.0).abs() < 1e-15);
    let line = vec![vec![0.0], vec![1.0], vec![3.0]];
    assert!((average_distance(&line).unwrap() - 2.0).abs() < 1e-15);
    let same = vec![vec![1.0, 2.0, 3.0]; 5];
    assert_eq!(average_distance(&same).unwrap(), 0.0);
    // Translation invariant, scales linearly.
    let x = random_set(30, 10, 9, 1.0, 0.0);
    let moved: Vec<Vec<f64>> = x
        .iter()
        .map(|r| r.iter().map(|v| 2.0 * v + 7.0).collect())
        .collect();
    let (a, b) = (
        average_distance(&x).unwrap(),
        average_distance(&moved).unwrap(),
    );
    assert!((b - 2.0 * a).abs() < 1e-12 * b);
    assert!(average_distance(&x[..1]).is_err());
}

/// Degenerate sets give finite FIDs (zero covariances, a single repeated vector) or a clear error
/// (non-finite features, one sample), never NaN.
#[test]
fn fid_of_degenerate_sets_is_finite_or_an_error() {
    let constant = vec![vec![1.0, 2.0, 3.0]; 5];
    let shifted = vec![vec![1.0, 2.0, 5.0]; 7];
    assert_eq!(fid(&constant, &constant).unwrap(), 0.0);
    let d = fid(&constant, &shifted).unwrap();
    assert!((d - 4.0).abs() < 1e-12, "{d}");
    let zeros = vec![vec![0.0; 72]; 40];
    let spread: Vec<Vec<f64>> = (0..40)
        .map(|i| (0..72).map(|j| ((i * 7 + j * 3) % 11) as f64).collect())
        .collect();
    let d = fid(&zeros, &spread).unwrap();
    assert!(d.is_finite() && d > 0.0, "{d}");
    let mut nan = spread.clone();
    nan[3][5] = f64::NAN;
    let err = fid(&nan, &spread).unwrap_err().to_string();
    assert!(
        err.contains("feature vector 3") && err.contains("dimension 5"),
        "{err}"
    );
    let mut inf = spread.clone();
    inf[0][0] = f64::INFINITY;
    assert!(fid(&spread, &inf).is_err());
    assert!(fid(&spread[..1], &spread).is_err());
}
