//! SPEC §9 item 12: kinetic features of linear motion in closed form.

use qean_eval::kinetic::{kinetic_features, KINETIC_DIM};
use qean_eval::{Frame, MetricsMode, N_JOINTS};

fn linear(p0: [f64; 3], delta: [f64; 3], t: usize) -> Vec<Frame> {
    (0..t)
        .map(|k| {
            let mut f = [[0.0; 3]; N_JOINTS];
            for (j, p) in f.iter_mut().enumerate() {
                for a in 0..3 {
                    // Each joint its own start, all the same velocity.
                    p[a] = p0[a] + 0.1 * j as f64 + k as f64 * delta[a];
                }
            }
            f
        })
        .collect()
}

#[test]
fn linear_motion_kinetic_energy_closed_form() {
    let (p0, d) = ([0.3, -1.2, 0.7], [0.01, -0.02, 0.005]);
    let feats = kinetic_features(&linear(p0, d, 50), MetricsMode::Reference).unwrap();
    assert_eq!(feats.len(), KINETIC_DIM);
    let ke_h = 3600.0 * (d[0] * d[0] + d[2] * d[2]);
    let ke_v = 3600.0 * d[1] * d[1];
    for j in 0..N_JOINTS {
        assert!((feats[3 * j] - ke_h).abs() < 1e-9 * ke_h, "KE_h joint {j}");
        assert!(
            (feats[3 * j + 1] - ke_v).abs() < 1e-9 * ke_v,
            "KE_v joint {j}"
        );
    }
}

#[test]
fn linear_motion_energy_expenditure_reference_bug_and_corrected() {
    let (p0, d, t) = ([0.3, -1.2, 0.7], [0.01, -0.02, 0.005], 40);
    let joints = linear(p0, d, t);
    let reference = kinetic_features(&joints, MetricsMode::Reference).unwrap();
    let corrected = kinetic_features(&joints, MetricsMode::Corrected).unwrap();
    for j in 0..N_JOINTS {
        // EE_reference(i) = |3540 · mean of p[k] over k = i−2..=i+2 with 1 ≤ k ≤ T−2|.
        let mut expected = 0.0;
        for i in 1..t {
            let ks: Vec<usize> = (i.saturating_sub(2)..=i + 2)
                .filter(|&k| k >= 1 && k + 1 < t)
                .collect();
            let mut mean = [0.0; 3];
            for &k in &ks {
                for a in 0..3 {
                    mean[a] += joints[k][j][a] / ks.len() as f64;
                }
            }
            expected += 3540.0 * (mean[0].powi(2) + mean[1].powi(2) + mean[2].powi(2)).sqrt();
        }
        expected /= (t - 1) as f64;
        let got = reference[3 * j + 2];
        assert!(
            (got - expected).abs() < 1e-9 * expected,
            "joint {j}: {got} vs {expected}"
        );
        assert!(corrected[3 * j + 2].abs() < 1e-7, "corrected EE joint {j}");
        // Kinetic energies do not depend on the mode.
        assert_eq!(reference[3 * j], corrected[3 * j]);
    }
}

#[test]
fn static_pose_has_zero_velocity_but_reference_ee_sees_position() {
    let joints = linear([0.0, 1.0, 0.0], [0.0; 3], 10);
    let f = kinetic_features(&joints, MetricsMode::Reference).unwrap();
    // Joint 0 sits at (0, 1, 0): EE = 3540 · 1.
    assert_eq!(f[0], 0.0);
    assert_eq!(f[1], 0.0);
    assert!((f[2] - 3540.0).abs() < 1e-9);
}

#[test]
fn too_few_frames_is_an_error() {
    let joints = linear([0.0; 3], [0.01; 3], 3);
    let err = kinetic_features(&joints, MetricsMode::Reference).unwrap_err();
    assert!(err.to_string().contains("at least 4 frames"), "{err}");
}
