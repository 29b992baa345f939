//! Feature normalisation by the reference (GT) set (SPEC §7.4, Bailando `metrics_new.py: normalize`):
//! μ and σ (ddof 0) per dimension from GT only; both sets map to (f − μ)/(σ + 1e-10).

use crate::error::{Error, Result};

/// The reference's additive guard: a constant GT dimension divides by 1e-10, it does not fail.
pub const STD_EPS: f64 = 1e-10;

#[derive(Debug, Clone, PartialEq)]
pub struct Normaliser {
    pub mean: Vec<f64>,
    pub std: Vec<f64>,
}

impl Normaliser {
    /// Fit on GT feature vectors (all of one length).
    pub fn fit(reference: &[Vec<f64>]) -> Result<Self> {
        let n = reference.len();
        let Some(first) = reference.first() else {
            return Err(Error::Invalid(
                "cannot normalise by an empty reference set".into(),
            ));
        };
        let d = first.len();
        if let Some(bad) = reference.iter().find(|f| f.len() != d) {
            return Err(Error::Invalid(format!(
                "feature vectors of lengths {d} and {} cannot be normalised together",
                bad.len()
            )));
        }
        let mut mean = vec![0.0; d];
        for f in reference {
            for (m, x) in mean.iter_mut().zip(f) {
                *m += x;
            }
        }
        mean.iter_mut().for_each(|m| *m /= n as f64);
        let mut var = vec![0.0; d];
        for f in reference {
            for ((v, x), m) in var.iter_mut().zip(f).zip(&mean) {
                *v += (x - m) * (x - m);
            }
        }
        let std = var.iter().map(|v| (v / n as f64).sqrt()).collect();
        Ok(Normaliser { mean, std })
    }

    pub fn apply_one(&self, f: &[f64]) -> Vec<f64> {
        f.iter()
            .zip(&self.mean)
            .zip(&self.std)
            .map(|((x, m), s)| (x - m) / (s + STD_EPS))
            .collect()
    }

    pub fn apply(&self, features: &[Vec<f64>]) -> Vec<Vec<f64>> {
        features.iter().map(|f| self.apply_one(f)).collect()
    }

    /// [`Normaliser::apply`] without the [`Normaliser::constant_dims`]: a dimension with no spread in the
    /// reference set says nothing about distances between distributions, and dividing by σ + 1e-10 would
    /// turn any difference there into up to 1e10.
    pub fn apply_varying(&self, features: &[Vec<f64>]) -> Vec<Vec<f64>> {
        let constant = self.constant_dims();
        features
            .iter()
            .map(|f| {
                self.apply_one(f)
                    .into_iter()
                    .enumerate()
                    .filter(|(i, _)| !constant.contains(i))
                    .map(|(_, x)| x)
                    .collect()
            })
            .collect()
    }

    /// Dimensions that are constant over the GT set up to round-off (worth a warning: any difference
    /// there, even round-off, is multiplied by up to 1e10).
    pub fn constant_dims(&self) -> Vec<usize> {
        (0..self.std.len())
            .filter(|&i| self.std[i] <= 64.0 * f64::EPSILON * self.mean[i].abs())
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_reference_dimensions_are_left_out() {
        // Dimension 1 never moves in the reference; a generated vector departing there by 1 would be
        // 1e10 away after the reference code's σ + 1e-10.
        let reference = vec![vec![0.0, 2.0, 1.0], vec![2.0, 2.0, 3.0]];
        let n = Normaliser::fit(&reference).unwrap();
        assert_eq!(n.constant_dims(), vec![1]);
        assert!(n.apply_one(&[1.0, 3.0, 2.0])[1] > 1e9);
        let v = n.apply_varying(&[vec![1.0, 3.0, 2.0]]);
        assert_eq!(v, vec![vec![0.0, 0.0]]);
    }
}
