//! The genre classifier at work (SPEC §13.10): a sequence's verdict is the argmax of its window logits summed
//! over windows every `eval_stride` frames; `qean eval --run CLFRUN` reports its accuracy on the ground-truth
//! test + val sequences (and warns below 0.8), with the confusion matrix.

use std::path::{Path, PathBuf};

use burn::tensor::{Device, Tensor, TensorData};
use qean_aistpp::dataset::Dataset;
use qean_checkpoint::checkpoint::Checkpoint;
use qean_checkpoint::genre_clf::pos72_rows;
use qean_checkpoint::FamilyModel;
use qean_config::genre_clf::GenreClfConfig;
use qean_models::control::genre_clf::GenreClassifier;
use qean_motion::motion::Motion;
use qean_motion::pos72::POS72;
use serde::Serialize;

use crate::evaluate::RunEvalRequest;
use crate::Result;

/// A trained classifier on the CPU.
pub struct TrainedClf {
    pub model: GenreClassifier,
    pub config: GenreClfConfig,
    pub checkpoint: Checkpoint,
}

impl TrainedClf {
    pub fn load(run: &Path, checkpoint: Option<&str>) -> Result<TrainedClf> {
        let checkpoint = qean_checkpoint::checkpoint::resolve_in_run(run, checkpoint)?;
        let FamilyModel::GenreClf(model) = checkpoint.load_family(&Device::flex())? else {
            return Err(checkpoint.not_family("a genre classifier").into());
        };
        Ok(TrainedClf {
            config: checkpoint.config.genre_clf_table().clone(),
            model,
            checkpoint,
        })
    }

    /// Summed window logits (one a genre) of a motion: windows of `window` frames every `eval_stride` (one
    /// window of the whole motion, cropped to a multiple of 8, when it is shorter).
    pub fn logits(&self, motion: &Motion) -> Vec<f32> {
        let rows = pos72_rows(motion);
        let (w, stride) = (self.config.window, self.config.eval_stride);
        let frames = motion.frames;
        let windows: Vec<(usize, usize)> = if frames >= w {
            (0..=(frames - w) / stride)
                .map(|i| (i * stride, w))
                .collect()
        } else {
            vec![(0, (frames / 8 * 8).max(8).min(frames))]
        };
        let device = Device::flex();
        let mut sum = vec![0f32; self.config.genres.count()];
        for (s, len) in windows {
            let x = Tensor::<3>::from_data(
                TensorData::new(rows[s * POS72..(s + len) * POS72].to_vec(), [1, len, POS72]),
                &device,
            );
            let l: Vec<f32> = self
                .model
                .forward(x)
                .into_data()
                .convert::<f32>()
                .try_to_vec()
                .expect("f32");
            for (a, b) in sum.iter_mut().zip(l) {
                *a += b;
            }
        }
        sum
    }

    /// An error unless `ds` names its genres as this classifier does.
    pub fn check_data(&self, ds: &Dataset) -> Result<()> {
        if ds.layout.genre_set() == Some(self.config.genres) {
            return Ok(());
        }
        Err(crate::Error::invalid(format!(
            "{}: the classifier of {} judges {:?} genres, the data is {}",
            ds.root.display(),
            self.checkpoint.dir.display(),
            self.config.genres,
            ds.layout.name()
        )))
    }

    /// The verdict: the genre index with the largest summed logit.
    pub fn classify(&self, motion: &Motion) -> usize {
        let l = self.logits(motion);
        (0..l.len()).fold(0, |b, i| if l[i] > l[b] { i } else { b })
    }
}

/// The classifier's report.
#[derive(Debug, Clone, Serialize)]
pub struct ClfEvaluation {
    pub checkpoint: PathBuf,
    pub step: u64,
    pub sequences: usize,
    pub accuracy: f64,
    /// The genres' names, in index order.
    pub genres: Vec<String>,
    /// confusion[true][predicted].
    pub confusion: Vec<Vec<usize>>,
}

/// The classifier's confusion matrix (rows: true genre) on the ground-truth test + val sequences that name
/// a genre, and how many those are.
pub fn ground_truth_confusion(clf: &TrainedClf, ds: &Dataset) -> Result<(Vec<Vec<usize>>, usize)> {
    clf.check_data(ds)?;
    let names = crate::evaluate::protocol_sequences(ds, Default::default())?;
    let n = clf.config.genres.count();
    let mut confusion = vec![vec![0usize; n]; n];
    let mut scored = 0;
    for name in &names {
        let Some(truth) = ds.genre(name) else {
            continue;
        };
        let motion = ds.read_motion(name)?;
        confusion[truth][clf.classify(&motion)] += 1;
        scored += 1;
    }
    Ok((confusion, scored))
}

/// Accuracy on the ground-truth test + val sequences; writes `R/eval/step-N/report.{md,json}`.
pub fn evaluate_clf(req: &RunEvalRequest) -> Result<(ClfEvaluation, String)> {
    let clf = TrainedClf::load(&req.run, req.checkpoint.as_deref())?;
    let ds = Dataset::open(&req.data)?;
    let (confusion, scored) = ground_truth_confusion(&clf, &ds)?;
    let correct: usize = (0..confusion.len()).map(|g| confusion[g][g]).sum();
    let accuracy = correct as f64 / scored.max(1) as f64;
    if accuracy < 0.8 {
        tracing::warn!(
            "the genre classifier is right on {:.0} % of the ground-truth test + val sequences (below 80 %): \
             its verdicts on generated dances say little",
            100.0 * accuracy
        );
    }
    let report = ClfEvaluation {
        checkpoint: clf.checkpoint.dir.clone(),
        step: clf.checkpoint.state.step,
        sequences: scored,
        accuracy,
        genres: clf
            .config
            .genres
            .names()
            .iter()
            .map(|g| g.to_string())
            .collect(),
        confusion,
    };
    let md = markdown(&report);
    crate::evaluate::write_eval_files(req, report.step, "report", &report, &md)?;
    Ok((report, md))
}

/// The report as markdown: accuracy and the confusion matrix (rows: true genre).
pub fn markdown(r: &ClfEvaluation) -> String {
    let mut s = format!(
        "# Genre classifier, step {}\n\nCheckpoint {}. Accuracy on {} ground-truth test + val sequences: **{:.3}** \
         (chance {:.2}).\n\n| true \\ predicted | {} |\n|---|{}\n",
        r.step,
        r.checkpoint.display(),
        r.sequences,
        r.accuracy,
        1.0 / r.genres.len().max(1) as f64,
        r.genres.join(" | "),
        "---|".repeat(r.genres.len())
    );
    for (g, row) in r.confusion.iter().enumerate() {
        let cells: Vec<String> = row.iter().map(|c| c.to_string()).collect();
        s += &format!("| {} | {} |\n", r.genres[g], cells.join(" | "));
    }
    s
}
