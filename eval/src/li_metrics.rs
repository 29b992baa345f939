//! The metrics of Li et al. 2020, the TSMT paper (SPEC §11.9–11.11), for every report: beat
//! precision/recall/F1 against the paired ground truth's motion beats, A-seq-D, I-seq-D, S-music-D
//! (checkpoint mode fills it from several rollouts per music), Authenticity and Coherence; `gt_`
//! values for the reference set where they apply.

use std::collections::HashMap;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::config::EvalConfig;
use crate::diversity::{chunk_starts, i_seq_d};
use crate::error::Result;
use crate::motion_beats::{beat_prf, motion_beats};
use crate::normalise::Normaliser;
use crate::plausibility::{authenticity, coherence, PlausibilityLimits};
use crate::positions::{Frame, Sequence};
use crate::protocol::features_of;

/// The TSMT paper's numbers of one evaluation.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct LiMetrics {
    /// Means over generated sequences with a same-named reference (None without one).
    pub beat_precision: Option<f64>,
    pub beat_recall: Option<f64>,
    pub beat_f1: Option<f64>,
    /// Sequences in the beat means.
    pub n_beat_prf: usize,
    /// Mean pairwise distance of the generated (reference) sets' normalised kinetic features.
    pub a_seq_d: f64,
    pub gt_a_seq_d: f64,
    /// Mean distance between 240-frame chunks of the same sequence (None: no sequence has two).
    pub i_seq_d: Option<f64>,
    pub gt_i_seq_d: Option<f64>,
    /// Mean over musics of the distance between rollouts for the same music (checkpoint mode with
    /// several rollouts per music; None otherwise).
    pub s_music_d: Option<f64>,
    /// Fraction of frames within the joint limits, and of transitions below ω_max.
    pub authenticity: f64,
    pub coherence: f64,
    pub gt_authenticity: f64,
    pub gt_coherence: f64,
}

/// Normalised kinetic features of each non-overlapping chunk of a segment.
fn chunk_features(joints: &[Frame], cfg: &EvalConfig, norm: &Normaliser) -> Result<Vec<Vec<f64>>> {
    chunk_starts(joints.len(), cfg.chunk)
        .into_iter()
        .map(|s| Ok(norm.apply_one(&features_of(&joints[s..s + cfg.chunk], cfg)?.kinetic)))
        .collect()
}

/// Authenticity and Coherence pooled over segments: (frames within limits / frames, smooth
/// transitions / transitions).
fn plausibility(segments: &[&[Frame]], cfg: &EvalConfig) -> (f64, f64) {
    let limits = PlausibilityLimits {
        slack_deg: cfg.limit_slack_deg,
        omega_max_deg_s: cfg.omega_max_deg_s,
    };
    let parts: Vec<(f64, f64, f64, f64)> = segments
        .par_iter()
        .map(|s| {
            let (t, moves) = (s.len() as f64, s.len().saturating_sub(1) as f64);
            (
                authenticity(s, &limits) * t,
                t,
                coherence(s, &limits) * moves,
                moves,
            )
        })
        .collect();
    let sum = |k: fn(&(f64, f64, f64, f64)) -> f64| parts.iter().map(k).sum::<f64>();
    let ratio = |a: f64, b: f64| if b > 0.0 { a / b } else { 1.0 };
    (
        ratio(sum(|p| p.0), sum(|p| p.1)),
        ratio(sum(|p| p.2), sum(|p| p.3)),
    )
}

/// Beat P/R/F1 means over the generated segments whose name has a reference sequence: both sets of
/// motion beats on frames [seed, seed + L) (L cut to the reference's length).
fn beat_means(gen: &[(&Sequence, usize)], refs: &[&Sequence], cfg: &EvalConfig) -> LiMetrics {
    let by_name: HashMap<&str, &Sequence> = refs.iter().map(|s| (s.name.as_str(), *s)).collect();
    let scores: Vec<_> = gen
        .par_iter()
        .filter_map(|(s, len)| {
            let r = by_name.get(s.name.as_str())?;
            let end = (cfg.seed_frames + len).min(r.joints.len());
            (end >= cfg.seed_frames + 3).then(|| {
                let g = motion_beats(&s.joints[cfg.seed_frames..end], cfg.kim_sigma);
                let t = motion_beats(&r.joints[cfg.seed_frames..end], cfg.kim_sigma);
                beat_prf(&g, &t, cfg.beat_tol)
            })
        })
        .collect();
    let n = scores.len();
    let mean = |k: fn(&crate::motion_beats::BeatPrf) -> f64| {
        (n > 0).then(|| scores.iter().map(k).sum::<f64>() / n as f64)
    };
    LiMetrics {
        beat_precision: mean(|s| s.precision),
        beat_recall: mean(|s| s.recall),
        beat_f1: mean(|s| s.f1),
        n_beat_prf: n,
        ..LiMetrics::default()
    }
}

