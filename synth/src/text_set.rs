//! A synthetic text–motion set in the HumanML3D layout (SPEC §13.1; issue 40 item 5): procedural dances of
//! each genre (with the genre's posture, so classes look different), written as HumanML3D writes motions
//! (22 joints at 20 fps), with two captions each — the whole dance and its second half — whose embeddings
//! are the genre's pseudo-embedding (`qean_aistpp::text_set::genre_embedding`). Tied to motion classes, not
//! language: it lets the whole text path (reader, T-Base training, fused sampling) run with no text encoder
//! and no external data.

use std::path::Path;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::dance::{self, BeatGrid, DanceStyle};
use crate::music::CHORDS;
use qean_aistpp::names::GENRES;
use qean_aistpp::text_set::genre_embedding;
use qean_io::error::Result;
use qean_io::fsutil::atomic_write;
use qean_motion::fk::FkRoot;
use qean_motion::humanml::{to_humanml, HUMANML_JOINTS};
use qean_motion::motion::FPS;

/// What to write.
#[derive(Debug, Clone)]
pub struct TextSynthOptions {
    /// Motions; one in six goes to `test.txt`, the rest to `train.txt`.
    pub motions: usize,
    /// Length of each motion in seconds (HumanML3D's are 2–10 s).
    pub seconds: f64,
    pub seed: u64,
    /// Frame rate of `new_joints` (HumanML3D: 20; 60 must be a multiple of it).
    pub fps: f64,
    /// Embedding width (CLIP ViT-B/32: 512).
    pub dim: usize,
}

/// The caption of a genre's dance.
fn caption(genre: &str) -> &'static str {
    match genre {
        "BR" => "a person breaks, dropping low and kicking",
        "PO" => "a person pops, hitting each beat with stiff arms",
        "LO" => "a person locks, pointing and freezing on the beat",
        "MH" => "a person dances middle hip-hop, bouncing at the knees",
        "LH" => "a person dances LA-style hip-hop with big arm swings",
        "HO" => "a person dances house, stepping quickly on the spot",
        "WA" => "a person waacks, whipping the arms over the head",
        "KR" => "a person krumps in a deep stance, stomping",
        "JS" => "a person dances street jazz with long lines",
        _ => "a person dances ballet jazz, turning gracefully",
    }
}

/// Write the set into `out` (which must not exist or be empty; written atomically). Returns the number of
/// motions.
pub fn generate_text_set(out: &Path, opts: &TextSynthOptions) -> Result<usize> {
    qean_io::fsutil::atomic_dir(out, |dir| {
        for sub in ["new_joints", "texts", "text_emb"] {
            std::fs::create_dir(dir.join(sub))
                .map_err(|e| qean_io::error::Error::io(dir.join(sub), e))?;
        }
        let (mut train, mut test) = (Vec::new(), Vec::new());
        for i in 0..opts.motions {
            let id = format!("{i:06}");
            write_motion(dir, &id, i, opts)?;
            if i % 6 == 5 { &mut test } else { &mut train }.push(id);
        }
        atomic_write(&dir.join("train.txt"), train.join("\n").as_bytes())?;
        atomic_write(&dir.join("test.txt"), test.join("\n").as_bytes())?;
        Ok(opts.motions)
    })
}

/// Motion `i`: genre i mod 10 at a random tempo, its joints, captions and embeddings.
fn write_motion(dir: &Path, id: &str, i: usize, opts: &TextSynthOptions) -> Result<()> {
    let genre = i % GENRES.len();
    let mut rng = ChaCha8Rng::seed_from_u64(opts.seed ^ (0x7465_7874_0000 + i as u64));
    let seconds = opts.seconds * rng.random_range(0.7..=1.0);
    let period = 60.0 / rng.random_range(90.0..130.0);
    let beats = (seconds / period).ceil() as usize + 2;
    let grid = BeatGrid {
        beat_times: (0..beats).map(|b| 0.25 + b as f64 * period).collect(),
        phrase_chords: (0..4).map(|_| rng.random_range(0..CHORDS.len())).collect(),
    };
    let style = DanceStyle {
        genre: GENRES[genre].to_string(),
        choreo: rng.random_range(0..6),
        energy: rng.random_range(0.8..1.2),
        seed: rng.random(),
        scaling: 1.0,
        posture: true,
    };
    let frames = (seconds * FPS).round() as usize;
    let joints = to_humanml(
        &dance::generate(&grid, &style, frames).joints(FkRoot::Smpl),
        opts.fps,
    );
    let n = joints.len() / HUMANML_JOINTS;
    let flat: Vec<f32> = joints.iter().flat_map(|p| p.map(|v| v as f32)).collect();
    qean_io::npy::write_f32(
        &dir.join("new_joints").join(format!("{id}.npy")),
        &[n, HUMANML_JOINTS, 3],
        &flat,
    )?;
    let text = caption(GENRES[genre]);
    let half = (n / 2) as f64 / opts.fps;
    let end = n as f64 / opts.fps;
    let second = format!("the second half of a {} dance", GENRES[genre]);
    let lines = format!(
        "{text}#{}#0.0#0.0\n{second}#{}#{half:.2}#{end:.2}\n",
        tags(text),
        tags(&second),
    );
    atomic_write(
        &dir.join("texts").join(format!("{id}.txt")),
        lines.as_bytes(),
    )?;
    let row = genre_embedding(genre, opts.dim);
    let rows: Vec<f32> = row.iter().chain(&row).copied().collect();
    qean_io::npy::write_f32(
        &dir.join("text_emb").join(format!("{id}.npy")),
        &[2, opts.dim],
        &rows,
    )
}

/// HumanML3D's token field (`word/POS` pairs); we write every word as `word/OTHER` (nothing reads it).
fn tags(text: &str) -> String {
    text.split_whitespace()
        .map(|w| format!("{}/OTHER", w.trim_matches(',')))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;
    use qean_aistpp::text_set::{TextSet, TextSetOptions};

    #[test]
    fn the_set_reads_back() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("text");
        let opts = TextSynthOptions {
            motions: 12,
            seconds: 4.0,
            seed: 3,
            fps: 20.0,
            dim: 16,
        };
        assert_eq!(generate_text_set(&out, &opts).unwrap(), 12);
        let train = TextSet::open(&out, "train").unwrap();
        let test = TextSet::open(&out, "test").unwrap();
        assert_eq!((train.ids.len(), test.ids.len()), (10, 2));
        let read = TextSetOptions {
            fps: 20.0,
            dim: 16,
            l2_normalise: false,
            rate: 8,
        };
        // Motion 7 is krump (genre 7 of GENRES).
        let clips = train.clips("000007", &read).unwrap();
        assert_eq!(clips.len(), 2);
        assert!(clips[0].caption.contains("krump"), "{}", clips[0].caption);
        assert_eq!(clips[0].embedding, genre_embedding(7, 16));
        // The second caption covers about the second half.
        let (a, b) = (clips[0].joints.len(), clips[1].joints.len());
        assert!(b * 2 <= a + 16 * 24 && b * 2 + 16 * 24 >= a, "{a} {b}");
        // The same seed writes the same set.
        let again = dir.path().join("again");
        generate_text_set(&again, &opts).unwrap();
        for f in [
            "new_joints/000003.npy",
            "texts/000003.txt",
            "text_emb/000003.npy",
        ] {
            assert_eq!(
                std::fs::read(out.join(f)).unwrap(),
                std::fs::read(again.join(f)).unwrap()
            );
        }
    }
}
