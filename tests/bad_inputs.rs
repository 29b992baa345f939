//! The bad-input suite: every command fed broken files, impossible settings or a hostile file
//! system. Each case must exit non-zero with exactly one `error: ...` line that names the file (or
//! setting) and the problem, print no panic text, and leave every file under the test directory as it
//! was (same names, same bytes).
//!
//! The cases share one small world (a synthetic dataset, two tiny trained runs, the bad files) built
//! once; they run in order and all failures are reported together.

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::*;
use qean_io::testdata::{npy_bytes, wav_bytes};

/// A 16-bit PCM WAV with a hand-written header, so that every field can be made wrong.
fn wav(samples: &[i16], channels: u16, rate: u32, format: u16) -> Vec<u8> {
    let data: Vec<u8> = samples.iter().flat_map(|s| s.to_le_bytes()).collect();
    wav_bytes(format, rate, channels, 16, &data, data.len() as u32)
}

/// A click track: a short 1 kHz burst every half second, `seconds` long, at 22050 Hz.
fn clicks(seconds: f64) -> Vec<i16> {
    let sr = 22050.0;
    (0..(seconds * sr) as usize)
        .map(|i| {
            let t = i as f64 / sr;
            let env = if t % 0.5 < 0.03 { 0.6 } else { 0.02 };
            (env * (2.0 * std::f64::consts::PI * 1000.0 * t).sin() * 32767.0) as i16
        })
        .collect()
}

/// Every file under `dir` with its length and a hash of its bytes.
fn snapshot(dir: &Path) -> BTreeMap<String, (u64, u64)> {
    use std::hash::{Hash, Hasher};
    let mut out = BTreeMap::new();
    for name in listing(dir) {
        let p = dir.join(&name);
        if p.is_file() {
            let bytes = std::fs::read(&p).unwrap();
            let mut h = std::collections::hash_map::DefaultHasher::new();
            bytes.hash(&mut h);
            out.insert(name, (bytes.len() as u64, h.finish()));
        } else {
            out.insert(name + "/", (0, 0));
        }
    }
    out
}

struct World {
    _tmp: tempfile::TempDir,
    root: PathBuf,
    data: PathBuf,
    run: PathBuf,
    other_run: PathBuf,
    out: PathBuf,
}

impl World {
    fn new() -> World {
        let tmp = tempfile::tempdir().unwrap();
        let root = tmp.path().to_path_buf();
        let data = root.join("ds");
        run_ok(
            qean()
                .args(["synth", "--sequences", "12", "--seconds", "8"])
                .args(["--sample-rate", "8000", "--out"])
                .arg(&data),
        );
        let run = root.join("run-fact");
        run_ok(&mut train_cmd(
            "tiny/fact.toml",
            &data,
            &run,
            &["train.steps=2", "train.checkpoint_every=2"],
        ));
        let other_run = root.join("run-qean");
        run_ok(&mut train_cmd(
            "tiny/full.toml",
            &data,
            &other_run,
            &["train.steps=2", "train.checkpoint_every=2"],
        ));
        let out = root.join("out");
        std::fs::create_dir(&out).unwrap();
        World {
            _tmp: tmp,
            root,
            data,
            run,
            other_run,
            out,
        }
    }

    fn file(&self, name: &str, bytes: impl AsRef<[u8]>) -> PathBuf {
        let p = self.root.join("inputs").join(name);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(&p, bytes).unwrap();
        p
    }
}

fn cmd(args: &[&dyn AsRefOs]) -> Command {
    let mut c = qean();
    for a in args {
        c.arg(a.os());
    }
    c
}

/// Lets a case list mix `&str` and paths.
trait AsRefOs {
    fn os(&self) -> OsString;
}
impl AsRefOs for &str {
    fn os(&self) -> OsString {
        OsString::from(self)
    }
}
impl AsRefOs for PathBuf {
    fn os(&self) -> OsString {
        self.clone().into_os_string()
    }
}

