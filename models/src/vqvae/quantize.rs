//! The EMA quantiser with dead-code reset (SPEC §13.2.3, T2M-GPT `QuantizeEMAReset`), in plain Rust: the
//! codebook statistics live on the host (they are not parameters), so one implementation serves training,
//! tokenisation and the parity fixtures. z rows are batch-major, time-minor (row = b·n + t).

use serde::{Deserialize, Serialize};

/// The randomness an EMA step draws: uniform and normal numbers, and permutations (ChaCha in training,
/// SplitMix64 for the parity fixtures of §13.12).
pub trait EmaRng {
    fn normal(&mut self) -> f64;
    /// A permutation of 0..n (Fisher–Yates from the top, j = draw mod (i + 1)).
    fn permutation(&mut self, n: usize) -> Vec<usize>;
}

/// SplitMix64 (SPEC §13.12), portable, for parity fixtures.
#[derive(Debug, Clone)]
pub struct SplitMix64(pub u64);

impl SplitMix64 {
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

impl EmaRng for SplitMix64 {
    fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    fn permutation(&mut self, n: usize) -> Vec<usize> {
        let mut p: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() {
            let j = (self.next_u64() % (i as u64 + 1)) as usize;
            p.swap(i, j);
        }
        p
    }
}

/// ChaCha8 as an [`EmaRng`] (training: seeded per update).
pub struct ChaChaEma(pub rand_chacha::ChaCha8Rng);

impl EmaRng for ChaChaEma {
    fn normal(&mut self) -> f64 {
        use rand::Rng;
        let (u1, u2): (f64, f64) = (self.0.random(), self.0.random());
        (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    }

    fn permutation(&mut self, n: usize) -> Vec<usize> {
        use rand::Rng;
        let mut p: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() {
            let j = self.0.random_range(0..=i);
            p.swap(i, j);
        }
        p
    }
}

/// How codes are reset.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EmaOptions {
    /// μ (0.99).
    pub mu: f32,
    /// Shuffle the candidates first (Bailando/Jukebox) instead of taking row k.
    pub randperm: bool,
    /// A reset code's statistics become (candidate, 1).
    pub reset_stats: bool,
}

impl Default for EmaOptions {
    fn default() -> Self {
        EmaOptions {
            mu: 0.99,
            randperm: false,
            reset_stats: false,
        }
    }
}

/// The codebook and its EMA statistics (f32, as the reference).
#[derive(Debug, Clone, PartialEq)]
pub struct EmaCodebook {
    pub codes: usize,
    pub dim: usize,
    /// e: K × C.
    pub codebook: Vec<f32>,
    pub code_sum: Vec<f32>,
    pub code_count: Vec<f32>,
    pub initialised: bool,
}

/// What one training step reports.
#[derive(Debug, Clone, PartialEq)]
pub struct EmaStep {
    /// The code of each z row, assigned with the codebook before the update.
    pub indices: Vec<usize>,
    /// exp(−Σ p log(p + 1e-7)), p = n/N.
    pub perplexity: f64,
    /// Codes reset by this update.
    pub reset: usize,
}

/// argmin_k Σ_c (z_c − e_k,c)² for each row of z (N × C); ties go to the lowest k.
pub fn assign(z: &[f32], codebook: &[f32], dim: usize) -> Vec<usize> {
    let codes = codebook.len() / dim;
    z.chunks_exact(dim)
        .map(|row| {
            let mut best = (f64::INFINITY, 0);
            for k in 0..codes {
                let e = &codebook[k * dim..(k + 1) * dim];
                let d: f64 = row
                    .iter()
                    .zip(e)
                    .map(|(a, b)| {
                        let x = (*a - *b) as f64;
                        x * x
                    })
                    .sum();
                if d < best.0 {
                    best = (d, k);
                }
            }
            best.1
        })
        .collect()
}

impl EmaCodebook {
    /// An uninitialised codebook (zeros; the first training batch fills it).
    pub fn new(codes: usize, dim: usize) -> Self {
        EmaCodebook {
            codes,
            dim,
            codebook: vec![0.0; codes * dim],
            code_sum: vec![0.0; codes * dim],
            code_count: vec![0.0; codes],
            initialised: false,
        }
    }

