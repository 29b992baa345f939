//! Timing of a full evaluation at AIST++ scale: 40 generated sequences (120 seed + 1200 frames)
//! against 1363 reference sequences of realistic lengths (80 % basic dances of 8–12 s, 20 % advanced
//! of 30–50 s, at 60 FPS), synthetic smooth motion, with BeatAlign.
//!
//! Run: `cargo run --release -p qean-eval --example bench_metrics [-- REPEATS]`
//! (RAYON_NUM_THREADS sets the thread count.)

use std::time::Instant;

use qean_eval::synthetic::SyntheticSet;
use qean_eval::{evaluate, EvalConfig, Sequence};

fn main() {
    let repeats: usize = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(3);
    let set = SyntheticSet::aist_sized(7, 40, 1320, 1363);
    let reference: Vec<Sequence> = set.reference.iter().map(|s| s.sequence()).collect();
    let generated: Vec<Sequence> = set.generated.iter().map(|s| s.sequence()).collect();
    let music = set.beats(6000);
    let beats = |_: &str| -> qean_eval::Result<Vec<usize>> { Ok(music.clone()) };
    let ref_frames = set.reference_frames();
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
    let t0 = Instant::now();
    for s in &reference {
        qean_eval::beat_align::score_ground_truth(&s.joints, &music);
    }
    let b = t0.elapsed().as_secs_f64() * 1e3;
    println!(
        "1 thread, reference set only: kinetic {k:.0} ms, geometric {g:.0} ms, BeatAlign {b:.0} ms"
    );
}
