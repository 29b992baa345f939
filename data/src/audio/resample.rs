//! Band-limited sinc resampling, reproducing resampy 0.2.2 (`resample`, `interpn.resample_f`) as
//! librosa 0.8.1 calls it (SPEC §2.1).
//!
//! resampy 0.2.2 keeps the input dtype: librosa hands it float32, so every accumulation step is rounded to
//! f32 (numba stores `y[t] += w * x` into a float32 array). We do the same, so the output matches to the bit
//! up to libm differences.

use std::fmt;
use std::str::FromStr;
use std::sync::OnceLock;

use rayon::prelude::*;

use crate::error::{Error, Result};

/// Which resampy 0.2.2 filter to use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Resampler {
    /// 64 zero crossings, rolloff 0.9476, Kaiser β 14.77 (librosa.load's default).
    #[default]
    KaiserBest,
    /// 16 zero crossings, rolloff 0.85, Kaiser β 8.56 (also the CQT's octave halving).
    KaiserFast,
}

impl fmt::Display for Resampler {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Resampler::KaiserBest => "kaiser_best",
            Resampler::KaiserFast => "kaiser_fast",
        })
    }
}

impl FromStr for Resampler {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "kaiser_best" => Ok(Resampler::KaiserBest),
            "kaiser_fast" => Ok(Resampler::KaiserFast),
            _ => Err(Error::msg(format!(
                "unknown resampler '{s}' (expected kaiser_best or kaiser_fast)"
            ))),
        }
    }
}

/// Entries per zero crossing of both resampy 0.2.2 tables.
const PRECISION: usize = 512;

struct FilterSpec {
    num_zeros: usize,
    rolloff: f64,
    beta: f64,
}

const KAISER_BEST: FilterSpec = FilterSpec {
    num_zeros: 64,
    rolloff: 0.9475937167399596,
    beta: 14.769656459379492,
};
const KAISER_FAST: FilterSpec = FilterSpec {
    num_zeros: 16,
    rolloff: 0.85,
    beta: 8.555504641634386,
};

/// Modified Bessel function of the first kind, order 0 (power series; converges fast for |x| < 30).
fn bessel_i0(x: f64) -> f64 {
    let q = 0.25 * x * x;
    let mut term = 1.0;
    let mut sum = 1.0;
    let mut k = 1.0;
    loop {
        term *= q / (k * k);
        sum += term;
        if term < sum * 1e-17 {
            return sum;
        }
        k += 1.0;
    }
}

/// The right half of the windowed sinc: h[i] = ρ·sinc(ρ·i/512)·kaiser(β)[i] (resampy 0.2.2 `sinc_window`;
/// equals the shipped kaiser_*.npz tables to 2e-16).
fn build_table(spec: &FilterSpec) -> Vec<f64> {
    let n = PRECISION * spec.num_zeros;
    let i0_beta = bessel_i0(spec.beta);
    (0..=n)
        .map(|i| {
            let x = spec.rolloff * (i as f64 / PRECISION as f64);
            let sinc = if x == 0.0 {
                1.0
            } else {
                let px = std::f64::consts::PI * x;
                px.sin() / px
            };
            let r = i as f64 / n as f64;
            let w = bessel_i0(spec.beta * (1.0 - r * r).max(0.0).sqrt()) / i0_beta;
            spec.rolloff * sinc * w
        })
        .collect()
}

fn table(filter: Resampler) -> &'static [f64] {
    static BEST: OnceLock<Vec<f64>> = OnceLock::new();
    static FAST: OnceLock<Vec<f64>> = OnceLock::new();
    match filter {
        Resampler::KaiserBest => BEST.get_or_init(|| build_table(&KAISER_BEST)),
        Resampler::KaiserFast => FAST.get_or_init(|| build_table(&KAISER_FAST)),
    }
}

