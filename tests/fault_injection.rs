//! Fault injection: training, sweeps and the feature cache are killed with SIGKILL at random moments
//! (checkpoint writes included) and restarted; the end result must equal an uninterrupted run's, and
//! nothing left behind at any kill may be half-written or unloadable.
//!
//! The moments come from a small PRNG seeded from the clock; the seed is printed, and
//! `QEAN_FAULT_SEED=N` replays a failure.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::*;

/// xorshift64*: enough randomness for kill moments, replayable from its seed.
struct Rng(u64);

impl Rng {
    fn new(what: &str) -> Rng {
        let seed = std::env::var("QEAN_FAULT_SEED")
            .ok()
            .and_then(|s| s.parse().ok())
            .unwrap_or_else(|| {
                std::time::SystemTime::now()
                    .duration_since(std::time::UNIX_EPOCH)
                    .unwrap()
                    .as_nanos() as u64
            });
        println!("{what}: QEAN_FAULT_SEED={seed}");
        Rng(seed | 1)
    }

    fn below(&mut self, n: u64) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) % n.max(1)
    }
}

/// Runs `cmd`, killing it with SIGKILL after `delay`. Returns true if it was killed, false if it ended
/// first (then it must have succeeded).
fn kill_after(cmd: &mut Command, delay: Duration) -> bool {
    kill_when(cmd, |elapsed| elapsed >= delay)
}

/// Runs `cmd`, killing it with SIGKILL as soon as `ready(elapsed)` holds (polled every 2 ms). Returns true
/// if it was killed, false if it ended first (then it must have succeeded).
fn kill_when(cmd: &mut Command, mut ready: impl FnMut(Duration) -> bool) -> bool {
    let mut child = cmd
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
            assert!(status.success(), "ended with {status}: {err}");
            return false;
        }
        if ready(start.elapsed()) {
            let _ = child.kill();
            child.wait().unwrap();
            return true;
        }
        std::thread::sleep(Duration::from_millis(2));
    }
}

fn timed(cmd: &mut Command) -> Duration {
    let start = Instant::now();
    run_ok(cmd);
    start.elapsed()
}

/// Every checkpoint directory left in `run` loads (its weights and state parse).
fn all_checkpoints_load(run: &Path) {
    for ck in checkpoints(run) {
        params_hash(&ck);
    }
}

