//! The demo's genre-control section (SPEC §13.5, §13.10): the genre classifier judged on the ground
//! truth, then the control test of the genre stage — every test + val music danced in each of the 10
//! genres, each dance classified — with how the steered dances move.

use std::path::{Path, PathBuf};

use crate::evaluate::RunEvalRequest;
use crate::genre_control::{control_test, ControlReport};
use qean_checkpoint::checkpoint::Checkpoint;

/// The genres whose dances to the held-out song the demo writes (`dances/genre-<G>/`): two whose
/// AIST++ styles differ most (krump's stomps and chest pops, waacking's arm whips).
pub const SHOWN: [&str; 2] = ["KR", "WA"];

/// What the section produced.
#[derive(Debug, Clone)]
pub struct GenreDemo {
    pub control: ControlReport,
    /// `runs/genre/eval/step-N/control.md`.
    pub control_md: PathBuf,
}

/// Runs the control test of the genre run `genre_run` with the classifier `clf` on the test + val
/// sequences (`max_frames` generated frames per dance).
pub fn run(
    data: &Path,
    clf: &Checkpoint,
    genre_run: &Path,
    max_frames: usize,
) -> crate::Result<GenreDemo> {
    let req = RunEvalRequest {
        max_frames,
        ..RunEvalRequest::new(genre_run, data)
    };
    let (control, _) = control_test(&req, &clf.dir)?;
    let control_md = genre_run
        .join("eval")
        .join(qean_checkpoint::run_dir::checkpoint_name(control.step))
        .join("control.md");
    append_to_report(&control_md)?;
    Ok(GenreDemo {
        control,
        control_md,
    })
}

/// The heading under which the control test joins the genre run's `report.md`.
const SECTION: &str = "## Genre control test";

/// Copies `control.md` (both accuracies with their confusion matrices) into the `report.md` beside
/// it, replacing the copy an earlier demo appended, so that the run's report holds the whole verdict.
fn append_to_report(control_md: &Path) -> crate::Result<()> {
    use crate::error::Context;
    let report = control_md.with_file_name("report.md");
    let read = |p: &Path| {
        std::fs::read_to_string(p).with_context(|| format!("{}: cannot read", p.display()))
    };
    let mut text = read(&report)?;
    if let Some(i) = text.find(&format!("\n{SECTION}")) {
        text.truncate(i);
    }
    let control = read(control_md)?;
    let body = control.split_once('\n').map_or("", |(_, rest)| rest);
    text = format!(
        "{}\n\n{SECTION} ({})\n{body}",
        text.trim_end(),
        control_md.display()
    );
    qean_io::fsutil::atomic_write(&report, text.as_bytes())?;
    Ok(())
}

/// The section's lines under the tables: the judge's accuracy, the control accuracy, how the steered
/// dances move; in words.
pub fn table(g: &GenreDemo) -> String {
    let c = &g.control;
    let dancing: usize = c.energy.iter().map(|e| e.dancing).sum();
    let slowest = c
        .energy
        .iter()
        .map(|e| e.min_span_speed_ratio)
        .fold(f64::INFINITY, f64::min);
    let sharpest = c
        .energy
        .iter()
        .map(|e| e.max_span_accel_ratio)
        .fold(0.0, f64::max);
    let judge = if c.classifier_accuracy >= 0.8 {
        "meets SPEC §13.10's 0.8"
    } else {
        "is BELOW SPEC §13.10's 0.8: its verdicts say little"
    };
    let steers = if c.accuracy >= 0.5 {
        "steers"
    } else {
        "does NOT steer well enough"
    };
    format!(
        "\nGenre control (SPEC §13.5): the genre classifier is right on {:.2} of the ground-truth test + val dances \
         ({judge}); asked for each of the 10 genres on every test + val music ({} dances), genre control {steers}: \
         the classifier names the requested genre for {:.2} of them (chance 0.10; {:.2} when the music's own genre \
         was asked for, {:.2} otherwise; target ≥ 0.5). {dancing} of the {} steered dances keep dancing (slowest \
         5-s span {slowest:.2}× the ground truth's speed, sharpest {sharpest:.2}× its acceleration). Both confusion \
         matrices: {}\n",
        c.classifier_accuracy,
        c.samples,
        c.accuracy,
        c.accuracy_own,
        c.accuracy_other,
        c.samples,
        g.control_md.display()
    )
}