/// The TSMT paper's metrics of the evaluated generated segments (`gen`: sequence and evaluated length)
/// against the reference set; `div_k`/`gt_div_k` are the sets' Dist_k (= A-seq-D), `norm_k` the
/// reference normalisation of the kinetic features.
pub fn li_metrics(
    gen: &[(&Sequence, usize)],
    refs: &[&Sequence],
    cfg: &EvalConfig,
    norm_k: &Normaliser,
    (div_k, gt_div_k): (f64, f64),
) -> Result<LiMetrics> {
    let segments: Vec<&[Frame]> = gen
        .iter()
        .map(|(s, len)| &s.joints[cfg.seed_frames..cfg.seed_frames + len])
        .collect();
    let whole: Vec<&[Frame]> = refs.iter().map(|s| s.joints.as_slice()).collect();
    let chunks = |set: &[&[Frame]]| -> Result<Vec<Vec<Vec<f64>>>> {
        set.par_iter()
            .map(|s| chunk_features(s, cfg, norm_k))
            .collect()
    };
    let (authenticity, coherence) = plausibility(&segments, cfg);
    let (gt_authenticity, gt_coherence) = plausibility(&whole, cfg);
    Ok(LiMetrics {
        a_seq_d: div_k,
        gt_a_seq_d: gt_div_k,
        i_seq_d: i_seq_d(&chunks(&segments)?),
        gt_i_seq_d: i_seq_d(&chunks(&whole)?),
        s_music_d: None,
        authenticity,
        coherence,
        gt_authenticity,
        gt_coherence,
        ..beat_means(gen, refs, cfg)
    })
}

/// S-music-D (SPEC §11.10) of several rollouts of the same inputs (`rollouts[r]`: one generated set,
/// seed ++ generated frames per `cfg`): the evaluated segments' kinetic features, normalised by the
/// reference set's statistics, grouped by music; None with fewer than two per music.
pub fn s_music_d_of(
    rollouts: &[&[Sequence]],
    reference: &[Sequence],
    cfg: &EvalConfig,
) -> Result<Option<f64>> {
    if crate::preset::needs_cut(cfg) {
        // No protocol of clips defines it: the whole dances, as the rest of the TSMT paper's metrics.
        return s_music_d_of(rollouts, reference, &crate::preset::whole_dances(cfg));
    }
    let ref_k: Vec<Vec<f64>> = reference
        .par_iter()
        .filter(|s| s.joints.len() >= crate::kinetic::MIN_FRAMES)
        .map(|s| Ok(features_of(&s.joints, cfg)?.kinetic))
        .collect::<Result<_>>()?;
    let norm = Normaliser::fit(&ref_k)?;
    let mut groups: HashMap<String, Vec<Vec<f64>>> = HashMap::new();
    for set in rollouts {
        for s in set.iter() {
            let len = s
                .joints
                .len()
                .saturating_sub(cfg.seed_frames)
                .min(cfg.max_frames);
            let Some(key) = crate::protocol::music_key(s) else {
                continue;
            };
            if len < crate::kinetic::MIN_FRAMES {
                continue;
            }
            let seg = &s.joints[cfg.seed_frames..cfg.seed_frames + len];
            groups
                .entry(key)
                .or_default()
                .push(norm.apply_one(&features_of(seg, cfg)?.kinetic));
        }
    }
    let mut keys: Vec<&String> = groups.keys().collect();
    keys.sort();
    let ordered: Vec<Vec<Vec<f64>>> = keys.iter().map(|k| groups[*k].clone()).collect();
    Ok(crate::diversity::s_music_d(&ordered))
}

impl LiMetrics {
    /// Every number with its report key (for the finiteness check).
    pub fn named(&self) -> Vec<(&'static str, f64)> {
        let mut v = vec![
            ("a_seq_d", self.a_seq_d),
            ("gt_a_seq_d", self.gt_a_seq_d),
            ("authenticity", self.authenticity),
            ("coherence", self.coherence),
            ("gt_authenticity", self.gt_authenticity),
            ("gt_coherence", self.gt_coherence),
        ];
        let opts = [
            ("beat_precision", self.beat_precision),
            ("beat_recall", self.beat_recall),
            ("beat_f1", self.beat_f1),
            ("i_seq_d", self.i_seq_d),
            ("gt_i_seq_d", self.gt_i_seq_d),
            ("s_music_d", self.s_music_d),
        ];
        v.extend(opts.iter().filter_map(|(k, x)| x.map(|x| (*k, x))));
        v
    }
}
