//! Euler angles (SPEC §12.1, Lin eq. 2.4): intrinsic Tait–Bryan triples, R = R_i(a)·R_j(b)·R_k(c) for the
//! order "ijk" (default XYZ, scipy `as_euler("XYZ")`), unwrapped along time like `np.unwrap`, and the 75-D
//! D_euler vectors (24 triples + root translation).

use qean_motion::rotation::{matmul, Mat3};
use qean_motion::Motion;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// The axis order of an intrinsic rotation R = R_first(a)·R_second(b)·R_third(c).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub enum EulerOrder {
    #[default]
    XYZ,
    XZY,
    YXZ,
    YZX,
    ZXY,
    ZYX,
}

impl EulerOrder {
    pub const ALL: [EulerOrder; 6] = [
        EulerOrder::XYZ,
        EulerOrder::XZY,
        EulerOrder::YXZ,
        EulerOrder::YZX,
        EulerOrder::ZXY,
        EulerOrder::ZYX,
    ];

    fn axes(self) -> [usize; 3] {
        match self {
            EulerOrder::XYZ => [0, 1, 2],
            EulerOrder::XZY => [0, 2, 1],
            EulerOrder::YXZ => [1, 0, 2],
            EulerOrder::YZX => [1, 2, 0],
            EulerOrder::ZXY => [2, 0, 1],
            EulerOrder::ZYX => [2, 1, 0],
        }
    }

    /// +1 for a cyclic order of (x, y, z), −1 otherwise.
    fn parity(self) -> f64 {
        match self {
            EulerOrder::XYZ | EulerOrder::YZX | EulerOrder::ZXY => 1.0,
            _ => -1.0,
        }
    }
}

/// Rotation by `angle` about coordinate axis `axis` (0 = x).
pub fn axis_rotation(axis: usize, angle: f64) -> Mat3 {
    let (s, c) = angle.sin_cos();
    match axis {
        0 => [1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c],
        1 => [c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c],
        _ => [c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0],
    }
}

/// R = R_i(a)·R_j(b)·R_k(c).
pub fn euler_to_matrix(angles: [f64; 3], order: EulerOrder) -> Mat3 {
    let [i, j, k] = order.axes();
    matmul(
        &matmul(&axis_rotation(i, angles[0]), &axis_rotation(j, angles[1])),
        &axis_rotation(k, angles[2]),
    )
}

/// The triple (a, b, c) with b ∈ [−π/2, π/2]. For XYZ: b = asin(R₀₂), a = atan2(−R₁₂, R₂₂),
/// c = atan2(−R₀₁, R₀₀); at gimbal lock (|R₀₂| > 1 − 1e-12) c = 0 and a = atan2(R₂₁, R₁₁).
pub fn matrix_to_euler(m: &Mat3, order: EulerOrder) -> [f64; 3] {
    let [i, j, k] = order.axes();
    let s = order.parity();
    let at = |r: usize, c: usize| m[3 * r + c];
    let sb = s * at(i, k);
    let b = sb.clamp(-1.0, 1.0).asin();
    if sb.abs() > 1.0 - 1e-12 {
        let a = (s * at(k, j)).atan2(at(j, j));
        return [a, b, 0.0];
    }
    let a = (-s * at(j, k)).atan2(at(k, k));
    let c = (-s * at(i, j)).atan2(at(i, i));
    [a, b, c]
}

/// `np.unwrap(p)` (discont π, period 2π) in place.
pub fn unwrap(p: &mut [f64]) {
    let mut correction = 0.0;
    let mut prev = match p.first() {
        Some(&v) => v,
        None => return,
    };
    for v in p.iter_mut().skip(1) {
        let raw = *v;
        let dd = raw - prev;
        let mut ddmod = (dd + PI).rem_euclid(2.0 * PI) - PI;
        if ddmod == -PI && dd > 0.0 {
            ddmod = PI;
        }
        if dd.abs() >= PI {
            correction += ddmod - dd;
        }
        prev = raw;
        *v = raw + correction;
    }
}

