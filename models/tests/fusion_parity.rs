//! SPEC §13.11 test 14: text control's fusion weights against the fixture `tools/make_fusion_fixtures.py`
//! transcribes from SPEC §13.7 in numpy (every schedule, intervals long and short, r = 0, one token, the
//! sequence's end).

use qean_models::control::fusion::{fusion_weights, TextSchedule};

#[derive(serde::Deserialize)]
struct Case {
    n: usize,
    s: usize,
    e: usize,
    ramp: usize,
    schedule: String,
    w: Vec<f64>,
}

#[test]
fn fusion_weights_match_the_numpy_fixture() {
    let text = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/fusion_weights.json"),
    )
    .unwrap();
    let cases: Vec<Case> = serde_json::from_str(&text).unwrap();
    assert_eq!(cases.len(), 18);
    for c in cases {
        let schedule = match c.schedule.as_str() {
            "linear" => TextSchedule::Linear,
            "cosine" => TextSchedule::Cosine,
            _ => TextSchedule::Step,
        };
        let w = fusion_weights(c.n, c.s, c.e, c.ramp, schedule);
        assert_eq!(w.len(), c.w.len());
        for (j, (a, b)) in w.iter().zip(&c.w).enumerate() {
            assert!(
                (a - b).abs() <= 1e-12,
                "{} [{}, {}) r {} token {j}: {a} vs {b}",
                c.schedule,
                c.s,
                c.e,
                c.ramp
            );
        }
    }
}
