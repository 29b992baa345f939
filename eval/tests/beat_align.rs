//! SPEC §9 item 15 and the beat-detection primitives against scipy.

use qean_eval::beat_align::{
    gaussian_filter1d, local_minima, motion_beats_bailando, motion_beats_mint, score_bailando,
    score_generated, score_mint,
};
use qean_eval::{BaSegment, Frame, N_JOINTS};

#[test]
fn identical_beats_score_one_and_a_three_frame_offset_scores_exp_minus_half() {
    let beats = [30, 75, 120, 160, 222];
    assert_eq!(score_bailando(&beats, &beats), Some(1.0));
    assert_eq!(score_mint(&beats, &beats), Some(1.0));
    let shifted: Vec<usize> = beats.iter().map(|b| b + 3).collect();
    let e = (-0.5f64).exp();
    assert!((score_bailando(&beats, &shifted).unwrap() - e).abs() < 1e-15);
    assert!((score_mint(&beats, &shifted).unwrap() - e).abs() < 1e-15);
}

#[test]
fn directions_differ_and_empty_lists_are_handled() {
    // One music beat at 10, motion beats at 10 and 40: Bailando averages over music (1.0),
    // mint over motion ((1 + exp(-900/18)) / 2).
    assert_eq!(score_bailando(&[10], &[10, 40]), Some(1.0));
    let m = score_mint(&[10], &[10, 40]).unwrap();
    assert!((m - (1.0 + (-50.0f64).exp()) / 2.0).abs() < 1e-15);
    assert_eq!(score_bailando(&[10], &[]), Some(0.0));
    assert_eq!(score_mint(&[10], &[]), Some(0.0));
    assert_eq!(score_bailando(&[], &[3]), None);
    assert_eq!(score_mint(&[], &[3]), None);
}

#[test]
fn gaussian_filter_matches_scipy() {
    // scipy 1.17.1: gaussian_filter1d(x, 5) (= ndimage.gaussian_filter on 1-D input); reflect mode
    // wraps more than once here because the radius (20) exceeds the length (12).
    let x = [0.3, 1.0, 0.2, 0.9, 0.1, 0.5, 0.5, 0.05, 0.8, 0.4, 0.7, 0.0];
    let scipy = [
        0.48968427, 0.48711136, 0.48218967, 0.47531668, 0.46705459, 0.45803003, 0.44888468,
        0.44024358, 0.43264094, 0.42653266, 0.42225654, 0.420055,
    ];
    let got = gaussian_filter1d(&x, 5.0);
    for (g, s) in got.iter().zip(scipy) {
        assert!((g - s).abs() < 1e-8, "{g} vs {s}");
    }
}

#[test]
fn local_minima_match_argrelextrema() {
    // scipy: argrelextrema(y, np.less) -> [1, 4]; order=2 -> [1, 4]. Plateaus and ends never count.
    let y = [3., 1., 2., 2., 0.5, 4., 1., 1., 5., 0.2];
    assert_eq!(local_minima(&y, 1), vec![1, 4]);
    assert_eq!(local_minima(&y, 2), vec![1, 4]);
    assert_eq!(local_minima(&[1.0, 2.0, 3.0], 10), Vec::<usize>::new());
}

/// All joints move along x with speed 1 + cos(2π t / period): speed minima at t = period/2 + k·period.
fn pulsing(frames: usize, period: f64) -> Vec<Frame> {
    let mut x = 0.0;
    (0..frames)
        .map(|t| {
            x += 0.01 * (1.0 + (2.0 * std::f64::consts::PI * t as f64 / period).cos());
            let mut f = [[0.0; 3]; N_JOINTS];
            for (j, p) in f.iter_mut().enumerate() {
                *p = [x + j as f64 * 0.01, 0.9, 0.0];
            }
            f
        })
        .collect()
}

#[test]
fn motion_beats_of_a_pulsing_motion() {
    let joints = pulsing(300, 40.0);
    // v[t] = |p[t+1] − p[t]| peaks down at t + 1 = 20 + 40k, i.e. t = 19 + 40k.
    let (b, n) = motion_beats_bailando(&joints);
    assert_eq!(n, 299);
    let expected: Vec<usize> = (0..7).map(|k| 19 + 40 * k).collect();
    assert_eq!(b, expected);
    // mint: e[t] = |p[t] − p[t−1]| minimal at t = 20 + 40k.
    let m = motion_beats_mint(&joints);
    assert_eq!(m, (0..7).map(|k| 20 + 40 * k).collect::<Vec<_>>());
}

#[test]
fn generated_segment_alignment_rules() {
    let seed = 120;
    let joints = pulsing(seed + 200, 40.0);
    // Music beats in sequence frames on the mint minima (t = 20 + 40k): all aligned.
    let music: Vec<usize> = (0..8).map(|k| 20 + 40 * k).collect();
    let s = score_generated(&joints, seed, 200, &music, BaSegment::Generated);
    assert_eq!(s.mint, Some(1.0));
    // Bailando scores the generated frames only, whose beats are one frame earlier (t = 19 + 40k).
    let b = s.bailando.unwrap();
    assert!((b - (-1.0f64 / 18.0).exp()).abs() < 1e-12, "{b}");
    // A track with beats only inside the seed has nothing to score in the generated segment.
    let s = score_generated(&joints, seed, 200, &[20, 60, 100], BaSegment::Generated);
    assert_eq!((s.bailando, s.mint), (None, None));
    let s = score_generated(&joints, seed, 200, &[20, 60, 100], BaSegment::Full);
    assert!(s.bailando.is_some() && s.mint.is_some());
}