/// Runs `c` under a file-size limit of `blocks` (SIGXFSZ ignored, so a write past it fails with EFBIG
/// as on a full disk).
fn size_limited(c: &Command, blocks: u32) -> Command {
    let mut s = Command::new("sh");
    s.arg("-c")
        .arg(format!(
            "trap '' XFSZ; ulimit -f {blocks}; exec \"$0\" \"$@\""
        ))
        .arg(c.get_program())
        .args(c.get_args());
    s
}

#[test]
fn every_bad_input_fails_cleanly_and_changes_nothing() {
    let w = World::new();
    let reference = w.data.join("motions");
    let good_pkl =
        std::fs::read(shared().join("aistpp/motions/softcat477_sample_with_scaling.pkl")).unwrap();
    let motion = qean_motion::Motion::read_pkl(
        &shared().join("aistpp/motions/softcat477_sample_with_scaling.pkl"),
    )
    .unwrap();
    let n = motion.frames;
    use qean_io::pickle::{dumps_dict, ArrayRef::F64};
    let pkl = |items: &[(&str, &[usize], qean_io::pickle::ArrayRef)]| dumps_dict(items, &[]);
    let song = clicks(8.0);

    // Audio.
    let corrupt_wav = w.file("corrupt.wav", {
        let mut v = b"RIFF\x10\x00\x00\x00WAVEjunk".to_vec();
        v.extend((0..2000u32).map(|i| (i * 7919 % 251) as u8));
        v
    });
    let good_wav_bytes = wav(&song, 1, 22050, 1);
    let truncated_wav = w.file("truncated.wav", &good_wav_bytes[..good_wav_bytes.len() / 3]);
    let empty_wav = w.file("empty.wav", b"");
    let silent_wav = w.file("silent.wav", wav(&vec![0; 22050 * 6], 1, 22050, 1));
    let huge_rate = w.file("huge_rate.wav", wav(&song, 1, 2_000_000_000, 1));
    let codec = w.file("adpcm_like.wav", wav(&song, 1, 22050, 0x1234));
    let corrupt_ogg = w.file("corrupt.ogg", {
        let mut v = b"OggS".to_vec();
        v.extend((0..3000u32).map(|i| (i * 31 % 256) as u8));
        v
    });
    let not_mp3 = w.file("noise.mp3", b"ID3 this is text, not an mp3 stream");
    let short = w.file("short.wav", wav(&clicks(2.0), 1, 22050, 1));
    let good_wav = w.file("good.wav", &good_wav_bytes);
    let eight: Vec<i16> = song.iter().flat_map(|&s| [s; 8]).collect();
    let eight_wav = w.file("eight.wav", wav(&eight, 8, 22050, 1));

    // Pickles.
    let garbage_pkl = w.file("garbage.pkl", b"this is not a pickle at all");
    let truncated_pkl = w.file("truncated.pkl", &good_pkl[..good_pkl.len() / 2]);
    // Protocol 5 with an out-of-band buffer (pickle.dumps(..., buffer_callback=...)): PROTO 5,
    // EMPTY_DICT, SHORT_BINUNICODE 'smpl_poses', NEXT_BUFFER, SETITEM, STOP.
    let oob = w.file("protocol5_oob.pkl", {
        let mut v = vec![0x80, 5, b'}', 0x8c, 10];
        v.extend_from_slice(b"smpl_poses");
        v.extend_from_slice(&[0x97, b's', b'.']);
        v
    });
    let good_pair = pkl(&[
        ("smpl_poses", &[n, 72], F64(&motion.poses)),
        ("smpl_trans", &[n, 3], F64(&motion.trans)),
    ]);
    // The dtype string 'f8' of the first array changed to the integer type 'i8'.
    let int_dtype = w.file("int_dtype.pkl", {
        let mut bytes = good_pair.clone();
        let at = bytes.windows(2).position(|w| w == b"f8").unwrap();
        bytes[at] = b'i';
        bytes
    });
    // The shape (127, 72) rewritten as (1e9, 72) over 127 frames of data: refused before any allocation.
    assert_eq!(n, 127);
    let huge_claim = w.file("huge_claim.pkl", {
        let at = good_pair
            .windows(4)
            .position(|w| w == [b'K', 127, b'K', 72])
            .unwrap();
        let mut bytes = good_pair[..at].to_vec();
        bytes.extend_from_slice(&[b'J', 0x00, 0xca, 0x9a, 0x3b]);
        bytes.extend_from_slice(&good_pair[at + 2..]);
        bytes
    });
    let missing_key = w.file(
        "missing_key.pkl",
        pkl(&[("smpl_poses", &[n, 72], F64(&motion.poses))]),
    );
    let mut nan_poses = motion.poses.clone();
    nan_poses[100] = f64::NAN;
    let nan_pkl = w.file(
        "nan.pkl",
        pkl(&[
            ("smpl_poses", &[n, 72], F64(&nan_poses)),
            ("smpl_trans", &[n, 3], F64(&motion.trans)),
        ]),
    );
    let inf_trans: Vec<f64> = motion.trans.iter().map(|_| f64::INFINITY).collect();
    let inf_pkl = w.file(
        "inf.pkl",
        pkl(&[
            ("smpl_poses", &[n, 72], F64(&motion.poses)),
            ("smpl_trans", &[n, 3], F64(&inf_trans)),
        ]),
    );
    let wrong_shape = w.file(
        "wrong_shape.pkl",
        pkl(&[
            ("smpl_poses", &[n * 2, 36], F64(&motion.poses)),
            ("smpl_trans", &[n, 3], F64(&motion.trans)),
        ]),
    );
    // .npy.
    let rank1 = w.file("rank1.npy", npy_bytes("<f4", "(10,)", &[0u8; 40]));
    let huge_npy = w.file(
        "huge.npy",
        npy_bytes("<f4", "(1000000000000, 24, 3)", &[0u8; 100]),
    );
    let complex_npy = w.file("complex.npy", npy_bytes("<c8", "(10, 24, 3)", &[0u8; 5760]));
    let gen_dir = w.root.join("inputs/generated");
    std::fs::create_dir_all(&gen_dir).unwrap();
    std::fs::write(
        gen_dir.join("dance.npy"),
        npy_bytes("<f4", "(7, 5)", &[0u8; 140]),
    )
    .unwrap();

    // TOML.
    let tiny_fact = configs().join("tiny/fact.toml").display().to_string();
    let toml = |name: &str, body: &str| {
        w.file(
            name,
            format!(
                "extends = \"{tiny_fact}\"\n[data]\ndir = \"{}\"\n{body}",
                w.data.display()
            ),
        )
    };
    let unknown_key = toml("unknown_key.toml", "[model]\nhidden_sise = 64\n");
    let wrong_type = toml("wrong_type.toml", "[model]\nhidden = \"big\"\n");
    let negative = toml("negative_steps.toml", "[train]\nsteps = -5\n");
    let zero_batch = toml("zero_batch.toml", "[train]\nbatch_size = 0\n");
    let boundaries = toml(
        "boundaries.toml",
        "[schedule]\nboundaries = [100, 50]\nvalues = [1e-4, 1e-5]\n",
    );
    let syntax = w.file("syntax.toml", "[model\nhidden = 3\n");
    let bad_extends = w.file("bad_extends.toml", "extends = \"no_such_base.toml\"\n");
    let sweep_unknown = w.file(
        "sweep_unknown.toml",
        format!("base = \"{tiny_fact}\"\nrunz = []\n"),
    );

    // Output places.
    let missing_out = w.root.join("no_such_dir");
    let nonempty = w.root.join("inputs");
    let read_only = if running_as_root() {
        // root ignores permission bits; sysfs refuses new files even to root.
        PathBuf::from("/sys")
    } else {
        let d = w.root.join("read_only");
        std::fs::create_dir(&d).unwrap();
        let mut perm = std::fs::metadata(&d).unwrap().permissions();
        std::os::unix::fs::PermissionsExt::set_mode(&mut perm, 0o555);
        std::fs::set_permissions(&d, perm).unwrap();
        d
    };

    let run = w.run.clone();
    // A checkpoint of the FACT run whose weights were replaced by the QEAN run's.
    let mixed_ck = w.root.join("inputs/mixed-checkpoint");
    std::fs::create_dir_all(&mixed_ck).unwrap();
    for f in ["config.toml", "optimizer.bpk", "state.json"] {
        std::fs::copy(run.join("checkpoints/step-2").join(f), mixed_ck.join(f)).unwrap();
    }
    std::fs::copy(
        w.other_run.join("checkpoints/step-2/model.bpk"),
        mixed_ck.join("model.bpk"),
    )
    .unwrap();
    let data = w.data.clone();
    let out = w.out.clone();
    let feat = |f: &PathBuf| cmd(&[&"features", f, &"--out", &out]);
    let joints = |f: &PathBuf| cmd(&[&"joints", f, &"--out", &out.join("j.npy")]);
    let inspect = |f: &PathBuf| cmd(&[&"inspect", f]);
    let render = |f: &PathBuf| cmd(&[&"render", f, &"--out", &out.join("r.png")]);
    let train_cfg = |f: &PathBuf| {
        cmd(&[
            &"train",
            &"--config",
            f,
            &"--run-dir",
            &w.root.join("new-run"),
        ])
    };
    // Tiny FACT on the good dataset into a new run, with the case's own arguments after.
    let train_fact = |extra: &[&dyn AsRefOs]| {
        let mut c = cmd(&[
            &"train",
            &"--config",
            &configs().join("tiny/fact.toml"),
            &"--data",
            &data,
            &"--run-dir",
            &w.root.join("new-run"),
        ]);
        for a in extra {
            c.arg(a.os());
        }
        c
    };
    let sample = |music: &PathBuf| {
        cmd(&[
            &"sample",
            &"--run",
            &run,
            &"--music",
            music,
            &"--out",
            &out,
            &"--frames",
            &"30",
        ])
    };

    let mut cases: Vec<(&str, Command, String)> = vec![
        // Audio.
        (
            "corrupt wav",
            feat(&corrupt_wav),
            "corrupt.wav: cannot read the container".into(),
        ),
        (
            "truncated wav",
            feat(&truncated_wav),
            "truncated.wav: reading the stream: the file is truncated".into(),
        ),
        (
            "empty audio",
            feat(&empty_wav),
            "empty.wav: empty file".into(),
        ),
        (
            "silent audio",
            feat(&silent_wav),
            "silent.wav: the audio is silent".into(),
        ),
        (
            "huge sample rate",
            feat(&huge_rate),
            "huge_rate.wav: implausible sample rate 2000000000 Hz".into(),
        ),
        (
            "unsupported codec",
            feat(&codec),
            "adpcm_like.wav: unsupported".into(),
        ),
        ("corrupt ogg", feat(&corrupt_ogg), "corrupt.ogg".into()),
        ("text named .mp3", feat(&not_mp3), "noise.mp3".into()),
        (
            "good file then a corrupt one: nothing written",
            cmd(&[&"features", &good_wav, &corrupt_wav, &"--out", &out]),
            "corrupt.wav".into(),
        ),
        ("song shorter than 4 s", sample(&short), "short.wav".into()),
        (
            "music file missing",
            sample(&w.root.join("gone.wav")),
            "gone.wav".into(),
        ),
        (
            "start BPM of zero",
            cmd(&[&"features", &good_wav, &"--out", &out, &"--start-bpm", &"0"]),
            "--start-bpm".into(),
        ),
        // Pickles.
        (
            "garbage pickle",
            joints(&garbage_pkl),
            "garbage.pkl: not a readable pickle".into(),
        ),
        (
            "truncated pickle",
            joints(&truncated_pkl),
            "truncated.pkl".into(),
        ),
        (
            "protocol-5 out-of-band pickle",
            inspect(&oob),
            "protocol5_oob.pkl: not a readable pickle: out-of-band buffers".into(),
        ),
        (
            "integer dtype",
            joints(&int_dtype),
            "int_dtype.pkl: 'smpl_poses' has dtype i8".into(),
        ),
        (
            "missing key",
            joints(&missing_key),
            "missing_key.pkl: missing key 'smpl_trans'".into(),
        ),
        ("NaN pose", joints(&nan_pkl), "nan.pkl".into()),
        (
            "Inf translation",
            render(&inf_pkl),
            "inf.pkl: smpl_trans has a non-finite value".into(),
        ),
        (
            "wrong pose shape",
            joints(&wrong_shape),
            "wrong_shape.pkl".into(),
        ),
        (
            "shape claims 1e9 frames",
            inspect(&huge_claim),
            "huge_claim.pkl".into(),
        ),
        (
            "pickle file missing",
            joints(&w.root.join("absent.pkl")),
            "absent.pkl: no such file".into(),
        ),
        // .npy.
        (
            "npy of rank 1",
            render(&rank1),
            "rank1.npy: array of shape [10] is not a motion".into(),
        ),
        (
            "npy header claims 288 TB",
            render(&huge_npy),
            "huge.npy: truncated".into(),
        ),
        (
            "npy of complex dtype",
            render(&complex_npy),
            "complex.npy".into(),
        ),
        (
            "generated npy of the wrong shape",
            cmd(&[
                &"eval",
                &"--generated",
                &gen_dir,
                &"--reference",
                &reference,
            ]),
            "dance.npy".into(),
        ),
        // TOML.
        (
            "unknown config key",
            train_cfg(&unknown_key),
            "unknown_key.toml:5: unknown field `hidden_sise`".into(),
        ),
        (
            "wrong value type",
            train_cfg(&wrong_type),
            "wrong_type.toml:5".into(),
        ),
        (
            "negative steps",
            train_cfg(&negative),
            "negative_steps.toml:5".into(),
        ),
        (
            "zero batch",
            train_cfg(&zero_batch),
            "zero_batch.toml: train.batch_size must be at least 1".into(),
        ),
        (
            "LR boundaries not increasing",
            train_cfg(&boundaries),
            "boundaries.toml: schedule.boundaries must be strictly increasing".into(),
        ),
        (
            "TOML syntax error",
            train_cfg(&syntax),
            "syntax.toml:1".into(),
        ),
        (
            "extends a missing file",
            train_cfg(&bad_extends),
            "no_such_base.toml".into(),
        ),
        (
            "unknown --set key",
            train_fact(&[&"--set", &"train.stepz=3"]),
            "unknown field `stepz`".into(),
        ),
        (
            "sweep with an unknown key",
            cmd(&[
                &"sweep",
                &"--config",
                &sweep_unknown,
                &"--out",
                &w.root.join("new-sweep"),
            ]),
            "sweep_unknown.toml".into(),
        ),
        // Runs and checkpoints.
        (
            "checkpoint holding another model's weights",
            cmd(&[
                &"sample",
                &"--run",
                &run,
                &"--checkpoint",
                &mixed_ck,
                &"--music",
                &good_wav,
                &"--out",
                &out,
            ]),
            "mixed-checkpoint".into(),
        ),
        (
            "inspect of that checkpoint",
            inspect(&mixed_ck),
            "mixed-checkpoint".into(),
        ),
        (
            "resume with another model",
            cmd(&[&"train", &"--resume", &run, &"--set", &"model.hidden=32"]),
            "different model".into(),
        ),
        (
            "resume of a directory that is not a run",
            cmd(&[&"train", &"--resume", &out]),
            "out".into(),
        ),
        (
            "missing dataset",
            cmd(&[
                &"train",
                &"--config",
                &configs().join("tiny/fact.toml"),
                &"--data",
                &w.root.join("nowhere"),
                &"--run-dir",
                &w.root.join("new-run"),
            ]),
            "nowhere".into(),
        ),
        (
            "checkpoint eval of a missing run",
            cmd(&[&"eval", &"--run", &w.root.join("no-run"), &"--data", &data]),
            "no-run".into(),
        ),
        // Output places.
        (
            "missing output directory",
            cmd(&[&"features", &good_wav, &"--out", &missing_out]),
            "no_such_dir: output directory does not exist".into(),
        ),
        (
            "read-only output directory",
            cmd(&[
                &"joints",
                &shared().join("aistpp/motions/softcat477_sample_with_scaling.pkl"),
                &"--out",
                &read_only.join("j.npy"),
            ]),
            "j.npy".into(),
        ),
        (
            "full disk (file-size limit)",
            size_limited(&feat(&good_wav), 8),
            "good.npy: File too large".into(),
        ),
        (
            "synth into a non-empty directory",
            cmd(&[&"synth", &"--out", &nonempty, &"--sequences", &"6"]),
            "inputs".into(),
        ),
    ];
    // A backend this build lacks (the test command builds with wgpu, not with ndarray).
    if !cfg!(feature = "ndarray") {
        cases.push((
            "a backend not in this build",
            train_fact(&[&"--backend", &"ndarray"]),
            "--features ndarray".into(),
        ));
    }

    let mut failures = Vec::new();
    let total = cases.len();
    for (name, mut c, needle) in cases {
        let before = snapshot(&w.root);
        let out = c.stdin(Stdio::null()).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
        let mut problems = Vec::new();
        if out.status.success() {
            problems.push("exit code 0".to_string());
        }
        if stderr.contains("panicked") || stderr.contains("RUST_BACKTRACE") {
            problems.push("panic text".into());
        }
        if lines.len() != 1 || !lines[0].starts_with("error: ") {
            problems.push(format!("not one `error:` line ({} lines)", lines.len()));
        }
        if !stderr.contains(&needle) {
            problems.push(format!("does not mention {needle:?}"));
        }
        let after = snapshot(&w.root);
        if before != after {
            let changed: Vec<&String> = after
                .keys()
                .chain(before.keys())
                .filter(|k| before.get(*k) != after.get(*k))
                .collect();
            problems.push(format!("files changed: {changed:?}"));
        }
        println!("{name:<48} {}", lines.last().unwrap_or(&""));
        if !problems.is_empty() {
            failures.push(format!(
                "{name}: {} — stderr: {stderr}",
                problems.join("; ")
            ));
        }
    }
    assert!(total >= 30, "only {total} cases");
    assert!(
        failures.is_empty(),
        "{} of {total} cases failed:\n{}",
        failures.len(),
        failures.join("\n")
    );

    // Accepted rather than refused (librosa mixes any channel count to mono): 8 channels give the same
    // features as the mono file.
    let eight_out = w.root.join("eight_out");
    std::fs::create_dir(&eight_out).unwrap();
    run_ok(cmd(&[&"features", &eight_wav, &good_wav, &"--out", &eight_out]).stdout(Stdio::null()));
    assert_eq!(
        std::fs::read(eight_out.join("eight.npy")).unwrap(),
        std::fs::read(eight_out.join("good.npy")).unwrap()
    );
}