    /// T2M-GPT `_tile`: z when N ≥ K, else z tiled ⌈K/N⌉ times plus N(0, (0.01/√C)²) noise; then
    /// (`randperm`) shuffled. The first K rows are the candidates.
    fn candidates(&self, z: &[f32], rng: &mut dyn EmaRng, opts: &EmaOptions) -> Vec<f32> {
        let (k_n, c) = (self.codes, self.dim);
        let n = z.len() / c;
        let mut rows = if n >= k_n {
            z.to_vec()
        } else {
            let reps = k_n.div_ceil(n);
            let std = 0.01 / (c as f64).sqrt();
            let mut out = Vec::with_capacity(reps * z.len());
            for _ in 0..reps {
                out.extend_from_slice(z);
            }
            for v in out.iter_mut() {
                *v += (rng.normal() * std) as f32;
            }
            out
        };
        if opts.randperm {
            let m = rows.len() / c;
            let p = rng.permutation(m);
            let src = rows.clone();
            for (i, &j) in p.iter().enumerate() {
                rows[i * c..(i + 1) * c].copy_from_slice(&src[j * c..(j + 1) * c]);
            }
        }
        rows.truncate(k_n * c);
        rows
    }

    /// One training forward's codebook work, in SPEC §13.2.3's order: init (first batch only), assign
    /// with the current codes, then the EMA update and the reset of codes whose count fell below 1.
    pub fn train_step(&mut self, z: &[f32], rng: &mut dyn EmaRng, opts: &EmaOptions) -> EmaStep {
        self.init_if_needed(z, rng, opts);
        let indices = assign(z, &self.codebook, self.dim);
        let (perplexity, reset) = self.update(z, &indices, rng, opts);
        EmaStep {
            indices,
            perplexity,
            reset,
        }
    }

    /// Step 1: on the first training batch, the codebook and its sums become the candidates, counts 1.
    pub fn init_if_needed(&mut self, z: &[f32], rng: &mut dyn EmaRng, opts: &EmaOptions) {
        assert!(
            !z.is_empty() && z.len().is_multiple_of(self.dim),
            "z must be N × C"
        );
        if !self.initialised {
            let cand = self.candidates(z, rng, opts);
            self.codebook.copy_from_slice(&cand);
            self.code_sum.copy_from_slice(&cand);
            self.code_count.fill(1.0);
            self.initialised = true;
        }
    }

    /// Codebook rows of `indices`, concatenated.
    pub fn rows(&self, indices: &[usize]) -> Vec<f32> {
        let c = self.dim;
        indices
            .iter()
            .flat_map(|&k| self.codebook[k * c..(k + 1) * c].iter().copied())
            .collect()
    }

