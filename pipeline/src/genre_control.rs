//! The genre control test (SPEC §13.10): every paired test music × all 10 genres (z-seed = the sequence's
//! index), each dance judged by a trained genre classifier. Reports the accuracy with respect to the
//! requested genre (split into requested = the track's genre and ≠), the 10 × 10 confusion matrix (rows:
//! requested) and per-genre FID_k / FID_g against the ground-truth sequences of that genre.
//! `qean eval --run GENRE_RUN --data D --classifier CLF_RUN` writes `R/eval/step-N[-TAG]/control.{md,json}`.

use std::path::{Path, PathBuf};

use qean_aistpp::dataset::Dataset;
use qean_eval::config::EvalConfig;
use qean_eval::positions::Sequence;
use qean_eval::run_report::{frames_of, pairings, Protocol};
use qean_motion::motion::Motion;
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
    /// Against that genre's ground truth, normalised with the whole ground truth's statistics (a genre's
    /// few sequences have near-zero spreads to divide by).
    pub fid_k: f64,
    pub fid_g: f64,
}

/// How the dances requested in one genre move (generated frames against the dataset's ground truth).
#[derive(Debug, Clone, Serialize)]
pub struct GenreEnergy {
    pub genre: String,
    pub samples: usize,
    /// Mean joint speed and acceleration over the genre's dances, as ratios to the ground truth's.
    pub speed_ratio: f64,
    pub accel_ratio: f64,
    /// The slowest and the fastest 5-s span over the genre's dances, and the largest acceleration ratio of
    /// a span.
    pub min_span_speed_ratio: f64,
    pub max_span_speed_ratio: f64,
    pub max_span_accel_ratio: f64,
    /// Dances with every 5-s span at speed 0.6–1.6× and acceleration ≤ 2× the ground truth's.
    pub dancing: usize,
}

/// The control test's report.
#[derive(Debug, Clone, Serialize)]
pub struct ControlReport {
    pub checkpoint: PathBuf,
    pub step: u64,
    pub classifier: PathBuf,
    /// The classifier on the ground-truth test + val sequences (the judge's own accuracy; SPEC §13.10
    /// asks for ≥ 0.8) and its confusion matrix (rows: true genre).
    pub classifier_accuracy: f64,
    pub classifier_confusion: Vec<Vec<usize>>,
    /// Generated frames per dance.
    pub frames: usize,
    pub samples: usize,
    /// Fraction classified as the requested genre: all, requested = the track's genre, and ≠.
    pub accuracy: f64,
    pub accuracy_own: f64,
    pub accuracy_other: f64,
    /// The genres' names, in index order (the run's vocabulary).
    pub genres: Vec<String>,
    /// confusion[requested][predicted].
    pub confusion: Vec<Vec<usize>>,
    pub per_genre: Vec<GenreQuality>,
    /// Motion energy of the dances of each requested genre.
    pub energy: Vec<GenreEnergy>,
}

/// The genre of a music ID: AIST++'s from the ID (`mBR0` → BR), FineDance's from its dance's label (each
/// dance has its own music).
pub(crate) fn music_genre(ds: &Dataset, music: &str) -> Option<usize> {
    match ds.layout {
        qean_aistpp::layout::DataLayout::Aistpp => {
            qean_aistpp::names::genre_index(music.strip_prefix('m')?)
        }
        _ => ds.genre(music),
    }
}

