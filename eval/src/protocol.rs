//! The evaluation protocol (SPEC §1.6, §7): from loaded joint sequences and a music-beat lookup to a
//! [`MetricsReport`]. Loading files is the caller's business (see `io`), so this is testable in memory.

use std::collections::HashMap;

use rayon::prelude::*;
use tracing::{info, warn};

use crate::beat_align::{score_generated, score_ground_truth, BeatScores};
use crate::config::{BaVariant, EvalConfig};
use crate::dist::average_distance;
use crate::error::{Error, Result};
use crate::fid::fid;
use crate::geometric::geometric_features_at;
use crate::kinetic::{self, kinetic_features_at};
use crate::li_metrics::li_metrics;
use crate::motion_energy::{
    foot_contact, motion_energy, root_drift, DancingCount, EnergyReference, FootContact,
    MotionEnergy, RootDrift,
};
use crate::normalise::Normaliser;
use crate::positions::{check_finite, prepare, Frame, Sequence};
use crate::preset::JointSet;
use crate::report::{Exclusion, Explosion, MetricsReport, SequenceMetrics};

/// Music beats (60 FPS frame indices of the whole track) for a music ID such as `mBR0`.
pub type BeatLookup<'a> = &'a (dyn Fn(&str) -> Result<Vec<usize>> + Sync);

/// Raw features of one sequence.
#[derive(Debug, Clone, PartialEq)]
pub struct Features {
    pub kinetic: Vec<f64>,
    pub geometric: Vec<f64>,
}

/// Kinetic and geometric features of an evaluated segment, positions prepared per `cfg`.
pub fn features_of(joints: &[Frame], cfg: &EvalConfig) -> Result<Features> {
    let mut p = prepare(joints, cfg.positions);
    if cfg.joints == JointSet::Body22 {
        p = crate::preset::body22(&p);
    }
    let mut kinetic = kinetic_features_at(&p, cfg.metrics_mode, 1.0 / cfg.kinetic_fps)?;
    if cfg.joints == JointSet::Body22 {
        kinetic.truncate(3 * 22);
    }
    Ok(Features {
        kinetic,
        geometric: geometric_features_at(&p, cfg.geometric, cfg.metrics_mode, cfg.fps)?,
    })
}

fn mean_of(values: impl Iterator<Item = Option<f64>>) -> (Option<f64>, usize) {
    let v: Vec<f64> = values.flatten().collect();
    if v.is_empty() {
        (None, 0)
    } else {
        (Some(v.iter().sum::<f64>() / v.len() as f64), v.len())
    }
}

fn pick(s: BeatScores, variant: BaVariant) -> Option<f64> {
    match variant {
        BaVariant::Bailando => s.bailando,
        BaVariant::Mint => s.mint,
    }
}

/// The key of a sequence's music beats: its explicit pairing, else the AIST++ music ID in its name.
pub fn music_key(s: &Sequence) -> Option<String> {
    s.music
        .clone()
        .or_else(|| qean_aistpp::names::music_id_of(&s.name))
}

fn music_id(s: &Sequence) -> Result<String> {
    music_key(s).ok_or_else(|| Error::Sequence {
        name: s.name.clone(),
        message: "no AIST++ music ID (e.g. mBR0) in the name and no pairing (--pairing FILE or a \
                  NAME.music file), needed to find its music beats"
            .into(),
    })
}

