//! Tempo estimation and the dynamic-programming beat tracker, librosa 0.8.1 `beat.tempo`,
//! `feature.tempogram` and `beat.beat_track` (SPEC §2.6).

use realfft::num_complex::Complex64;
use realfft::RealFftPlanner;

use super::stft::hann_periodic;

/// Result of [`beat_track`].
#[derive(Debug, Clone, PartialEq)]
pub struct BeatTrack {
    /// Estimated tempo in BPM (on the grid 60·sr/(hop·k)); 0 when the envelope is all zero.
    pub tempo_bpm: f64,
    /// Beat frames, increasing.
    pub beats: Vec<usize>,
}

/// Frames per second of an envelope at (sr, hop).
fn frame_rate(sr: f64, hop: usize) -> f64 {
    sr / hop as f64
}

/// Mean autocorrelation tempogram (librosa 0.8.1 `tempogram(win_length)` averaged over frames):
/// linear-ramp padding, periodic Hann window, linear autocorrelation per frame normalised by its max.
pub fn mean_tempogram(env: &[f64], win_length: usize) -> Vec<f64> {
    let n = env.len();
    let half = win_length / 2;
    // np.pad(mode='linear_ramp', end_values=0): left k ↦ env[0]·k/half, right j ↦ env[n−1]·(half−1−j)/half.
    let mut padded = Vec::with_capacity(n + 2 * half);
    let (first, last) = (env[0], env[n - 1]);
    let lstep = first / half as f64;
    let rstep = last / half as f64;
    for k in 0..half {
        padded.push(k as f64 * lstep);
    }
    padded.extend_from_slice(env);
    for j in 0..half {
        padded.push((half - 1 - j) as f64 * rstep);
    }
    let window = hann_periodic(win_length);
    // Linear autocorrelation through a zero-padded real FFT of size ≥ 2·win − 1.
    let nfft = (2 * win_length - 1).next_power_of_two();
    let mut planner = RealFftPlanner::<f64>::new();
    let fwd = planner.plan_fft_forward(nfft);
    let inv = planner.plan_fft_inverse(nfft);
    let mut buf = vec![0.0; nfft];
    let mut spec = vec![Complex64::new(0.0, 0.0); nfft / 2 + 1];
    let mut sf = fwd.make_scratch_vec();
    let mut si = inv.make_scratch_vec();
    let mut acc = vec![0.0; win_length];
    for t in 0..n {
        buf.iter_mut().for_each(|b| *b = 0.0);
        for (b, (&x, &w)) in buf
            .iter_mut()
            .zip(padded[t..t + win_length].iter().zip(&window))
        {
            *b = x * w;
        }
        fwd.process_with_scratch(&mut buf, &mut spec, &mut sf)
            .expect("fixed sizes");
        for c in spec.iter_mut() {
            *c = Complex64::new(c.norm_sqr(), 0.0);
        }
        inv.process_with_scratch(&mut spec, &mut buf, &mut si)
            .expect("fixed sizes");
        let ac = &buf[..win_length];
        let max = ac.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        if max > f64::MIN_POSITIVE {
            for (a, v) in acc.iter_mut().zip(ac) {
                *a += v / max;
            }
        }
    }
    acc.iter_mut().for_each(|a| *a /= n as f64);
    acc
}

/// librosa 0.8.1 `beat.tempo(onset_envelope, sr, hop_length, start_bpm)` (std_bpm 1, ac_size 8 s,
/// max_tempo 320, mean aggregate).
pub fn tempo(env: &[f64], sr: f64, hop: usize, start_bpm: f64) -> f64 {
    let win_length = (8.0 * sr) as usize / hop;
    let tg = mean_tempogram(env, win_length);
    let fr = frame_rate(sr, hop);
    let bpm = |k: usize| 60.0 * fr / k as f64;
    let mut best = (f64::NEG_INFINITY, 0usize);
    for (k, &g) in tg.iter().enumerate().skip(1) {
        let b = bpm(k);
        if b >= 320.0 {
            continue;
        }
        let d = b.log2() - start_bpm.log2();
        let score = (1e6 * g).ln_1p() - 0.5 * d * d;
        if score > best.0 {
            best = (score, k);
        }
    }
    if best.1 == 0 {
        return 0.0;
    }
    bpm(best.1)
}

