//! Dist (Bailando: Div), the mean pairwise Euclidean distance of normalised features (SPEC §7.4;
//! `calculate_avg_distance`): Σ_{i<j} |X_i − X_j| / (n(n−1)/2).

use rayon::prelude::*;

use crate::error::{Error, Result};

pub fn average_distance(features: &[Vec<f64>]) -> Result<f64> {
    let n = features.len();
    if n < 2 {
        return Err(Error::Invalid(format!(
            "Dist needs at least 2 sequences, got {n}"
        )));
    }
    let total: f64 = (0..n)
        .into_par_iter()
        .map(|i| {
            let fi = &features[i];
            features[i + 1..]
                .iter()
                .map(|fj| {
                    fi.iter()
                        .zip(fj)
                        .map(|(a, b)| (a - b) * (a - b))
                        .sum::<f64>()
                        .sqrt()
                })
                .sum::<f64>()
        })
        .sum();
    Ok(total / ((n * n - n) as f64 / 2.0))
}