/// The sequences the metrics can use: generated ones with their evaluated length, reference ones, and
/// the exclusions (too short for the features), logged. Fewer than 2 on either side is an error.
#[allow(clippy::type_complexity)]
fn usable<'a>(
    generated: &'a [Sequence],
    reference: &'a [Sequence],
    cfg: &EvalConfig,
) -> Result<(
    Vec<(&'a Sequence, usize)>,
    Vec<&'a Sequence>,
    Vec<Exclusion>,
)> {
    let mut excluded = Vec::new();
    let min = kinetic::MIN_FRAMES;

    // Generated: frames [seed, seed + L), L = min(max_frames, T − seed).
    let mut gen: Vec<(&Sequence, usize)> = Vec::new();
    for s in generated {
        let len = s
            .joints
            .len()
            .saturating_sub(cfg.seed_frames)
            .min(cfg.max_frames);
        if len < min {
            let reason = format!(
                "{} frame(s) after the {}-frame seed; the features need at least {min}",
                len, cfg.seed_frames
            );
            warn!(sequence = %s.name, "excluded from the generated set: {reason}");
            excluded.push(Exclusion {
                set: "generated".into(),
                name: s.name.clone(),
                from: "all".into(),
                reason,
            });
        } else {
            gen.push((s, len));
        }
    }
    let mut refs: Vec<&Sequence> = Vec::new();
    for s in reference {
        if s.joints.len() < min {
            let reason = format!(
                "{} frame(s); the features need at least {min}",
                s.joints.len()
            );
            warn!(sequence = %s.name, "excluded from the reference set: {reason}");
            excluded.push(Exclusion {
                set: "reference".into(),
                name: s.name.clone(),
                from: "all".into(),
                reason,
            });
        } else {
            refs.push(s);
        }
    }
    for (set, got) in [("generated", gen.len()), ("reference", refs.len())] {
        if got < 2 {
            return Err(Error::TooFewSequences {
                set,
                what: "FID (a covariance) and Dist",
                needed: 2,
                got,
            });
        }
    }

    Ok((gen, refs, excluded))
}

/// FID and Dist of the normalised features (normalised by the reference set's statistics).
struct Distribution {
    fid_k: f64,
    fid_g: f64,
    div_k: f64,
    div_g: f64,
    gt_div_k: f64,
    gt_div_g: f64,
    norm_k: Normaliser,
    norm_g: Normaliser,
}

fn distribution(gen_feats: &[Features], ref_feats: &[Features]) -> Result<Distribution> {
    let split = |f: &[Features]| -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
        f.iter()
            .map(|x| (x.kinetic.clone(), x.geometric.clone()))
            .unzip()
    };
    let (gen_k, gen_g) = split(gen_feats);
    let (ref_k, ref_g) = split(ref_feats);
    let norm_k = Normaliser::fit(&ref_k)?;
    let norm_g = Normaliser::fit(&ref_g)?;
    for (what, n) in [("kinetic", &norm_k), ("geometric", &norm_g)] {
        let dims = n.constant_dims();
        if !dims.is_empty() {
            // The report says so too (its notes); a log line per evaluation mode is enough at -v.
            info!(
                "{what} feature dimension(s) {dims:?} are constant over the reference set: left out of \
                 FID and Dist (the reference code divides by σ + 1e-10 there, so any difference is \
                 multiplied by up to 1e10)"
            );
        }
    }
    let (gen_kn, ref_kn) = (norm_k.apply_varying(&gen_k), norm_k.apply_varying(&ref_k));
    let (gen_gn, ref_gn) = (norm_g.apply_varying(&gen_g), norm_g.apply_varying(&ref_g));
    let fid_k = fid(&gen_kn, &ref_kn)?;
    let fid_g = fid(&gen_gn, &ref_gn)?;
    let div_k = average_distance(&gen_kn)?;
    let div_g = average_distance(&gen_gn)?;
    let gt_div_k = average_distance(&ref_kn)?;
    let gt_div_g = average_distance(&ref_gn)?;

    Ok(Distribution {
        fid_k,
        fid_g,
        div_k,
        div_g,
        gt_div_k,
        gt_div_g,
        norm_k,
        norm_g,
    })
}

/// FID_k and FID_g of `generated` (evaluated frames per `cfg`) against `reference`, both normalised with
/// the statistics of the larger set `normalise_by` (whole sequences) instead of `reference`'s own: a
/// reference of a few sequences — one genre's six — has near-zero spreads in many dimensions, and
/// normalising by them turns small differences into numbers like 4e6. Dimensions constant over
/// `normalise_by` are left out, as in [`evaluate`].
pub fn fid_within(
    generated: &[Sequence],
    reference: &[Sequence],
    normalise_by: &[Sequence],
    cfg: &EvalConfig,
) -> Result<(f64, f64)> {
    if crate::preset::needs_cut(cfg) {
        let (held, _) = hold_exploded(generated, cfg.seed_frames);
        let c = crate::preset::cut(&held, reference, cfg)?;
        let all = crate::preset::cut(&[], normalise_by, cfg)?;
        return fid_within(&c.generated, &c.reference, &all.reference, &c.cfg);
    }
    let (held, _) = hold_exploded(generated, cfg.seed_frames);
    let (gen, refs, _) = usable(&held, reference, cfg)?;
    let feats = |set: Vec<&[Frame]>| -> Result<Vec<Features>> {
        set.par_iter().map(|j| features_of(j, cfg)).collect()
    };
    let gen_feats = feats(
        gen.iter()
            .map(|(s, len)| &s.joints[cfg.seed_frames..cfg.seed_frames + len])
            .collect(),
    )?;
    let ref_feats = feats(refs.iter().map(|s| s.joints.as_slice()).collect())?;
    let all_feats = feats(
        normalise_by
            .iter()
            .filter(|s| s.joints.len() >= kinetic::MIN_FRAMES)
            .map(|s| s.joints.as_slice())
            .collect(),
    )?;
    let split = |f: &[Features]| -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
        f.iter()
            .map(|x| (x.kinetic.clone(), x.geometric.clone()))
            .unzip()
    };
    let (gk, gg) = split(&gen_feats);
    let (rk, rg) = split(&ref_feats);
    let (ak, ag) = split(&all_feats);
    let (nk, ng) = (Normaliser::fit(&ak)?, Normaliser::fit(&ag)?);
    Ok((
        fid(&nk.apply_varying(&gk), &nk.apply_varying(&rk))?,
        fid(&ng.apply_varying(&gg), &ng.apply_varying(&rg))?,
    ))
}