    /// Step 4: the EMA update with this batch's assignment; returns (perplexity, codes reset).
    pub fn update(
        &mut self,
        z: &[f32],
        indices: &[usize],
        rng: &mut dyn EmaRng,
        opts: &EmaOptions,
    ) -> (f64, usize) {
        let (k_n, c) = (self.codes, self.dim);
        let mut counts = vec![0f32; k_n];
        let mut sums = vec![0f32; k_n * c];
        for (row, &k) in z.chunks_exact(c).zip(indices) {
            counts[k] += 1.0;
            for (s, v) in sums[k * c..(k + 1) * c].iter_mut().zip(row) {
                *s += v;
            }
        }
        let cand = self.candidates(z, rng, opts);
        let mu = opts.mu;
        let mut reset = 0;
        for k in 0..k_n {
            self.code_count[k] = mu * self.code_count[k] + (1.0 - mu) * counts[k];
            let block = k * c..(k + 1) * c;
            for (s, new) in self.code_sum[block.clone()].iter_mut().zip(&sums[block]) {
                *s = mu * *s + (1.0 - mu) * new;
            }
            // The usage test guards the division (the reference divides first).
            if self.code_count[k] >= 1.0 {
                let count = self.code_count[k];
                for i in k * c..(k + 1) * c {
                    self.codebook[i] = self.code_sum[i] / count;
                }
            } else {
                reset += 1;
                self.codebook[k * c..(k + 1) * c].copy_from_slice(&cand[k * c..(k + 1) * c]);
                if opts.reset_stats {
                    self.code_sum[k * c..(k + 1) * c].copy_from_slice(&cand[k * c..(k + 1) * c]);
                    self.code_count[k] = 1.0;
                }
            }
        }
        (perplexity(&counts, indices.len()), reset)
    }
}

/// exp(−Σ p log(p + 1e-7)), p = n_k/N.
pub fn perplexity(counts: &[f32], n: usize) -> f64 {
    let h: f64 = counts
        .iter()
        .map(|&c| {
            let p = c as f64 / n.max(1) as f64;
            -p * (p + 1e-7).ln()
        })
        .sum();
    h.exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix_first_output_and_ties_to_the_lowest_code() {
        assert_eq!(SplitMix64(0).next_u64(), 0xE220_A839_7B1D_CDAF);
        let codebook = [1.0, 0.0, 0.0, 1.0, 1.0, 0.0];
        // Row (0.5, 0.5) is equally far from codes 0 and 1 (and 2 = 0): the lowest wins.
        assert_eq!(assign(&[0.5, 0.5, 1.0, 0.1], &codebook, 2), vec![0, 0]);
        assert_eq!(assign(&[0.1, 0.9], &codebook, 2), vec![1]);
    }

    #[test]
    fn init_update_and_reset() {
        // N = 4 ≥ K = 3: the codebook starts as the first 3 rows, two of them equal.
        let z = [0.0f32, 0.0, 0.0, 0.0, 1.0, 1.0, 1.2, 1.0];
        let mut cb = EmaCodebook::new(3, 2);
        let mut rng = SplitMix64(1);
        let opts = EmaOptions::default();
        let step = cb.train_step(&z, &mut rng, &opts);
        // Rows 0 and 1 tie between codes 0 and 1: code 0. Rows 2 and 3 → code 2.
        assert_eq!(step.indices, vec![0, 0, 2, 2]);
        // Code 1: count 0.99 < 1 → reset to candidate row 1 (z row 1), statistics kept.
        assert_eq!(step.reset, 1);
        assert_eq!(&cb.codebook[2..4], &[0.0, 0.0]);
        assert_eq!(cb.code_count[1], opts.mu);
        let mu = opts.mu;
        let count = mu * 1.0 + (1.0 - mu) * 2.0;
        assert_eq!(cb.code_count[2], count);
        assert!((cb.codebook[4] - (mu * 1.0 + (1.0 - mu) * 2.2) / count).abs() < 1e-6);
        assert!((step.perplexity - 2.0).abs() < 1e-5, "{}", step.perplexity);
        // reset_stats: the reset code's statistics become (candidate, 1).
        let mut cb = EmaCodebook::new(3, 2);
        let opts = EmaOptions {
            reset_stats: true,
            ..opts
        };
        cb.train_step(&z, &mut rng, &opts);
        assert_eq!(cb.code_count[1], 1.0);
    }

    #[test]
    fn unused_codes_never_divide_by_zero() {
        let mut cb = EmaCodebook::new(4, 2);
        let mut rng = SplitMix64(7);
        let z = [1.0f32, 2.0];
        for _ in 0..20_000 {
            cb.train_step(&z, &mut rng, &EmaOptions::default());
        }
        assert!(cb.codebook.iter().all(|v| v.is_finite()));
        assert!(cb.code_count.iter().all(|v| v.is_finite()));
    }
}
