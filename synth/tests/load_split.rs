//! A split of a synthetic dataset loads into training windows (the AIST++ window loader on files the
//! generator wrote).

use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::windows::{SequenceSet, WindowSpec, AUDIO_DIM};
use qean_motion::Layout;

#[test]
fn load_split_of_a_synthetic_dataset() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("ds");
    let opts = qean_synth::SynthOptions {
        sequences: 8,
        seconds: 5.0,
        seed: 2,
        sample_rate: 8000,
        real_music: Vec::new(),
        varied_music: false,
        genre_postures: false,
        genre_music: false,
    };
    qean_synth::generate(&dir, &opts).unwrap();
    let ds = Dataset::open(&dir).unwrap();
    let mut calls = Vec::new();
    let set = SequenceSet::load(
        &ds,
        Split::Train,
        Layout::L219,
        WindowSpec::default(),
        |m| {
            calls.push(m.to_string());
            Ok((vec![0.5; 400 * AUDIO_DIM], 400))
        },
    )
    .unwrap();
    assert_eq!(set.sequences.len(), ds.split(Split::Train).len());
    let mut unique = calls.clone();
    unique.sort();
    unique.dedup();
    assert_eq!(
        unique.len(),
        calls.len(),
        "features loaded once per music ID"
    );
    assert!(set
        .sequences
        .iter()
        .all(|s| s.motion.len() == s.motion_frames * 219));
    // Features of the wrong width are refused.
    let e = SequenceSet::load(
        &ds,
        Split::Train,
        Layout::L225,
        WindowSpec::default(),
        |_| Ok((vec![0.0; 400 * 34], 400)),
    )
    .unwrap_err();
    assert!(e.to_string().contains("expected frames × 35"), "{e}");
    // Audio shorter than a window: every sequence skipped, which is an error.
    let e = SequenceSet::load(&ds, Split::Val, Layout::L225, WindowSpec::default(), |_| {
        Ok((vec![0.0; 100 * AUDIO_DIM], 100))
    })
    .unwrap_err();
    assert!(
        e.to_string().contains("shorter than a 240-frame window"),
        "{e}"
    );
}
