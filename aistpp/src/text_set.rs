//! A user's text–motion set in the HumanML3D layout (SPEC §13.1 "Text–motion data"), read for the T-Base's
//! text steps:
//!
//! - `<root>/<split>.txt`: one motion id per line;
//! - `<root>/new_joints/<id>.npy`: (N, 22 or 24, 3) joint positions, y up, metres, SMPL joint order;
//! - `<root>/texts/<id>.txt`: lines `caption#tokens#from#to` (from/to in seconds; `0#0` = the whole motion);
//! - `<root>/text_emb/<id>.npy`: (lines, D) text embeddings, row r for line r (e.g. CLIP ViT-B/32
//!   `encode_text`, which the user computes: no text encoder ships with qean).
//!
//! Each (motion, caption) pair is one [`TextClip`]: its embedding and its joints as ours (24 joints, 60 fps;
//! `qean_motion::humanml`), cut to the caption's slice.

use std::path::{Path, PathBuf};

use qean_io::error::{Error, Result};
use qean_motion::humanml::{to_ours, HUMANML_JOINTS};
use qean_motion::motion::FPS;
use qean_motion::skeleton::NUM_JOINTS;
use rand::{Rng, SeedableRng};

/// How a set is read.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TextSetOptions {
    /// Frame rate of `new_joints` (HumanML3D: 20).
    pub fps: f64,
    /// Embedding width D (CLIP ViT-B/32: 512).
    pub dim: usize,
    /// Scale every embedding to unit length (SPEC option `text.l2_normalise`; off: T2M-GPT feeds CLIP raw).
    pub l2_normalise: bool,
    /// Frames per token of the tokenizer: a caption's slice [from, to) seconds covers tokens
    /// [int(from·60/rate), int(to·60/rate)) (T2M-GPT's int(tag·fps/unit_length)).
    pub rate: usize,
}

/// One caption of one motion.
#[derive(Debug, Clone, PartialEq)]
pub struct TextClip {
    pub id: String,
    /// Line of `texts/<id>.txt` (0-based) = row of `text_emb/<id>.npy`.
    pub line: usize,
    pub caption: String,
    pub embedding: Vec<f32>,
    /// Frames × 24 joint positions at 60 fps, a whole number of tokens long.
    pub joints: Vec<[f64; 3]>,
}

/// The motion ids of one split of a set.
#[derive(Debug, Clone)]
pub struct TextSet {
    pub root: PathBuf,
    pub ids: Vec<String>,
}

impl TextSet {
    /// The ids listed in `<root>/<split>.txt`; the three folders must exist.
    pub fn open(root: &Path, split: &str) -> Result<TextSet> {
        for sub in ["new_joints", "texts", "text_emb"] {
            if !root.join(sub).is_dir() {
                return Err(Error::at(
                    root,
                    format!("not a text–motion set in the HumanML3D layout: no {sub}/ folder (SPEC §13.1: new_joints/, texts/, text_emb/, {split}.txt)"),
                ));
            }
        }
        let list = root.join(format!("{split}.txt"));
        let text = std::fs::read_to_string(&list).map_err(|e| Error::io(&list, e))?;
        let ids: Vec<String> = text
            .lines()
            .map(str::trim)
            .filter(|l| !l.is_empty())
            .map(String::from)
            .collect();
        if ids.is_empty() {
            return Err(Error::at(&list, "lists no motion ids"));
        }
        Ok(TextSet {
            root: root.to_path_buf(),
            ids,
        })
    }

    /// Every caption of motion `id` with its embedding and its slice of the motion. Captions whose slice
    /// holds no whole token are left out. An id whose files are missing is an error naming the file.
    pub fn clips(&self, id: &str, opts: &TextSetOptions) -> Result<Vec<TextClip>> {
        let joints = self.joints(id, opts.fps)?;
        let text_path = self.root.join("texts").join(format!("{id}.txt"));
        let text = std::fs::read_to_string(&text_path).map_err(|e| Error::io(&text_path, e))?;
        let lines: Vec<&str> = text.lines().filter(|l| !l.trim().is_empty()).collect();
        let embeddings = self.embeddings(id, lines.len(), opts)?;
        let frames = joints.len() / NUM_JOINTS;
        let tokens = frames / opts.rate;
        let mut out = Vec::new();
        for (line, (row, embedding)) in lines.iter().zip(embeddings).enumerate() {
            let (caption, from, to) = parse_line(row)
                .map_err(|m| Error::at(&text_path, format!("line {}: {m}", line + 1)))?;
            let token = |s: f64| ((s * FPS / opts.rate as f64) as usize).min(tokens);
            let (a, b) = if from == 0.0 && to == 0.0 {
                (0, tokens)
            } else {
                (token(from), token(to))
            };
            if b <= a {
                continue;
            }
            out.push(TextClip {
                id: id.to_string(),
                line,
                caption,
                embedding,
                joints: joints[a * opts.rate * NUM_JOINTS..b * opts.rate * NUM_JOINTS].to_vec(),
            });
        }
        Ok(out)
    }

