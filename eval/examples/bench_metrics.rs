//! Timing of a full evaluation at AIST++ scale: 40 generated sequences (120 seed + 1200 frames)
//! against 1363 reference sequences of realistic lengths (80 % basic dances of 8–12 s, 20 % advanced
//! of 30–50 s, at 60 FPS), synthetic smooth motion, with BeatAlign.
//!
//! Run: `cargo run --release -p qean-eval --example bench_metrics [-- REPEATS]`
//! (RAYON_NUM_THREADS sets the thread count.)

use std::time::Instant;

use qean_eval::{evaluate, EvalConfig, Frame, Sequence, N_JOINTS};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn motion(rng: &mut ChaCha8Rng, frames: usize) -> Vec<Frame> {
    let base: Vec<[f64; 3]> = (0..N_JOINTS)
        .map(|_| {
            [
                rng.random_range(-0.5..0.5),
                rng.random_range(-1.0..0.7),
                rng.random_range(-0.2..0.2),
            ]
        })
        .collect();
    let params: Vec<[(f64, f64, f64); 3]> = (0..N_JOINTS)
        .map(|_| {
            [0; 3].map(|_| {
                (
                    rng.random_range(0.01..0.2),
                    rng.random_range(0.3..3.0),
                    rng.random_range(0.0..std::f64::consts::TAU),
                )
            })
        })
        .collect();
    (0..frames)
        .map(|t| {
            let t = t as f64 / 60.0;
            let mut f = [[0.0; 3]; N_JOINTS];
            for j in 0..N_JOINTS {
                for a in 0..3 {
                    let (amp, freq, phase) = params[j][a];
                    f[j][a] = base[j][a] + amp * (std::f64::consts::TAU * freq * t + phase).sin();
                }
            }
            f
        })
        .collect()
}

fn main() {
    let repeats: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let genres = ["BR", "PO", "LO", "MH", "LH", "HO", "WA", "KR", "JS", "JB"];
    let name = |i: usize| {
        let g = genres[i % 10];
        format!(
            "g{g}_sBM_cAll_d{:02}_m{g}{}_ch{:02}",
            i % 30,
            (i / 10) % 6,
            i % 100
        )
    };
    let reference: Vec<Sequence> = (0..1363)
        .map(|i| {
            let frames = if rng.random_bool(0.8) {
                rng.random_range(480..=720)
            } else {
                rng.random_range(1800..=3000)
            };
            Sequence::new(name(i), motion(&mut rng, frames))
        })
        .collect();
    let generated: Vec<Sequence> = (0..40)
        .map(|i| Sequence::new(name(i), motion(&mut rng, 1320)))
        .collect();
    let beats =
        |_: &str| -> qean_eval::Result<Vec<usize>> { Ok((0..200).map(|k| 13 + 30 * k).collect()) };
    let ref_frames: usize = reference.iter().map(|s| s.joints.len()).sum();
    println!(
        "40 generated x 1320 frames vs 1363 reference ({ref_frames} frames, mean {:.0}); {} rayon threads",
        ref_frames as f64 / 1363.0,
        rayon::current_num_threads()
    );
    let cfg = EvalConfig::default();
    let mut times = Vec::new();
    for r in 0..repeats {
        let t0 = Instant::now();
        let rep = evaluate(&generated, &reference, Some(&beats), &cfg).expect("evaluation");
        let ms = t0.elapsed().as_secs_f64() * 1e3;
        times.push(ms);
        println!(
            "run {r}: {ms:.0} ms (FID_k {:.3}, FID_g {:.3}, Dist_k {:.3}, BA {:.4})",
            rep.fid_k,
            rep.fid_g,
            rep.div_k,
            rep.beat_align.unwrap_or(f64::NAN)
        );
    }
    times.sort_by(f64::total_cmp);
    println!(
        "median {:.0} ms over {repeats} runs",
        times[times.len() / 2]
    );

    // Where the time goes, single-threaded, over the reference set.
    let t0 = Instant::now();
    for s in &reference {
        qean_eval::kinetic::kinetic_features(&s.joints, cfg.metrics_mode).expect("kinetic");
    }
    let k = t0.elapsed().as_secs_f64() * 1e3;
    let t0 = Instant::now();
    for s in &reference {
        qean_eval::geometric::geometric_features(&s.joints, cfg.geometric, cfg.metrics_mode)
            .expect("geometric");
    }
    let g = t0.elapsed().as_secs_f64() * 1e3;
    let music = beats("").expect("beats");
    let t0 = Instant::now();
    for s in &reference {
        qean_eval::beat_align::score_ground_truth(&s.joints, &music);
    }
    let b = t0.elapsed().as_secs_f64() * 1e3;
    println!(
        "1 thread, reference set only: kinetic {k:.0} ms, geometric {g:.0} ms, BeatAlign {b:.0} ms"
    );
}
