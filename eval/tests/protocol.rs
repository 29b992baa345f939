//! The evaluation protocol end to end, and each degenerate input (one sequence, too short, constant
//! features, NaN joints, no music beats): a clear error or a logged, reported exclusion, never a NaN.

mod common;

use std::collections::HashMap;

use common::{aist_name, rest_pose, seq, synthetic_motion};
use qean_eval::{evaluate, render_markdown, BaVariant, Error, EvalConfig, Sequence};

fn sets(n_gen: usize, n_ref: usize, gen_frames: usize) -> (Vec<Sequence>, Vec<Sequence>) {
    let reference: Vec<Sequence> = (0..n_ref)
        .map(|i| {
            seq(
                &aist_name("BR", i % 6, i, i),
                synthetic_motion(1000 + i as u64, 200 + 7 * i),
            )
        })
        .collect();
    let generated: Vec<Sequence> = (0..n_gen)
        .map(|i| {
            seq(
                &aist_name("BR", i % 6, i, i),
                synthetic_motion(i as u64, gen_frames),
            )
        })
        .collect();
    (generated, reference)
}

fn beats_every(period: usize) -> impl Fn(&str) -> qean_eval::Result<Vec<usize>> + Sync {
    move |_id: &str| Ok((0..40).map(|k| 15 + k * period).collect())
}

fn cfg() -> EvalConfig {
    EvalConfig {
        seed_frames: 20,
        max_frames: 150,
        ..EvalConfig::default()
    }
}

#[test]
fn full_report_is_finite_and_tagged() {
    let (g, r) = sets(6, 12, 200);
    let beats = beats_every(30);
    let rep = evaluate(&g, &r, Some(&beats), &cfg()).unwrap();
    assert_eq!((rep.n_generated, rep.n_reference), (6, 12));
    assert!(rep.fid_k > 0.0 && rep.fid_g >= 0.0 && rep.div_k > 0.0 && rep.gt_div_k > 0.0);
    assert_eq!(rep.sequences.len(), 6);
    assert!(rep.sequences.iter().all(|s| s.frames == 150));
    assert_eq!(rep.beat_align, rep.beat_align_bailando);
    // Generated names equal the first 6 reference names: 6 paired GT sequences.
    assert_eq!(rep.n_gt_beat_align, 6);
    let json = serde_json::to_string(&rep).unwrap();
    assert!(!json.contains("NaN") && !json.contains("null,\"beat_align_bailando\":null"));
    let md = render_markdown(&[("ours", &rep)]);
    assert!(md.contains("| AIST++ | - | - |"));
    assert!(md.contains("BeatAlign = bailando variant"), "{md}");
    assert!(md.contains("metrics_mode=reference"));
    // How the dances meet the ground, each beside the reference set's: PFC, feet on the floor, and how
    // many dances (and reference sequences) are within the dancing limits.
    assert!(rep.pfc.is_some_and(|p| p >= 0.0) && rep.gt_pfc.is_some_and(|p| p >= 0.0));
    let contact = rep.foot_contact.unwrap();
    assert_eq!(contact.frames, 6 * 150);
    assert!((0.0..=1.0).contains(&contact.share));
    let (dancing, reference) = (rep.dancing.unwrap(), rep.reference_dancing.unwrap());
    assert_eq!((dancing.of, reference.of), (6, 12));
    assert!(dancing.dancing <= 6 && reference.dancing <= 12);
    assert!(
        md.contains("| PFC ↓ |")
            && md.contains("feet on the floor")
            && md.contains("dances within the dancing limits")
    );
    assert!(md.contains("PFC=ours"), "{md}");
    // The TSMT paper's metrics: top-level keys and the second markdown block.
    let value: serde_json::Value = serde_json::from_str(&json).unwrap();
    for key in [
        "beat_precision",
        "beat_recall",
        "beat_f1",
        "a_seq_d",
        "i_seq_d",
        "s_music_d",
        "authenticity",
        "coherence",
        "gt_a_seq_d",
        "gt_authenticity",
        "gt_coherence",
    ] {
        assert!(value.get(key).is_some(), "{key} missing: {json}");
    }
    assert_eq!(rep.li.a_seq_d, rep.div_k);
    assert_eq!(rep.li.n_beat_prf, 6);
    assert!((0.0..=1.0).contains(&rep.li.beat_f1.unwrap()));
    assert!(md.contains("| Methods (Li et al. 2020 metrics) |"), "{md}");

    let mint = EvalConfig {
        ba_variant: BaVariant::Mint,
        ..cfg()
    };
    let rep2 = evaluate(&g, &r, Some(&beats), &mint).unwrap();
    assert_eq!(rep2.beat_align, rep.beat_align_mint);
    assert_eq!(rep2.fid_k, rep.fid_k);
}

