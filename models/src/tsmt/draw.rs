//! Drawing one bin from a coordinate's logits (SPEC §11.8 step 3): temperature, optional top-k, and
//! inverse-CDF sampling with a given uniform u, so a rollout is reproducible from its RNG alone.

use super::decode::{argmax, quantile, weights};

/// The bin drawn from `logits` (one coordinate's C values) with temperature `tau` (0 = argmax),
/// `top_k` (0 = all bins) and u ∈ [0, 1): the smallest k with cumsum(p)[k] > u·Σp, where
/// p = softmax(logits/τ) over the kept bins. Ties in argmax and top-k go to the lower index.
pub fn draw(logits: &[f32], tau: f64, top_k: usize, u: f64) -> usize {
    if tau == 0.0 || logits.len() == 1 {
        return argmax(logits);
    }
    quantile(&weights(logits, tau, top_k), u).0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_cases() {
        let equal = [0.0f32; 4];
        // u = 0 → the first bin; u exactly at a CDF boundary → the next bin.
        assert_eq!(draw(&equal, 1.0, 0, 0.0), 0);
        assert_eq!(draw(&equal, 1.0, 0, 0.25), 1);
        assert_eq!(draw(&equal, 1.0, 0, 0.5), 2);
        assert_eq!(draw(&equal, 1.0, 0, 0.999_999), 3);
        // τ = 0 → argmax, ties to the lower index.
        assert_eq!(draw(&[1.0, 3.0, 3.0, 0.0], 0.0, 0, 0.9), 1);
        // top-k keeps only the k largest: never draws outside them.
        let logits = [2.0f32, -1.0, 2.0, 5.0, 0.0];
        for i in 0..100 {
            let k = draw(&logits, 1.0, 2, i as f64 / 100.0);
            assert!(k == 3 || k == 0, "drew {k}");
        }
        // With k = 1 top-k is argmax whatever u.
        assert_eq!(draw(&logits, 2.0, 1, 0.99), 3);
        // Temperature: p ∝ exp(l/τ); with l = [0, ln 3] and τ = 1, p = [1/4, 3/4].
        let l = [0.0f32, 3f32.ln()];
        assert_eq!(draw(&l, 1.0, 0, 0.2499), 0);
        assert_eq!(draw(&l, 1.0, 0, 0.2501), 1);
        // τ = 0.5 squares the odds: p = [1/10, 9/10].
        assert_eq!(draw(&l, 0.5, 0, 0.0999), 0);
        assert_eq!(draw(&l, 0.5, 0, 0.1001), 1);
    }
}