/// BeatAlign per generated sequence, of the ground truth of the same name, and the music IDs.
struct Beats {
    scores: Vec<Option<BeatScores>>,
    gt_scores: Vec<BeatScores>,
    music_ids: Vec<Option<String>>,
}

/// BeatAlign, the music beats looked up once per music ID; sequences without beats in their scored
/// segment are added to `excluded`.
fn beat_scores(
    gen: &[(&Sequence, usize)],
    refs: &[&Sequence],
    music_beats: Option<BeatLookup>,
    cfg: &EvalConfig,
    excluded: &mut Vec<Exclusion>,
) -> Result<Beats> {
    let mut scores: Vec<Option<BeatScores>> = vec![None; gen.len()];
    let mut gt_scores: Vec<BeatScores> = Vec::new();
    let mut music_ids: Vec<Option<String>> = vec![None; gen.len()];
    if let Some(lookup) = music_beats {
        let ids: Vec<String> = gen
            .iter()
            .map(|(s, _)| music_id(s))
            .collect::<Result<_>>()?;
        let mut beats: HashMap<&str, Vec<usize>> = HashMap::new();
        for id in &ids {
            if !beats.contains_key(id.as_str()) {
                beats.insert(id, lookup(id)?);
            }
        }
        scores = gen
            .par_iter()
            .zip(&ids)
            .map(|((s, len), id)| {
                let offset = cfg.music_offset + s.music_offset;
                let shifted: Vec<usize> = beats[id.as_str()]
                    .iter()
                    .filter(|&&b| b >= offset)
                    .map(|&b| b - offset)
                    .collect();
                Some(score_generated(
                    &s.joints,
                    cfg.seed_frames,
                    *len,
                    &shifted,
                    cfg.ba_segment,
                ))
            })
            .collect();
        let by_name: HashMap<&str, &Sequence> =
            refs.iter().map(|s| (s.name.as_str(), *s)).collect();
        let paired: Vec<(&Sequence, &str)> = gen
            .iter()
            .zip(&ids)
            .filter_map(|((s, _), id)| by_name.get(s.name.as_str()).map(|r| (*r, id.as_str())))
            .collect();
        if paired.is_empty() {
            warn!("no reference sequence has a generated sequence's name: no GT BeatAlign");
        }
        // A reference clip starts `music_offset` frames into its music.
        gt_scores = paired
            .par_iter()
            .map(|(r, id)| {
                let shifted: Vec<usize> = beats[id]
                    .iter()
                    .filter(|&&b| b >= r.music_offset)
                    .map(|&b| b - r.music_offset)
                    .collect();
                score_ground_truth(&r.joints, &shifted)
            })
            .collect();
        for ((s, _), sc) in gen.iter().zip(&scores) {
            if pick(sc.unwrap_or_default(), cfg.ba_variant).is_none() {
                let reason = "no music beats inside the scored segment".to_string();
                warn!(sequence = %s.name, "left out of BeatAlign: {reason}");
                excluded.push(Exclusion {
                    set: "generated".into(),
                    name: s.name.clone(),
                    from: "beat_align".into(),
                    reason,
                });
            }
        }
        music_ids = ids.into_iter().map(Some).collect();
    }
    Ok(Beats {
        scores,
        gt_scores,
        music_ids,
    })
}

