//! The genre control test (SPEC §13.10): every paired test music × all 10 genres (z-seed = the sequence's
//! index), each dance judged by a trained genre classifier. Reports the accuracy with respect to the
//! requested genre (split into requested = the track's genre and ≠), the 10 × 10 confusion matrix (rows:
//! requested) and per-genre FID_k / FID_g against the ground-truth sequences of that genre.
//! `qean eval --run GENRE_RUN --data D --classifier CLF_RUN` writes `R/eval/step-N[-TAG]/control.{md,json}`.

use std::path::{Path, PathBuf};

use qean_aistpp::dataset::Dataset;
use qean_aistpp::names::GENRES;
use qean_eval::config::EvalConfig;
use qean_eval::positions::Sequence;
use qean_eval::run_report::{frames_of, pairings, Protocol};
use qean_motion::motion::Motion;
use qean_train::genre_clf::genre_of;
use serde::Serialize;

use crate::evaluate::RunEvalRequest;
use crate::genre_clf::TrainedClf;
use crate::gpt::{GenreChoice, GptRun, Picking};
use crate::{Error, Result};

/// Per-genre quality of the dances requested in that genre.
#[derive(Debug, Clone, Serialize)]
pub struct GenreQuality {
    pub genre: String,
    pub samples: usize,
    /// Ground-truth sequences of that genre (all splits).
    pub reference: usize,
    pub fid_k: f64,
    pub fid_g: f64,
    /// Feature dimensions constant over that genre's ground truth (kinetic + geometric): with few ground-truth
    /// sequences their normalisation divides by ~0 and the FIDs say nothing.
    pub constant_dims: usize,
}

/// The control test's report.
#[derive(Debug, Clone, Serialize)]
pub struct ControlReport {
    pub checkpoint: PathBuf,
    pub step: u64,
    pub classifier: PathBuf,
    /// Generated frames per dance.
    pub frames: usize,
    pub samples: usize,
    /// Fraction classified as the requested genre: all, requested = the track's genre, and ≠.
    pub accuracy: f64,
    pub accuracy_own: f64,
    pub accuracy_other: f64,
    /// confusion[requested][predicted].
    pub confusion: Vec<Vec<usize>>,
    pub per_genre: Vec<GenreQuality>,
}

/// The genre of a music ID (`mBR0` → BR).
pub(crate) fn music_genre(music: &str) -> Option<usize> {
    qean_train::genre_clf::genre_index(music.strip_prefix('m')?)
}

/// Runs the control test; writes the report beside the run's evaluations.
pub fn control_test(req: &RunEvalRequest, classifier: &Path) -> Result<(ControlReport, String)> {
    let ck = qean_train::checkpoint::resolve_in_run(&req.run, req.checkpoint.as_deref())?;
    if !ck.config.is_gpt_genre() {
        return Err(Error::Invalid(format!(
            "{}: --classifier runs the genre control test, which needs a genre-control run (model.arch = \"gpt_genre\"), not {:?}",
            ck.dir.display(),
            ck.config.model.arch
        )));
    }
    let clf = TrainedClf::load(classifier, None)?;
    if req.max_frames < clf.config.window {
        return Err(Error::Invalid(format!(
            "--max-frames {}: the classifier needs at least one {}-frame window",
            req.max_frames, clf.config.window
        )));
    }
    let ds = Dataset::open(&req.data)?;
    let names = crate::evaluate::protocol_sequences(&ds)?;
    let pairs = pairings(&names, Protocol::Paired);
    let (requests, _) = crate::evaluate::sample_requests(&ds, &pairs, &ck.config, req.seed_start)?;
    let g = qean_train::gpt::gpt_of(&ck.config);
    let run = GptRun::load(&ck)?;
    let picking = Picking {
        top_k: req.sampling.top_k.unwrap_or(g.top_k),
        temperature: req.sampling.temperature.unwrap_or(g.temperature),
        seed: req.sampling.sample_seed,
    };
    let layout = ck.config.layout();
    let dim = qean_aistpp::windows::AUDIO_DIM;
    let total = requests.len() * GENRES.len();
    let pb = qean_train::progress::bar(total as u64, "genre control test", "dances");
    let mut confusion = vec![vec![0usize; GENRES.len()]; GENRES.len()];
    let (mut own, mut other) = ((0, 0), (0, 0));
    let mut generated: Vec<Vec<Sequence>> = vec![Vec::new(); GENRES.len()];
    for (i, (r, (_, music, _))) in requests.iter().zip(&pairs).enumerate() {
        let seed = Motion::from_layout(&r.seed, layout).map_err(Error::Invalid)?;
        let audio = (r.audio.as_slice(), r.audio.len() / dim);
        for (genre, dances) in generated.iter_mut().enumerate() {
            let choice = GenreChoice {
                genre,
                z_seed: i as u64,
            };
            let motion = run
                .dance(
                    g,
                    &seed,
                    audio,
                    req.max_frames,
                    &picking,
                    Some(choice),
                    &mut |_, _| {},
                )?
                .ok_or_else(|| {
                    Error::Invalid(format!("{music}: shorter than the seed and one token"))
                })?;
            let dance = motion.slice(seed.frames, motion.frames);
            let predicted = clf.classify(&dance);
            confusion[genre][predicted] += 1;
            let hit = usize::from(predicted == genre);
            let tally = if music_genre(music) == Some(genre) {
                &mut own
            } else {
                &mut other
            };
            *tally = (tally.0 + hit, tally.1 + 1);
            dances.push(Sequence::new(
                format!("{music}-as-{}", GENRES[genre]),
                frames_of(dance.joints(req.root)),
            ));
            pb.inc(1);
        }
    }
    pb.finish_and_clear();
    let per_genre = per_genre_quality(&ds, &generated, req)?;
    let ratio = |(a, b): (usize, usize)| a as f64 / b.max(1) as f64;
    let report = ControlReport {
        checkpoint: ck.dir.clone(),
        step: ck.state.step,
        classifier: clf.checkpoint.dir.clone(),
        frames: req.max_frames,
        samples: total,
        accuracy: ratio((own.0 + other.0, own.1 + other.1)),
        accuracy_own: ratio(own),
        accuracy_other: ratio(other),
        confusion,
        per_genre,
    };
    let md = markdown(&report);
    let out_dir = crate::evaluate::write_eval_files(req, report.step, "control", &report, &md)?;
    Ok((
        report,
        md + &format!("\nreport: {}\n", out_dir.join("control.md").display()),
    ))
}