#[test]
fn generated_sequence_equal_to_reference_scores_zero_fid_against_itself() {
    let (_, r) = sets(0, 10, 0);
    let g: Vec<Sequence> = r.clone();
    let c = EvalConfig {
        seed_frames: 0,
        max_frames: 100_000,
        ..EvalConfig::default()
    };
    let rep = evaluate(&g, &r, None, &c).unwrap();
    assert!(
        rep.fid_k.abs() < 1e-8 && rep.fid_g.abs() < 1e-8,
        "{} {}",
        rep.fid_k,
        rep.fid_g
    );
    assert!((rep.div_k - rep.gt_div_k).abs() < 1e-12);
    assert_eq!(rep.beat_align, None);
}

#[test]
fn one_generated_sequence_is_an_error() {
    let (g, r) = sets(1, 5, 200);
    let err = evaluate(&g, &r, None, &cfg()).unwrap_err();
    assert!(
        matches!(
            err,
            Error::TooFewSequences {
                set: "generated",
                got: 1,
                ..
            }
        ),
        "{err}"
    );
    let (g, r) = sets(3, 1, 200);
    let err = evaluate(&g, &r, None, &cfg()).unwrap_err();
    assert!(
        matches!(
            err,
            Error::TooFewSequences {
                set: "reference",
                got: 1,
                ..
            }
        ),
        "{err}"
    );
}

#[test]
fn short_sequences_are_excluded_and_reported() {
    let (mut g, mut r) = sets(4, 6, 200);
    // 20 seed frames + 3 generated: too short.
    g.push(seq(&aist_name("PO", 1, 9, 9), synthetic_motion(77, 23)));
    r.push(seq(&aist_name("PO", 2, 9, 9), synthetic_motion(78, 3)));
    let rep = evaluate(&g, &r, None, &cfg()).unwrap();
    assert_eq!((rep.n_generated, rep.n_reference), (4, 6));
    assert_eq!(rep.excluded.len(), 2);
    assert!(rep.excluded.iter().all(|e| e.from == "all"));
    assert!(rep.excluded[0]
        .reason
        .contains("3 frame(s) after the 20-frame seed"));
    // If that leaves fewer than 2, it is an error.
    let (g, r) = sets(1, 6, 200);
    let mut g2 = g.clone();
    g2.push(seq("short", synthetic_motion(5, 10)));
    assert!(matches!(
        evaluate(&g2, &r, None, &cfg()),
        Err(Error::TooFewSequences { got: 1, .. })
    ));
}

#[test]
fn nan_joint_is_an_error_naming_the_sequence() {
    let (mut g, r) = sets(3, 5, 200);
    g[1].joints[57][13][2] = f64::NAN;
    let err = evaluate(&g, &r, None, &cfg()).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains(&g[1].name) && msg.contains("joint 13 of frame 57"),
        "{msg}"
    );
}

#[test]
fn constant_features_stay_finite() {
    // Every sequence is the same motionless pose: all features constant, σ = 0 everywhere.
    let still: Vec<_> = vec![rest_pose(); 60];
    let r: Vec<Sequence> = (0..5)
        .map(|i| seq(&format!("ref{i}"), still.clone()))
        .collect();
    let g: Vec<Sequence> = (0..3)
        .map(|i| seq(&format!("gen{i}"), still.clone()))
        .collect();
    let rep = evaluate(&g, &r, None, &cfg()).unwrap();
    assert_eq!(rep.constant_reference_dims_k.len(), 72);
    assert_eq!(rep.constant_reference_dims_g.len(), 32);
    // Every dimension is left out of FID and Dist (the reference code would divide by 1e-10): 0 over
    // no dimensions, and the report says so.
    assert_eq!(
        (rep.div_k, rep.gt_div_g, rep.fid_k, rep.fid_g),
        (0.0, 0.0, 0.0, 0.0)
    );
    let md = qean_eval::report::render_markdown(&[("gen", &rep)]);
    assert!(md.contains("over 0 of 72 dimensions"), "{md}");
    // A generated set that moves, against a constant reference: finite (no dimension to compare).
    let (g, _) = sets(3, 0, 200);
    let rep = evaluate(&g, &r, None, &cfg()).unwrap();
    assert!(rep.fid_k.is_finite() && rep.fid_k < 1e3);
}