/// Runs the control test; writes the report beside the run's evaluations.
pub fn control_test(req: &RunEvalRequest, classifier: &Path) -> Result<(ControlReport, String)> {
    let ck = qean_checkpoint::checkpoint::resolve_in_run(&req.run, req.checkpoint.as_deref())?;
    if !matches!(ck.config.spec(), qean_config::ModelSpec::GptGenre(..)) {
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
    let genres = crate::gpt::run_genres(&ck, &ds)?;
    let names = crate::evaluate::protocol_sequences(&ds, req.splits())?;
    let pairs = pairings(&names, Protocol::Paired, |n| ds.music_id(n));
    let (requests, _) = crate::evaluate::sample_requests(&ds, &pairs, &ck.config, req.seed_start)?;
    let (g, mut run) = (ck.config.gpt_table(), GptRun::load(&ck)?);
    run.decoding = req.sampling.decoding(run.decoding);
    let picking = Picking::of(g, &req.sampling.picking(), req.sampling.sample_seed);
    let layout = ck.config.layout();
    let dim = qean_aistpp::windows::AUDIO_DIM;
    let total = requests.len() * genres.len();
    let pb = qean_checkpoint::progress::bar(total as u64, "genre control test", "dances");
    let mut confusion = vec![vec![0usize; genres.len()]; genres.len()];
    let (mut own, mut other) = ((0, 0), (0, 0));
    let mut generated: Vec<Vec<Sequence>> = vec![Vec::new(); genres.len()];
    for (i, (r, (_, music, _))) in requests.iter().zip(&pairs).enumerate() {
        let seed = Motion::from_layout(&r.seed, layout).map_err(Error::Invalid)?;
        let audio = (r.audio.as_slice(), r.audio.len() / dim);
        let track_genre = music_genre(&ds, music);
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
                    crate::gpt::Controls::genre(Some(choice)),
                    &mut |_, _| {},
                )?
                .ok_or_else(|| {
                    Error::Invalid(format!("{music}: shorter than the seed and one token"))
                })?;
            let dance = motion.slice(seed.frames, motion.frames);
            let predicted = clf.classify(&dance);
            confusion[genre][predicted] += 1;
            let hit = usize::from(predicted == genre);
            let tally = if track_genre == Some(genre) {
                &mut own
            } else {
                &mut other
            };
            *tally = (tally.0 + hit, tally.1 + 1);
            dances.push(Sequence::new(
                format!("{music}-as-{}", genres[genre]),
                frames_of(dance.joints(req.root)),
            ));
            pb.inc(1);
        }
    }
    pb.finish_and_clear();
    let reference = crate::evaluate::reference_set(&ds, req.root, req.splits())?;
    let per_genre = per_genre_quality((&ds, &genres), &reference, &generated, req)?;
    let energy = genre_energy(&genres, &reference, &generated);
    let (classifier_confusion, scored) = crate::genre_clf::ground_truth_confusion(&clf, &ds)?;
    let ratio = |(a, b): (usize, usize)| a as f64 / b.max(1) as f64;
    let right: usize = (0..genres.len()).map(|g| classifier_confusion[g][g]).sum();
    let report = ControlReport {
        checkpoint: ck.dir.clone(),
        step: ck.state.step,
        classifier: clf.checkpoint.dir.clone(),
        classifier_accuracy: ratio((right, scored)),
        classifier_confusion,
        frames: req.max_frames,
        samples: total,
        accuracy: ratio((own.0 + other.0, own.1 + other.1)),
        accuracy_own: ratio(own),
        accuracy_other: ratio(other),
        genres: genres.iter().map(|g| g.to_string()).collect(),
        confusion,
        per_genre,
        energy,
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
    (ds, genres): (&Dataset, &[&str]),
    reference: &[Sequence],
    generated: &[Vec<Sequence>],
    req: &RunEvalRequest,
) -> Result<Vec<GenreQuality>> {
    let base = req.configs.first().cloned().unwrap_or_default();
    let cfg = EvalConfig {
        seed_frames: 0,
        music_offset: 0,
        // A protocol preset fixes its own clip length; the request's is how long the dances are.
        max_frames: match base.preset {
            Some(_) => base.max_frames,
            None => req.max_frames,
        },
        ..base
    };
    let reference_genres: Vec<Option<usize>> =
        reference.iter().map(|s| ds.genre(&s.name)).collect();
    let mut out = Vec::new();
    for (genre, dances) in generated.iter().enumerate() {
        let gt: Vec<Sequence> = reference
            .iter()
            .zip(&reference_genres)
            .filter(|(_, g)| **g == Some(genre))
            .map(|(s, _)| s.clone())
            .collect();
        if gt.len() < 2 || dances.len() < 2 {
            continue;
        }
        let (fid_k, fid_g) = qean_eval::protocol::fid_within(dances, &gt, reference, &cfg)?;
        out.push(GenreQuality {
            genre: genres[genre].to_string(),
            samples: dances.len(),
            reference: gt.len(),
            fid_k,
            fid_g,
        });
    }
    Ok(out)
}

