//! Linear + SLERP in-betweening (SPEC §12.4a, Lin eq. 2.5–2.6): the root moves on a straight line between
//! keys, each joint turns along the shortest great arc at constant angular speed.

use qean_motion::Motion;

/// Unit quaternion (w, x, y, z) of an axis-angle vector: w = cos(θ/2), v = r·sin(θ/2)/θ.
pub fn quat_from_axis_angle(r: [f64; 3]) -> [f64; 4] {
    let theta = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    // sin(θ/2)/θ, with its series near 0.
    let k = if theta < 1e-6 {
        0.5 - theta * theta / 48.0
    } else {
        (theta / 2.0).sin() / theta
    };
    [(theta / 2.0).cos(), r[0] * k, r[1] * k, r[2] * k]
}

/// Axis-angle of a unit quaternion through its w ≥ 0 representative (angle in [0, π]).
pub fn quat_to_axis_angle(q: [f64; 4]) -> [f64; 3] {
    let q = if q[0] < 0.0 { q.map(|v| -v) } else { q };
    let v = (q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if v < 1e-12 {
        return [2.0 * q[1], 2.0 * q[2], 2.0 * q[3]];
    }
    let angle = 2.0 * v.atan2(q[0]);
    [q[1] / v * angle, q[2] / v * angle, q[3] / v * angle]
}

fn dot(a: [f64; 4], b: [f64; 4]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3]
}

fn normalise(q: [f64; 4]) -> [f64; 4] {
    let n = dot(q, q).sqrt();
    q.map(|v| v / n)
}

/// Spherical linear interpolation on the shortest arc: q2 → −q2 when ⟨q1, q2⟩ < 0; the normalised lerp
/// when θ < 1e-6.
pub fn slerp(q1: [f64; 4], q2: [f64; 4], u: f64) -> [f64; 4] {
    let mut q2 = q2;
    let mut d = dot(q1, q2);
    if d < 0.0 {
        q2 = q2.map(|v| -v);
        d = -d;
    }
    let theta = d.clamp(-1.0, 1.0).acos();
    let out: [f64; 4] = if theta < 1e-6 {
        std::array::from_fn(|i| (1.0 - u) * q1[i] + u * q2[i])
    } else {
        let s = theta.sin();
        let (w1, w2) = (((1.0 - u) * theta).sin() / s, (u * theta).sin() / s);
        std::array::from_fn(|i| w1 * q1[i] + w2 * q2[i])
    };
    normalise(out)
}

/// Rebuild every frame that is not a key by linear translation and per-joint SLERP between the keys
/// around it. Keys (sorted, in range) are copied exactly; frames before the first or after the last key
/// hold that key.
pub fn inbetween(motion: &Motion, keys: &[usize]) -> Motion {
    assert!(!keys.is_empty(), "inbetween needs at least one key");
    assert!(keys.windows(2).all(|w| w[0] < w[1]) && *keys.last().unwrap() < motion.frames);
    let mut out = motion.clone();
    let copy_frame = |out: &mut Motion, to: usize, from: usize| {
        out.poses.copy_within(from * 72..from * 72 + 72, to * 72);
        out.trans.copy_within(from * 3..from * 3 + 3, to * 3);
    };
    for t in 0..keys[0] {
        copy_frame(&mut out, t, keys[0]);
    }
    let last = *keys.last().unwrap();
    for t in last + 1..motion.frames {
        copy_frame(&mut out, t, last);
    }
    for w in keys.windows(2) {
        let (t1, t2) = (w[0], w[1]);
        let q1: Vec<[f64; 4]> = (0..24)
            .map(|j| quat_from_axis_angle(aa(motion, t1, j)))
            .collect();
        let q2: Vec<[f64; 4]> = (0..24)
            .map(|j| quat_from_axis_angle(aa(motion, t2, j)))
            .collect();
        for t in t1 + 1..t2 {
            let u = (t - t1) as f64 / (t2 - t1) as f64;
            for j in 0..24 {
                let r = quat_to_axis_angle(slerp(q1[j], q2[j], u));
                out.poses[t * 72 + 3 * j..t * 72 + 3 * j + 3].copy_from_slice(&r);
            }
            for a in 0..3 {
                out.trans[t * 3 + a] =
                    (1.0 - u) * motion.trans[t1 * 3 + a] + u * motion.trans[t2 * 3 + a];
            }
        }
    }
    out
}

