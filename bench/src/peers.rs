//! The peer implementations (Python scripts in `bench/peer/`), run on the same inputs. Each script
//! prints one JSON object as its last line: `name`, `value` (in the measure's unit), `peak_rss_mb`
//! and `detail`.

use std::path::PathBuf;
use std::process::Command;

use qean_pipeline::error::Context;

use super::measures::{Inputs, MeasureId, Sizes};
use super::report::PeerResult;

/// Where the peers are and which Python runs each (they need different packages: librosa 0.8.1
/// wants an old numpy, PyTorch a new one).
#[derive(Debug, Clone)]
pub struct Peers {
    pub script_dir: PathBuf,
    pub librosa_python: String,
    pub numpy_python: String,
    pub torch_python: String,
}

/// A peer invocation, printable as a shell command.
#[derive(Debug, Clone)]
pub struct PeerCommand {
    pub program: String,
    pub args: Vec<String>,
}

impl std::fmt::Display for PeerCommand {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}", self.program)?;
        for a in &self.args {
            write!(f, " {a}")?;
        }
        Ok(())
    }
}

impl Peers {
    /// The command that measures `id`'s peer.
    pub fn command(&self, id: MeasureId, inputs: &Inputs, sizes: &Sizes) -> PeerCommand {
        let script = |name: &str| self.script_dir.join(name).display().to_string();
        // fact_torch.py --size S --what W, then (flag, count) pairs.
        let torch = |id: MeasureId, what: &str, counts: &[(&str, usize)]| -> Vec<String> {
            let mut args = vec![
                script("fact_torch.py"),
                "--size".into(),
                id.size().into(),
                "--what".into(),
                what.into(),
            ];
            for (flag, n) in counts {
                args.push(flag.to_string());
                args.push(n.to_string());
            }
            args
        };
        let (program, args) = match id {
            MeasureId::Features => (
                &self.librosa_python,
                vec![
                    script("features_librosa.py"),
                    inputs.track.display().to_string(),
                    "--repeats".into(),
                    sizes.feature_repeats.max(1).to_string(),
                ],
            ),
            MeasureId::FeaturesDataset => (&self.librosa_python, {
                let mut args = vec![script("features_librosa.py")];
                args.extend(
                    inputs
                        .dataset_tracks(sizes)
                        .iter()
                        .map(|p| p.display().to_string()),
                );
                args.extend(["--repeats".into(), sizes.feature_repeats.max(1).to_string()]);
                args
            }),
            MeasureId::Metrics => (
                &self.numpy_python,
                vec![
                    script("metrics_numpy.py"),
                    inputs.set_json.display().to_string(),
                ],
            ),
            MeasureId::TrainTiny | MeasureId::TrainMint => {
                let steps = match id {
                    MeasureId::TrainMint => sizes.train_steps_mint,
                    _ => sizes.train_steps_tiny,
                };
                let batch = [("--batch", sizes.batch), ("--steps", steps.max(1))];
                (&self.torch_python, torch(id, "train", &batch))
            }
            MeasureId::SampleTiny | MeasureId::SampleMint => {
                let frames = match id {
                    MeasureId::SampleMint => sizes.sample_frames_mint,
                    _ => sizes.sample_frames_tiny,
                };
                let counts = [
                    ("--sequences", sizes.sequences),
                    ("--frames", frames.max(1)),
                ];
                (&self.torch_python, torch(id, "sample", &counts))
            }
            MeasureId::TrainTsmt | MeasureId::SampleTsmt => {
                let (what, counts) = if id == MeasureId::TrainTsmt {
                    (
                        "train",
                        [
                            ("--batch", super::measures::TSMT_BATCH),
                            ("--steps", sizes.train_steps_tsmt.max(1)),
                        ],
                    )
                } else {
                    (
                        "sample",
                        [
                            ("--sequences", sizes.sequences),
                            ("--frames", sizes.sample_frames_tsmt.max(1)),
                        ],
                    )
                };
                let mut args = vec![script("tsmt_torch.py"), "--what".into(), what.into()];
                for (flag, n) in counts {
                    args.push(flag.to_string());
                    args.push(n.to_string());
                }
                (&self.torch_python, args)
            }
        };
        PeerCommand {
            program: program.clone(),
            args,
        }
    }

    /// Runs `id`'s peer and reads its result.
    pub fn run(&self, id: MeasureId, inputs: &Inputs, sizes: &Sizes) -> crate::Result<PeerResult> {
        let cmd = self.command(id, inputs, sizes);
        let out = Command::new(&cmd.program)
            .args(&cmd.args)
            .current_dir(&inputs.dir)
            .output()
            .with_context(|| format!("peer of {}: cannot start `{}`", id.name(), cmd.program))?;
        let stdout = String::from_utf8_lossy(&out.stdout);
        if !out.status.success() {
            let stderr = String::from_utf8_lossy(&out.stderr);
            let last = stderr.lines().last().unwrap_or("no message");
            qean_pipeline::bail!("peer of {} failed (`{cmd}`): {last}", id.name());
        }
        parse_result(&stdout).with_context(|| format!("peer of {} (`{cmd}`)", id.name()))
    }
}

/// The JSON object on the last non-empty line of a peer's output.
pub fn parse_result(stdout: &str) -> crate::Result<PeerResult> {
    let line = stdout
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .context("printed nothing")?;
    let v: serde_json::Value =
        serde_json::from_str(line).with_context(|| format!("last line is not JSON: {line}"))?;
    let num = |k: &str| v.get(k).and_then(serde_json::Value::as_f64);
    let text = |k: &str| v.get(k).and_then(serde_json::Value::as_str).unwrap_or("");
    let value = num("value").context("no numeric `value`")?;
    qean_pipeline::ensure!(
        value.is_finite() && value > 0.0,
        "`value` {value} is not a positive number"
    );
    Ok(PeerResult {
        name: text("name").to_string(),
        value,
        peak_rss_mb: num("peak_rss_mb").unwrap_or(f64::NAN),
        detail: text("detail").to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_the_last_json_line() {
        let r = parse_result(
            "warming up\n{\"name\": \"PyTorch 2.1\", \"value\": 1.5, \"peak_rss_mb\": 300, \"detail\": \"x\"}\n\n",
        )
        .unwrap();
        assert_eq!(r.name, "PyTorch 2.1");
        assert_eq!(r.value, 1.5);
        assert_eq!(r.peak_rss_mb, 300.0);
        assert!(parse_result("").is_err());
        assert!(parse_result("{\"name\": \"x\"}").is_err());
        assert!(parse_result("{\"value\": -1}").is_err());
        assert!(parse_result("not json").is_err());
    }
}
