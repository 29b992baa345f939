//! NMFD drum activations (SPEC §12.3d, Lin §3.3.2 after Smaragdis 2004): a magnitude spectrogram V
//! (bins × frames) ≈ Σ_τ W_τ·shift_τ(H), with R templates of T frames. The update rules, normalisation and
//! initialisation are libnmfd 1.0.0's `nmfd` (Kullback–Leibler, random templates from seed 42, H = 1).

use crate::mt19937::Mt19937;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// libnmfd's EPS.
const EPS: f64 = f64::EPSILON;

/// NMFD sizes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct NmfdSize {
    /// R: components.
    pub components: usize,
    /// L: iterations.
    pub iterations: usize,
    /// T: frames per template.
    pub template_frames: usize,
}

impl Default for NmfdSize {
    fn default() -> Self {
        NmfdSize {
            components: 3,
            iterations: 30,
            template_frames: 8,
        }
    }
}

/// The factorisation: activations H (R × M, row-major), templates W (K × R × T) and the cost before
/// each iteration.
#[derive(Debug, Clone)]
pub struct Nmfd {
    pub activations: Vec<f64>,
    pub templates: Vec<f64>,
    pub components: usize,
    pub frames: usize,
    pub cost: Vec<f64>,
}

impl Nmfd {
    /// Row r of H.
    pub fn activation(&self, r: usize) -> &[f64] {
        &self.activations[r * self.frames..(r + 1) * self.frames]
    }

    /// c = Σ_r w_r·H[r] (SPEC §12.3d step 4).
    pub fn curve(&self, weights: &[f64]) -> Vec<f64> {
        let mut c = vec![0.0; self.frames];
        for (r, &w) in weights.iter().enumerate().take(self.components) {
            for (ci, h) in c.iter_mut().zip(self.activation(r)) {
                *ci += w * h;
            }
        }
        c
    }
}

/// libnmfd `init_templates(strategy="random")`: np.random.seed(42); W_r = rand(K, T) row-major, each
/// divided by (EPS + its sum). Returned as W[k][r][τ] flattened (K × R × T).
pub fn random_templates(bins: usize, size: &NmfdSize) -> Vec<f64> {
    let (r_n, t_n) = (size.components, size.template_frames);
    let mut w = vec![0.0; bins * r_n * t_n];
    let mut rng = Mt19937::new(42);
    for r in 0..r_n {
        let mut sum = 0.0;
        for k in 0..bins {
            for t in 0..t_n {
                let v = rng.next_f64();
                w[(k * r_n + r) * t_n + t] = v;
                sum += v;
            }
        }
        for k in 0..bins {
            for t in 0..t_n {
                w[(k * r_n + r) * t_n + t] /= EPS + sum;
            }
        }
    }
    w
}

/// libnmfd `initialize_drum_specific_nmfd_templates` after its STFT: per drum class (kick, snare, hi-hat),
/// a one-component NMFD of the class's spectrogram, started from `init_templates(1, K, "random")` (one
/// seed-42 column over (EPS + its sum), which `nmfd` broadcasts to all T frames) and H = 1; each learnt
/// template then divided by (EPS + its sum) as `init_templates(strategy="drums")` does. Returns W
/// (K × R × T) with R = the number of classes. `class_spectra` are K × M_c row-major magnitudes.
pub fn drum_templates(class_spectra: &[&[f64]], bins: usize, size: &NmfdSize) -> Vec<f64> {
    let (r_n, t_n) = (class_spectra.len(), size.template_frames);
    let one = NmfdSize {
        components: 1,
        ..*size
    };
    let mut rng = Mt19937::new(42);
    let column: Vec<f64> = (0..bins).map(|_| rng.next_f64()).collect();
    let sum: f64 = column.iter().sum();
    let w0: Vec<f64> = column
        .iter()
        .flat_map(|c| std::iter::repeat_n(c / (EPS + sum), t_n))
        .collect();
    let mut w = vec![0.0; bins * r_n * t_n];
    for (r, v) in class_spectra.iter().enumerate() {
        let learnt = nmfd_from(v, bins, &one, w0.clone()).templates;
        let total: f64 = learnt.iter().sum();
        for k in 0..bins {
            for t in 0..t_n {
                w[(k * r_n + r) * t_n + t] = learnt[k * t_n + t] / (EPS + total);
            }
        }
    }
    w
}

/// Factorise V (K × M, row-major magnitudes) from libnmfd's seed-42 random templates.
pub fn nmfd(v: &[f64], bins: usize, size: &NmfdSize) -> Nmfd {
    nmfd_from(v, bins, size, random_templates(bins, size))
}

