//! The fuzz targets' readers, in the normal test suite: every input that ever crashed a target
//! (fuzz/regressions/<target>/) and a few thousand deterministic mutations of real seed files must give
//! a value or an error — never a panic, and never an error that forgets to name the file.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

mod common;
use common::shared;

fn regressions(target: &str) -> Vec<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("fuzz/regressions")
        .join(target);
    let mut v: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| !p.file_name().unwrap().to_string_lossy().starts_with('.'))
        .collect();
    v.sort();
    v
}

/// Small deterministic mutations: byte flips, truncations, insertions, duplicated spans and
/// "interesting" integers written over length fields.
struct Mutator(u64);

impl Mutator {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }

    fn mutate(&mut self, seed: &[u8]) -> Vec<u8> {
        let mut v = seed.to_vec();
        for _ in 0..1 + self.below(4) {
            if v.is_empty() {
                v.push(self.next() as u8);
                continue;
            }
            let at = self.below(v.len());
            match self.below(6) {
                0 => v[at] ^= 1 << self.below(8),
                1 => v.truncate(at),
                2 => v.insert(at, self.next() as u8),
                3 => {
                    let end = (at + 1 + self.below(64)).min(v.len());
                    let span = v[at..end].to_vec();
                    let to = self.below(v.len());
                    v.splice(to..to, span);
                }
                4 => {
                    let word: u32 =
                        [0, 1, 0x7f, 0xff, 0xffff, 0x7fff_ffff, 0xffff_ffff][self.below(7)];
                    for (k, b) in word.to_le_bytes().iter().enumerate() {
                        if at + k < v.len() {
                            v[at + k] = *b;
                        }
                    }
                }
                _ => {
                    let chars = b"0123456789()[]{}=\"',.:-\n";
                    v[at] = chars[self.below(chars.len())];
                }
            }
        }
        v
    }
}

fn no_panic<T>(what: &str, input: &[u8], f: impl FnOnce() -> T) -> T {
    match catch_unwind(AssertUnwindSafe(f)) {
        Ok(v) => v,
        Err(_) => {
            let dump = std::env::temp_dir().join(format!("qean-fuzz-panic-{what}"));
            std::fs::write(&dump, input).unwrap();
            panic!("{what} panicked on an input saved at {}", dump.display());
        }
    }
}

/// Runs `check` on every regression input of `target` and on `count` mutations of each seed.
fn exercise(target: &str, seeds: &[Vec<u8>], count: usize, mut check: impl FnMut(&[u8])) {
    for p in regressions(target) {
        let bytes = std::fs::read(&p).unwrap();
        check(&bytes);
    }
    let mut m = Mutator(0x9E37_79B9_7F4A_7C15);
    for seed in seeds {
        check(seed);
        for _ in 0..count {
            let input = m.mutate(seed);
            check(&input);
        }
    }
}

#[test]
fn pickle_reader_survives_mutations_and_regressions() {
    let seeds = vec![
        std::fs::read(shared().join("aistpp/motions/softcat477_sample_with_scaling.pkl")).unwrap(),
        std::fs::read(shared().join("aistpp/motions/softcat477_SMPL-to-FBX_sample.pkl")).unwrap(),
    ];
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.pkl");
    exercise("pickle", &seeds, 3000, |input| {
        no_panic("pickle", input, || {
            let _ = qean_io::pickle::loads(input);
            std::fs::write(&path, input).unwrap();
            if let Err(e) = qean_motion::Motion::read_pkl(&path) {
                assert!(e.to_string().contains("m.pkl"), "{e}");
            }
        })
    });
}

#[test]
fn npy_reader_survives_mutations_and_regressions() {
    let joints: Vec<[f64; 3]> = (0..24 * 10).map(|i| [i as f64, 0.5, -1.0]).collect();
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("j.npy");
    qean_motion::joints_file::write_joints(&p, &joints).unwrap_or_else(|e| panic!("{e}"));
    let seeds = vec![std::fs::read(&p).unwrap()];
    exercise("npy", &seeds, 3000, |input| {
        no_panic("npy", input, || {
            let _ = qean_io::npy::parse(input);
        })
    });
}

#[test]
fn bvh_reader_survives_mutations_and_regressions() {
    let motion = qean_motion::Motion::read_pkl(
        &shared().join("aistpp/motions/softcat477_sample_with_scaling.pkl"),
    )
    .unwrap();
    let text = qean_motion::bvh::to_bvh(&motion, qean_motion::FkRoot::Smpl);
    // Keep the seed short: the hierarchy and a few frames.
    let short: String = text.lines().take(140).collect::<Vec<_>>().join("\n");
    exercise("bvh", &[short.into_bytes()], 3000, |input| {
        no_panic("bvh", input, || {
            if let Ok(t) = std::str::from_utf8(input) {
                if let Ok(m) = qean_motion::bvh::parse(t, 0.01) {
                    let _ = m.smpl_positions();
                }
            }
        })
    });
}

#[test]
fn config_loader_survives_mutations_and_regressions() {
    let configs = Path::new(env!("CARGO_MANIFEST_DIR")).join("configs");
    let seeds = vec![
        std::fs::read(configs.join("fact.toml")).unwrap(),
        std::fs::read(configs.join("sweeps/tiny-ablation.toml")).unwrap(),
    ];
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.toml");
    exercise("config", &seeds, 2000, |input| {
        no_panic("config", input, || {
            std::fs::write(&path, input).unwrap();
            if let Err(e) = qean_config::RunConfig::load(&path, &[]) {
                assert!(e.to_string().contains("c.toml"), "{e}");
            }
            let _ = qean_train::sweep::plan(&path, Some(&dir.path().join("out")), &[]);
        })
    });
}

#[test]
fn audio_decoder_survives_mutations_and_regressions() {
    let ogg = std::fs::read(shared().join("music/sorohanro_-_solo-trumpet-06.ogg")).unwrap();
    let wav: Vec<u8> = std::fs::read(shared().join("music/sorohanro_-_solo-trumpet-06_90bpm.wav"))
        .unwrap()[..8192]
        .to_vec();
    let mut seeds = vec![
        [&[0u8][..], &wav].concat(),
        [&[1u8][..], &ogg[..4096]].concat(),
    ];
    seeds.push([&[3u8][..], b"fLaC\0\0\0\x22"].concat());
    let dir = tempfile::tempdir().unwrap();
    exercise("audio", &seeds, 1000, |input| {
        let Some((&pick, body)) = input.split_first() else {
            return;
        };
        let ext = ["wav", "ogg", "mp3", "flac"][pick as usize % 4];
        let path = dir.path().join(format!("a.{ext}"));
        std::fs::write(&path, body).unwrap();
        no_panic("audio", input, || {
            if let Err(e) = qean_audio::decode::decode_file(&path, 30.0) {
                assert!(e.to_string().contains(&format!("a.{ext}")), "{e}");
            }
        });
    });
}
