//! How TSMT's predicted bins become coordinates (docs/tsmt.md, "Decoding"). SPEC §11.8 draws one bin per
//! coordinate and §11.2 takes its centre: that is `bin`, the paper's. The other decodings keep the model and
//! its tokens' meaning and change only how a distribution is read: `subbin` (the mean around the drawn bin),
//! `coherent` (one smooth quantile shared by the frame's coordinates, read continuously) and `mean`.

use qean_config::tsmt::TsmtDecode;

/// How one coordinate is read from its logits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading {
    /// Temperature τ (0 = the most likely bin, whatever the decoding).
    pub temperature: f64,
    /// Keep the k most likely bins (0 = all).
    pub top_k: usize,
    pub decode: TsmtDecode,
    /// `subbin`: bins on each side of the drawn bin.
    pub subbin_radius: usize,
}

/// The kept, unnormalised probabilities of SPEC §11.8 step 3: exp((l − max)/τ) over the k largest logits
/// (all with k = 0; ties to the lower index), 0 elsewhere.
pub fn weights(logits: &[f32], tau: f64, top_k: usize) -> Vec<f64> {
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
    logits
        .iter()
        .zip(&keep)
        .map(|(&v, &k)| {
            if k {
                ((v as f64 - max) / tau).exp()
            } else {
                0.0
            }
        })
        .collect()
}

/// The first maximum of `logits`.
pub fn argmax(logits: &[f32]) -> usize {
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
}

/// The inverse CDF of weights `p` at u ∈ [0, 1): the smallest kept k with cumsum(p)[k] > u·Σp (SPEC
/// §11.8), and where inside that bin the target falls, in [0, 1).
pub fn quantile(p: &[f64], u: f64) -> (usize, f64) {
    let target = u * p.iter().sum::<f64>();
    let mut cum = 0.0;
    let mut last_kept = 0;
    for (i, &pi) in p.iter().enumerate() {
        if pi > 0.0 {
            last_kept = i;
            if cum + pi > target {
                return (i, ((target - cum) / pi).clamp(0.0, ONE_BELOW));
            }
        }
        cum += pi;
    }
    (last_kept, ONE_BELOW)
}

/// The largest fraction that keeps a position inside its bin.
const ONE_BELOW: f64 = 1.0 - 1e-9;

/// The mean bin position Σ p_j (j + ½) / Σ p_j over bins `from..to`.
fn mean_position(p: &[f64], from: usize, to: usize) -> f64 {
    let (mut s, mut w) = (0.0, 0.0);
    for (j, &pj) in p.iter().enumerate().take(to).skip(from) {
        s += pj * (j as f64 + 0.5);
        w += pj;
    }
    s / w
}

/// One coordinate read from its logits with uniform `u`: the bin fed back to the model and the position in
/// bin units (the coordinate is lo + pos·w; bin k's centre is k + ½, and pos always lies in the returned
/// bin). With τ = 0 every decoding returns the most likely bin's centre.
pub fn read(logits: &[f32], r: &Reading, u: f64) -> (usize, f64) {
    if r.temperature == 0.0 || logits.len() == 1 {
        let k = argmax(logits);
        return (k, k as f64 + 0.5);
    }
    let p = weights(logits, r.temperature, r.top_k);
    match r.decode {
        TsmtDecode::Bin => {
            let k = quantile(&p, u).0;
            (k, k as f64 + 0.5)
        }
        TsmtDecode::Subbin => {
            let k = quantile(&p, u).0;
            let from = k.saturating_sub(r.subbin_radius);
            let to = (k + r.subbin_radius + 1).min(p.len());
            let pos = mean_position(&p, from, to);
            (k, pos.clamp(k as f64, k as f64 + ONE_BELOW))
        }
        TsmtDecode::Coherent => {
            let (k, frac) = quantile(&p, u);
            (k, k as f64 + frac)
        }
        TsmtDecode::Mean => {
            let pos = mean_position(&p, 0, p.len());
            let k = (pos.floor().max(0.0) as usize).min(p.len() - 1);
            (k, pos)
        }
    }
}

/// The shared quantile of `coherent` decoding for one dance: Φ(z(t)) with z a sum of sinusoids of random
/// periods (between `period` and 4 × `period` frames) and phases, of unit variance, so the quantile wanders
/// over [0, 1) smoothly (no frame-to-frame noise of its own).
#[derive(Clone, Debug, PartialEq)]
pub struct SmoothQuantile {
    /// (angular frequency per frame, phase) of each sinusoid.
    parts: Vec<(f64, f64)>,
}

/// Sinusoids in the sum.
const PARTS: usize = 6;

impl SmoothQuantile {
    /// From 2 × 6 uniforms in [0, 1) (periods and phases).
    pub fn new(period_frames: f64, mut uniform: impl FnMut() -> f64) -> SmoothQuantile {
        let parts = (0..PARTS)
            .map(|_| {
                let period = period_frames * (1.0 + 3.0 * uniform());
                let phase = std::f64::consts::TAU * uniform();
                (std::f64::consts::TAU / period, phase)
            })
            .collect();
        SmoothQuantile { parts }
    }