#[test]
fn an_exploding_dance_is_held_flagged_and_scored_finitely() {
    let (mut g, r) = sets(3, 6, 200);
    let seed = cfg().seed_frames;
    // Dance 1 explodes at generated frame 50: its joints fly off, by 1e8 m more every frame.
    let at = seed + 50;
    for (t, frame) in g[1].joints.iter_mut().enumerate().skip(at) {
        for p in frame.iter_mut().skip(1) {
            p[0] += 1e8 * (t - at + 1) as f64;
        }
    }
    let rep = evaluate(&g, &r, None, &cfg()).unwrap();
    assert_eq!(rep.exploded.len(), 1);
    assert_eq!(
        (rep.exploded[0].name.as_str(), rep.exploded[0].frame),
        (g[1].name.as_str(), at)
    );
    assert!(rep.fid_k.is_finite() && rep.fid_k < 1e6, "{}", rep.fid_k);
    let e = rep.motion_energy.as_ref().unwrap();
    assert!(e.speed_ratio < 10.0, "{}", e.speed_ratio);
    let md = qean_eval::report::render_markdown(&[("gen", &rep)]);
    assert!(md.contains("EXPLODED at frame"), "{md}");
    // A reference sequence with a NaN is still bad input.
    let mut bad = r.clone();
    bad[0].joints[5][2][0] = f64::NAN;
    assert!(evaluate(&g, &bad, None, &cfg()).is_err());
}

#[test]
fn sequence_without_music_beats_is_left_out_of_beat_align() {
    let (g, r) = sets(4, 6, 200);
    let silent_id = qean_aistpp::names::music_id_of(&g[0].name).unwrap();
    let beats = move |id: &str| -> qean_eval::Result<Vec<usize>> {
        Ok(if id == silent_id {
            vec![]
        } else {
            (0..20).map(|k| 10 + 25 * k).collect()
        })
    };
    let rep = evaluate(&g, &r, Some(&beats), &cfg()).unwrap();
    assert_eq!(rep.sequences[0].beat_align_bailando, None);
    assert_eq!(rep.n_beat_align, 3);
    assert!(rep
        .excluded
        .iter()
        .any(|e| e.name == g[0].name && e.from == "beat_align"));
    // No music beats at all: BeatAlign is absent (null), never NaN.
    let none = |_: &str| -> qean_eval::Result<Vec<usize>> { Ok(vec![]) };
    let rep = evaluate(&g, &r, Some(&none), &cfg()).unwrap();
    assert_eq!((rep.beat_align, rep.gt_beat_align), (None, None));
    let json = serde_json::to_value(&rep).unwrap();
    assert!(json["beat_align"].is_null());
}

#[test]
fn music_offset_shifts_the_track() {
    let (g, r) = sets(3, 5, 200);
    let base: Vec<usize> = (0..30).map(|k| 7 + 13 * k).collect();
    let shifted: HashMap<usize, Vec<usize>> = [
        (0, base.clone()),
        (50, base.iter().map(|b| b + 50).collect()),
    ]
    .into();
    let mut results = Vec::new();
    for offset in [0usize, 50] {
        let list = shifted[&offset].clone();
        let lookup = move |_: &str| -> qean_eval::Result<Vec<usize>> { Ok(list.clone()) };
        let c = EvalConfig {
            music_offset: offset,
            ..cfg()
        };
        results.push(
            evaluate(&g, &r, Some(&lookup), &c)
                .unwrap()
                .beat_align_bailando,
        );
    }
    assert!(results[0].is_some());
    assert_eq!(results[0], results[1]);
}

#[test]
fn name_without_music_id_is_an_error_when_beats_are_needed() {
    let (mut g, r) = sets(3, 5, 200);
    g[2].name = "my_dance".into();
    let beats = beats_every(30);
    let err = evaluate(&g, &r, Some(&beats), &cfg()).unwrap_err();
    assert!(err.to_string().contains("my_dance"), "{err}");
    // Without beats the name does not matter.
    assert!(evaluate(&g, &r, None, &cfg()).is_ok());
}