/// Local score: env/std(env, ddof=1), convolved ('same') with exp(−0.5·(32u/P)²), u = −P..P.
pub fn local_score(env: &[f64], period: usize) -> Vec<f64> {
    let n = env.len();
    let mut x = env.to_vec();
    if n > 1 {
        let mean = x.iter().sum::<f64>() / n as f64;
        let var = x.iter().map(|v| (v - mean) * (v - mean)).sum::<f64>() / (n - 1) as f64;
        let sd = var.sqrt();
        if sd > 0.0 {
            x.iter_mut().for_each(|v| *v /= sd);
        }
    }
    let p = period as isize;
    let g: Vec<f64> = (-p..=p)
        .map(|u| (-0.5 * (u as f64 * 32.0 / period as f64).powi(2)).exp())
        .collect();
    (0..n as isize)
        .map(|i| {
            let mut s = 0.0;
            for (j, &w) in g.iter().enumerate() {
                let k = i + j as isize - p;
                if k >= 0 && (k as usize) < n {
                    s += x[k as usize] * w;
                }
            }
            s
        })
        .collect()
}

/// The DP of `__beat_track_dp`: (backlink, cumscore); backlink −1 marks "no predecessor".
pub fn beat_dp(score: &[f64], period: usize, tightness: f64) -> (Vec<isize>, Vec<f64>) {
    let n = score.len();
    let p = period as isize;
    // np.round(P/2) rounds half to even.
    let half = (period as f64 / 2.0).round_ties_even() as isize;
    let offsets: Vec<isize> = (-2 * p..=-half).collect();
    let txwt: Vec<f64> = offsets
        .iter()
        .map(|&w| -tightness * ((-w as f64) / period as f64).ln().powi(2))
        .collect();
    let max_score = score.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let mut backlink = vec![0isize; n];
    let mut cum = vec![0.0; n];
    let mut first_beat = true;
    for i in 0..n {
        let mut best = f64::NEG_INFINITY;
        let mut best_w = offsets[0];
        for (&w, &tx) in offsets.iter().zip(&txwt) {
            let j = i as isize + w;
            let c = if j >= 0 { tx + cum[j as usize] } else { tx };
            if c > best {
                best = c;
                best_w = w;
            }
        }
        cum[i] = score[i] + best;
        if first_beat && score[i] < 0.01 * max_score {
            backlink[i] = -1;
        } else {
            backlink[i] = i as isize + best_w;
            first_beat = false;
        }
    }
    (backlink, cum)
}

/// `__last_beat`: the last i with 2·cum[i]·[local max] > median of cum at its local maxima.
fn last_beat(cum: &[f64]) -> Option<usize> {
    let n = cum.len();
    let is_max = |i: usize| {
        let prev = cum[i.saturating_sub(1)];
        let next = cum[(i + 1).min(n - 1)];
        cum[i] > prev && cum[i] >= next
    };
    let mut maxima: Vec<f64> = (0..n).filter(|&i| is_max(i)).map(|i| cum[i]).collect();
    if maxima.is_empty() {
        return None;
    }
    maxima.sort_by(|a, b| a.total_cmp(b));
    let m = maxima.len();
    let med = if m % 2 == 1 {
        maxima[m / 2]
    } else {
        0.5 * (maxima[m / 2 - 1] + maxima[m / 2])
    };
    (0..n)
        .rev()
        .find(|&i| (if is_max(i) { cum[i] * 2.0 } else { 0.0 }) > med)
}

/// `__trim_beats`: smooth the beats' local scores with Hann(5), keep [first valid, last valid).
fn trim_beats(score: &[f64], beats: &[usize]) -> Vec<usize> {
    let b = beats.len();
    let w = [0.0, 0.5, 1.0, 0.5, 0.0];
    let vals: Vec<f64> = beats.iter().map(|&i| score[i]).collect();
    let smooth: Vec<f64> = (0..b as isize)
        .map(|i| {
            (0..5isize)
                .filter_map(|j| {
                    let k = i + j - 2;
                    (k >= 0 && (k as usize) < b).then(|| vals[k as usize] * w[j as usize])
                })
                .sum()
        })
        .collect();
    let thr = 0.5 * (smooth.iter().map(|s| s * s).sum::<f64>() / b as f64).sqrt();
    let first = smooth.iter().position(|&s| s > thr);
    let last = smooth.iter().rposition(|&s| s > thr);
    match (first, last) {
        (Some(f), Some(l)) => beats[f..l].to_vec(),
        _ => Vec::new(),
    }
}

