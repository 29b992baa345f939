//! The motion VQ-VAE's representation `pos72` (SPEC §13.2.1, after Bailando's `global_vel`): per frame the
//! root's velocity and the 23 other joints relative to the root, x_t = [v | J_j(t) − J_0(t), j = 1..23],
//! with v(t) = J_0(t+1) − J_0(t) (the last frame repeats the one before). Decoding integrates the root from
//! a given J_0(0).

use serde::{Deserialize, Serialize};

/// Values per frame.
pub const POS72: usize = 72;
/// Joints per frame.
const J: usize = 24;

/// What the first three channels hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum RootChannels {
    /// The root's velocity per frame (x, y, z).
    #[default]
    Velocity,
    /// Velocity in x and z; channel 1 is the root's height above the sequence's lowest joint.
    Floor,
}

/// How `pos72` is built.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Pos72Options {
    pub root: RootChannels,
    /// A factor on the velocity channels (1; e.g. 60 for metres per second).
    pub root_vel_scale: f64,
}

impl Default for Pos72Options {
    fn default() -> Self {
        Pos72Options {
            root: RootChannels::Velocity,
            root_vel_scale: 1.0,
        }
    }
}

/// Joints (T × 24 points, metres, y up) → pos72 rows (T × 72).
pub fn joints_to_pos72(joints: &[[f64; 3]], opts: &Pos72Options) -> Vec<f64> {
    assert!(
        joints.len().is_multiple_of(J),
        "joints must be frames × 24 points"
    );
    let t_n = joints.len() / J;
    let root = |t: usize| joints[t * J];
    let velocity = |t: usize| -> [f64; 3] {
        let (a, b) = match t_n {
            0 | 1 => return [0.0; 3],
            _ if t + 1 < t_n => (t, t + 1),
            _ => (t_n - 2, t_n - 1),
        };
        let (p, q) = (root(a), root(b));
        [q[0] - p[0], q[1] - p[1], q[2] - p[2]]
    };
    let floor = joints.iter().map(|p| p[1]).fold(f64::INFINITY, f64::min);
    let mut out = Vec::with_capacity(t_n * POS72);
    for t in 0..t_n {
        let v = velocity(t);
        let s = opts.root_vel_scale;
        match opts.root {
            RootChannels::Velocity => out.extend([v[0] * s, v[1] * s, v[2] * s]),
            RootChannels::Floor => out.extend([v[0] * s, root(t)[1] - floor, v[2] * s]),
        }
        let r = root(t);
        for j in 1..J {
            let p = joints[t * J + j];
            out.extend([p[0] - r[0], p[1] - r[1], p[2] - r[2]]);
        }
    }
    out
}

/// pos72 rows (T × 72) → joints (T × 24 points), the root integrated from `start` = J_0(0).
pub fn pos72_to_joints(x: &[f64], start: [f64; 3], opts: &Pos72Options) -> Vec<[f64; 3]> {
    assert!(
        x.len().is_multiple_of(POS72),
        "pos72 rows must be frames × 72"
    );
    let t_n = x.len() / POS72;
    let s = opts.root_vel_scale;
    // With `floor`, the height channel is relative to a floor that J_0(0) fixes.
    let floor = if opts.root == RootChannels::Floor && t_n > 0 {
        start[1] - x[1]
    } else {
        0.0
    };
    let mut out = Vec::with_capacity(t_n * J);
    let mut root = start;
    for t in 0..t_n {
        let row = &x[t * POS72..(t + 1) * POS72];
        if opts.root == RootChannels::Floor {
            root[1] = floor + row[1];
        }
        out.push(root);
        for j in 1..J {
            let d = &row[3 * j..3 * j + 3];
            out.push([root[0] + d[0], root[1] + d[1], root[2] + d[2]]);
        }
        root[0] += row[0] / s;
        root[2] += row[2] / s;
        if opts.root == RootChannels::Velocity {
            root[1] += row[1] / s;
        }
    }
    out
}

/// The same as [`joints_to_pos72`] in f32 rows (what the model reads).
pub fn joints_to_pos72_f32(joints: &[[f64; 3]], opts: &Pos72Options) -> Vec<f32> {
    joints_to_pos72(joints, opts)
        .into_iter()
        .map(|v| v as f32)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wobbly(frames: usize) -> Vec<[f64; 3]> {
        (0..frames * J)
            .map(|i| {
                let (t, j) = ((i / J) as f64, (i % J) as f64);
                [
                    (0.3 * t + j).sin() + 0.01 * t,
                    0.9 + 0.2 * (0.2 * t + 0.5 * j).cos(),
                    (0.1 * t * j).cos() - 0.02 * t,
                ]
            })
            .collect()
    }

    #[test]
    fn round_trip_is_exact_both_root_modes() {
        let joints = wobbly(37);
        for opts in [
            Pos72Options::default(),
            Pos72Options {
                root: RootChannels::Floor,
                root_vel_scale: 60.0,
            },
        ] {
            let x = joints_to_pos72(&joints, &opts);
            assert_eq!(x.len(), 37 * POS72);
            let back = pos72_to_joints(&x, joints[0], &opts);
            let worst = back
                .iter()
                .zip(&joints)
                .flat_map(|(a, b)| (0..3).map(move |k| (a[k] - b[k]).abs()))
                .fold(0.0, f64::max);
            assert!(worst < 1e-12, "{opts:?}: {worst:e}");
        }
    }

    #[test]
    fn layout_velocity_and_last_frame() {
        let joints = wobbly(5);
        let x = joints_to_pos72(&joints, &Pos72Options::default());
        // v(0) = J_0(1) − J_0(0); v(T−1) = v(T−2); joint 1 relative to the root.
        assert_eq!(x[0], joints[J][0] - joints[0][0]);
        assert_eq!(&x[4 * POS72..4 * POS72 + 3], &x[3 * POS72..3 * POS72 + 3]);
        assert_eq!(x[3 + 1], joints[1][1] - joints[0][1]);
        // One frame: no velocity.
        let one = joints_to_pos72(&joints[..J], &Pos72Options::default());
        assert_eq!(&one[..3], &[0.0; 3]);
    }
}