#[test]
fn twenty_sigkills_then_resume_equal_an_uninterrupted_run() {
    let d = tempfile::tempdir().unwrap();
    let data = dataset(d.path());
    // QEAN full (dropout, SPE, QRA), a checkpoint every step (so kills land inside checkpoint writes
    // and prunes), validation and logging every few steps.
    let extra = [
        "train.steps=60",
        "train.checkpoint_every=1",
        "train.log_every=1",
        "train.val_every=5",
        "train.keep_last=3",
    ];
    let straight = d.path().join("straight");
    let full = timed(&mut train_cmd("tiny/full.toml", &data, &straight, &extra));
    println!("uninterrupted run: {full:?}");

    let run = d.path().join("killed");
    let mut rng = Rng::new("train");
    let mut kills = 0;
    let mut moments = Vec::new();
    while kills < 20 {
        let mut cmd = if run.join("config.toml").is_file() {
            let mut c = qean();
            c.arg("train").arg("--resume").arg(&run).arg("--plain");
            c
        } else {
            train_cmd("tiny/full.toml", &data, &run, &extra)
        };
        // Anywhere from process start to 1/24 of a whole run: a killed process can have done no
        // more than its lifetime's worth of steps, so 20 kills always land before the end.
        let delay = Duration::from_millis(rng.below(full.as_millis() as u64 / 24));
        assert!(
            kill_after(&mut cmd, delay),
            "the run finished before 20 kills (after {kills}): raise train.steps"
        );
        kills += 1;
        let step = checkpoints(&run)
            .last()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned());
        moments.push(format!(
            "{} ms → {}",
            delay.as_millis(),
            step.as_deref().unwrap_or("none")
        ));
        all_checkpoints_load(&run);
    }
    println!("kills (delay → newest checkpoint): {}", moments.join(", "));
    let mut resume = qean();
    resume.arg("train").arg("--resume").arg(&run).arg("--plain");
    run_ok(&mut resume);

    assert_eq!(losses(&straight), losses(&run), "metrics.csv differs");
    let last = |r: &Path| checkpoints(r).last().unwrap().clone();
    assert!(last(&run).ends_with("step-60"));
    assert_eq!(params_hash(&last(&straight)), params_hash(&last(&run)));
    // No temporaries left once a run has finished.
    let leftovers: Vec<String> = listing(&run)
        .into_iter()
        .filter(|p| p.contains(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

fn sweep_cmd(data: &Path, out: &Path) -> Command {
    let mut cmd = qean();
    cmd.arg("sweep")
        .arg("--config")
        .arg(configs().join("sweeps/tiny-ablation.toml"))
        .arg("--data")
        .arg(data)
        .arg("--out")
        .arg(out)
        .args(["--seeds", "0"])
        .arg("--plain");
    for s in SMALL.iter().chain(&[
        "train.steps=8",
        "train.checkpoint_every=1",
        "train.keep_last=2",
    ]) {
        cmd.arg("--set").arg(s);
    }
    cmd
}

/// The run directories of a sweep.
fn run_dirs(out: &Path) -> Vec<PathBuf> {
    let mut runs: Vec<PathBuf> = std::fs::read_dir(out)
        .map(|d| {
            d.map(|e| e.unwrap().path())
                .filter(|p| p.is_dir())
                .collect()
        })
        .unwrap_or_default();
    runs.sort();
    runs
}

/// The updates a run has checkpointed so far (its newest checkpoint's step; 0 before the first).
fn progress(run: &Path) -> u64 {
    checkpoints(run).last().map_or(0, |c| checkpoint_step(c))
}

/// The updates all runs of a sweep have checkpointed so far.
fn sweep_progress(out: &Path) -> u64 {
    run_dirs(out).iter().map(|r| progress(r)).sum()
}

/// Runs a sweep into `out`, killing it `extra_ms` after its runs have checkpointed `goal` updates in all.
/// Returns true if it was killed, false if it ended first.
fn kill_at_progress(cmd: &mut Command, out: &Path, goal: u64, extra_ms: u64) -> bool {
    let mut reached: Option<Duration> = None;
    kill_when(cmd, |elapsed| {
        if reached.is_none() && sweep_progress(out) >= goal {
            reached = Some(elapsed);
        }
        reached.is_some_and(|at| elapsed >= at + Duration::from_millis(extra_ms))
    })
}

/// The final checkpoint hash of every run of a sweep, by run name.
fn sweep_hashes(out: &Path) -> Vec<(String, String)> {
    run_dirs(out)
        .iter()
        .map(|r| {
            let name = r.file_name().unwrap().to_string_lossy().into_owned();
            (name, params_hash(checkpoints(r).last().unwrap()))
        })
        .collect()
}

#[test]
fn a_sweep_killed_between_and_inside_runs_finishes_like_an_uninterrupted_one() {
    let d = tempfile::tempdir().unwrap();
    let data = dataset(d.path());
    let straight = d.path().join("straight");
    let full = timed(&mut sweep_cmd(&data, &straight));
    assert_eq!(run_dirs(&straight).len(), 4, "{:?}", listing(&straight));

    let out = d.path().join("killed");
    let mut rng = Rng::new("sweep");
    let mut kills = 0;
    // Spread over the whole sweep by its progress (the updates checkpointed in all its runs), not by the
    // clock, which a loaded machine stretches: attempt k waits for k/8 of the sweep's updates, then a random
    // moment up to a 40th of the uninterrupted sweep. Kills at a run's last update land between runs.
    let total = sweep_progress(&straight);
    for k in 0..8u64 {
        let (goal, extra) = (total * k / 8, rng.below(full.as_millis() as u64 / 40));
        kills += kill_at_progress(&mut sweep_cmd(&data, &out), &out, goal, extra) as usize;
        for r in run_dirs(&out) {
            all_checkpoints_load(&r);
        }
    }
    println!("sweep: {kills} of 8 attempts killed (uninterrupted: {full:?})");
    assert!(kills >= 6, "only {kills} kills landed");
    run_ok(&mut sweep_cmd(&data, &out));
    assert_eq!(sweep_hashes(&straight), sweep_hashes(&out));
    for run in run_dirs(&out) {
        let name = run.file_name().unwrap().to_owned();
        assert_eq!(losses(&straight.join(&name)), losses(&run), "{name:?}");
    }
}

#[test]
fn the_feature_cache_killed_mid_way_ends_with_the_same_files() {
    let d = tempfile::tempdir().unwrap();
    let data = dataset(d.path());
    let copy = d.path().join("copy");
    std::fs::create_dir(&copy).unwrap();
    for sub in ["motions", "wav", "splits"] {
        let from = data.join(sub);
        if from.is_dir() {
            std::fs::create_dir(copy.join(sub)).unwrap();
            for e in std::fs::read_dir(&from).unwrap() {
                let p = e.unwrap().path();
                std::fs::copy(&p, copy.join(sub).join(p.file_name().unwrap())).unwrap();
            }
        }
    }
    let features = |ds: &Path| {
        let mut c = qean();
        c.arg("features").arg("--dataset").arg(ds);
        c
    };
    let full = timed(&mut features(&data));
    let cached = |ds: &Path| -> Vec<(String, Vec<u8>)> {
        let mut v: Vec<(String, Vec<u8>)> = std::fs::read_dir(ds.join("features"))
            .map(|d| {
                d.map(|e| {
                    let p = e.unwrap().path();
                    (
                        p.file_name().unwrap().to_string_lossy().into_owned(),
                        std::fs::read(&p).unwrap(),
                    )
                })
                .collect()
            })
            .unwrap_or_default();
        v.sort();
        v
    };
    let mut rng = Rng::new("features");
    let mut kills = 0;
    for _ in 0..6 {
        let delay = Duration::from_millis(rng.below(full.as_millis() as u64 / 2));
        if kill_after(&mut features(&copy), delay) {
            kills += 1;
        }
        // Whatever is in the cache is whole: every .npy parses with the right width.
        for (name, bytes) in cached(&copy) {
            if name.ends_with(".npy") {
                let a = qean_io::npy::parse(&bytes)
                    .unwrap_or_else(|e| panic!("{name}: half-written: {e}"));
                assert_eq!(a.shape[1], 35, "{name}");
            }
        }
    }
    println!("features: {kills} of 6 attempts killed (uninterrupted: {full:?})");
    assert!(kills >= 1);
    run_ok(&mut features(&copy));
    let (a, b) = (cached(&data), cached(&copy));
    assert_eq!(
        a.iter().map(|x| &x.0).collect::<Vec<_>>(),
        b.iter().map(|x| &x.0).collect::<Vec<_>>()
    );
    for ((name, x), (_, y)) in a.iter().zip(&b) {
        if name.ends_with(".npy") {
            assert_eq!(x, y, "{name} differs");
        }
    }
}

/// The tiny Table 1 (every family, the VQ-VAE → GPT → genre chain, evaluated) killed at random moments
/// and run again ends with the same table, summary and records as an uninterrupted sweep.
#[test]
fn the_tiny_table1_sweep_killed_mid_way_writes_the_same_table() {
    let d = tempfile::tempdir().unwrap();
    let data = dataset(d.path());
    let cmd = |out: &Path| {
        let mut c = qean();
        c.arg("sweep")
            .arg("--config")
            .arg(configs().join("sweeps/table1-tiny.toml"))
            .arg("--data")
            .arg(&data)
            .arg("--out")
            .arg(out)
            .args(["--seeds", "0", "--eval-frames", "60", "--plain"]);
        for s in SMALL.iter().chain(&[
            "train.steps=4",
            "train.checkpoint_every=2",
            "train.val_every=2",
            "train.log_every=1",
        ]) {
            c.arg("--set").arg(s);
        }
        c
    };
    let straight = d.path().join("straight");
    let full = timed(&mut cmd(&straight));
    let out = d.path().join("killed");
    let mut rng = Rng::new("table1 sweep");
    let mut kills = 0;
    // By the sweep's progress, as above: attempt k after k/5 of its checkpointed updates.
    let total = sweep_progress(&straight);
    for k in 0..5u64 {
        let (goal, extra) = (total * k / 5, rng.below(full.as_millis() as u64 / 20));
        kills += kill_at_progress(&mut cmd(&out), &out, goal, extra) as usize;
    }
    println!("table1 sweep: {kills} of 5 attempts killed (uninterrupted: {full:?})");
    assert!(kills >= 4, "only {kills} kills landed");
    run_ok(&mut cmd(&out));
    for f in ["table1.md", "table1.json", "summary.json"] {
        let read = |dir: &Path| std::fs::read_to_string(dir.join(f)).unwrap();
        assert_eq!(read(&straight), read(&out), "{f}");
    }
    assert_eq!(sweep_hashes(&straight), sweep_hashes(&out));
}