/// D_euler: frames × 75 (24 Euler triples in radians, then trans/scaling), each channel unwrapped along
/// time when `unwrap_time`.
pub fn motion_to_euler(motion: &Motion, order: EulerOrder, unwrap_time: bool) -> Vec<f64> {
    let rots = motion.rotations();
    let roots = motion.root_positions();
    let mut out = vec![0.0; motion.frames * 75];
    for t in 0..motion.frames {
        for j in 0..24 {
            let e = matrix_to_euler(&rots[t * 24 + j], order);
            out[t * 75 + 3 * j..t * 75 + 3 * j + 3].copy_from_slice(&e);
        }
        out[t * 75 + 72..t * 75 + 75].copy_from_slice(&roots[t]);
    }
    if unwrap_time {
        let mut channel = vec![0.0; motion.frames];
        for c in 0..72 {
            for t in 0..motion.frames {
                channel[t] = out[t * 75 + c];
            }
            unwrap(&mut channel);
            for t in 0..motion.frames {
                out[t * 75 + c] = channel[t];
            }
        }
    }
    out
}

/// The motion of D_euler vectors (scaling 1).
pub fn euler_to_motion(x: &[f64], order: EulerOrder) -> Motion {
    let frames = x.len() / 75;
    let mut poses = Vec::with_capacity(frames * 72);
    let mut trans = Vec::with_capacity(frames * 3);
    for row in x.chunks_exact(75) {
        for j in 0..24 {
            let m = euler_to_matrix([row[3 * j], row[3 * j + 1], row[3 * j + 2]], order);
            poses.extend(qean_motion::rotation::matrix_to_axis_angle(&m));
        }
        trans.extend_from_slice(&row[72..75]);
    }
    Motion::new(poses, trans, 1.0).expect("finite Euler vectors make a valid motion")
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn close(a: &Mat3, b: &Mat3) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn every_order_round_trips() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        for order in EulerOrder::ALL {
            for _ in 0..200 {
                let e = [
                    rng.random_range(-3.1..3.1),
                    rng.random_range(-1.5..1.5),
                    rng.random_range(-3.1..3.1),
                ];
                let m = euler_to_matrix(e, order);
                let back = matrix_to_euler(&m, order);
                for a in 0..3 {
                    assert!((back[a] - e[a]).abs() < 1e-9, "{order:?} {e:?} {back:?}");
                }
            }
            // Gimbal lock: the matrix still round-trips.
            let m = euler_to_matrix([0.4, PI / 2.0, -0.3], order);
            assert!(close(&euler_to_matrix(matrix_to_euler(&m, order), order), &m) < 1e-12);
        }
    }

    #[test]
    fn xyz_hand_case() {
        // R = Rx(a)·Ry(b)·Rz(c) at (a, b, c) = (0.1, 0.2, 0.3); R₀₂ = sin b.
        let m = euler_to_matrix([0.1, 0.2, 0.3], EulerOrder::XYZ);
        assert!((m[2] - 0.2f64.sin()).abs() < 1e-15);
        let e = matrix_to_euler(&m, EulerOrder::XYZ);
        assert!(
            (e[0] - 0.1).abs() < 1e-15 && (e[1] - 0.2).abs() < 1e-15 && (e[2] - 0.3).abs() < 1e-15
        );
    }

    #[test]
    fn unwrap_like_numpy() {
        // np.unwrap([0, 3, -3, -0.5, 2.9, -3.0]) = [0, 3, 3.28318531, 5.78318531, 2.9, 3.28318531]
        let mut p = vec![0.0, 3.0, -3.0, -0.5, 2.9, -3.0];
        unwrap(&mut p);
        let want = [
            0.0,
            3.0,
            -3.0 + 2.0 * PI,
            -0.5 + 2.0 * PI,
            2.9,
            -3.0 + 2.0 * PI,
        ];
        for (a, b) in p.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "{p:?}");
        }
    }
}
