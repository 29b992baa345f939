//! Property tests: what the features must and must not see. Geometric features and kinetic energies
//! ignore where the dancer stands and which way they face (yaw); the reference energy expenditure
//! does not ignore position (SPEC §7.2's bug), the corrected one does.

mod common;

use common::synthetic_motion;
use qean_eval::beat_align::{motion_beats_bailando, motion_beats_mint};
use qean_eval::geometric::geometric_features;
use qean_eval::kinetic::kinetic_features;
use qean_eval::{Frame, GeometricVariant, MetricsMode};

fn rigid(joints: &[Frame], yaw: f64, shift: [f64; 3]) -> Vec<Frame> {
    let (c, s) = (yaw.cos(), yaw.sin());
    joints
        .iter()
        .map(|f| {
            let mut g = *f;
            for p in g.iter_mut() {
                let (x, z) = (p[0], p[2]);
                *p = [
                    c * x + s * z + shift[0],
                    p[1] + shift[1],
                    -s * x + c * z + shift[2],
                ];
            }
            g
        })
        .collect()
}

#[test]
fn geometric_features_ignore_position_and_facing() {
    for seed in 0..5 {
        let x = synthetic_motion(seed, 240);
        let y = rigid(&x, 0.3 + seed as f64, [1.5, -0.4, -2.0]);
        for variant in [
            GeometricVariant::ManualNew,
            GeometricVariant::LegacyFairmotion,
        ] {
            for mode in [MetricsMode::Reference, MetricsMode::Corrected] {
                let a = geometric_features(&x, variant, mode).unwrap();
                let b = geometric_features(&y, variant, mode).unwrap();
                assert!(
                    a.iter().filter(|v| **v > 0.0 && **v < 1.0).count() >= 8,
                    "{a:?}"
                );
                // A frame may flip where a value sits on its threshold to round-off: allow one.
                for (i, (u, v)) in a.iter().zip(&b).enumerate() {
                    assert!(
                        (u - v).abs() <= 1.0 / 239.0 + 1e-12,
                        "seed {seed} {variant:?} {mode:?} feature {i}: {u} vs {v}"
                    );
                }
            }
        }
    }
}

#[test]
fn kinetic_energies_ignore_position_but_reference_expenditure_does_not() {
    let x = synthetic_motion(11, 200);
    let y = rigid(&x, 1.1, [0.8, 0.3, -1.2]);
    let rel = |a: f64, b: f64| (a - b).abs() / a.abs().max(1e-12);
    let (rx, ry) = (
        kinetic_features(&x, MetricsMode::Reference).unwrap(),
        kinetic_features(&y, MetricsMode::Reference).unwrap(),
    );
    let (cx, cy) = (
        kinetic_features(&x, MetricsMode::Corrected).unwrap(),
        kinetic_features(&y, MetricsMode::Corrected).unwrap(),
    );
    let mut ee_moved = 0;
    for j in 0..24 {
        for k in 0..2 {
            assert!(rel(rx[3 * j + k], ry[3 * j + k]) < 1e-9, "KE joint {j}");
        }
        assert!(
            rel(cx[3 * j + 2], cy[3 * j + 2]) < 1e-9,
            "corrected EE joint {j}"
        );
        if rel(rx[3 * j + 2], ry[3 * j + 2]) > 1e-3 {
            ee_moved += 1;
        }
    }
    assert_eq!(
        ee_moved, 24,
        "the reference EE should see the absolute position of every joint"
    );
}

#[test]
fn motion_beats_ignore_position_and_facing() {
    let x = synthetic_motion(4, 400);
    let y = rigid(&x, -2.0, [3.0, 0.1, 0.5]);
    assert_eq!(motion_beats_bailando(&x), motion_beats_bailando(&y));
    assert_eq!(motion_beats_mint(&x), motion_beats_mint(&y));
}
