//! Drawing one bin from a coordinate's logits (SPEC §11.8 step 3): temperature, optional top-k, and
//! inverse-CDF sampling with a given uniform u, so a rollout is reproducible from its RNG alone.

/// The bin drawn from `logits` (one coordinate's C values) with temperature `tau` (0 = argmax),
/// `top_k` (0 = all bins) and u ∈ [0, 1): the smallest k with cumsum(p)[k] > u·Σp, where
/// p = softmax(logits/τ) over the kept bins. Ties in argmax and top-k go to the lower index.
pub fn draw(logits: &[f32], tau: f64, top_k: usize, u: f64) -> usize {
    let argmax = || {
        logits
            .iter()
            .enumerate()
            .fold((0, f32::NEG_INFINITY), |(bi, bv), (i, &v)| {
                if v > bv {
                    (i, v)
                } else {
                    (bi, bv)
                }
            })
            .0
    };
    if tau == 0.0 || logits.len() == 1 {
        return argmax();
    }
    let mut keep = vec![true; logits.len()];
    if top_k > 0 && top_k < logits.len() {
        // Rank by value (descending), lower index first among equals; keep the first k.
        let mut order: Vec<usize> = (0..logits.len()).collect();
        order.sort_by(|&a, &b| logits[b].total_cmp(&logits[a]).then(a.cmp(&b)));
        keep.fill(false);
        for &i in &order[..top_k] {
            keep[i] = true;
        }
    }
    let max = logits
        .iter()
        .zip(&keep)
        .filter(|(_, &k)| k)
        .map(|(&v, _)| v as f64)
        .fold(f64::NEG_INFINITY, f64::max);
    let p: Vec<f64> = logits
        .iter()
        .zip(&keep)
        .map(|(&v, &k)| {
            if k {
                ((v as f64 - max) / tau).exp()
            } else {
                0.0
            }
        })
        .collect();
    let total: f64 = p.iter().sum();
    let target = u * total;
    let mut cum = 0.0;
    let mut last_kept = 0;
    for (i, &pi) in p.iter().enumerate() {
        if pi > 0.0 {
            last_kept = i;
        }
        cum += pi;
        if cum > target && pi > 0.0 {
            return i;
        }
    }
    last_kept
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