/// Beats for a known tempo (`__beat_tracker` with trim).
pub fn track_beats(env: &[f64], bpm: f64, sr: f64, hop: usize, tightness: f64) -> Vec<usize> {
    if env.is_empty() || bpm <= 0.0 || !bpm.is_finite() {
        return Vec::new();
    }
    let period = (60.0 * frame_rate(sr, hop) / bpm)
        .round_ties_even()
        .max(1.0) as usize;
    let score = local_score(env, period);
    let (backlink, cum) = beat_dp(&score, period, tightness);
    let Some(last) = last_beat(&cum) else {
        return Vec::new();
    };
    let mut beats = vec![last];
    while backlink[*beats.last().unwrap()] >= 0 {
        beats.push(backlink[*beats.last().unwrap()] as usize);
    }
    beats.reverse();
    trim_beats(&score, &beats)
}

/// librosa 0.8.1 `beat.beat_track(onset_envelope=env, sr, hop_length, start_bpm, tightness)`.
/// An all-zero (or empty) envelope gives tempo 0 and no beats.
pub fn beat_track(env: &[f64], sr: f64, hop: usize, start_bpm: f64, tightness: f64) -> BeatTrack {
    if env.iter().all(|&v| v == 0.0) || start_bpm.is_nan() || start_bpm <= 0.0 {
        return BeatTrack {
            tempo_bpm: 0.0,
            beats: Vec::new(),
        };
    }
    let bpm = tempo(env, sr, hop, start_bpm);
    BeatTrack {
        tempo_bpm: bpm,
        beats: track_beats(env, bpm, sr, hop, tightness),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn clicks(n: usize, period: usize, phase: usize) -> Vec<f64> {
        let mut env = vec![0.0; n];
        for i in (phase..n).step_by(period) {
            env[i] = 1.0;
        }
        env
    }

    #[test]
    fn click_envelope_tempo_and_spacing() {
        // 30-frame period at 60 fps is 120 BPM, on the 3600/k grid.
        let env = clicks(1200, 30, 7);
        let bt = beat_track(&env, 30720.0, 512, 120.0, 100.0);
        assert_eq!(bt.tempo_bpm, 120.0);
        assert!(bt.beats.len() > 30);
        for w in bt.beats.windows(2) {
            assert_eq!(w[1] - w[0], 30);
        }
        assert!(bt.beats.iter().all(|&b| (b - 7) % 30 == 0));
    }

    #[test]
    fn prior_picks_the_metrical_level() {
        // Clicks every 24 frames = 150 BPM; a prior at 75 BPM can pick the half tempo (48 frames).
        let env = clicks(1500, 24, 3);
        let fast = beat_track(&env, 30720.0, 512, 150.0, 100.0);
        assert_eq!(fast.tempo_bpm, 150.0);
        let slow = tempo(&env, 30720.0, 512, 75.0);
        assert!(slow == 75.0 || slow == 150.0, "{slow}");
    }

    #[test]
    fn silence_has_no_beats() {
        let bt = beat_track(&[0.0; 500], 30720.0, 512, 120.0, 100.0);
        assert_eq!(bt.tempo_bpm, 0.0);
        assert!(bt.beats.is_empty());
    }

    #[test]
    fn short_envelopes_do_not_panic() {
        for n in 1..40 {
            let env: Vec<f64> = (0..n).map(|i| ((i * 7) % 5) as f64).collect();
            let _ = beat_track(&env, 30720.0, 512, 120.0, 100.0);
        }
    }

    #[test]
    fn half_to_even_in_dp_window() {
        // P = 31: offsets −62 ..= −16 (round(15.5) = 16).
        let (bl, _) = beat_dp(&[1.0; 100], 31, 100.0);
        assert!(bl[99] <= 99 - 16 && bl[99] >= 99 - 62);
    }
}
