//! Fréchet distance between the Gaussians fitted to two feature sets (SPEC §7.4; Bailando
//! `metrics_new.py: calc_fid`, mint `calculate_frechet_distance`).
//!
//! The reference takes scipy `sqrtm(S1·S2)`, adds ε·I when that is not finite, and keeps or drops a
//! complex part depending on the codebase. We compute tr sqrt(S1·S2) exactly instead, as
//! Σ sqrt(max(λ, 0)) over the eigenvalues of the symmetric PSD S1^½·S2·S1^½ (same spectrum as S1·S2),
//! which stays real and finite for the rank-deficient covariances of 40 samples in 72 dimensions.

use nalgebra::{DMatrix, DVector};

use crate::error::{Error, Result};

/// Sample mean and covariance (ddof 1, `np.cov(rowvar=False)`).
#[derive(Debug, Clone)]
pub struct Gaussian {
    pub mean: DVector<f64>,
    pub cov: DMatrix<f64>,
}

impl Gaussian {
    pub fn fit(samples: &[Vec<f64>]) -> Result<Self> {
        let n = samples.len();
        if n < 2 {
            return Err(Error::Invalid(format!(
                "a covariance needs at least 2 samples, got {n}"
            )));
        }
        let d = samples[0].len();
        if samples.iter().any(|s| s.len() != d) {
            return Err(Error::Invalid(
                "feature vectors of different lengths".into(),
            ));
        }
        for (i, s) in samples.iter().enumerate() {
            if let Some(j) = s.iter().position(|v| !v.is_finite()) {
                return Err(Error::Invalid(format!(
                    "feature vector {i} has a non-finite value ({}) in dimension {j}",
                    s[j]
                )));
            }
        }
        let x = DMatrix::from_fn(n, d, |i, j| samples[i][j]);
        let mean = DVector::from_fn(d, |j, _| x.column(j).sum() / n as f64);
        let mut centred = x;
        for j in 0..d {
            let m = mean[j];
            centred.column_mut(j).add_scalar_mut(-m);
        }
        let cov = centred.tr_mul(&centred) / (n as f64 - 1.0);
        Ok(Gaussian { mean, cov })
    }
}

/// Eigenvalues at or below d·ε·λ_max are round-off (as in a pseudo-inverse's rank cut): zero them,
/// or the null space of a 40-sample covariance adds Σ sqrt(noise) ≈ 1e-5 to the trace term.
fn clip_noise(eigenvalues: &DVector<f64>) -> DVector<f64> {
    let max = eigenvalues.iter().fold(0.0f64, |a, &b| a.max(b));
    let tol = max * eigenvalues.len() as f64 * f64::EPSILON;
    eigenvalues.map(|l| if l > tol { l } else { 0.0 })
}

/// Symmetric PSD square root through a symmetric eigendecomposition; negative and round-off
/// eigenvalues count as 0.
pub fn psd_sqrt(m: &DMatrix<f64>) -> DMatrix<f64> {
    let sym = (m + m.transpose()) * 0.5;
    let eig = sym.symmetric_eigen();
    let roots = clip_noise(&eig.eigenvalues).map(f64::sqrt);
    &eig.eigenvectors * DMatrix::from_diagonal(&roots) * eig.eigenvectors.transpose()
}

/// tr sqrt(S1·S2) for symmetric PSD S1, S2.
pub fn trace_sqrt_product(s1: &DMatrix<f64>, s2: &DMatrix<f64>) -> f64 {
    let r = psd_sqrt(s1);
    let m = &r * s2 * &r;
    let sym = (&m + m.transpose()) * 0.5;
    clip_noise(&sym.symmetric_eigenvalues())
        .map(f64::sqrt)
        .sum()
}

/// |μ1 − μ2|² + tr S1 + tr S2 − 2 tr sqrt(S1·S2).
pub fn frechet_distance(a: &Gaussian, b: &Gaussian) -> Result<f64> {
    if a.mean.len() != b.mean.len() {
        return Err(Error::Invalid(format!(
            "FID between {}-D and {}-D features",
            a.mean.len(),
            b.mean.len()
        )));
    }
    let diff = &a.mean - &b.mean;
    Ok(diff.dot(&diff) + a.cov.trace() + b.cov.trace() - 2.0 * trace_sqrt_product(&a.cov, &b.cov))
}

/// FID between two sets of (normalised) feature vectors.
/// With zero dimensions (every one constant over the reference set, left out) the distance is 0.
pub fn fid(a: &[Vec<f64>], b: &[Vec<f64>]) -> Result<f64> {
    let (ga, gb) = (Gaussian::fit(a)?, Gaussian::fit(b)?);
    if ga.mean.is_empty() {
        return Ok(0.0);
    }
    frechet_distance(&ga, &gb)
}