/// Under a clip protocol (EDGE: 30 fps, 5-s slices), ground-truth dances scored as if generated match
/// the ground truth's own row clip by clip: the same clips, named alike, on the same music beats (a
/// reference clip's beats shifted by where it starts in its music); a still figure's PFC is 0.
#[test]
fn ground_truth_scored_as_dances_matches_its_own_row_under_edge_clips() {
    use qean_eval::preset::ProtocolPreset;
    let reference: Vec<Sequence> = (0..4)
        .map(|i| {
            seq(
                &aist_name("BR", i, i, i),
                synthetic_motion(70 + i as u64, 700),
            )
        })
        .collect();
    let cfg = ProtocolPreset::Edge.apply(EvalConfig {
        seed_frames: 0,
        ..EvalConfig::default()
    });
    let beats = beats_every(23);
    let rep = evaluate(&reference, &reference, Some(&beats), &cfg).unwrap();
    // 700 frames → 350 at 30 fps → slices at 0, 75 and 150: 12 clips on each side.
    assert_eq!((rep.n_generated, rep.n_reference), (12, 12));
    assert_eq!(rep.n_gt_beat_align, 12);
    let (ba, gt) = (rep.beat_align.unwrap(), rep.gt_beat_align.unwrap());
    assert!((ba - gt).abs() < 1e-12, "{ba} vs {gt}");
    assert!(rep.fid_k.abs() < 1e-6 && (rep.div_k - rep.gt_div_k).abs() < 1e-9);
    assert_eq!(rep.pfc, rep.gt_pfc);

    let still: Vec<Sequence> = (0..3)
        .map(|i| seq(&aist_name("BR", i, i, i), vec![rest_pose(); 700]))
        .collect();
    let rep = evaluate(&still, &reference, Some(&beats), &cfg).unwrap();
    assert_eq!(rep.pfc, Some(0.0));
}

/// Under EDGE's clips, a dance that explodes is held before it is cut: every slice after the explosion
/// sees the held pose, the record names the whole dance's frame, and every number stays finite; a NaN in
/// a frame the clips skip is still bad input; a dance too short for a clip is listed, not lost.
#[test]
fn clip_protocols_hold_explosions_before_cutting_and_list_short_dances() {
    use qean_eval::preset::ProtocolPreset;
    let (mut g, r) = sets(3, 6, 20 + 700);
    let cfg = ProtocolPreset::Edge.apply(cfg());
    let at = cfg.seed_frames + 400;
    for (t, frame) in g[1].joints.iter_mut().enumerate().skip(at) {
        for p in frame.iter_mut().skip(1) {
            p[0] += 1e8 * (t - at + 1) as f64;
        }
    }
    let reference: Vec<Sequence> = r
        .iter()
        .map(|s| seq(&s.name, synthetic_motion(3 + s.name.len() as u64, 700)))
        .collect();
    let rep = evaluate(&g, &reference, None, &cfg).unwrap();
    assert_eq!(rep.exploded.len(), 1);
    assert_eq!(rep.exploded[0].frame, at);
    // Scored exactly as the same dance stopped by hand at its last plausible frame.
    let mut stopped = g.clone();
    let last = stopped[1].joints[at - 1];
    stopped[1].joints[at..].fill(last);
    let by_hand = evaluate(&stopped, &reference, None, &cfg).unwrap();
    assert!(by_hand.exploded.is_empty());
    assert_eq!((rep.fid_k, rep.div_k), (by_hand.fid_k, by_hand.div_k));
    assert!(rep.fid_k.is_finite() && rep.div_k.is_finite());

    let mut odd = g.clone();
    odd[0].joints[cfg.seed_frames + 3][4][1] = f64::NAN; // an odd frame: not in any 30-fps clip
    assert!(evaluate(&odd, &reference, None, &cfg).is_err());

    let mut short = g.clone();
    short[2].joints.truncate(cfg.seed_frames + 200); // 100 frames at 30 fps: no 150-frame clip
    let rep = evaluate(&short, &reference, None, &cfg).unwrap();
    assert!(
        rep.excluded.iter().any(
            |e| e.name == short[2].name && e.reason.contains("shorter than one 150-frame clip")
        ),
        "{:?}",
        rep.excluded
    );
}
