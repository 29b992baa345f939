//! Rotations (SPEC §3.1–3.2): axis-angle ↔ rotation matrix (Rodrigues), projection to SO(3), quaternions.
//! Matrices are row-major `[f64; 9]`.

pub type Mat3 = [f64; 9];

pub const IDENTITY: Mat3 = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];

/// Rodrigues: R = I + sin θ·K + (1 − cos θ)·K², K = skew(r/θ). Near zero, I + [r]× + ½[r]×².
/// Matches scipy `Rotation.from_rotvec(r).as_matrix()`.
pub fn axis_angle_to_matrix(r: [f64; 3]) -> Mat3 {
    let theta = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    let (k, s, c1) = if theta < 1e-8 {
        (r, 1.0, 0.5)
    } else {
        (
            [r[0] / theta, r[1] / theta, r[2] / theta],
            theta.sin(),
            1.0 - theta.cos(),
        )
    };
    let kx = [0.0, -k[2], k[1], k[2], 0.0, -k[0], -k[1], k[0], 0.0];
    let kk = matmul(&kx, &kx);
    let mut m = IDENTITY;
    for i in 0..9 {
        m[i] += s * kx[i] + c1 * kk[i];
    }
    m
}

/// Unit quaternion (w, x, y, z) with w ≥ 0 of a rotation matrix (Shepperd's method).
pub fn matrix_to_quaternion(m: &Mat3) -> [f64; 4] {
    let (m00, m01, m02, m10, m11, m12, m20, m21, m22) =
        (m[0], m[1], m[2], m[3], m[4], m[5], m[6], m[7], m[8]);
    let tr = m00 + m11 + m22;
    let q = if tr > 0.0 {
        let s = (tr + 1.0).sqrt() * 2.0;
        [0.25 * s, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s]
    } else if m00 > m11 && m00 > m22 {
        let s = (1.0 + m00 - m11 - m22).sqrt() * 2.0;
        [(m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s]
    } else if m11 > m22 {
        let s = (1.0 + m11 - m00 - m22).sqrt() * 2.0;
        [(m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s]
    } else {
        let s = (1.0 + m22 - m00 - m11).sqrt() * 2.0;
        [(m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s]
    };
    let n = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    let sign = if q[0] < 0.0 { -1.0 } else { 1.0 };
    [
        sign * q[0] / n,
        sign * q[1] / n,
        sign * q[2] / n,
        sign * q[3] / n,
    ]
}

/// Axis-angle of a rotation matrix, through the quaternion with w ≥ 0: angle = 2·atan2(|v|, w) ∈ [0, π].
pub fn matrix_to_axis_angle(m: &Mat3) -> [f64; 3] {
    let q = matrix_to_quaternion(m);
    let v = (q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if v < 1e-12 {
        // Small angle: r ≈ 2·v_vec / w.
        return [2.0 * q[1], 2.0 * q[2], 2.0 * q[3]];
    }
    let angle = 2.0 * v.atan2(q[0]);
    [q[1] / v * angle, q[2] / v * angle, q[3] / v * angle]
}

/// The closest rotation to `m` (mint `get_closest_rotmat`): M = U·S·Vᵀ, R = U·diag(1, 1, sign det(U·Vᵀ))·Vᵀ.
pub fn project_to_so3(m: &Mat3) -> Mat3 {
    let a = nalgebra::Matrix3::from_row_slice(m);
    let svd = a.svd(true, true);
    let (u, vt) = match (svd.u, svd.v_t) {
        (Some(u), Some(vt)) => (u, vt),
        _ => return IDENTITY,
    };
    if !u.iter().chain(vt.iter()).all(|x| x.is_finite()) {
        return IDENTITY;
    }
    let d = (u * vt).determinant().signum();
    let r = u * nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(1.0, 1.0, d)) * vt;
    let mut out = [0.0; 9];
    for i in 0..3 {
        for j in 0..3 {
            out[3 * i + j] = r[(i, j)];
        }
    }
    out
}

pub fn matmul(a: &Mat3, b: &Mat3) -> Mat3 {
    let mut c = [0.0; 9];
    for i in 0..3 {
        for j in 0..3 {
            c[3 * i + j] = a[3 * i] * b[j] + a[3 * i + 1] * b[3 + j] + a[3 * i + 2] * b[6 + j];
        }
    }
    c
}

pub fn mat_vec(a: &Mat3, v: [f64; 3]) -> [f64; 3] {
    [
        a[0] * v[0] + a[1] * v[1] + a[2] * v[2],
        a[3] * v[0] + a[4] * v[1] + a[5] * v[2],
        a[6] * v[0] + a[7] * v[1] + a[8] * v[2],
    ]
}

pub fn transpose(a: &Mat3) -> Mat3 {
    [a[0], a[3], a[6], a[1], a[4], a[7], a[2], a[5], a[8]]
}

pub fn determinant(a: &Mat3) -> f64 {
    a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6])
        + a[2] * (a[3] * a[7] - a[4] * a[6])
}

/// Euler angles (degrees) of a rotation matrix for the BVH `Zrot Yrot Xrot` channel order, i.e.
/// R = Rz(z)·Ry(y)·Rx(x). Returns [z, y, x].
pub fn matrix_to_euler_zyx_deg(m: &Mat3) -> [f64; 3] {
    let sy = (-m[6]).clamp(-1.0, 1.0);
    let y = sy.asin();
    let (z, x) = if sy.abs() < 1.0 - 1e-9 {
        (m[3].atan2(m[0]), m[7].atan2(m[8]))
    } else {
        // Gimbal lock: put everything into z.
        ((-m[1]).atan2(m[4]), 0.0)
    };
    [z.to_degrees(), y.to_degrees(), x.to_degrees()]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn rodrigues_round_trip() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        for _ in 0..2000 {
            let scale = [1e-10, 1e-3, 1.0, 3.1][rng.random_range(0..4)];
            let r: [f64; 3] = std::array::from_fn(|_| rng.random_range(-1.0..1.0) * scale);
            let n = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
            if n > std::f64::consts::PI - 0.0016 {
                continue;
            }
            let m = axis_angle_to_matrix(r);
            assert!((determinant(&m) - 1.0).abs() < 1e-12);
            let back = matrix_to_axis_angle(&m);
            assert!(max_abs_diff(&r, &back) < 1e-9, "{r:?} -> {back:?}");
        }
    }

    #[test]
    fn known_rotation() {
        // 90° about z maps x to y.
        let m = axis_angle_to_matrix([0.0, 0.0, std::f64::consts::FRAC_PI_2]);
        let v = mat_vec(&m, [1.0, 0.0, 0.0]);
        assert!(max_abs_diff(&v, &[0.0, 1.0, 0.0]) < 1e-15);
    }

    #[test]
    fn projection_gives_rotation() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2);
        for _ in 0..500 {
            let r: [f64; 3] = std::array::from_fn(|_| rng.random_range(-2.0..2.0));
            let mut m = axis_angle_to_matrix(r);
            for x in m.iter_mut() {
                *x += rng.random_range(-0.2..0.2);
            }
            let p = project_to_so3(&m);
            let ptp = matmul(&transpose(&p), &p);
            assert!(max_abs_diff(&ptp, &IDENTITY) < 1e-12);
            assert!((determinant(&p) - 1.0).abs() < 1e-12);
        }
        // A reflection is mapped to a proper rotation.
        let refl = [-1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        assert!((determinant(&project_to_so3(&refl)) - 1.0).abs() < 1e-12);
        // A rotation is its own projection.
        let m = axis_angle_to_matrix([0.3, -0.2, 1.1]);
        assert!(max_abs_diff(&project_to_so3(&m), &m) < 1e-12);
    }

    #[test]
    fn euler_round_trip() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for _ in 0..500 {
            let r: [f64; 3] = std::array::from_fn(|_| rng.random_range(-1.5..1.5));
            let m = axis_angle_to_matrix(r);
            let [z, y, x] = matrix_to_euler_zyx_deg(&m);
            let rz = axis_angle_to_matrix([0.0, 0.0, z.to_radians()]);
            let ry = axis_angle_to_matrix([0.0, y.to_radians(), 0.0]);
            let rx = axis_angle_to_matrix([x.to_radians(), 0.0, 0.0]);
            let back = matmul(&matmul(&rz, &ry), &rx);
            assert!(max_abs_diff(&back, &m) < 1e-9);
        }
    }
}
