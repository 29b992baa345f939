//! Statistics over training seeds: a metric's mean with its 95 % confidence interval from Student's t
//! distribution (n − 1 degrees of freedom), and paired differences between two variants trained with the
//! same seeds. With one seed there is no interval: a number, not a result.

use serde::{Deserialize, Serialize};

/// ln Γ(x) for x > 0 (Lanczos, g = 7, nine terms: ~15 significant digits).
fn ln_gamma(x: f64) -> f64 {
    const G: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x)Γ(1 − x) = π / sin(πx).
        let pi = std::f64::consts::PI;
        return (pi / (pi * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = G[0];
    let t = x + 7.5;
    for (i, g) in G.iter().enumerate().skip(1) {
        a += g / (x + i as f64);
    }
    0.5 * (2.0 * std::f64::consts::PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// The continued fraction of the incomplete beta function (modified Lentz).
fn beta_fraction(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let (qab, qap, qam) = (a + b, a + 1.0, a - 1.0);
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..=300 {
        let m = m as f64;
        let m2 = 2.0 * m;
        for aa in [
            m * (b - m) * x / ((qam + m2) * (a + m2)),
            -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2)),
        ] {
            d = 1.0 + aa * d;
            if d.abs() < TINY {
                d = TINY;
            }
            c = 1.0 + aa / c;
            if c.abs() < TINY {
                c = TINY;
            }
            d = 1.0 / d;
            h *= d * c;
            if aa != 0.0 && (d * c - 1.0).abs() < 1e-15 {
                return h;
            }
        }
    }
    h
}

/// The regularised incomplete beta function I_x(a, b).
fn incomplete_beta(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let front =
        (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (1.0 - x).ln()).exp();
    // The fraction converges fast for x < (a + 1)/(a + b + 2); otherwise use the symmetry.
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_fraction(a, b, x) / a
    } else {
        1.0 - front * beta_fraction(b, a, 1.0 - x) / b
    }
}

/// P(T ≤ t) for Student's t with `df` degrees of freedom.
pub fn t_cdf(t: f64, df: f64) -> f64 {
    let tail = 0.5 * incomplete_beta(df / 2.0, 0.5, df / (df + t * t));
    if t >= 0.0 {
        1.0 - tail
    } else {
        tail
    }
}

/// The t quantile q with P(T ≤ q) = p (0.5 < p < 1), by bisection on the CDF.
pub fn t_quantile(p: f64, df: f64) -> f64 {
    assert!(p > 0.5 && p < 1.0 && df > 0.0, "t_quantile({p}, {df})");
    let (mut lo, mut hi) = (0.0, 1.0);
    while t_cdf(hi, df) < p {
        hi *= 2.0;
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if t_cdf(mid, df) < p {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-14 * hi {
            break;
        }
    }
    0.5 * (lo + hi)
}

/// Mean and sample standard deviation (n − 1; 0 for one value).
pub fn mean_sd(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let sd = if v.len() > 1 {
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0)).sqrt()
    } else {
        0.0
    };
    (m, sd)
}

/// A mean over seeds with its 95 % confidence interval: mean ± `half_width`
/// (t_{0.975, n−1} · s / √n, s the sample standard deviation). `half_width` is `None` for one value.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Interval {
    pub mean: f64,
    pub half_width: Option<f64>,
    /// Sample standard deviation (n − 1), `None` for one value.
    pub sd: Option<f64>,
    pub n: usize,
}

impl Interval {
    /// The interval of `values` (finite ones only; `None` when there are none).
    pub fn of(values: &[f64]) -> Option<Interval> {
        let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        let n = v.len();
        if n == 0 {
            return None;
        }
        let (mean, sd) = mean_sd(&v);
        if n == 1 {
            return Some(Interval {
                mean,
                half_width: None,
                sd: None,
                n,
            });
        }
        let half = t_quantile(0.975, (n - 1) as f64) * sd / (n as f64).sqrt();
        Some(Interval {
            mean,
            half_width: Some(half),
            sd: Some(sd),
            n,
        })
    }

    /// [`Interval::display`], noting "(n of N)" when fewer than the `seeds` that ran gave a value (a
    /// non-finite score, or a seed the baseline lacks).
    pub fn display_of(&self, decimals: usize, seeds: usize) -> String {
        if self.n < seeds {
            format!("{} ({} of {seeds})", self.display(decimals), self.n)
        } else {
            self.display(decimals)
        }
    }

