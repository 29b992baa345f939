//! SPEC §9 item 13: the body constants and the manual predicates on hand-built poses.

mod common;

use common::rest_pose;
use qean_eval::geometric::{
    evaluate, feature_table, geometric_features, time_step, BodyConstants, Predicate,
    GEOMETRIC_DIM, REST_LELBOW, REST_LHIP, REST_LSHOULDER, REST_RHIP, REST_RSHOULDER,
};
use qean_eval::{Frame, GeometricVariant, MetricsMode};

const ROOT: usize = 0;
const LHIP: usize = 1;
const RHIP: usize = 2;
const BELLY: usize = 3;
const RANKLE: usize = 8;
const CHEST: usize = 9;
const NECK: usize = 12;
const LSHOULDER: usize = 16;
const RSHOULDER: usize = 17;
const LELBOW: usize = 18;
const RELBOW: usize = 19;
const LWRIST: usize = 20;
const RWRIST: usize = 21;

fn close(a: f64, b: f64, tol: f64) -> bool {
    (a - b).abs() <= tol
}

#[test]
fn body_constants_match_spec() {
    let k = BodyConstants::of(GeometricVariant::ManualNew);
    assert!(close(k.hl, 0.2568381, 1e-7), "hl {}", k.hl);
    assert!(close(k.sw, 0.3908484, 1e-7), "sw {}", k.sw);
    assert!(close(k.hw, 0.1192471, 1e-7), "hw {}", k.hw);
    let l = BodyConstants::of(GeometricVariant::LegacyFairmotion);
    assert!(close(l.hl, 0.2493235, 1e-7), "legacy hl {}", l.hl);
    assert!(close(l.sw, 0.4857135, 1e-7), "legacy sw {}", l.sw);
    assert!(close(l.hw, 0.4241398, 1e-7), "legacy hw {}", l.hw);
}

#[test]
fn hard_coded_rest_joints_equal_the_skeleton_rest_pose() {
    let rest = rest_pose();
    for (name, idx, table) in [
        ("lshoulder", LSHOULDER, REST_LSHOULDER),
        ("lelbow", LELBOW, REST_LELBOW),
        ("rshoulder", RSHOULDER, REST_RSHOULDER),
        ("lhip", LHIP, REST_LHIP),
        ("rhip", RHIP, REST_RHIP),
    ] {
        for a in 0..3 {
            assert!(
                close(rest[idx][a], table[a], 2e-7),
                "{name}[{a}]: {} vs {}",
                rest[idx][a],
                table[a]
            );
        }
    }
    // SPEC §3.3: joint 16 of the identity pose.
    let j16 = [0.19911, 0.23681, -0.01807];
    for a in 0..3 {
        assert!(close(rest[LSHOULDER][a], j16[a], 1e-5));
    }
}

fn table() -> Vec<Predicate> {
    feature_table(GeometricVariant::ManualNew)
}

fn moved(f: &Frame, joint: usize, d: [f64; 3]) -> Frame {
    let mut g = *f;
    for a in 0..3 {
        g[joint][a] += d[a];
    }
    g
}

#[test]
fn fast_uses_tau_one_120th_in_reference_and_one_60th_corrected() {
    let t = table();
    let rest = rest_pose();
    let hl = BodyConstants::of(GeometricVariant::ManualNew).hl;
    // Feature 32: fast(root, 2.3 hl). A step of s metres gives s/τ m/s.
    let s = 2.3 * hl / 90.0; // 90 s/s: above the threshold at 120 FPS-τ, below at 60.
    let cur = moved(&rest, ROOT, [s, 0.0, 0.0]);
    assert!(evaluate(
        &t[31],
        &cur,
        &rest,
        time_step(MetricsMode::Reference)
    ));
    assert!(!evaluate(
        &t[31],
        &cur,
        &rest,
        time_step(MetricsMode::Corrected)
    ));
    assert!(!evaluate(
        &t[31],
        &rest,
        &rest,
        time_step(MetricsMode::Reference)
    ));
}

#[test]
fn elbow_angle_feature() {
    let t = table();
    let tau = time_step(MetricsMode::Reference);
    let mut f = rest_pose();
    // Feature 7: angle(relbow, rshoulder, relbow, rwrist) in (0, 110). Rest arm is nearly straight.
    assert!(!evaluate(&t[6], &f, &f, tau));
    // Bend the forearm 90° forward.
    f[RWRIST] = [f[RELBOW][0], f[RELBOW][1], f[RELBOW][2] + 0.25];
    assert!(evaluate(&t[6], &f, &f, tau));
}