/// A joint farther than this from its root (metres) is not a body any more: the dance exploded.
pub const EXPLODED_REACH: f64 = 5.0;
/// A root farther than this from the origin (metres) has left any stage.
pub const EXPLODED_TRAVEL: f64 = 1000.0;

/// Why a finite frame is not a body, if it is not: a joint beyond [`EXPLODED_REACH`] of its root, or the
/// root beyond [`EXPLODED_TRAVEL`]. (A non-finite value is not judged here: it is bad input, an error.)
fn implausible(frame: &Frame) -> Option<String> {
    let root = frame[0];
    if frame.iter().flatten().any(|x| !x.is_finite()) {
        return None;
    }
    if root.iter().map(|x| x * x).sum::<f64>().sqrt() > EXPLODED_TRAVEL {
        return Some(format!(
            "the root is over {EXPLODED_TRAVEL} m from the origin"
        ));
    }
    let reach = frame
        .iter()
        .map(|p| (0..3).map(|a| (p[a] - root[a]).powi(2)).sum::<f64>().sqrt())
        .fold(0.0, f64::max);
    (reach > EXPLODED_REACH)
        .then(|| format!("a joint is {reach:.3e} m from the root (over {EXPLODED_REACH} m)"))
}

/// Generated dances with their exploded tails held: from the first generated frame that is not a body
/// ([`implausible`]) on, each frame repeats the last plausible one, so the metrics score a dance that
/// stopped there (finite, and far from the data) instead of printing astronomically large numbers.
/// Returns the dances and the record of each explosion.
pub fn hold_exploded(
    generated: &[Sequence],
    seed_frames: usize,
) -> (Vec<Sequence>, Vec<Explosion>) {
    let mut record = Vec::new();
    let held = generated
        .iter()
        .map(|s| {
            let mut s = s.clone();
            let start = seed_frames.min(s.joints.len());
            let first = (start..s.joints.len())
                .take_while(|&t| s.joints[t].iter().flatten().all(|x| x.is_finite()))
                .find_map(|t| implausible(&s.joints[t]).map(|r| (t, r)));
            if let Some((t, reason)) = first {
                if t > 0 && implausible(&s.joints[t - 1]).is_none() {
                    let last = s.joints[t - 1];
                    s.joints[t..].fill(last);
                    warn!(sequence = %s.name, "the dance exploded at frame {t} ({reason}); held at frame {} from there", t - 1);
                    record.push(Explosion {
                        name: s.name.clone(),
                        frame: t,
                        reason,
                    });
                }
            }
            s
        })
        .collect();
    (held, record)
}

/// The kinetic and geometric features of the generated dances' evaluated frames and of the reference set.
fn features_of_sets(
    gen: &[(&Sequence, usize)],
    refs: &[&Sequence],
    cfg: &EvalConfig,
) -> Result<(Vec<Features>, Vec<Features>)> {
    let gen_feats: Vec<Features> = gen
        .par_iter()
        .map(|(s, len)| features_of(&s.joints[cfg.seed_frames..cfg.seed_frames + len], cfg))
        .collect::<Result<_>>()?;
    let ref_feats: Vec<Features> = refs
        .par_iter()
        .map(|s| features_of(&s.joints, cfg))
        .collect::<Result<_>>()?;
    Ok((gen_feats, ref_feats))
}

/// How the dances meet the ground and how many keep dancing, each beside the reference set's: root drift,
/// foot contact, PFC and the dancing-limits count of the evaluated frames.
struct Ground {
    root_drift: RootDrift,
    reference_root_drift: RootDrift,
    foot_contact: FootContact,
    reference_foot_contact: FootContact,
    pfc: Option<f64>,
    gt_pfc: Option<f64>,
    dancing: DancingCount,
    reference_dancing: DancingCount,
}