    /// Whether the interval excludes zero (a paired difference that seeds do not explain).
    pub fn excludes_zero(&self) -> bool {
        self.half_width.is_some_and(|h| self.mean.abs() > h)
    }

    /// "m ± h" with `decimals` places after the point ("m (1 seed)" without an interval).
    pub fn display(&self, decimals: usize) -> String {
        match self.half_width {
            Some(h) => format!("{:.*} ± {:.*}", decimals, self.mean, decimals, h),
            None => format!("{:.*} (1 seed)", decimals, self.mean),
        }
    }
}

/// The paired differences `a_s − b_s` over the seeds both have, as an interval (the seeds' shared
/// part cancels: tighter than comparing two intervals). `None` without a common seed.
pub fn paired_difference(a: &[(u64, f64)], b: &[(u64, f64)]) -> Option<Interval> {
    let diffs: Vec<f64> = a
        .iter()
        .filter_map(|(s, x)| b.iter().find(|(t, _)| t == s).map(|(_, y)| x - y))
        .collect();
    Interval::of(&diffs)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t_quantiles_match_scipy() {
        // scipy.stats.t.ppf(0.975, df), df = 1..10, 30, 100.
        let want = [
            (1.0, 12.706204736174694),
            (2.0, 4.302652729749462),
            (3.0, 3.1824463052837078),
            (4.0, 2.7764451051977934),
            (5.0, 2.5705818356363146),
            (6.0, 2.4469118511449786),
            (7.0, 2.364624251592784),
            (8.0, 2.306004135204166),
            (9.0, 2.262157162798205),
            (10.0, 2.228138851986274),
            (30.0, 2.0422724563012378),
            (100.0, 1.9839715185235518),
        ];
        for (df, q) in want {
            let got = t_quantile(0.975, df);
            assert!((got - q).abs() < 1e-9 * q, "df {df}: {got} vs {q}");
        }
        // scipy.stats.t.cdf(1.5, 3), t.cdf(-2, 7).
        assert!((t_cdf(1.5, 3.0) - 0.8847080673775886).abs() < 1e-12);
        assert!((t_cdf(-2.0, 7.0) - 0.042809664281488025).abs() < 1e-12);
        assert_eq!(t_cdf(0.0, 4.0), 0.5);
    }

    #[test]
    fn intervals_by_hand() {
        // numpy: mean 62.3, sd 8.126499861564016, t.ppf(.975, 2) * sd / sqrt(3) = 20.18734477064501.
        let i = Interval::of(&[60.1, 55.5, 71.3]).unwrap();
        assert!((i.mean - 62.3).abs() < 1e-12);
        assert!((i.sd.unwrap() - 8.126499861564016).abs() < 1e-12);
        assert!((i.half_width.unwrap() - 20.18734477064501).abs() < 1e-9);
        assert_eq!(i.display(1), "62.3 ± 20.2");
        // Two seeds: t(1) = 12.71, sd of {1, 3} = √2: 12.706 · √2 / √2.
        let two = Interval::of(&[1.0, 3.0]).unwrap();
        assert!((two.half_width.unwrap() - 12.706204736174694).abs() < 1e-9);
        let one = Interval::of(&[4.0, f64::NAN]).unwrap();
        assert_eq!((one.n, one.half_width), (1, None));
        assert_eq!(one.display(2), "4.00 (1 seed)");
        assert!(Interval::of(&[]).is_none());
    }

    #[test]
    fn paired_differences_cancel_what_seeds_share() {
        // Seeds shift both variants alike: the unpaired intervals overlap, the paired one excludes 0.
        let a = [(0, 10.0), (1, 20.0), (2, 30.0), (3, 40.0)];
        let b = [(0, 11.0), (1, 21.5), (2, 30.5), (3, 41.0), (9, 0.0)];
        let d = paired_difference(&a, &b).unwrap();
        assert_eq!(d.n, 4);
        assert!((d.mean + 1.0).abs() < 1e-12);
        // Differences −1, −1.5, −0.5, −1: sd √(1/6), t(3) = 3.1824463 → half 3.1824463·0.408248/2.
        let want = 3.1824463052837078 * (1.0f64 / 6.0).sqrt() / 2.0;
        assert!((d.half_width.unwrap() - want).abs() < 1e-9);
        assert!(d.excludes_zero());
        let ia = Interval::of(&[10.0, 20.0, 30.0, 40.0]).unwrap();
        assert!(
            ia.half_width.unwrap() > 1.0,
            "unpaired: inside the seeds' spread"
        );
        assert!(paired_difference(&a, &[(7, 1.0)]).is_none());
    }
}
