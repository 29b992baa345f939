//! Learning-rate schedules indexed by the number of updates already applied (SPEC §4.8: the update with 0-based
//! index 100,000 is the first at the second value). Piecewise-constant (the papers' step function), with
//! optional linear warmup, or cosine decay.

use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum ScheduleKind {
    /// `initial` until the first boundary, then `values[i]` from boundary i on.
    #[default]
    Piecewise,
    /// Cosine decay from `initial` to `final_lr` over the steps after warmup.
    Cosine,
}

/// The `[schedule]` table of a run config.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ScheduleConfig {
    #[serde(default)]
    pub kind: ScheduleKind,
    /// Learning rate of the first update.
    pub initial: f64,
    /// Update indices at which the rate changes (piecewise), strictly increasing.
    #[serde(default)]
    pub boundaries: Vec<u64>,
    /// Rate from each boundary on (piecewise); as many as `boundaries`.
    #[serde(default)]
    pub values: Vec<f64>,
    /// Linear warmup over the first `warmup_steps` updates (rate × (step + 1)/warmup_steps).
    #[serde(default)]
    pub warmup_steps: u64,
    /// Final rate of the cosine schedule.
    #[serde(default)]
    pub final_lr: f64,
}

impl Default for ScheduleConfig {
    /// The QEAN paper's schedule: 1e-4, 1e-5 from 90k, 1e-6 from 150k.
    fn default() -> Self {
        ScheduleConfig {
            kind: ScheduleKind::Piecewise,
            initial: 1e-4,
            boundaries: vec![90_000, 150_000],
            values: vec![1e-5, 1e-6],
            warmup_steps: 0,
            final_lr: 0.0,
        }
    }
}

impl ScheduleConfig {
    /// Check the schedule; `total_steps` is the run length (needed by cosine).
    pub fn validate(&self, total_steps: u64) -> Result<(), String> {
        let ok = |x: f64| x.is_finite() && x > 0.0;
        if !ok(self.initial) {
            return Err(format!(
                "schedule.initial must be a positive number, got {}",
                self.initial
            ));
        }
        match self.kind {
            ScheduleKind::Piecewise => {
                if self.boundaries.len() != self.values.len() {
                    return Err(format!(
                        "schedule.boundaries has {} entries but schedule.values has {}",
                        self.boundaries.len(),
                        self.values.len()
                    ));
                }
                for w in self.boundaries.windows(2) {
                    if w[1] <= w[0] {
                        return Err(format!(
                            "schedule.boundaries must be strictly increasing ({} then {})",
                            w[0], w[1]
                        ));
                    }
                }
                if self.boundaries.first() == Some(&0) {
                    return Err(
                        "schedule.boundaries must be positive (use schedule.initial for step 0)"
                            .into(),
                    );
                }
                if let Some(v) = self.values.iter().find(|v| !ok(**v)) {
                    return Err(format!("schedule.values must be positive numbers, got {v}"));
                }
            }
            ScheduleKind::Cosine => {
                if !(self.final_lr.is_finite() && self.final_lr >= 0.0) {
                    return Err(format!(
                        "schedule.final_lr must be ≥ 0, got {}",
                        self.final_lr
                    ));
                }
                if self.warmup_steps >= total_steps {
                    return Err(format!(
                        "schedule.warmup_steps ({}) must be below train.steps ({total_steps}) for cosine",
                        self.warmup_steps
                    ));
                }
            }
        }
        Ok(())
    }

    /// The rate of the update with 0-based index `step` in a run of `total_steps` updates.
    pub fn lr(&self, step: u64, total_steps: u64) -> f64 {
        let base = match self.kind {
            ScheduleKind::Piecewise => {
                let i = self.boundaries.partition_point(|&b| b <= step);
                if i == 0 {
                    self.initial
                } else {
                    self.values[i - 1]
                }
            }
            ScheduleKind::Cosine => {
                let span = total_steps.saturating_sub(self.warmup_steps).max(1) as f64;
                let t = (step.saturating_sub(self.warmup_steps) as f64 / span).min(1.0);
                self.final_lr
                    + 0.5
                        * (self.initial - self.final_lr)
                        * (1.0 + (std::f64::consts::PI * t).cos())
            }
        };
        if step < self.warmup_steps {
            base * (step + 1) as f64 / self.warmup_steps as f64
        } else {
            base
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn paper_step_function() {
        let s = ScheduleConfig::default();
        s.validate(500_000).unwrap();
        assert_eq!(s.lr(0, 500_000), 1e-4);
        assert_eq!(s.lr(89_999, 500_000), 1e-4);
        assert_eq!(s.lr(90_000, 500_000), 1e-5);
        assert_eq!(s.lr(149_999, 500_000), 1e-5);
        assert_eq!(s.lr(150_000, 500_000), 1e-6);
        assert_eq!(s.lr(499_999, 500_000), 1e-6);
    }

    #[test]
    fn warmup_and_cosine() {
        let s = ScheduleConfig {
            kind: ScheduleKind::Cosine,
            initial: 1.0,
            final_lr: 0.0,
            warmup_steps: 10,
            boundaries: vec![],
            values: vec![],
        };
        s.validate(110).unwrap();
        assert!((s.lr(0, 110) - 0.1).abs() < 1e-12);
        assert!((s.lr(9, 110) - 1.0).abs() < 1e-12);
        assert!((s.lr(10, 110) - 1.0).abs() < 1e-12);
        assert!((s.lr(60, 110) - 0.5).abs() < 1e-12);
        assert!(s.lr(110, 110).abs() < 1e-12);
    }

    #[test]
    fn invalid_schedules() {
        let bad = |f: &dyn Fn(&mut ScheduleConfig)| {
            let mut s = ScheduleConfig::default();
            f(&mut s);
            s.validate(1000).unwrap_err()
        };
        assert!(bad(&|s| s.boundaries = vec![100, 50]).contains("strictly increasing"));
        assert!(bad(&|s| s.values = vec![1e-5]).contains("has 2 entries"));
        assert!(bad(&|s| s.initial = -1.0).contains("positive"));
        assert!(bad(&|s| s.boundaries = vec![0, 5]).contains("positive"));
        assert!(bad(&|s| {
            s.kind = ScheduleKind::Cosine;
            s.warmup_steps = 5000
        })
        .contains("warmup"));
    }
}
