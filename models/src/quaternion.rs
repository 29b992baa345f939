//! The Hamilton product on plain f64 quaternions (a, b, c, d) = a + b·i + c·j + d·k (SPEC §4.6).
//!
//! The reference the tensor code (QuaternionLinear's block matrix, QRA's closed-form rotations)
//! is tested against. QEAN eq. 5 has a typo in the j part (Q_h·R_e for Q_h·R_f); this is the
//! corrected product.

/// A quaternion as (real, i, j, k).
pub type Quaternion = [f64; 4];

/// p ⊗ q.
pub fn hamilton(p: Quaternion, q: Quaternion) -> Quaternion {
    let [a1, b1, c1, d1] = p;
    let [a2, b2, c2, d2] = q;
    [
        a1 * a2 - b1 * b2 - c1 * c2 - d1 * d2,
        a1 * b2 + b1 * a2 + c1 * d2 - d1 * c2,
        a1 * c2 - b1 * d2 + c1 * a2 + d1 * b2,
        a1 * d2 + b1 * c2 - c1 * b2 + d1 * a2,
    ]
}

/// Squared norm a² + b² + c² + d².
pub fn norm_sq(q: Quaternion) -> f64 {
    q.iter().map(|x| x * x).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_products_follow_hamilton_rules() {
        let (one, i, j, k) = (
            [1.0, 0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0, 0.0],
            [0.0, 0.0, 1.0, 0.0],
            [0.0, 0.0, 0.0, 1.0],
        );
        let neg = |q: Quaternion| q.map(|x| -x);
        assert_eq!(hamilton(i, j), k);
        assert_eq!(hamilton(j, k), i);
        assert_eq!(hamilton(k, i), j);
        assert_eq!(hamilton(j, i), neg(k));
        assert_eq!(hamilton(i, i), neg(one));
        assert_eq!(hamilton(one, k), k);
    }

    #[test]
    fn norm_is_multiplicative() {
        let p = [0.3, -1.2, 0.7, 2.0];
        let q = [-0.5, 0.1, 1.4, -0.9];
        let lhs = norm_sq(hamilton(p, q));
        assert!((lhs - norm_sq(p) * norm_sq(q)).abs() < 1e-12);
    }
}
