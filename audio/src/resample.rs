//! Band-limited sinc resampling, reproducing resampy 0.2.2 (`resample`, `interpn.resample_f`) as
//! librosa 0.8.1 calls it (SPEC §2.1).
//!
//! resampy 0.2.2 keeps the input dtype: librosa hands it float32, so every accumulation step is rounded to
//! f32 (numba stores `y[t] += w * x` into a float32 array). We do the same, so the output matches to the bit
//! up to libm differences.
//!
//! Speed without changing a bit: when the rate ratio makes the time register periodic (44.1, 48 or 22.05 kHz
//! to 30720 Hz, every halving), outputs one period apart share their taps, so 32 of them are summed side by
//! side from a lane-interleaved copy of the input (AVX2 where the CPU has it). A test checks every path
//! against a literal transcription of resampy's loop.

use std::borrow::Cow;
use std::fmt;
use std::str::FromStr;
use std::sync::OnceLock;

use rayon::prelude::*;

use qean_io::error::{Error, Result};

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
    let xf: Vec<f32> = x.iter().map(|&v| v as f32).collect();
    resampy_core(&xf, sr_in, sr_out, filter, true, 0).map(|(y, _)| y)
}

/// A range of outputs, [start, end).
type Span = (usize, usize);

/// resampy's interpolation table in polyphase layout (row o holds (win, delta)[o + i·step] for i = 0.., so
/// each wing reads contiguously), and the float32 signal it filters.
struct Kernel<'a> {
    xf: &'a [f32],
    poly: Vec<(f64, f64)>,
    row: usize,
    nwin: usize,
    index_step: usize,
    scale: f64,
}

/// Outputs accumulated in lockstep by the exact path.
const G: usize = 32;

impl<'a> Kernel<'a> {
    fn new(xf: &'a [f32], filter: Resampler, ratio: f64) -> Self {
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
        let scale = ratio.min(1.0);
        let index_step = (scale * PRECISION as f64) as usize;
        let nwin = win.len();
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
        Kernel {
            xf,
            poly,
            row,
            nwin,
            index_step,
            scale,
        }
    }

    /// Where output at `time_register` reads: n = floor(register), and for each wing the table offset and
    /// interpolation fraction eta (resampy's arithmetic, step by step).
    fn position(&self, time_register: f64) -> (usize, (usize, f64), (usize, f64)) {
        let num_table = PRECISION as f64;
        let n = time_register as usize;
        let frac = self.scale * (time_register - n as f64);
        let index_frac = frac * num_table;
        let off_l = index_frac as usize;
        let eta_l = index_frac - off_l as f64;
        let frac = self.scale - frac;
        let index_frac = frac * num_table;
        let off_r = index_frac as usize;
        let eta_r = index_frac - off_r as f64;
        (n, (off_l, eta_l), (off_r, eta_r))
    }

    /// The two wings: (table row, eta) for the left wing (read backwards from x[n]) and the right wing
    /// (forwards from x[n + 1]), with as many taps as resampy takes at this position.
    #[allow(clippy::type_complexity)]
    fn wings(&self, time_register: f64) -> (usize, (&[(f64, f64)], f64), (&[(f64, f64)], f64)) {
        let (n, (off_l, eta_l), (off_r, eta_r)) = self.position(time_register);
        let (row, step) = (self.row, self.index_step);
        let i_max = (n + 1).min((self.nwin - off_l) / step);
        let k_max = (self.xf.len().saturating_sub(n + 1)).min((self.nwin - off_r) / step);
        (
            n,
            (&self.poly[off_l * row..off_l * row + i_max], eta_l),
            (&self.poly[off_r * row..off_r * row + k_max], eta_r),
        )
    }

    /// Products of output j, in resampy's order, written interleaved: q[idx·G + j]. Returns the count.
    fn fill(&self, time_register: f64, q: &mut [f64], j: usize) -> usize {
        let (n, (left, eta_l), (right, eta_r)) = self.wings(time_register);
        let xs = &self.xf[n + 1 - left.len()..=n];
        let mut idx = 0;
        for (&(w, d), &x) in left.iter().zip(xs.iter().rev()) {
            q[idx * G + j] = (w + eta_l * d) * x as f64;
            idx += 1;
        }
        let xs = &self.xf[n + 1..n + 1 + right.len()];
        for (&(w, d), &x) in right.iter().zip(xs) {
            q[idx * G + j] = (w + eta_r * d) * x as f64;
            idx += 1;
        }
        idx
    }