/// FID_k / FID_g of each genre's requested dances against the ground truth of that genre (genres with
/// fewer than 2 of either are left out).
fn per_genre_quality(
    ds: &Dataset,
    generated: &[Vec<Sequence>],
    req: &RunEvalRequest,
) -> Result<Vec<GenreQuality>> {
    let reference = crate::evaluate::reference_set(ds, req.root)?;
    let cfg = EvalConfig {
        seed_frames: 0,
        music_offset: 0,
        max_frames: req.max_frames,
        ..req.configs.first().cloned().unwrap_or_default()
    };
    let mut out = Vec::new();
    for (genre, dances) in generated.iter().enumerate() {
        let gt: Vec<Sequence> = reference
            .iter()
            .filter(|s| genre_of(&s.name) == Some(genre))
            .cloned()
            .collect();
        if gt.len() < 2 || dances.len() < 2 {
            continue;
        }
        let r = qean_eval::protocol::evaluate(dances, &gt, None, &cfg)?;
        out.push(GenreQuality {
            genre: GENRES[genre].to_string(),
            samples: dances.len(),
            reference: gt.len(),
            fid_k: r.fid_k,
            fid_g: r.fid_g,
            constant_dims: r.constant_reference_dims_k.len() + r.constant_reference_dims_g.len(),
        });
    }
    Ok(out)
}

/// The report as markdown.
pub fn markdown(r: &ControlReport) -> String {
    let mut s = format!(
        "# Genre control test, step {}\n\nCheckpoint {}; classifier {}. {} dances of {} frames (every paired \
         music × 10 requested genres).\n\nAccuracy w.r.t. the requested genre: **{:.3}** (chance 0.1); \
         requested = the track's genre {:.3}, requested ≠ the track's genre {:.3}.\n\n\
         | requested \\ predicted | {} |\n|---|{}\n",
        r.step,
        r.checkpoint.display(),
        r.classifier.display(),
        r.samples,
        r.frames,
        r.accuracy,
        r.accuracy_own,
        r.accuracy_other,
        GENRES.join(" | "),
        "---|".repeat(GENRES.len())
    );
    for (g, row) in r.confusion.iter().enumerate() {
        let cells: Vec<String> = row.iter().map(|c| c.to_string()).collect();
        s += &format!("| {} | {} |\n", GENRES[g], cells.join(" | "));
    }
    s += "\n| genre | dances | GT sequences | FID_k | FID_g | constant GT feature dims |\n|---|---|---|---|---|---|\n";
    for q in &r.per_genre {
        s += &format!(
            "| {} | {} | {} | {:.2} | {:.2} | {} |\n",
            q.genre, q.samples, q.reference, q.fid_k, q.fid_g, q.constant_dims
        );
    }
    if r.per_genre.iter().any(|q| q.constant_dims > 0) {
        s += "\nSome genres' ground truth has constant feature dimensions (too few sequences): their FIDs divide by \
              ~0 after normalisation and are not meaningful.\n";
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn music_ids_name_their_genre() {
        assert_eq!(music_genre("mBR0"), Some(0));
        assert_eq!(music_genre("mJB5"), Some(9));
        assert_eq!(music_genre("mXX1"), None);
        assert_eq!(music_genre("song"), None);
    }
}