    /// `new_joints/<id>.npy` (at `fps`) as 24 joints at 60 fps.
    pub fn joints(&self, id: &str, fps: f64) -> Result<Vec<[f64; 3]>> {
        let path = self.root.join("new_joints").join(format!("{id}.npy"));
        let a = qean_io::npy::read(&path)?;
        let j = match a.shape.as_slice() {
            [n, j, 3] if *n > 0 && (*j == HUMANML_JOINTS || *j == NUM_JOINTS) => *j,
            other => {
                return Err(Error::at(
                    &path,
                    format!("joints of shape {other:?}; expected (frames, 22 or 24, 3)"),
                ))
            }
        };
        if let Some(i) = a.data.iter().position(|v| !v.is_finite()) {
            return Err(Error::at(
                &path,
                format!("joint positions are not finite at frame {}", i / (3 * j)),
            ));
        }
        let frames: Vec<[f64; 3]> = a.data.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        Ok(to_ours(&frames, j, fps))
    }

    /// `text_emb/<id>.npy`: one row of `opts.dim` values per caption line ((D,) for a single line).
    fn embeddings(&self, id: &str, lines: usize, opts: &TextSetOptions) -> Result<Vec<Vec<f32>>> {
        let path = self.root.join("text_emb").join(format!("{id}.npy"));
        let a = qean_io::npy::read(&path)?;
        let rows = match a.shape.as_slice() {
            [d] if *d == opts.dim => 1,
            [r, d] if *d == opts.dim => *r,
            other => {
                return Err(Error::at(
                    &path,
                    format!(
                        "embeddings of shape {other:?}; expected (lines, {}) (gpt.text_dim)",
                        opts.dim
                    ),
                ))
            }
        };
        if rows != lines {
            return Err(Error::at(
                &path,
                format!("{rows} embedding rows for the {lines} caption lines of texts/{id}.txt"),
            ));
        }
        if a.data.iter().any(|v| !v.is_finite()) {
            return Err(Error::at(&path, "embeddings are not finite"));
        }
        Ok(a.data
            .chunks_exact(opts.dim)
            .map(|r| {
                let v: Vec<f32> = r.iter().map(|&x| x as f32).collect();
                if opts.l2_normalise {
                    l2_normalised(&v)
                } else {
                    v
                }
            })
            .collect())
    }
}

/// `caption#tokens#from#to` → (caption, from, to); NaN times read as 0 (T2M-GPT).
fn parse_line(line: &str) -> std::result::Result<(String, f64, f64), String> {
    let parts: Vec<&str> = line.trim().split('#').collect();
    let [caption, _tokens, from, to] = parts.as_slice() else {
        return Err(format!(
            "{:?} is not caption#tokens#from#to ({} fields)",
            line.trim(),
            parts.len()
        ));
    };
    let time = |s: &str| -> std::result::Result<f64, String> {
        let v: f64 = s
            .trim()
            .parse()
            .map_err(|_| format!("time {s:?} is not a number"))?;
        if v.is_nan() {
            Ok(0.0)
        } else if v < 0.0 || !v.is_finite() {
            Err(format!("time {s:?} is not a time in seconds"))
        } else {
            Ok(v)
        }
    };
    Ok((caption.trim().to_string(), time(from)?, time(to)?))
}

/// One text embedding file (a `.npy` of `dim` values, e.g. a CLIP text embedding), unit length when
/// `l2_normalise`.
pub fn read_embedding(path: &Path, dim: usize, l2_normalise: bool) -> Result<Vec<f32>> {
    let a = qean_io::npy::read(path)?;
    if a.data.len() != dim {
        return Err(Error::at(
            path,
            format!(
                "a text embedding of {} values; this GPT's T-Base takes gpt.text_dim = {dim}",
                a.data.len()
            ),
        ));
    }
    let v: Vec<f32> = a.data.iter().map(|&v| v as f32).collect();
    if v.iter().any(|x| !x.is_finite()) {
        return Err(Error::at(path, "the text embedding is not finite"));
    }
    Ok(if l2_normalise { l2_normalised(&v) } else { v })
}

/// `v` scaled to unit length (unchanged when zero).
pub fn l2_normalised(v: &[f32]) -> Vec<f32> {
    let norm = v.iter().map(|x| x * x).sum::<f32>().sqrt();
    if norm > 0.0 {
        v.iter().map(|x| x / norm).collect()
    } else {
        v.to_vec()
    }
}

/// A pseudo text embedding of a genre: a unit vector of `dim` seeded normal values (synthetic text data).
pub fn genre_embedding(genre: usize, dim: usize) -> Vec<f32> {
    l2_normalised(&normal_noise(0x7465_7874 ^ genre as u64, dim))
}