    /// f64 dot product of one output, four lanes.
    fn dot(&self, time_register: f64) -> f64 {
        let (n, (left, eta_l), (right, eta_r)) = self.wings(time_register);
        let mut lanes = [0.0f64; 4];
        let xs = &self.xf[n + 1 - left.len()..=n];
        for (i, (&(w, d), &x)) in left.iter().zip(xs.iter().rev()).enumerate() {
            lanes[i & 3] += (w + eta_l * d) * x as f64;
        }
        let xs = &self.xf[n + 1..n + 1 + right.len()];
        for (i, (&(w, d), &x)) in right.iter().zip(xs).enumerate() {
            lanes[i & 3] += (w + eta_r * d) * x as f64;
        }
        (lanes[0] + lanes[1]) + (lanes[2] + lanes[3])
    }

    /// Every tap of a wing (no clipping at the signal's ends), interpolation applied.
    fn taps(&self, off: usize, eta: f64) -> Vec<f64> {
        self.poly[off * self.row..off * self.row + (self.nwin - off) / self.index_step]
            .iter()
            .map(|&(w, d)| w + eta * d)
            .collect()
    }

    /// The outputs at `regs`, output by output. Products in resampy's accumulation order (left wing
    /// i = 0.., then right wing k = 0..); with `exact` the sum is rounded to f32 after every addition, and
    /// 32 outputs are accumulated in lockstep so the serial rounding chains overlap (each output's own
    /// order is unchanged, so the result is identical).
    fn serial(&self, out: &mut [f64], regs: &[f64], exact: bool) {
        out.par_chunks_mut(4096)
            .zip(regs.par_chunks(4096))
            .for_each(|(out, regs)| {
                if !exact {
                    for (o, &r) in out.iter_mut().zip(regs) {
                        *o = self.dot(r) as f32 as f64;
                    }
                    return;
                }
                let cap = 2 * (self.nwin / self.index_step + 2);
                let mut q = vec![0.0f64; cap * G];
                for (og, rg) in out.chunks_mut(G).zip(regs.chunks(G)) {
                    let mut len = [0usize; G];
                    for (j, &r) in rg.iter().enumerate() {
                        len[j] = self.fill(r, &mut q, j);
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
    }
}

/// resampy on float32 input. `exact` = true rounds every partial sum to f32 (bit-exact); false sums each
/// output's products in f64 and rounds once (faster, within a few f32 ulps). The output has room for
/// `spare` more samples (librosa pads by one). Also returns the outputs the periodic kernel computed.
fn resampy_core(
    xf: &[f32],
    sr_in: f64,
    sr_out: f64,
    filter: Resampler,
    exact: bool,
    spare: usize,
) -> Result<(Vec<f64>, Option<Span>)> {
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
    let n_out = resampy_len(xf.len(), sr_in, sr_out);
    if n_out < 1 {
        return Err(Error::msg(format!(
            "signal of {} samples is too short to resample from {sr_in} to {sr_out} Hz",
            xf.len()
        )));
    }
    let kernel = Kernel::new(xf, filter, ratio);
    let registers = Registers::new(n_out, 1.0 / ratio);
    let mut out = Vec::with_capacity(n_out + spare);
    out.resize(n_out, 0.0f64);
    let periodic = match &registers {
        Registers::Periodic { first, stride, .. } => {
            let phases: Vec<Phase> = first
                .iter()
                .map(|&r| {
                    let (n, (off_l, eta_l), (off_r, eta_r)) = kernel.position(r);
                    Phase {
                        n,
                        left: kernel.taps(off_l, eta_l),
                        right: kernel.taps(off_r, eta_r),
                    }
                })
                .collect();
            Periodic::new(phases, *stride, xf.len(), &registers, n_out)
        }
        Registers::All(_) => None,
    };
    match &periodic {
        Some(plan) => {
            let (a, b) = plan.range;
            kernel.serial(&mut out[..a], &registers.span(0, a), exact);
            kernel.serial(&mut out[b..], &registers.span(b, n_out), exact);
            plan.run(xf, &mut out[a..b], exact);
        }
        None => kernel.serial(&mut out, &registers.span(0, n_out), exact),
    }
    Ok((out, periodic.map(|p| p.range)))
}

/// Lanes of the periodic kernel: outputs one filter period apart, accumulated side by side.
const LANES: usize = 32;

/// The filter taps of one phase (one output of the first period), left and right wing, with resampy's
/// interpolation `win + eta·delta` already applied.
struct Phase {
    /// floor(time register) of this phase's first output.
    n: usize,
    left: Vec<f64>,
    right: Vec<f64>,
}

/// When the time register repeats its fraction every `period` outputs (a rational rate ratio whose
/// increment is exact in binary: 44.1 kHz, 48 kHz or 22.05 kHz to 30720 Hz, any halving), outputs one
/// period apart use the same taps on inputs `stride` apart. `LANES` such outputs are accumulated at once,
/// in resampy's order each, from a lane-interleaved copy of the input: same sums, same roundings.
struct Periodic {
    phases: Vec<Phase>,
    stride: usize,
    max_left: usize,
    max_right: usize,
    /// Consecutive periods each lane takes in one block.
    per_lane: usize,
    /// Outputs [a, b) go through the kernel: whole blocks of LANES periods, every wing unclipped.
    range: (usize, usize),
}

/// resampy's time register of every output. resampy advances it by repeated addition, so any drift is
/// part of its output; when the register comes back to a whole number after `first.len()` outputs and
/// every later value is exactly `first[t % P] + (t / P)·stride` (checked), it is stored as one period.
enum Registers {
    All(Vec<f64>),
    Periodic { first: Vec<f64>, stride: usize },
}

impl Registers {
    fn new(n_out: usize, increment: f64) -> Self {
        const MAX_PERIOD: usize = 4096;
        let mut first: Vec<f64> = Vec::new();
        let mut r = 0.0f64;
        for t in 0..n_out.min(MAX_PERIOD + 1) {
            if t > 0 && r.fract() == 0.0 {
                let (period, stride) = (t, r as u64);
                // (whole part, fraction) of each phase; registers are ≥ 0, so `as u64` is floor.
                let parts: Vec<(u64, f64)> = first
                    .iter()
                    .map(|&f| (f as u64, f - (f as u64) as f64))
                    .collect();
                let mut r = 0.0f64;
                let repeats = (0..n_out).all(|t| {
                    let (whole, frac) = parts[t % period];
                    let n = r as u64;
                    let same = n == whole + (t / period) as u64 * stride && r - n as f64 == frac;
                    r += increment;
                    same
                });
                if repeats {
                    return Registers::Periodic {
                        first,
                        stride: stride as usize,
                    };
                }
                break;
            }
            first.push(r);
            r += increment;
        }
        let mut all = Vec::with_capacity(n_out);
        let mut r = 0.0f64;
        for _ in 0..n_out {
            all.push(r);
            r += increment;
        }
        Registers::All(all)
    }

    /// The register of output t (exactly the repeated-addition value).
    fn get(&self, t: usize) -> f64 {
        match self {
            Registers::All(all) => all[t],
            Registers::Periodic { first, stride } => {
                let p = first.len();
                first[t % p] + ((t / p) * stride) as f64
            }
        }
    }

    /// Registers a..b: borrowed when all are stored, computed for the (short) edges otherwise.
    fn span(&self, a: usize, b: usize) -> Cow<'_, [f64]> {
        match self {
            Registers::All(all) => Cow::Borrowed(&all[a..b]),
            Registers::Periodic { .. } => (a..b).map(|t| self.get(t)).collect(),
        }
    }
}

impl Periodic {
    fn new(
        phases: Vec<Phase>,
        stride: usize,
        n_orig: usize,
        registers: &Registers,
        n_out: usize,
    ) -> Option<Self> {
        let period = phases.len();
        let max_left = phases.iter().map(|p| p.left.len()).max()?;
        let max_right = phases.iter().map(|p| p.right.len()).max()?;
        // First whole period whose outputs all have full left wings.
        let mut a = 0;
        while a < n_out && (registers.get(a) as usize) + 1 < max_left {
            a += period;
        }
        // Whole blocks whose last output still has a full right wing.
        let blocks_end = |block: usize| {
            let mut b = a;
            while b + block <= n_out
                && (registers.get(b + block - 1) as usize) + 1 + max_right <= n_orig
            {
                b += block;
            }
            b
        };
        // Periods per lane: as many as keep the lane-interleaved input near ROWS rows (it is rebuilt for
        // every block, so short filters want long blocks), while leaving at least two blocks to share out.
        const ROWS: usize = 1536;
        let span = phases[period - 1].n + max_left + max_right;
        let mut per_lane = ROWS.saturating_sub(span) / stride.max(1) + 1;
        let mut b = blocks_end(period * LANES * per_lane);
        while per_lane > 1 && (b - a) / (period * LANES * per_lane) < 2 {
            per_lane = per_lane.div_ceil(2);
            b = blocks_end(period * LANES * per_lane);
        }
        (b > a).then_some(Periodic {
            phases,
            stride,
            max_left,
            max_right,
            per_lane,
            range: (a, b),
        })
    }

    /// Fills `out` (outputs `range.0..range.1`), block by block in parallel. In a block, lane l holds
    /// `per_lane` consecutive periods, lanes one after another.
    fn run(&self, x: &[f32], out: &mut [f64], exact: bool) {
        let period = self.phases.len();
        let per_lane = self.per_lane;
        let first_period = self.range.0 / period;
        let lane_stride = self.stride * per_lane;
        let n_rows = self.stride * (per_lane - 1)
            + self.phases[period - 1].n
            + self.max_left
            + self.max_right;
        out.par_chunks_mut(period * per_lane * LANES)
            .enumerate()
            .for_each_init(
                || vec![0.0f64; n_rows * LANES],
                |rows, (blk, out)| {
                    // rows[r·LANES + l] = x[base + r + lane_stride·l], row r = input (1 − max_left) + r
                    // relative to the block's first output.
                    let base =
                        (first_period + blk * per_lane * LANES) * self.stride + 1 - self.max_left;
                    let x = &x[base..base + lane_stride * (LANES - 1) + n_rows];
                    for (r, row) in rows.chunks_exact_mut(LANES).enumerate() {
                        for (l, v) in row.iter_mut().enumerate() {
                            *v = x[r + lane_stride * l] as f64;
                        }
                    }
                    for k in 0..per_lane {
                        for (p, phase) in self.phases.iter().enumerate() {
                            let at = k * self.stride + phase.n + self.max_left - 1;
                            let acc = phase_sums(rows, at, &phase.left, &phase.right, exact);
                            for (l, v) in acc.iter().enumerate() {
                                out[(l * per_lane + k) * period + p] = *v;
                            }
                        }
                    }
                },
            );
    }
}

/// The LANES outputs of one phase: left taps read rows at, at − 1, …; right taps rows at + 1, ….
fn phase_sums(rows: &[f64], at: usize, left: &[f64], right: &[f64], exact: bool) -> [f64; LANES] {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU supports AVX2 (checked just above).
        return unsafe { phase_sums_avx2(rows, at, left, right, exact) };
    }
    phase_sums_portable(rows, at, left, right, exact)
}

/// [`phase_sums_portable`] with AVX explicitly: eight 4-lane accumulators, so eight rounding chains
/// overlap; each lane's operations are the portable version's, in its order.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn phase_sums_avx2(
    rows: &[f64],
    at: usize,
    left: &[f64],
    right: &[f64],
    exact: bool,
) -> [f64; LANES] {
    use std::arch::x86_64::*;
    const V: usize = LANES / 4;
    assert!((at + right.len() + 1) * LANES <= rows.len() && left.len() <= at + 1);
    let mut acc = [_mm256_setzero_pd(); V];
    let base = rows.as_ptr();
    let mut tap = |w: f64, r: usize| {
        let w = _mm256_set1_pd(w);
        // SAFETY: r < rows.len() / LANES (asserted above for every row the wings read).
        let xs = unsafe { base.add(r * LANES) };
        for (v, a) in acc.iter_mut().enumerate() {
            let x = unsafe { _mm256_loadu_pd(xs.add(4 * v)) };
            let s = _mm256_add_pd(*a, _mm256_mul_pd(w, x));
            *a = if exact {
                _mm256_cvtps_pd(_mm256_cvtpd_ps(s))
            } else {
                s
            };
        }
    };
    for (i, &w) in left.iter().enumerate() {
        tap(w, at - i);
    }
    for (k, &w) in right.iter().enumerate() {
        tap(w, at + 1 + k);
    }
    let mut out = [0.0f64; LANES];
    for (v, a) in acc.iter().enumerate() {
        // SAFETY: out has LANES = 4·V values.
        unsafe { _mm256_storeu_pd(out.as_mut_ptr().add(4 * v), *a) };
    }
    if !exact {
        for v in &mut out {
            *v = *v as f32 as f64;
        }
    }
    out
}

/// One tap on every lane (plain loops, no closures: they must inline into the AVX2 copy).
#[inline(always)]
fn tap(acc: &mut [f64; LANES], w: f64, xs: &[f64], exact: bool) {
    let xs = &xs[..LANES];
    if exact {
        for l in 0..LANES {
            acc[l] = ((acc[l] + w * xs[l]) as f32) as f64;
        }
    } else {
        for l in 0..LANES {
            acc[l] += w * xs[l];
        }
    }
}

/// resampy's order per lane: y = f32(y + w·x) after every tap when `exact`, else f64 sums rounded once.
#[inline(always)]
fn phase_sums_portable(
    rows: &[f64],
    at: usize,
    left: &[f64],
    right: &[f64],
    exact: bool,
) -> [f64; LANES] {
    let mut acc = [0.0f64; LANES];
    for (i, &w) in left.iter().enumerate() {
        tap(&mut acc, w, &rows[(at - i) * LANES..], exact);
    }
    for (k, &w) in right.iter().enumerate() {
        tap(&mut acc, w, &rows[(at + 1 + k) * LANES..], exact);
    }
    if !exact {
        for v in &mut acc {
            *v = *v as f32 as f64;
        }
    }
    acc
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
    let xf: Vec<f32> = x.iter().map(|&v| v as f32).collect();
    resample_f32(&xf, sr_in, sr_out, filter, scale, exact)
}

/// [`resample_with`] on a float32 signal (a decoder's output), without an f64 copy of the input.
pub fn resample_f32(
    x: &[f32],
    sr_in: f64,
    sr_out: f64,
    filter: Resampler,
    scale: bool,
    exact: bool,
) -> Result<Vec<f64>> {
    if sr_in == sr_out {
        return Ok(x.iter().map(|&v| v as f64).collect());
    }
    let n = librosa_len(x.len(), sr_in, sr_out);
    let (mut y, _) = resampy_core(
        x,
        sr_in,
        sr_out,
        filter,
        exact,
        n.saturating_sub(resampy_len(x.len(), sr_in, sr_out)),
    )?;
    y.resize(n, 0.0);
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

    /// resampy 0.2.2's `resample_f` transcribed loop for loop (float32 output, repeated-addition time
    /// register), the reference for the fast paths.
    fn resampy_literal(
        x: &[f32],
        sr_in: f64,
        sr_out: f64,
        filter: Resampler,
        exact: bool,
    ) -> Vec<f64> {
        let ratio = sr_out / sr_in;
        let mut win = table(filter).to_vec();
        if ratio < 1.0 {
            win.iter_mut().for_each(|w| *w *= ratio);
        }
        let mut delta = vec![0.0; win.len()];
        for i in 0..win.len() - 1 {
            delta[i] = win[i + 1] - win[i];
        }
        let scale = ratio.min(1.0);
        let time_increment = 1.0 / ratio;
        let index_step = (scale * 512.0) as usize;
        let (nwin, n_orig) = (win.len(), x.len());
        let n_out = (n_orig as f64 * ratio) as usize;
        let mut y = vec![0.0f64; n_out];
        let mut time_register = 0.0f64;
        for out in y.iter_mut() {
            let mut acc = 0.0f64;
            let mut add = |v: f64| {
                acc = if exact {
                    ((acc + v) as f32) as f64
                } else {
                    acc + v
                }
            };
            let n = time_register as usize;
            let frac = scale * (time_register - n as f64);
            let index_frac = frac * 512.0;
            let offset = index_frac as usize;
            let eta = index_frac - offset as f64;
            let i_max = (n + 1).min((nwin - offset) / index_step);
            for i in 0..i_max {
                let k = offset + i * index_step;
                add((win[k] + eta * delta[k]) * x[n - i] as f64);
            }
            let frac = scale - frac;
            let index_frac = frac * 512.0;
            let offset = index_frac as usize;
            let eta = index_frac - offset as f64;
            let k_max = (n_orig - n - 1).min((nwin - offset) / index_step);
            for k in 0..k_max {
                let j = offset + k * index_step;
                add((win[j] + eta * delta[j]) * x[n + k + 1] as f64);
            }
            *out = acc as f32 as f64;
            time_register += time_increment;
        }
        y
    }

    #[test]
    fn fast_paths_equal_the_literal_loop() {
        // Noise-like input (an LCG), so every tap matters.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut noise = |n: usize| -> Vec<f64> {
            (0..n)
                .map(|_| {
                    state = state
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    ((state >> 40) as f64 / (1u64 << 24) as f64 - 0.5) as f32 as f64
                })
                .collect()
        };
        // (sr_in, sr_out, filter, seconds, periodic kernel expected)
        let cases = [
            (44100.0, 30720.0, Resampler::KaiserBest, 2.5, true),
            (48000.0, 30720.0, Resampler::KaiserBest, 2.5, true),
            (22050.0, 30720.0, Resampler::KaiserBest, 3.0, true),
            (2.0, 1.0, Resampler::KaiserFast, 40000.0, true),
            (16000.0, 30720.0, Resampler::KaiserBest, 1.0, false),
        ];
        for (sr_in, sr_out, filter, seconds, periodic) in cases {
            let x = noise((sr_in * seconds) as usize);
            let xf: Vec<f32> = x.iter().map(|&v| v as f32).collect();
            let want = resampy_literal(&xf, sr_in, sr_out, filter, true);
            let (got, range) = resampy_core(&xf, sr_in, sr_out, filter, true, 0).unwrap();
            assert_eq!(range.is_some(), periodic, "{sr_in} -> {sr_out}: {range:?}");
            if let Some((a, b)) = range {
                assert!(
                    b - a > got.len() / 2,
                    "{sr_in} -> {sr_out}: kernel did {a}..{b}"
                );
            }
            assert_eq!(got.len(), want.len());
            for (t, (g, w)) in got.iter().zip(&want).enumerate() {
                assert_eq!(
                    g.to_bits(),
                    w.to_bits(),
                    "{sr_in} -> {sr_out}, output {t}: {g} vs {w}"
                );
            }
            // Shorter signals: fewer or no whole blocks, more outputs on the edge paths.
            for len in [7, 300, x.len() / 3 + 17, x.len() / 2 + 1] {
                let want = resampy_literal(&xf[..len], sr_in, sr_out, filter, true);
                let (got, _) = resampy_core(&xf[..len], sr_in, sr_out, filter, true, 0).unwrap();
                assert_eq!(got.len(), want.len());
                assert!(
                    got.iter()
                        .zip(&want)
                        .all(|(g, w)| g.to_bits() == w.to_bits()),
                    "{sr_in} -> {sr_out}, {len} samples"
                );
            }
            // f64 sums: within a few float32 ulps of the f64 literal loop.
            let want = resampy_literal(&xf, sr_in, sr_out, filter, false);
            let (got, _) = resampy_core(&xf, sr_in, sr_out, filter, false, 0).unwrap();
            for (g, w) in got.iter().zip(&want) {
                assert!(
                    (g - w).abs() <= 4.0 * f32::EPSILON as f64 * w.abs().max(1e-3),
                    "{g} vs {w}"
                );
            }
        }
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