fn aa(m: &Motion, t: usize, j: usize) -> [f64; 3] {
    let b = t * 72 + 3 * j;
    [m.poses[b], m.poses[b + 1], m.poses[b + 2]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use qean_motion::rotation::{axis_angle_to_matrix, Mat3};
    use rand::{Rng, SeedableRng};

    fn random_quat(rng: &mut impl Rng) -> [f64; 4] {
        normalise(std::array::from_fn(|_| rng.random_range(-1.0..1.0)))
    }

    fn quat_mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
        [
            a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
            a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
            a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
            a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0],
        ]
    }

    fn quat_matrix(q: [f64; 4]) -> Mat3 {
        axis_angle_to_matrix(quat_to_axis_angle(q))
    }

    fn max_diff(a: &[f64], b: &[f64]) -> f64 {
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn slerp_properties() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for _ in 0..100 {
            let (q1, q2) = (random_quat(&mut rng), random_quat(&mut rng));
            assert!(max_diff(&slerp(q1, q2, 0.0), &q1) < 1e-12);
            let end = slerp(q1, q2, 1.0);
            assert!(max_diff(&quat_matrix(end), &quat_matrix(q2)) < 1e-12);
            let neg = q2.map(|v| -v);
            // q2 and −q2 are the same rotation and give the same path, step for step.
            let mut angles = vec![];
            for s in 0..=10 {
                let u = s as f64 / 10.0;
                let a = slerp(q1, q2, u);
                assert!((dot(a, a) - 1.0).abs() < 1e-12);
                assert!(max_diff(&quat_matrix(a), &quat_matrix(slerp(q1, neg, u))) < 1e-12);
                angles.push(a);
            }
            // Constant angular speed: equal steps subtend equal angles.
            let step = |a: [f64; 4], b: [f64; 4]| dot(a, b).abs().min(1.0).acos();
            let first = step(angles[0], angles[1]);
            for w in angles.windows(2) {
                assert!((step(w[0], w[1]) - first).abs() < 1e-9);
            }
            // Equals q1·(q1⁻¹·q2)^u on the shortest arc.
            let mut q2s = q2;
            if dot(q1, q2) < 0.0 {
                q2s = neg;
            }
            let inv = [q1[0], -q1[1], -q1[2], -q1[3]];
            let rel = quat_mul(inv, q2s);
            let half = rel[0].clamp(-1.0, 1.0).acos();
            let vn = (rel[1] * rel[1] + rel[2] * rel[2] + rel[3] * rel[3]).sqrt();
            let u = 0.37;
            let pow = if vn < 1e-15 {
                [1.0, 0.0, 0.0, 0.0]
            } else {
                let s = (u * half).sin() / vn;
                [(u * half).cos(), rel[1] * s, rel[2] * s, rel[3] * s]
            };
            assert!(max_diff(&slerp(q1, q2, u), &quat_mul(q1, pow)) < 1e-12);
        }
    }

    #[test]
    fn tiny_angle_branch_is_continuous() {
        let q1 = quat_from_axis_angle([0.3, 0.1, -0.2]);
        let q2 = quat_from_axis_angle([0.3 + 1e-7, 0.1, -0.2]);
        let q3 = quat_from_axis_angle([0.3 + 3e-6, 0.1, -0.2]);
        let a = slerp(q1, q2, 0.5);
        let b = slerp(q1, q3, 0.5);
        assert!(max_diff(&a, &b) < 2e-6);
        assert!(max_diff(&a, &q1) < 1e-7);
    }

    #[test]
    fn constant_rate_rotation_is_rebuilt_exactly() {
        // Every joint turns at a constant rate about a fixed axis; the root moves on a line.
        let frames = 31;
        let mut poses = vec![0.0; frames * 72];
        let mut trans = vec![0.0; frames * 3];
        for t in 0..frames {
            for j in 0..24 {
                let angle = 0.05 * t as f64 * (1.0 + j as f64 / 24.0);
                let axis = [0.6, 0.0, 0.8];
                for a in 0..3 {
                    poses[t * 72 + 3 * j + a] = axis[a] * angle;
                }
            }
            trans[t * 3] = 0.01 * t as f64;
            trans[t * 3 + 1] = 0.9;
        }
        let m = Motion::new(poses, trans, 1.0).unwrap();
        let keys = [0, 10, 30];
        let out = inbetween(&m, &keys);
        assert!(max_diff(&out.poses, &m.poses) < 1e-12);
        assert!(max_diff(&out.trans, &m.trans) < 1e-12);
        for &k in &keys {
            assert_eq!(out.poses[k * 72..k * 72 + 72], m.poses[k * 72..k * 72 + 72]);
        }
    }

    #[test]
    fn quaternion_axis_angle_round_trip() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for _ in 0..100 {
            let r: [f64; 3] = std::array::from_fn(|_| rng.random_range(-1.7..1.7));
            let back = quat_to_axis_angle(quat_from_axis_angle(r));
            assert!(max_diff(&back, &r) < 1e-12);
        }
        assert_eq!(quat_from_axis_angle([0.0; 3]), [1.0, 0.0, 0.0, 0.0]);
    }
}