/// `n` standard normal values from a seeded ChaCha stream (Box–Muller, row-major).
pub fn normal_noise(seed: u64, n: usize) -> Vec<f32> {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let (u1, u2): (f64, f64) = (rng.random(), rng.random());
            ((-2.0 * (1.0 - u1).ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()) as f32
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use qean_motion::skeleton::rest_joints;

    const OPTS: TextSetOptions = TextSetOptions {
        fps: 20.0,
        dim: 4,
        l2_normalise: false,
        rate: 8,
    };

    /// A set of one motion of `frames` frames at 20 fps (22 joints) with the given caption lines and
    /// embedding shape.
    fn set(dir: &Path, frames: usize, lines: &[&str], emb_shape: &[usize]) -> TextSet {
        for sub in ["new_joints", "texts", "text_emb"] {
            std::fs::create_dir_all(dir.join(sub)).unwrap();
        }
        let rest = rest_joints([0.0, 0.9, 0.0]);
        let joints: Vec<f32> = (0..frames)
            .flat_map(|t| {
                rest[..22]
                    .iter()
                    .flat_map(move |p| [p[0] + t as f64 * 0.01, p[1], p[2]])
            })
            .map(|v| v as f32)
            .collect();
        qean_io::npy::write_f32(&dir.join("new_joints/m1.npy"), &[frames, 22, 3], &joints).unwrap();
        std::fs::write(dir.join("texts/m1.txt"), lines.join("\n")).unwrap();
        let n: usize = emb_shape.iter().product();
        let emb: Vec<f32> = (0..n).map(|i| i as f32 + 1.0).collect();
        qean_io::npy::write_f32(&dir.join("text_emb/m1.npy"), emb_shape, &emb).unwrap();
        std::fs::write(dir.join("train.txt"), "m1\n").unwrap();
        TextSet::open(dir, "train").unwrap()
    }

    #[test]
    fn whole_and_sliced_captions() {
        let dir = tempfile::tempdir().unwrap();
        // 61 frames at 20 fps = 3 s → 181 frames at 60 fps → 22 tokens of 8.
        let s = set(
            dir.path(),
            61,
            &[
                "a person walks#a/DET#0.0#0.0",
                "then turns#t/VERB#1.0#2.0",
                "late#x#nan#nan",
            ],
            &[3, 4],
        );
        let clips = s.clips("m1", &OPTS).unwrap();
        assert_eq!(clips.len(), 3);
        assert_eq!(clips[0].caption, "a person walks");
        assert_eq!(clips[0].joints.len(), 22 * 8 * NUM_JOINTS);
        // 1.0 s → token int(60/8) = 7, 2.0 s → 15: 8 tokens starting at frame 56.
        assert_eq!(clips[1].joints.len(), 8 * 8 * NUM_JOINTS);
        assert!((clips[1].joints[0][0] - 56.0 / 3.0 * 0.01).abs() < 1e-6);
        assert_eq!(clips[1].embedding, vec![5.0, 6.0, 7.0, 8.0]);
        // NaN times mean the whole motion (T2M-GPT).
        assert_eq!(clips[2].joints.len(), clips[0].joints.len());
        let unit = s
            .clips(
                "m1",
                &TextSetOptions {
                    l2_normalise: true,
                    ..OPTS
                },
            )
            .unwrap();
        let norm: f32 = unit[0].embedding.iter().map(|x| x * x).sum::<f32>().sqrt();
        assert!((norm - 1.0).abs() < 1e-6);
    }

    #[test]
    fn bad_files_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let s = set(dir.path(), 61, &["a#b#0#0", "c#d#0#0"], &[1, 4]);
        let e = s.clips("m1", &OPTS).unwrap_err().to_string();
        assert!(
            e.contains("m1.npy") && e.contains("1 embedding rows for the 2 caption lines"),
            "{e}"
        );
        let s = set(dir.path(), 61, &["a#b#0#0"], &[1, 5]);
        let e = s.clips("m1", &OPTS).unwrap_err().to_string();
        assert!(e.contains("(lines, 4)"), "{e}");
        let s = set(dir.path(), 61, &["just a caption"], &[1, 4]);
        let e = s.clips("m1", &OPTS).unwrap_err().to_string();
        assert!(e.contains("m1.txt") && e.contains("line 1"), "{e}");
        let e = s.clips("m2", &OPTS).unwrap_err().to_string();
        assert!(e.contains("m2.npy"), "{e}");
        let e = TextSet::open(&dir.path().join("texts"), "train")
            .unwrap_err()
            .to_string();
        assert!(e.contains("HumanML3D layout"), "{e}");
    }

    #[test]
    fn genre_embeddings_are_unit_and_distinct() {
        let a = genre_embedding(0, 512);
        let b = genre_embedding(7, 512);
        let dot: f32 = a.iter().zip(&b).map(|(x, y)| x * y).sum();
        assert!((a.iter().map(|x| x * x).sum::<f32>() - 1.0).abs() < 1e-5);
        assert!(dot.abs() < 0.3, "{dot}");
    }
}