/// Output length of resampy 0.2.2: int(n · sr_out / sr_in).
pub fn resampy_len(n: usize, sr_in: f64, sr_out: f64) -> usize {
    (n as f64 * (sr_out / sr_in)) as usize
}

/// Output length after librosa 0.8.1's `fix_length`: ceil(n · sr_out / sr_in).
pub fn librosa_len(n: usize, sr_in: f64, sr_out: f64) -> usize {
    (n as f64 * (sr_out / sr_in)).ceil() as usize
}

/// resampy 0.2.2 `resample(x, sr_in, sr_out, filter)` on a float32 signal: floor(n·ratio) samples.
/// Inputs are rounded to f32 first, as librosa's float32 arrays are.
pub fn resampy(x: &[f64], sr_in: f64, sr_out: f64, filter: Resampler) -> Result<Vec<f64>> {
    resampy_impl(x, sr_in, sr_out, filter, true)
}

/// resampy with `exact` = true rounds every partial sum to f32 (bit-exact); false sums each output's
/// products in f64 with four lanes and rounds once (faster, within a few f32 ulps).
fn resampy_impl(
    x: &[f64],
    sr_in: f64,
    sr_out: f64,
    filter: Resampler,
    exact: bool,
) -> Result<Vec<f64>> {
    if !(sr_in > 0.0 && sr_out > 0.0 && sr_in.is_finite() && sr_out.is_finite()) {
        return Err(Error::msg(format!(
            "invalid sample rates for resampling: {sr_in} -> {sr_out}"
        )));
    }
    let ratio = sr_out / sr_in;
    if ratio < 1.0 / PRECISION as f64 {
        return Err(Error::msg(format!(
            "cannot downsample by more than {PRECISION}x ({sr_in} -> {sr_out} Hz)"
        )));
    }
    let n_out = resampy_len(x.len(), sr_in, sr_out);
    if n_out < 1 {
        return Err(Error::msg(format!(
            "signal of {} samples is too short to resample from {sr_in} to {sr_out} Hz",
            x.len()
        )));
    }
    let base = table(filter);
    // Downsampling scales the table by the ratio (resampy: `interp_win *= sample_ratio`).
    let win: Vec<f64> = if ratio < 1.0 {
        base.iter().map(|&h| h * ratio).collect()
    } else {
        base.to_vec()
    };
    let mut delta = vec![0.0; win.len()];
    for i in 0..win.len() - 1 {
        delta[i] = win[i + 1] - win[i];
    }
    let xf: Vec<f32> = x.iter().map(|&v| v as f32).collect();

    let scale = ratio.min(1.0);
    let time_increment = 1.0 / ratio;
    let index_step = (scale * PRECISION as f64) as usize;
    let nwin = win.len();
    let n_orig = xf.len();
    let num_table = PRECISION as f64;

    // resampy advances a floating time register by repeated addition; the drift is part of its output.
    let mut registers = Vec::with_capacity(n_out);
    let mut time_register = 0.0f64;
    for _ in 0..n_out {
        registers.push(time_register);
        time_register += time_increment;
    }

    // Products in resampy's accumulation order (left wing i = 0.., then right wing k = 0..); the sum is
    // then rounded to f32 after every addition. 32 outputs are accumulated in lockstep so the serial
    // rounding chains overlap; each output's own order is unchanged, so the result is identical.
    // Polyphase layout: row o holds (win, delta)[o + i·step] for i = 0.., so each wing reads contiguously.
    let row = nwin / index_step + 1;
    let mut poly = vec![(0.0f64, 0.0f64); (index_step + 1) * row];
    for o in 0..=index_step {
        for i in 0..row {
            let k = o + i * index_step;
            if k < nwin {
                poly[o * row + i] = (win[k], delta[k]);
            }
        }
    }
    // The two wings of output at `time_register`: (table row start, eta, taps) for the left wing (read
    // backwards from x[n]) and the right wing (forwards from x[n + 1]), exactly as resampy bounds them.
    const G: usize = 32;
    let wings = |time_register: f64| {
        let n = time_register as usize;
        let frac = scale * (time_register - n as f64);
        let index_frac = frac * num_table;
        let off_l = index_frac as usize;
        let eta_l = index_frac - off_l as f64;
        let i_max = (n + 1).min((nwin - off_l) / index_step);
        let frac = scale - frac;
        let index_frac = frac * num_table;
        let off_r = index_frac as usize;
        let eta_r = index_frac - off_r as f64;
        let k_max = (n_orig.saturating_sub(n + 1)).min((nwin - off_r) / index_step);
        (
            n,
            (&poly[off_l * row..off_l * row + i_max], eta_l),
            (&poly[off_r * row..off_r * row + k_max], eta_r),
        )
    };
    // Products of output j, in resampy's order, written interleaved: q[idx·G + j]. Returns the count.
    let fill = |time_register: f64, q: &mut [f64], j: usize| -> usize {
        let (n, (left, eta_l), (right, eta_r)) = wings(time_register);
        let xs = &xf[n + 1 - left.len()..=n];
        let mut idx = 0;
        for (&(w, d), &x) in left.iter().zip(xs.iter().rev()) {
            q[idx * G + j] = (w + eta_l * d) * x as f64;
            idx += 1;
        }
        let xs = &xf[n + 1..n + 1 + right.len()];
        for (&(w, d), &x) in right.iter().zip(xs) {
            q[idx * G + j] = (w + eta_r * d) * x as f64;
            idx += 1;
        }
        idx
    };
    // f64 dot product of one output, four lanes.
    let dot = |time_register: f64| -> f64 {
        let (n, (left, eta_l), (right, eta_r)) = wings(time_register);
        let mut lanes = [0.0f64; 4];
        let xs = &xf[n + 1 - left.len()..=n];
        for (i, (&(w, d), &x)) in left.iter().zip(xs.iter().rev()).enumerate() {
            lanes[i & 3] += (w + eta_l * d) * x as f64;
        }
        let xs = &xf[n + 1..n + 1 + right.len()];
        for (i, (&(w, d), &x)) in right.iter().zip(xs).enumerate() {
            lanes[i & 3] += (w + eta_r * d) * x as f64;
        }
        (lanes[0] + lanes[1]) + (lanes[2] + lanes[3])
    };
    let mut out = vec![0.0f64; n_out];
    out.par_chunks_mut(4096)
        .zip(registers.par_chunks(4096))
        .for_each(|(out, regs)| {
            let cap = 2 * (nwin / index_step + 2);
            if !exact {
                for (o, &r) in out.iter_mut().zip(regs) {
                    *o = dot(r) as f32 as f64;
                }
                return;
            }
            let mut q = vec![0.0f64; cap * G];
            for (og, rg) in out.chunks_mut(G).zip(regs.chunks(G)) {
                let mut len = [0usize; G];
                for (j, &r) in rg.iter().enumerate() {
                    len[j] = fill(r, &mut q, j);
                }
                let m = rg.len();
                let mut acc = [0.0f32; G];
                let mut common = 0;
                if m == G {
                    common = *len.iter().min().unwrap();
                    for step in q[..common * G].chunks_exact(G) {
                        for j in 0..G {
                            acc[j] = (acc[j] as f64 + step[j]) as f32;
                        }
                    }
                }
                for j in 0..m {
                    for idx in common..len[j] {
                        acc[j] = (acc[j] as f64 + q[idx * G + j]) as f32;
                    }
                    og[j] = acc[j] as f64;
                }
            }
        });
    Ok(out)
}

