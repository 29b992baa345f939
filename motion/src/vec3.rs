//! 3-vectors as plain `[f64; 3]` (joint positions, bone directions): the few operations the IK, the
//! metrics and the glTF export share. Written out component by component, so results are bit-identical
//! wherever they replaced a local copy.

/// A 3-vector.
pub type Vec3 = [f64; 3];

pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Euclidean length.
pub fn norm(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

pub fn scale(a: Vec3, s: f64) -> Vec3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// `a` divided by its length; `None` for a (near-)zero vector.
pub fn unit(a: Vec3) -> Option<Vec3> {
    let n = norm(a);
    (n > 1e-12).then(|| [a[0] / n, a[1] / n, a[2] / n])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cross_is_right_handed_and_orthogonal() {
        assert_eq!(cross([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]), [0.0, 0.0, 1.0]);
        let (a, b) = ([0.3, -1.2, 2.0], [1.5, 0.4, -0.7]);
        let c = cross(a, b);
        assert!(dot(c, a).abs() < 1e-12 && dot(c, b).abs() < 1e-12);
        assert_eq!(cross(b, a), scale(c, -1.0));
    }

    #[test]
    fn unit_has_length_one_and_refuses_zero() {
        let u = unit([3.0, 0.0, 4.0]).unwrap();
        assert_eq!(u, [0.6, 0.0, 0.8]);
        assert!((norm(u) - 1.0).abs() < 1e-15);
        assert_eq!(unit([0.0; 3]), None);
        assert_eq!(norm(sub([1.0, 2.0, 2.0], [0.0; 3])), 3.0);
    }
}
