//! Training progress on stderr: a bar on a terminal, a plain line every 10 s otherwise, or nothing.

use std::io::IsTerminal;
use std::time::Instant;

use indicatif::ProgressBar;

use qean_checkpoint::progress::{bar, ProgressMode};

/// Shows one run's progress.
pub struct Reporter {
    mode: ProgressMode,
    bar: Option<ProgressBar>,
    last_line: Instant,
    label: String,
}

impl Reporter {
    pub fn new(mode: ProgressMode, total: u64, done: u64, label: &str) -> Self {
        let mode = match mode {
            ProgressMode::Auto if std::io::stderr().is_terminal() => ProgressMode::Auto,
            ProgressMode::Auto => ProgressMode::Lines,
            m => m,
        };
        let bar = (mode == ProgressMode::Auto).then(|| {
            let pb = bar(total, label, "");
            pb.set_position(done);
            pb.reset_eta();
            pb
        });
        Reporter {
            mode,
            bar,
            last_line: Instant::now(),
            label: label.to_string(),
        }
    }

    pub fn update(&mut self, step: u64, total: u64, loss: f64, lr: f64, rate: f64, force: bool) {
        let msg = format!("loss {loss:.4e} lr {lr:.1e}");
        match self.mode {
            ProgressMode::Auto => {
                if let Some(pb) = &self.bar {
                    pb.set_position(step);
                    pb.set_message(msg);
                }
            }
            ProgressMode::Lines => {
                if force || self.last_line.elapsed().as_secs_f64() >= 10.0 {
                    let eta = if rate > 0.0 {
                        (total - step) as f64 / rate
                    } else {
                        0.0
                    };
                    let label = if self.label.is_empty() {
                        String::new()
                    } else {
                        format!("{}: ", self.label)
                    };
                    eprintln!("{label}step {step}/{total} {msg} {rate:.2} steps/s eta {eta:.0} s");
                    self.last_line = Instant::now();
                }
            }
            ProgressMode::Quiet => {}
        }
    }

    pub fn println(&self, line: &str) {
        match (&self.bar, self.mode) {
            (Some(pb), _) => pb.println(line),
            (None, ProgressMode::Quiet) => {}
            (None, _) => eprintln!("{line}"),
        }
    }

    pub fn finish(&self) {
        if let Some(pb) = &self.bar {
            pb.finish_and_clear();
        }
    }
}