/// librosa 0.8.1 `resample(y, sr_in, sr_out, res_type, fix=True, scale)`: resampy, then zero-pad or trim
/// to ceil(n·ratio), then divide by sqrt(ratio) when `scale`; rounded to f32 like librosa's output.
pub fn resample(
    x: &[f64],
    sr_in: f64,
    sr_out: f64,
    filter: Resampler,
    scale: bool,
) -> Result<Vec<f64>> {
    resample_with(x, sr_in, sr_out, filter, scale, true)
}

/// [`resample`] with the choice of exact (f32 per step, as resampy) or f64 accumulation.
pub fn resample_with(
    x: &[f64],
    sr_in: f64,
    sr_out: f64,
    filter: Resampler,
    scale: bool,
    exact: bool,
) -> Result<Vec<f64>> {
    if sr_in == sr_out {
        return Ok(x.to_vec());
    }
    let mut y = resampy_impl(x, sr_in, sr_out, filter, exact)?;
    y.resize(librosa_len(x.len(), sr_in, sr_out), 0.0);
    if scale {
        let s = (sr_out / sr_in).sqrt();
        for v in &mut y {
            *v = (*v as f32 / s as f32) as f64;
        }
    }
    Ok(y)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_shapes_and_peak() {
        let best = table(Resampler::KaiserBest);
        assert_eq!(best.len(), 64 * 512 + 1);
        assert!((best[0] - KAISER_BEST.rolloff).abs() < 1e-15);
        let fast = table(Resampler::KaiserFast);
        assert_eq!(fast.len(), 16 * 512 + 1);
        assert!((fast[0] - 0.85).abs() < 1e-15);
        assert!(best[best.len() - 1].abs() < 1e-6);
    }

    #[test]
    fn bessel_matches_known_values() {
        assert!((bessel_i0(0.0) - 1.0).abs() < 1e-15);
        // scipy.special.i0(1) and i0(10)
        assert!((bessel_i0(1.0) - 1.2660658777520082).abs() < 1e-14);
        assert!((bessel_i0(10.0) / 2815.716628466254 - 1.0).abs() < 1e-14);
    }

    #[test]
    fn lengths_follow_resampy_and_librosa() {
        // 117601 · 30720/22050 = 163841.39 (the trumpet loop: librosa returns 163842 samples).
        assert_eq!(resampy_len(117601, 22050.0, 30720.0), 163841);
        assert_eq!(librosa_len(117601, 22050.0, 30720.0), 163842);
        let x = vec![0.25; 1000];
        let y = resample(&x, 22050.0, 30720.0, Resampler::KaiserFast, false).unwrap();
        assert_eq!(y.len(), librosa_len(1000, 22050.0, 30720.0));
        // A constant is preserved away from the edges (unit DC gain within the filter's ripple).
        let mid = y[y.len() / 2];
        assert!((mid - 0.25).abs() < 2e-3, "{mid}");
        assert!(resampy(&x, 0.0, 1.0, Resampler::KaiserBest).is_err());
        assert!(resampy(&[1.0], 30720.0, 1.0, Resampler::KaiserBest).is_err());
    }

    #[test]
    fn sine_survives_up_and_down() {
        let sr = 22050.0;
        let x: Vec<f64> = (0..22050)
            .map(|i| (2.0 * std::f64::consts::PI * 440.0 * i as f64 / sr).sin())
            .collect();
        let y = resample(&x, sr, 30720.0, Resampler::KaiserBest, false).unwrap();
        for t in (5000..25000).step_by(997) {
            let want = (2.0 * std::f64::consts::PI * 440.0 * t as f64 / 30720.0).sin();
            assert!((y[t] - want).abs() < 1e-4, "t={t} {} vs {want}", y[t]);
        }
        let z = resample(&y, 2.0, 1.0, Resampler::KaiserFast, true).unwrap();
        assert_eq!(z.len(), y.len().div_ceil(2));
        for t in (3000..12000).step_by(991) {
            let want = (2.0 * std::f64::consts::PI * 440.0 * t as f64 / 15360.0).sin();
            assert!((z[t] / 2f64.sqrt() - want).abs() < 5e-3, "t={t}");
        }
    }
}