/// Λ = Σ_τ W_τ·shift_τ(H) + EPS (K × M), for W (K × R × T) and H (R × M).
fn approximate(lambda: &mut [f64], w: &[f64], h: &[f64], (r_n, t_n, m_n): (usize, usize, usize)) {
    lambda.par_chunks_mut(m_n).enumerate().for_each(|(k, row)| {
        row.fill(0.0);
        let mut tmp = vec![0.0; m_n];
        for t in 0..t_n {
            tmp.fill(0.0);
            for r in 0..r_n {
                let wk = w[(k * r_n + r) * t_n + t];
                let hr = &h[r * m_n..(r + 1) * m_n];
                for m in t..m_n {
                    tmp[m] += wk * hr[m - t];
                }
            }
            for (l, x) in row.iter_mut().zip(&tmp) {
                *l += x;
            }
        }
        for l in row.iter_mut() {
            *l += EPS;
        }
    });
}

/// Templates to unit sum per component (H is not rescaled: a libnmfd quirk kept).
fn normalise_templates(w: &mut [f64], (k_n, r_n, t_n): (usize, usize, usize)) {
    for r in 0..r_n {
        let mut norm = 0.0;
        for k in 0..k_n {
            for t in 0..t_n {
                norm += w[(k * r_n + r) * t_n + t];
            }
        }
        let f = 1.0 / (EPS + norm);
        for k in 0..k_n {
            for t in 0..t_n {
                w[(k * r_n + r) * t_n + t] *= f;
            }
        }
    }
}

/// Factorise V from the templates `w0` (K × R × T, e.g. [`drum_templates`]) and H = 1.
pub fn nmfd_from(v: &[f64], bins: usize, size: &NmfdSize, w0: Vec<f64>) -> Nmfd {
    let (k_n, r_n, t_n) = (bins, size.components, size.template_frames);
    let m_n = v.len() / bins;
    assert_eq!(v.len(), k_n * m_n, "V must be bins × frames");
    assert_eq!(
        w0.len(),
        k_n * r_n * t_n,
        "W must be bins × components × frames"
    );
    let mut w = w0;
    let mut h = vec![1.0; r_n * m_n];
    let total: f64 = v.iter().sum();
    let vn: Vec<f64> = v.iter().map(|x| x / (EPS + total)).collect();
    let mut cost = Vec::with_capacity(size.iterations);
    let mut lambda = vec![0.0; k_n * m_n];
    let mut q = vec![0.0; k_n * m_n];
    for _ in 0..size.iterations {
        approximate(&mut lambda, &w, &h, (r_n, t_n, m_n));
        let c: f64 = vn
            .par_iter()
            .zip(&lambda)
            .map(|(&x, &l)| x * (1.0 + x / (l + EPS)).ln() - x + l)
            .sum();
        cost.push(c / (k_n * m_n) as f64);
        q.par_iter_mut()
            .zip(vn.par_iter().zip(&lambda))
            .for_each(|(qi, (&x, &l))| *qi = x / (l + EPS));

        let mut mult_h = vec![0.0; r_n * m_n];
        for t in 0..t_n {
            // W_τ ∗= (Q·shift_τ(H)ᵀ) / (1·shift_τ(H)ᵀ + EPS).
            let den: Vec<f64> = (0..r_n)
                .map(|r| h[r * m_n..r * m_n + (m_n - t.min(m_n))].iter().sum::<f64>())
                .collect();
            w.par_chunks_mut(r_n * t_n).enumerate().for_each(|(k, wk)| {
                let qk = &q[k * m_n..(k + 1) * m_n];
                for r in 0..r_n {
                    let hr = &h[r * m_n..(r + 1) * m_n];
                    let num: f64 = (t..m_n).map(|m| qk[m] * hr[m - t]).sum();
                    wk[r * t_n + t] *= num / (den[r] + EPS);
                }
            });
            // mult_H += (W_τᵀ·shift_{−τ}(Q)) / (W_τᵀ·1 + EPS), with the updated W_τ.
            for r in 0..r_n {
                let col: Vec<f64> = (0..k_n).map(|k| w[(k * r_n + r) * t_n + t]).collect();
                let wsum: f64 = col.iter().sum();
                let acc = &mut mult_h[r * m_n..(r + 1) * m_n];
                acc.par_chunks_mut(256)
                    .enumerate()
                    .for_each(|(chunk, out)| {
                        let m0 = chunk * 256;
                        for (i, o) in out.iter_mut().enumerate() {
                            let m = m0 + i;
                            if m + t >= m_n {
                                continue;
                            }
                            let s: f64 = (0..k_n).map(|k| col[k] * q[k * m_n + m + t]).sum();
                            *o += s / (wsum + EPS);
                        }
                    });
            }
        }
        for (hi, mi) in h.iter_mut().zip(&mult_h) {
            *hi *= mi / t_n as f64;
        }
        normalise_templates(&mut w, (k_n, r_n, t_n));
    }
    Nmfd {
        activations: h,
        templates: w,
        components: r_n,
        frames: m_n,
        cost,
    }
}
