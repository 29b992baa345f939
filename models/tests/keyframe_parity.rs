//! SPEC §13.11 test 12: keyframe control's index set against the fixture `tools/make_keyframe_control_fixtures.py`
//! transcribes from SPEC §13.6 with Python sets (one keyframe, overlapping ones, the seed's edge, the
//! sequence's end, two keyframes on one token, out of range).

use qean_models::control::keyframe::{key_tokens, kf_mask_positions};

#[derive(serde::Deserialize)]
struct Case {
    name: String,
    frames: Vec<usize>,
    k: usize,
    n_fixed: usize,
    n: usize,
    positions: Vec<usize>,
    masked: Option<Vec<usize>>,
    error: bool,
}

#[test]
fn mask_positions_match_the_python_fixture() {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/kf_mask_positions.json"),
    )
    .unwrap();
    let cases: Vec<Case> = serde_json::from_str(&text).unwrap();
    assert_eq!(cases.len(), 9);
    for c in cases {
        let keys = key_tokens(&c.frames.iter().map(|&f| (f, 0)).collect::<Vec<_>>(), 8);
        let positions: Vec<usize> = keys.iter().map(|k| k.position).collect();
        assert_eq!(positions, c.positions, "{}", c.name);
        let got = kf_mask_positions(&positions, c.k, c.n_fixed, c.n);
        match (got, c.error) {
            (Err(_), true) => {}
            (Ok(m), false) => assert_eq!(Some(m), c.masked, "{}", c.name),
            (got, _) => panic!("{}: {got:?}", c.name),
        }
    }
}
