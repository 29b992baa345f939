//! Time the 35-D music feature on one file (release mode):
//!
//!     cargo run --release -p qean-audio --example bench_features -- [PATH] [REPEATS]
//!
//! Peer: bench/peer/features_librosa.py (librosa 0.8.1 + resampy 0.2.2).

use std::path::PathBuf;
use std::time::Instant;

use qean_audio::{self as audio, FeatureOptions, LoadOptions};
use qean_audio::{beat, chroma, cqt, mel, mfcc, onset, stft, tuning};

/// CPU seconds used by this process so far, all threads (Linux /proc; 0 elsewhere). On a shared
/// machine this is steadier than wall time.
fn cpu_seconds() -> f64 {
    let Ok(s) = std::fs::read_to_string("/proc/self/stat") else {
        return 0.0;
    };
    // Fields after the command name: state is field 3; utime and stime are fields 14 and 15.
    let rest = &s[s.rfind(')').map_or(0, |i| i + 2)..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let tick = |i: usize| f.get(i).and_then(|v| v.parse::<f64>().ok()).unwrap_or(0.0);
    (tick(11) + tick(12)) / 100.0
}

/// One pass with each stage timed on its own (wall and process CPU seconds).
fn stages(path: &std::path::Path) -> Result<(), Box<dyn std::error::Error>> {
    let mut t = Instant::now();
    let mut c = cpu_seconds();
    let mut lap = |name: &str| {
        let c1 = cpu_seconds();
        println!(
            "  {name:<24} wall {:.3} s  cpu {:.2} s",
            t.elapsed().as_secs_f64(),
            c1 - c
        );
        t = Instant::now();
        c = c1;
    };
    let d = audio::decode::decode_file(path, 3600.0)?;
    lap("decode");
    let x: Vec<f64> = d.samples.iter().map(|&v| v as f64).collect();
    let y = audio::resample::resample(&x, d.rate as f64, 30720.0, Default::default(), false)?;
    lap("resample (kaiser_best)");
    let _ = audio::resample::resample_with(
        &x,
        d.rate as f64,
        30720.0,
        Default::default(),
        false,
        false,
    )?;
    lap("(resample, f64 sums)");
    let sr = 30720.0;
    let power = stft::power_spectrogram(&y, 2048, 512);
    lap("stft power");
    let env = onset::onset_strength_from_power(&power, sr, onset::Aggregate::Mean);
    lap("onset envelope");
    let bank = mel::MelBank::new(sr, 2048, 128, 0.0, sr / 2.0);
    let mut m = bank.apply(&power);
    mel::power_to_db(&mut m.data);
    let _ = mfcc::mfcc_from_db_mel(&m, 20);
    lap("mel + mfcc");
    let tu = tuning::estimate_tuning(&power, sr, 2048, 36);
    lap("tuning");
    let fmin = cqt::C1_HZ * 2f64.powf(tu / 36.0);
    let c = cqt::cqt_magnitude(&y, sr, 512, fmin, 252, 36)?;
    lap("cqt");
    let _ = chroma::cens_from_cqt(&c);
    lap("cens");
    let _ = onset::onset_detect(&env, sr, 512);
    lap("onset_detect");
    let _ = beat::beat_track(&env, sr, 512, 120.0, 100.0);
    lap("beat_track");
    let _ = audio::hpss::bailando_beats(&y, sr);
    lap("(hpss bailando beats)");
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let path = args.get(1).map(PathBuf::from).unwrap_or_else(|| {
        let rel = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../../shared/data/music/Kevin_MacLeod_-_Vibe_Ace.wav");
        if rel.exists() {
            rel
        } else {
            PathBuf::from("/work/shared/data/music/Kevin_MacLeod_-_Vibe_Ace.wav")
        }
    });
    let repeats: usize = args.get(2).map(|s| s.parse()).transpose()?.unwrap_or(3);
    let opts = FeatureOptions::default();
    let mut loads = Vec::new();
    let mut feats = Vec::new();
    let mut frames = 0;
    let cpu0 = cpu_seconds();
    for _ in 0..repeats {
        let t0 = Instant::now();
        let a = audio::load_audio(&path, &LoadOptions::default())?;
        let t1 = Instant::now();
        let f = audio::music_features(&a.samples, &opts)?;
        let t2 = Instant::now();
        frames = f.frames;
        loads.push((t1 - t0).as_secs_f64());
        feats.push((t2 - t1).as_secs_f64());
    }
    let cpu_per_track = (cpu_seconds() - cpu0) / repeats as f64;
    stages(&path)?;
    // The public one-call path, once, as a check that it costs the same.
    let t = Instant::now();
    audio::features_for_file(&path, &opts)?;
    let once = t.elapsed().as_secs_f64();
    let med = |v: &mut Vec<f64>| {
        v.sort_by(|a, b| a.total_cmp(b));
        v[v.len() / 2]
    };
    let mut tot: Vec<f64> = loads.iter().zip(&feats).map(|(a, b)| a + b).collect();
    println!(
        "qean-audio: {} ({frames} frames, {} rayon threads)",
        path.display(),
        rayon::current_num_threads()
    );
    println!("load+resample: median {:.3} s", med(&mut loads));
    println!("features:      median {:.3} s", med(&mut feats));
    println!(
        "total:         median {:.3} s per track (features_for_file once: {once:.3} s); \
         CPU {cpu_per_track:.2} s per track",
        med(&mut tot)
    );
    Ok(())
}
