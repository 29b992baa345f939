//! TSMT's pose tokens (SPEC §11.2): root-relative joint coordinates, each cut into C bins fitted on
//! the training split. The bins are stored as f64 in the run config and the checkpoint and never
//! recomputed at inference.

use qean_config::tsmt::{BinsMode, RootMode, TsmtConfig};
use qean_motion::skeleton::NUM_JOINTS as JOINTS;

/// The coordinates of every frame, frames × n (n = 69, or 72 with `RootMode::Delta`), joint-major:
/// x[3(j−1) + a] = p_j[a] − p_0[a] for j = 1..23; `Delta` appends (Δx, y, Δz) of the root, the
/// ground-plane step from the previous frame (0 on the first) and the height.
pub fn pose_coords(joints: &[[f64; 3]], root: RootMode) -> Vec<f64> {
    let frames = joints.len() / JOINTS;
    let mut out = Vec::with_capacity(frames * 72);
    for t in 0..frames {
        let p = &joints[t * JOINTS..(t + 1) * JOINTS];
        for joint in &p[1..] {
            out.extend((0..3).map(|a| joint[a] - p[0][a]));
        }
        if root == RootMode::Delta {
            let prev = if t == 0 {
                p[0]
            } else {
                joints[(t - 1) * JOINTS]
            };
            out.extend([p[0][0] - prev[0], p[0][1], p[0][2] - prev[2]]);
        }
    }
    out
}

/// Joint positions from coordinates (the inverse of [`pose_coords`]). `start` is the root before
/// the first frame: with `Drop` every frame's root is `start`; with `Delta` the ground-plane steps
/// are added up from `start` and the height is read from the coordinates.
pub fn coords_to_joints(coords: &[f64], root: RootMode, start: [f64; 3]) -> Vec<[f64; 3]> {
    let n = root.coords();
    let mut out = Vec::with_capacity(coords.len() / n * JOINTS);
    let mut r = start;
    for x in coords.chunks_exact(n) {
        if root == RootMode::Delta {
            r = [r[0] + x[69], x[70], r[2] + x[71]];
        }
        out.push(r);
        for j in 0..23 {
            out.push([r[0] + x[3 * j], r[1] + x[3 * j + 1], r[2] + x[3 * j + 2]]);
        }
    }
    out
}

/// The fitted bins: C bins of width (hi_d − lo_d)/C per coordinate d.
#[derive(Clone, Debug, PartialEq)]
pub struct Bins {
    pub n_bins: usize,
    pub lo: Vec<f64>,
    pub hi: Vec<f64>,
}

impl Bins {
    /// Fits lo/hi on `coords` (frames × `dim`): per coordinate, or one range for all (`Shared`).
    /// hi is raised to at least lo + 1e-6 so every bin has a width.
    pub fn fit(coords: &[f64], dim: usize, n_bins: usize, mode: BinsMode) -> Result<Bins, String> {
        Self::fit_many([coords], dim, n_bins, mode)
    }