    /// The quantile at generated frame `t`.
    pub fn at(&self, t: usize) -> f64 {
        let amp = (2.0 / PARTS as f64).sqrt();
        let z: f64 = self
            .parts
            .iter()
            .map(|(w, phase)| amp * (w * t as f64 + phase).sin())
            .sum();
        normal_cdf(z).clamp(0.0, ONE_BELOW)
    }
}

/// Φ(z), the standard normal CDF (Abramowitz & Stegun 7.1.26 for erf: error below 1.5e-7).
pub fn normal_cdf(z: f64) -> f64 {
    let x = z.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-x * x).exp();
    if z >= 0.0 {
        0.5 * (1.0 + erf)
    } else {
        0.5 * (1.0 - erf)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reading(decode: TsmtDecode) -> Reading {
        Reading {
            temperature: 1.0,
            top_k: 0,
            decode,
            subbin_radius: 1,
        }
    }

    #[test]
    fn bin_is_the_paper_draw_and_every_position_lies_in_its_bin() {
        let logits: Vec<f32> = (0..12).map(|i| -((i as f32 - 5.3).powi(2)) / 4.0).collect();
        for i in 0..200 {
            let u = i as f64 / 200.0;
            let (k, pos) = read(&logits, &reading(TsmtDecode::Bin), u);
            assert_eq!(k, super::super::draw::draw(&logits, 1.0, 0, u));
            assert_eq!(pos, k as f64 + 0.5);
            for d in [TsmtDecode::Subbin, TsmtDecode::Coherent, TsmtDecode::Mean] {
                let (k, pos) = read(&logits, &reading(d), u);
                assert!(
                    pos >= k as f64 && pos < k as f64 + 1.0,
                    "{d:?} u {u}: {k} {pos}"
                );
            }
            // Subbin draws the same bins as the paper.
            assert_eq!(read(&logits, &reading(TsmtDecode::Subbin), u).0, k);
        }
    }

    #[test]
    fn hand_cases() {
        // Two equal bins: the mean sits on their border, coherent interpolates linearly.
        let two = [0.0f32, 0.0];
        let (k, pos) = read(&two, &reading(TsmtDecode::Mean), 0.3);
        assert_eq!((k, pos), (1, 1.0));
        assert_eq!(read(&two, &reading(TsmtDecode::Coherent), 0.25), (0, 0.5));
        assert_eq!(
            read(&two, &reading(TsmtDecode::Coherent), 0.75),
            (1, 0.5 + 1.0)
        );
        // p = [1/4, 3/4] (logits 0, ln 3): mean = ¼·½ + ¾·1½ = 1.25; subbin radius 1 the same.
        let l = [0.0f32, 3f32.ln()];
        let (k, pos) = read(&l, &reading(TsmtDecode::Mean), 0.0);
        assert_eq!(k, 1);
        assert!((pos - 1.25).abs() < 1e-6);
        let (k, pos) = read(&l, &reading(TsmtDecode::Subbin), 0.9);
        assert_eq!(k, 1);
        assert!((pos - 1.25).abs() < 1e-6);
        // Subbin clamps into the drawn bin: drawing bin 0 gives a position inside it.
        let (k, pos) = read(&l, &reading(TsmtDecode::Subbin), 0.1);
        assert_eq!(k, 0);
        assert!(pos < 1.0);
        // τ = 0: the argmax's centre for every decoding.
        for d in [
            TsmtDecode::Bin,
            TsmtDecode::Subbin,
            TsmtDecode::Coherent,
            TsmtDecode::Mean,
        ] {
            let r = Reading {
                temperature: 0.0,
                ..reading(d)
            };
            assert_eq!(read(&l, &r, 0.1), (1, 1.5));
        }
        // top-k keeps the mean among the kept bins.
        let r = Reading {
            top_k: 1,
            ..reading(TsmtDecode::Mean)
        };
        assert_eq!(read(&[0.0, 1.0, 0.5], &r, 0.5), (1, 1.5));
    }

    #[test]
    fn the_shared_quantile_is_smooth_and_spans_its_range() {
        let mut state = 7u64;
        let mut uniform = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let q = SmoothQuantile::new(120.0, &mut uniform);
        let u: Vec<f64> = (0..6000).map(|t| q.at(t)).collect();
        assert!(u.iter().all(|&x| (0.0..1.0).contains(&x)));
        let (lo, hi) = u
            .iter()
            .fold((1.0f64, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
        assert!(lo < 0.1 && hi > 0.9, "{lo} {hi}");
        // Frame to frame it changes little, and its second difference far less.
        let step = u
            .windows(2)
            .map(|w| (w[1] - w[0]).abs())
            .fold(0.0, f64::max);
        let bend = u
            .windows(3)
            .map(|w| (w[2] - 2.0 * w[1] + w[0]).abs())
            .fold(0.0, f64::max);
        assert!(step < 0.05 && bend < 0.005, "{step} {bend}");
        assert!((normal_cdf(0.0) - 0.5).abs() < 1e-9);
        assert!((normal_cdf(1.959_964) - 0.975).abs() < 1e-6);
        assert!((normal_cdf(-1.0) - 0.158_655_25).abs() < 1e-6);
    }
}