impl Ground {
    /// `energies`: the generated dances' motion energy against `reference`.
    fn of(
        gen: &[(&Sequence, usize)],
        refs: &[&Sequence],
        cfg: &EvalConfig,
        energies: &[MotionEnergy],
        reference: &EnergyReference,
    ) -> Ground {
        let scored = |len: usize| cfg.seed_frames..cfg.seed_frames + len;
        let evaluated = || gen.iter().map(|(s, len)| &s.joints[scored(*len)]);
        let whole = || refs.iter().map(|s| s.joints.as_slice());
        Ground {
            root_drift: root_drift(evaluated()),
            reference_root_drift: root_drift(whole()),
            foot_contact: foot_contact(
                gen.iter()
                    .map(|(s, len)| (s.joints.as_slice(), scored(*len))),
            ),
            reference_foot_contact: foot_contact(whole().map(|j| (j, 0..j.len()))),
            pfc: crate::pfc::pfc_from(evaluated(), cfg.pfc, cfg.fps),
            gt_pfc: crate::pfc::pfc_from(whole(), cfg.pfc, cfg.fps),
            dancing: DancingCount::of(energies),
            // The reference's sequences from where the dances' scoring starts (after the seed).
            reference_dancing: DancingCount::of(
                &motion_energy(
                    whole().map(|j| &j[cfg.seed_frames.min(j.len().saturating_sub(3))..]),
                    reference,
                )
                .0,
            ),
        }
    }
}

/// Motion energy (the evaluated frames against the whole reference set; raw positions: differences do
/// not depend on the zero-start), and how the dances meet the ground.
fn energy_and_ground(
    gen: &[(&Sequence, usize)],
    refs: &[&Sequence],
    cfg: &EvalConfig,
) -> (Vec<MotionEnergy>, MotionEnergy, EnergyReference, Ground) {
    let energy_reference = EnergyReference::fit(refs.iter().map(|s| s.joints.as_slice()));
    let evaluated = gen
        .iter()
        .map(|(s, len)| &s.joints[cfg.seed_frames..cfg.seed_frames + len]);
    let (seq_energy, set_energy) = motion_energy(evaluated, &energy_reference);
    let ground = Ground::of(gen, refs, cfg, &seq_energy, &energy_reference);
    (seq_energy, set_energy, energy_reference, ground)
}

/// The report's line per generated dance.
fn per_sequence(
    gen: &[(&Sequence, usize)],
    gen_feats: Vec<Features>,
    scores: &[Option<BeatScores>],
    music_ids: Vec<Option<String>>,
    seq_energy: Vec<crate::motion_energy::MotionEnergy>,
) -> Vec<SequenceMetrics> {
    gen.iter()
        .zip(gen_feats)
        .zip(scores.iter().zip(music_ids))
        .zip(seq_energy)
        .map(|((((s, len), f), (sc, id)), energy)| SequenceMetrics {
            name: s.name.clone(),
            music_id: id,
            frames: *len,
            beat_align_bailando: sc.and_then(|x| x.bailando),
            beat_align_mint: sc.and_then(|x| x.mint),
            kinetic: f.kinetic,
            geometric: f.geometric,
            motion_energy: Some(energy),
        })
        .collect()
}