/// Speed and acceleration of each requested genre's dances against the whole ground truth (every genre's),
/// the yardstick of every dance the demo judges.
fn genre_energy(
    genres: &[&str],
    reference: &[Sequence],
    generated: &[Vec<Sequence>],
) -> Vec<GenreEnergy> {
    use qean_eval::motion_energy::{motion_energy, EnergyReference};
    let yardstick = EnergyReference::fit(reference.iter().map(|s| s.joints.as_slice()));
    generated
        .iter()
        .enumerate()
        .filter(|(_, d)| !d.is_empty())
        .map(|(g, dances)| {
            let (each, all) = motion_energy(dances.iter().map(|s| s.joints.as_slice()), &yardstick);
            let spans = || each.iter().flat_map(|e| e.spans.iter());
            GenreEnergy {
                genre: genres[g].to_string(),
                samples: dances.len(),
                speed_ratio: all.speed_ratio,
                accel_ratio: all.accel_ratio,
                min_span_speed_ratio: spans().map(|s| s.speed_ratio).fold(f64::INFINITY, f64::min),
                max_span_speed_ratio: spans().map(|s| s.speed_ratio).fold(0.0, f64::max),
                max_span_accel_ratio: spans().map(|s| s.accel_ratio).fold(0.0, f64::max),
                dancing: each.iter().filter(|e| e.dances()).count(),
            }
        })
        .collect()
}

/// The report as markdown.
pub fn markdown(r: &ControlReport) -> String {
    let mut s = format!(
        "# Genre control test, step {}\n\nCheckpoint {}; classifier {}. {} dances of {} frames (every paired \
         music × {} requested genres).\n\nAccuracy w.r.t. the requested genre: **{:.3}** (chance {:.2}); \
         requested = the track's genre {:.3}, requested ≠ the track's genre {:.3}.\n\n\
         | requested \\ predicted | {} |\n|---|{}\n",
        r.step,
        r.checkpoint.display(),
        r.classifier.display(),
        r.samples,
        r.frames,
        r.genres.len(),
        r.accuracy,
        1.0 / r.genres.len().max(1) as f64,
        r.accuracy_own,
        r.accuracy_other,
        r.genres.join(" | "),
        "---|".repeat(r.genres.len())
    );
    for (g, row) in r.confusion.iter().enumerate() {
        let cells: Vec<String> = row.iter().map(|c| c.to_string()).collect();
        s += &format!("| {} | {} |\n", r.genres[g], cells.join(" | "));
    }
    s += "\nEach requested genre's dances against that genre's ground truth (features normalised with the whole \
          ground truth's statistics):\n\n| genre | dances | GT sequences | FID_k | FID_g |\n|---|---|---|---|---|\n";
    for q in &r.per_genre {
        s += &format!(
            "| {} | {} | {} | {:.2} | {:.2} |\n",
            q.genre, q.samples, q.reference, q.fid_k, q.fid_g
        );
    }
    s += "\nHow the steered dances move (generated frames; ratios to the ground truth's mean joint speed and \
          acceleration; a dance dances when every 5-s span is at 0.6–1.6× the speed and ≤ 2× the acceleration):\n\n\
          | requested genre | dances | speed ratio | accel ratio | slowest span | fastest span | sharpest span (accel) | dancing |\n\
          |---|---|---|---|---|---|---|---|\n";
    for e in &r.energy {
        s += &format!(
            "| {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {} of {} |\n",
            e.genre,
            e.samples,
            e.speed_ratio,
            e.accel_ratio,
            e.min_span_speed_ratio,
            e.max_span_speed_ratio,
            e.max_span_accel_ratio,
            e.dancing,
            e.samples
        );
    }
    s += &format!(
        "\nThe judge: the classifier is right on **{:.3}** of the ground-truth test + val sequences (SPEC §13.10 asks for \
         ≥ 0.8){}.\n\n| true \\ predicted | {} |\n|---|{}\n",
        r.classifier_accuracy,
        if r.classifier_accuracy < 0.8 {
            ": below it, its verdicts on the generated dances say little"
        } else {
            ""
        },
        r.genres.join(" | "),
        "---|".repeat(r.genres.len())
    );
    for (g, row) in r.classifier_confusion.iter().enumerate() {
        let cells: Vec<String> = row.iter().map(|c| c.to_string()).collect();
        s += &format!("| {} | {} |\n", r.genres[g], cells.join(" | "));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn music_ids_name_their_genre() {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir(d.path().join("motions")).unwrap();
        let ds = Dataset::open(d.path()).unwrap();
        assert_eq!(music_genre(&ds, "mBR0"), Some(0));
        assert_eq!(music_genre(&ds, "mJB5"), Some(9));
        assert_eq!(music_genre(&ds, "mXX1"), None);
        assert_eq!(music_genre(&ds, "song"), None);
    }
}