/// Two processes training into one run directory: the second refuses (the lock), the first goes on.
#[test]
fn a_second_trainer_on_the_same_run_directory_refuses() {
    let tmp = tempfile::tempdir().unwrap();
    let data = tmp.path().join("ds");
    run_ok(
        qean()
            .args(["synth", "--sequences", "8", "--seconds", "6"])
            .args(["--sample-rate", "8000", "--out"])
            .arg(&data),
    );
    let run = tmp.path().join("run");
    let mut first = train_cmd("tiny/fact.toml", &data, &run, &["train.steps=100000"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !run.join("lock").exists() {
        assert!(start.elapsed() < Duration::from_secs(120), "no lock file");
        assert!(first.try_wait().unwrap().is_none(), "first trainer ended");
        std::thread::sleep(Duration::from_millis(20));
    }
    let before = listing(&data);
    let err = assert_clean_failure(
        &mut train_cmd("tiny/fact.toml", &data, &run, &["train.steps=3"]),
        "lock",
    );
    assert_eq!(before, listing(&data));
    assert!(err.contains(&run.display().to_string()), "{err}");
    println!("{}", err.trim());
    assert!(
        first.try_wait().unwrap().is_none(),
        "the first trainer died"
    );
    let _ = first.kill();
    first.wait().unwrap();
}

fn running_as_root() -> bool {
    // Without a libc dependency: /proc/self/status has "Uid: real effective ...".
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("Uid:"))
                .and_then(|l| l.split_whitespace().nth(2).map(|u| u == "0"))
        })
        .unwrap_or(false)
}