    /// [`Bins::fit`] over several sequences at once (the training split, one sequence at a time).
    pub fn fit_many<'a>(
        sequences: impl IntoIterator<Item = &'a [f64]>,
        dim: usize,
        n_bins: usize,
        mode: BinsMode,
    ) -> Result<Bins, String> {
        let mut lo = vec![f64::INFINITY; dim];
        let mut hi = vec![f64::NEG_INFINITY; dim];
        let mut frames = 0;
        for coords in sequences {
            if dim == 0 || !coords.len().is_multiple_of(dim) {
                return Err(format!(
                    "cannot fit bins: {} values are not whole frames of {dim} coordinates",
                    coords.len()
                ));
            }
            if let Some(i) = coords.iter().position(|x| !x.is_finite()) {
                return Err(format!(
                    "cannot fit bins: coordinate {} of frame {} is not finite",
                    i % dim,
                    frames + i / dim
                ));
            }
            for frame in coords.chunks_exact(dim) {
                for (d, &x) in frame.iter().enumerate() {
                    lo[d] = lo[d].min(x);
                    hi[d] = hi[d].max(x);
                }
            }
            frames += coords.len() / dim;
        }
        if frames == 0 {
            return Err("cannot fit bins: no frames".into());
        }
        if mode == BinsMode::Shared {
            let (l, h) = (
                lo.iter().copied().fold(f64::INFINITY, f64::min),
                hi.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            );
            lo.fill(l);
            hi.fill(h);
        }
        for d in 0..dim {
            hi[d] = hi[d].max(lo[d] + 1e-6);
        }
        Ok(Bins { n_bins, lo, hi })
    }

    /// The bins a config stores, if it has them.
    pub fn from_config(c: &TsmtConfig) -> Option<Bins> {
        (!c.bins_lo.is_empty()).then(|| Bins {
            n_bins: c.n_bins,
            lo: c.bins_lo.clone(),
            hi: c.bins_hi.clone(),
        })
    }

    /// Coordinates per frame.
    pub fn dim(&self) -> usize {
        self.lo.len()
    }

    /// Width of coordinate `d`'s bins.
    pub fn width(&self, d: usize) -> f64 {
        (self.hi[d] - self.lo[d]) / self.n_bins as f64
    }

    /// The bin of value `x` of coordinate `d`: floor((x − lo)/w), clamped to 0..C−1.
    pub fn quantise(&self, d: usize, x: f64) -> usize {
        let k = ((x - self.lo[d]) / self.width(d)).floor();
        if k.is_nan() || k < 0.0 {
            0
        } else {
            (k as usize).min(self.n_bins - 1)
        }
    }

    /// The centre of bin `k` of coordinate `d`: lo + (k + ½)·w.
    pub fn dequantise(&self, d: usize, k: usize) -> f64 {
        self.lo[d] + (k as f64 + 0.5) * self.width(d)
    }

    /// Tokens of frames × dim coordinates.
    pub fn encode(&self, coords: &[f64]) -> Vec<u16> {
        let n = self.dim();
        coords
            .iter()
            .enumerate()
            .map(|(i, &x)| self.quantise(i % n, x) as u16)
            .collect()
    }

    /// Coordinates of frames × dim positions in bin units: lo + pos·w (a token k is at k + ½).
    pub fn decode_positions(&self, positions: &[f64]) -> Vec<f64> {
        let n = self.dim();
        positions
            .iter()
            .enumerate()
            .map(|(i, &pos)| self.lo[i % n] + pos * self.width(i % n))
            .collect()
    }

    /// Coordinates of frames × dim tokens.
    pub fn decode(&self, tokens: &[u16]) -> Vec<f64> {
        let n = self.dim();
        tokens
            .iter()
            .enumerate()
            .map(|(i, &k)| self.dequantise(i % n, k as usize))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wave(frames: usize, dim: usize) -> Vec<f64> {
        (0..frames * dim)
            .map(|i| {
                ((i % dim) as f64 * 0.37 + (i / dim) as f64 * 0.11).sin() * (1.0 + (i % dim) as f64)
            })
            .collect()
    }

    #[test]
    fn bins_round_trip_bound_and_clamp_in_both_modes() {
        let (frames, dim) = (50, 7);
        let x = wave(frames, dim);
        for mode in [BinsMode::PerDim, BinsMode::Shared] {
            let b = Bins::fit(&x, dim, 300, mode).unwrap();
            for d in 0..dim {
                assert!(b.lo[d] < b.hi[d]);
                // q(x̂(k)) = k for every bin.
                for k in 0..300 {
                    assert_eq!(b.quantise(d, b.dequantise(d, k)), k, "{mode:?} d {d} k {k}");
                }
                // The maximum falls in the last bin; out-of-range values clamp.
                assert_eq!(b.quantise(d, b.hi[d]), 299);
                assert_eq!(b.quantise(d, b.lo[d] - 5.0), 0);
                assert_eq!(b.quantise(d, b.hi[d] + 5.0), 299);
                assert_eq!(b.quantise(d, f64::NAN), 0);
            }
            let back = b.decode(&b.encode(&x));
            for (i, (a, r)) in x.iter().zip(&back).enumerate() {
                assert!(
                    (a - r).abs() <= b.width(i % dim) / 2.0 + 1e-12,
                    "{mode:?} {i}"
                );
            }
            // Positions at the centres decode as the tokens do.
            let centres: Vec<f64> = b.encode(&x).iter().map(|&k| k as f64 + 0.5).collect();
            for (p, q) in b.decode_positions(&centres).iter().zip(&back) {
                assert!((p - q).abs() < 1e-12);
            }
            // Idempotent: decoding and encoding again changes nothing.
            assert_eq!(b.encode(&back), b.encode(&x));
        }
        let shared = Bins::fit(&x, dim, 300, BinsMode::Shared).unwrap();
        assert!(shared.lo.iter().all(|&l| l == shared.lo[0]));
        // A constant coordinate still gets a width.
        let flat = Bins::fit(&[1.0, 1.0, 1.0], 1, 10, BinsMode::PerDim).unwrap();
        assert_eq!(flat.hi[0], 1.0 + 1e-6);
        assert!(Bins::fit(&[1.0, f64::NAN], 2, 10, BinsMode::PerDim).is_err());
        assert!(Bins::fit(&[1.0, 2.0, 3.0], 2, 10, BinsMode::PerDim).is_err());
    }

    #[test]
    fn coordinates_round_trip_for_both_root_modes() {
        let frames = 6;
        let joints: Vec<[f64; 3]> = (0..frames * JOINTS)
            .map(|i| {
                let (t, j) = ((i / JOINTS) as f64, (i % JOINTS) as f64);
                [
                    0.1 * t + 0.01 * j,
                    0.9 + 0.05 * j - 0.02 * t,
                    -0.2 * t + 0.03 * j * j,
                ]
            })
            .collect();
        for root in [RootMode::Drop, RootMode::Delta] {
            let c = pose_coords(&joints, root);
            assert_eq!(c.len(), frames * root.coords());
            let back = coords_to_joints(&c, root, joints[0]);
            for t in 0..frames {
                // Drop keeps the start root on every frame: compare relative positions.
                let shift = match root {
                    RootMode::Drop => [
                        joints[t * JOINTS][0] - joints[0][0],
                        joints[t * JOINTS][1] - joints[0][1],
                        joints[t * JOINTS][2] - joints[0][2],
                    ],
                    RootMode::Delta => [0.0; 3],
                };
                for j in 0..JOINTS {
                    for a in 0..3 {
                        let want = joints[t * JOINTS + j][a] - shift[a];
                        assert!(
                            (back[t * JOINTS + j][a] - want).abs() < 1e-12,
                            "{root:?} t {t} j {j}"
                        );
                    }
                }
            }
        }
    }
}