#[test]
fn foot_raised_plane_feature() {
    let t = table();
    let tau = time_step(MetricsMode::Reference);
    let hl = BodyConstants::of(GeometricVariant::ManualNew).hl;
    let rest = rest_pose();
    // Feature 17: nplane(zero, y_unit, y_min, rankle, 1.2 hl): ankle height above the lowest joint.
    assert!(!evaluate(&t[16], &rest, &rest, tau));
    let lifted = moved(&rest, RANKLE, [0.0, 1.3 * hl + 0.2, 0.0]);
    assert!(evaluate(&t[16], &lifted, &rest, tau));
}

#[test]
fn move_feature_measures_its_third_joint() {
    // Feature 5 is move(belly, chest, chest, rwrist): the reference moves the chest, not the wrist.
    let t = table();
    let tau = time_step(MetricsMode::Reference);
    let hl = BodyConstants::of(GeometricVariant::ManualNew).hl;
    let rest = rest_pose();
    let step = 1.8 * hl * tau * 2.0;
    let up = |f: &Frame, j| moved(f, j, [0.0, step, 0.0]);
    assert!(!evaluate(&t[4], &up(&rest, RWRIST), &rest, tau));
    assert!(evaluate(&t[4], &up(&rest, CHEST), &rest, tau));
    // Moving the belly down lengthens belly→chest as well.
    assert!(evaluate(
        &t[4],
        &moved(&rest, BELLY, [0.0, -step, 0.0]),
        &rest,
        tau
    ));
}

#[test]
fn nmove_feature_along_the_body_normal() {
    // Feature 1: nmove(neck, rhip, lhip, rwrist): rwrist speed relative to the neck along
    // (lhip − neck) × (rhip − neck), which points forward (+z) for the rest pose.
    let t = table();
    let tau = time_step(MetricsMode::Reference);
    let hl = BodyConstants::of(GeometricVariant::ManualNew).hl;
    let rest = rest_pose();
    let n = {
        let (a, b, c) = (rest[NECK], rest[RHIP], rest[LHIP]);
        let u = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
        let v = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
        [
            u[1] * v[2] - u[2] * v[1],
            u[2] * v[0] - u[0] * v[2],
            u[0] * v[1] - u[1] * v[0],
        ]
    };
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    let step = 2.0 * 1.8 * hl * tau;
    let along = [n[0] / len * step, n[1] / len * step, n[2] / len * step];
    let back = [-along[0], -along[1], -along[2]];
    assert!(evaluate(&t[0], &moved(&rest, RWRIST, along), &rest, tau));
    assert!(!evaluate(&t[0], &moved(&rest, RWRIST, back), &rest, tau));
}

#[test]
fn zero_length_direction_is_false() {
    // Feature 3: nplane(chest, neck, neck, rwrist, 0.2 hl) with chest == neck: 0/0, false.
    let t = table();
    let tau = time_step(MetricsMode::Reference);
    let mut f = rest_pose();
    f[RWRIST] = [f[NECK][0], f[NECK][1] + 1.0, f[NECK][2]];
    assert!(evaluate(&t[2], &f, &f, tau));
    f[CHEST] = f[NECK];
    assert!(!evaluate(&t[2], &f, &f, tau));
}

#[test]
fn legacy_names_read_other_joints() {
    // Legacy "lwrist" is SMPL joint 17 (R_Shoulder): feature 14 fast(lwrist) fires on joint 17.
    let tau = time_step(MetricsMode::Reference);
    let rest = rest_pose();
    let cur = moved(&rest, RSHOULDER, [0.2, 0.0, 0.0]);
    let legacy = feature_table(GeometricVariant::LegacyFairmotion);
    let fixed = table();
    assert!(evaluate(&legacy[13], &cur, &rest, tau));
    assert!(!evaluate(&fixed[13], &cur, &rest, tau));
    assert!(evaluate(
        &fixed[13],
        &moved(&rest, LWRIST, [0.2, 0.0, 0.0]),
        &rest,
        tau
    ));
}

#[test]
fn features_are_frame_means() {
    // Root jumps on 2 of 4 transitions: feature 32 = 0.5.
    let rest = rest_pose();
    let a = moved(&rest, ROOT, [0.3, 0.0, 0.0]);
    let joints = vec![rest, rest, a, a, rest];
    let f =
        geometric_features(&joints, GeometricVariant::ManualNew, MetricsMode::Reference).unwrap();
    assert_eq!(f.len(), GEOMETRIC_DIM);
    assert_eq!(f[31], 0.5);
    assert!(f.iter().all(|x| (0.0..=1.0).contains(x)));
}