/// Evaluate `generated` (seed ++ generated frames, per `cfg.seed_frames`) against the GT
/// `reference` set (full length). With `music_beats`, BeatAlign is computed too.
///
/// Degenerate inputs: a generated dance that explodes (finite, but no longer a body) is held at its last
/// plausible frame and recorded ([`hold_exploded`]); a non-finite joint is an error; feature dimensions constant over
/// the reference set are left out of FID and Dist (and named in the report); a sequence too short for the features
/// (fewer than 4 evaluated frames) is excluded and logged; fewer than 2 usable sequences on
/// either side is an error (covariances and Dist need 2); a sequence without music beats in range
/// is left out of BeatAlign and logged.
pub fn evaluate(
    generated: &[Sequence],
    reference: &[Sequence],
    music_beats: Option<BeatLookup>,
    cfg: &EvalConfig,
) -> Result<MetricsReport> {
    if crate::preset::needs_cut(cfg) {
        return evaluate_clips(generated, reference, music_beats, cfg);
    }
    let (held, exploded) = hold_exploded(generated, cfg.seed_frames);
    let generated = held.as_slice();
    generated
        .par_iter()
        .chain(reference.par_iter())
        .try_for_each(|s| check_finite(&s.name, &s.joints))?;
    let (gen, refs, mut excluded) = usable(generated, reference, cfg)?;
    info!(
        generated = gen.len(),
        reference = refs.len(),
        "computing features ({})",
        cfg.label()
    );
    let (gen_feats, ref_feats) = features_of_sets(&gen, &refs, cfg)?;
    let Distribution {
        fid_k,
        fid_g,
        div_k,
        div_g,
        gt_div_k,
        gt_div_g,
        norm_k,
        norm_g,
    } = distribution(&gen_feats, &ref_feats)?;
    let li = li_metrics(&gen, &refs, cfg, &norm_k, (div_k, gt_div_k))?;
    let Beats {
        scores,
        gt_scores,
        music_ids,
    } = beat_scores(&gen, &refs, music_beats, cfg, &mut excluded)?;
    let (seq_energy, set_energy, energy_reference, ground) = energy_and_ground(&gen, &refs, cfg);

    let (ba_b, n_b) = mean_of(scores.iter().map(|s| s.and_then(|s| s.bailando)));
    let (ba_m, n_m) = mean_of(scores.iter().map(|s| s.and_then(|s| s.mint)));
    let (gt_b, gn_b) = mean_of(gt_scores.iter().map(|s| s.bailando));
    let (gt_m, gn_m) = mean_of(gt_scores.iter().map(|s| s.mint));
    let (beat_align, n_beat_align, gt_beat_align, n_gt) = match cfg.ba_variant {
        BaVariant::Bailando => (ba_b, n_b, gt_b, gn_b),
        BaVariant::Mint => (ba_m, n_m, gt_m, gn_m),
    };

    let sequences = per_sequence(&gen, gen_feats, &scores, music_ids, seq_energy);
    let report = MetricsReport {
        config: cfg.clone(),
        label: cfg.label(),
        fid_k,
        fid_g,
        div_k,
        div_g,
        beat_align,
        beat_align_bailando: ba_b,
        beat_align_mint: ba_m,
        gt_div_k,
        gt_div_g,
        gt_beat_align,
        gt_beat_align_bailando: gt_b,
        gt_beat_align_mint: gt_m,
        n_generated: gen.len(),
        n_reference: refs.len(),
        n_beat_align,
        n_gt_beat_align: n_gt,
        constant_reference_dims_k: norm_k.constant_dims(),
        constant_reference_dims_g: norm_g.constant_dims(),
        motion_energy: Some(set_energy),
        energy_reference: Some(energy_reference),
        root_drift: Some(ground.root_drift),
        reference_root_drift: Some(ground.reference_root_drift),
        pfc: ground.pfc,
        gt_pfc: ground.gt_pfc,
        foot_contact: Some(ground.foot_contact),
        reference_foot_contact: Some(ground.reference_foot_contact),
        dancing: Some(ground.dancing),
        reference_dancing: Some(ground.reference_dancing),
        sequences,
        excluded,
        exploded,
        li,
    };
    report.check_finite()?;
    Ok(report)
}

/// [`evaluate`] under a protocol that scores clips ([`crate::preset::cut`]): the clips of the dances
/// (exploded tails held first) scored as they are, music beats on their grid; the report keeps the
/// protocol's own configuration. What no protocol defines (motion energy, drift, foot contact, the dancing
/// limits, the TSMT paper's metrics) and the explosions' records describe the whole dances at 60 fps
/// ([`crate::preset::whole_dances`]).
fn evaluate_clips(
    generated: &[Sequence],
    reference: &[Sequence],
    music_beats: Option<BeatLookup>,
    cfg: &EvalConfig,
) -> Result<MetricsReport> {
    let whole = evaluate(
        generated,
        reference,
        music_beats,
        &crate::preset::whole_dances(cfg),
    )?;
    let (held, _) = hold_exploded(generated, cfg.seed_frames);
    let cut = crate::preset::cut(&held, reference, cfg)?;
    let stride = cut.stride;
    let on_grid = |id: &str| -> Result<Vec<usize>> {
        match music_beats {
            Some(lookup) => Ok(crate::preset::beats_at_stride(&lookup(id)?, stride)),
            None => Ok(Vec::new()),
        }
    };
    let lookup: Option<BeatLookup> = music_beats.map(|_| &on_grid as BeatLookup);
    let mut report = evaluate(&cut.generated, &cut.reference, lookup, &cut.cfg)?;
    report.config = cfg.clone();
    report.label = cfg.label();
    report.excluded.extend(cut.dropped);
    report.exploded = whole.exploded;
    report.li = whole.li;
    report.motion_energy = whole.motion_energy;
    report.energy_reference = whole.energy_reference;
    report.root_drift = whole.root_drift;
    report.reference_root_drift = whole.reference_root_drift;
    report.foot_contact = whole.foot_contact;
    report.reference_foot_contact = whole.reference_foot_contact;
    report.dancing = whole.dancing;
    report.reference_dancing = whole.reference_dancing;
    for s in &mut report.sequences {
        s.motion_energy = None; // a clip's own would be at the clip's rate
    }
    report.check_finite()?;
    Ok(report)
}
