//! Keyframe control at sampling (SPEC §13.6 "Inference"): `qean sample --keyframes K.json` (or
//! `--keyframes-from M.pkl --keyframe-frames 240,600`) puts poses at output frames of a keyframe-control
//! run's dance. The pose becomes its static-clip token, overwrites
//! the generated token at ⌊F/d⌋, and the k tokens on each side are predicted again by the keyframe
//! module's mask attention (one window per keyframe); the whole sequence is then decoded.

use std::path::Path;

use burn::tensor::{Device, Tensor, TensorData};
use qean_config::gpt::GptConfig;
use qean_config::keyframe::{KeyframeConfig, KfDecode, KfTokenize};
use qean_io::error::{Error, Result};
use qean_models::control::gpt::{music_token_dim, Gpt};
use qean_models::control::keyframe::{key_tokens, predict_window, refill, KeyframeModule};
use qean_motion::fk::FkRoot;
use qean_motion::motion::{read_motion, Motion};

use qean_checkpoint::gpt::FrozenVq;

/// One keyframe as asked for: a pose of 24 joints (metres, the SMPL root convention) at an output frame.
#[derive(Debug, Clone, PartialEq)]
pub struct KeyframeRequest {
    /// Output frame, seed included (60 fps).
    pub frame: usize,
    pub pose: Vec<[f64; 3]>,
    /// What the user wrote, for messages.
    pub spec: String,
}

/// The `--keyframes K.json` file.
#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct KeyframeFile {
    keyframes: Vec<KeyframeEntry>,
}

#[derive(serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct KeyframeEntry {
    frame: usize,
    pose_aa: Vec<f64>,
    trans: Vec<f64>,
}

impl KeyframeRequest {
    /// `--keyframes K.json`: `{"keyframes": [{"frame": f, "pose_aa": [72 SMPL axis-angle values],
    /// "trans": [3]}, ...]}`, each pose through the SMPL forward kinematics (§3.3).
    pub fn from_json(path: &Path) -> Result<Vec<KeyframeRequest>> {
        let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let file: KeyframeFile = serde_json::from_str(&text)
            .map_err(|e| Error::at(path, format!("not a keyframes file ({e})")))?;
        if file.keyframes.is_empty() {
            return Err(Error::at(path, "the file lists no keyframes"));
        }
        file.keyframes
            .into_iter()
            .enumerate()
            .map(|(i, k)| {
                let which = format!("keyframe {} (frame {})", i + 1, k.frame);
                if k.pose_aa.len() != 72 || k.trans.len() != 3 {
                    return Err(Error::at(
                        path,
                        format!(
                            "{which}: pose_aa has {} values and trans {}; a pose is 72 (24 joints × axis-angle) and 3",
                            k.pose_aa.len(),
                            k.trans.len()
                        ),
                    ));
                }
                if k.pose_aa.iter().chain(&k.trans).any(|v| !v.is_finite()) {
                    return Err(Error::at(path, format!("{which}: a value is not finite")));
                }
                let one = Motion::new(k.pose_aa, k.trans, 1.0)
                    .map_err(|e| Error::at(path, format!("{which}: {e}")))?;
                Ok(KeyframeRequest {
                    frame: k.frame,
                    pose: one.joints(FkRoot::Smpl),
                    spec: format!("{} {which}", path.display()),
                })
            })
            .collect()
    }

    /// `--keyframes-from M --keyframe-frames F,...`: the dance's frame f takes the pose of M's frame f (a
    /// motion file: .pkl, or .npy of SMPL parameters).
    pub fn from_motion(path: &Path, frames: &[usize]) -> Result<Vec<KeyframeRequest>> {
        let motion = read_motion(path)?;
        if frames.is_empty() {
            return Err(Error::at(path, "--keyframe-frames lists no frames"));
        }
        frames
            .iter()
            .map(|&f| {
                if f >= motion.frames {
                    return Err(Error::at(
                        path,
                        format!(
                            "--keyframe-frames {f}: the motion has {} frames",
                            motion.frames
                        ),
                    ));
                }
                Ok(KeyframeRequest {
                    frame: f,
                    pose: motion.slice(f, f + 1).joints(FkRoot::Smpl),
                    spec: format!("{} frame {f}", path.display()),
                })
            })
            .collect()
    }

    /// The keyframes a command line asks for: a JSON file, or frames of a motion file (at most one).
    pub fn of_args(
        json: Option<&Path>,
        from: Option<(&Path, &[usize])>,
    ) -> Result<Vec<KeyframeRequest>> {
        match (json, from) {
            (Some(j), None) => Self::from_json(j),
            (None, Some((m, frames))) => Self::from_motion(m, frames),
            (None, None) => Ok(Vec::new()),
            (Some(_), Some(_)) => Err(Error::msg(
                "--keyframes and --keyframes-from: give one source of keyframes",
            )),
        }
    }

    /// The frame must fall after the seed and within the frames asked for.
    pub fn check(&self, seed_frames: usize, frames: usize) -> Result<()> {
        if self.frame < seed_frames {
            return Err(Error::msg(format!(
                "{}: frame {} is inside the seed (its first {seed_frames} frames)",
                self.spec, self.frame
            )));
        }
        if self.frame >= seed_frames + frames {
            return Err(Error::msg(format!(
                "{}: frame {} is after the dance ({} frames with the seed)",
                self.spec,
                self.frame,
                seed_frames + frames
            )));
        }
        Ok(())
    }
}

/// The keyframe module of the keyframe-control run `dir` (its newest checkpoint), for a GPT run whose
/// sampled weights hash to `gpt_hash` (the GPT itself, or a genre stage's frozen GPT): unified sampling
/// plugs it into another run of the same GPT (SPEC §13.8). Its `warp_frames` come with it.
pub fn keyframe_module_for(dir: &Path, gpt_hash: &str) -> Result<(KeyframeModule, KeyframeConfig)> {
    let ck = qean_checkpoint::checkpoint::resolve(dir)?;
    let qean_checkpoint::FamilyModel::GptKeyframe(m) = ck.load_family(&Device::flex())? else {
        return Err(Error::at(
            &ck.dir,
            format!(
                "--keyframe-run needs a keyframe-control run (model.arch = \"gpt_keyframe\"), not {:?}",
                ck.config.model.arch
            ),
        ));
    };
    let theirs = crate::gpt::gpt_hash(&ck)?;
    if theirs != gpt_hash {
        return Err(Error::at(
            &ck.dir,
            format!(
                "--keyframe-run was trained over another GPT (weights hash {theirs}); this run's GPT is {gpt_hash}"
            ),
        ));
    }
    Ok((m.keyframe, ck.config.keyframe_table().clone()))
}

/// The generated `tokens` (the first `seed_tokens` the seed's) edited by the keyframes: their static-clip
/// tokens written in, the masked positions around them predicted again in one window each, over the music
/// tokens `music` (n × 280, the dance's).
#[allow(clippy::too_many_arguments)]
pub fn apply_keyframes(
    (gpt, module, c): (&Gpt, &KeyframeModule, &KeyframeConfig),
    vq: &FrozenVq,
    g: &GptConfig,
    tokens: &[usize],
    seed_tokens: usize,
    music: &[f32],
    keys: &[KeyframeRequest],
) -> Result<Vec<usize>> {
    let n = tokens.len();
    if let Some(k) = keys.iter().find(|k| k.frame / g.rate >= n) {
        return Err(Error::msg(format!(
            "{}: frame {} is after the dance, which the music ends at frame {}",
            k.spec,
            k.frame,
            n * g.rate
        )));
    }
    let poses: Vec<&[[f64; 3]]> = keys.iter().map(|k| k.pose.as_slice()).collect();
    let codes = match c.tokenize {
        KfTokenize::StaticClip => vq.static_tokens(&poses)?,
        KfTokenize::Paste => keys
            .iter()
            .map(|k| vq.paste_token(tokens, k.frame / g.rate, &k.pose))
            .collect::<Result<Vec<_>>>()?,
    };
    let pairs: Vec<(usize, usize)> = keys.iter().map(|k| k.frame).zip(codes).collect();
    let passes = match c.decode {
        KfDecode::OneShot => 1,
        KfDecode::Iterative => c.passes,
    };
    let w = music_token_dim(g);
    let device = Device::flex();
    refill(
        tokens,
        &key_tokens(&pairs, g.rate),
        (c.radius, seed_tokens, g.window),
        |s, inputs| {
            let rows: Vec<f32> = (s..s + inputs.len())
                .flat_map(|j| {
                    let j = (j + g.music_lookahead).min(n - 1);
                    music[j * w..(j + 1) * w].iter().copied()
                })
                .collect();
            let rows = Tensor::<3>::from_data(TensorData::new(rows, [1, inputs.len(), w]), &device);
            predict_window(gpt, module, inputs, rows, passes)
        },
    )
    .map_err(Error::msg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keyframe_files_are_read_and_bad_ones_say_what_is_wrong() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("k.json");
        let write = |text: &str| std::fs::write(&path, text).unwrap();
        let pose = |n: usize| format!("[{}]", vec!["0.1"; n].join(", "));
        write(&format!(
            r#"{{"keyframes": [{{"frame": 240, "pose_aa": {}, "trans": [0, 0.9, 0]}}]}}"#,
            pose(72)
        ));
        let k = KeyframeRequest::from_json(&path).unwrap();
        assert_eq!((k.len(), k[0].frame, k[0].pose.len()), (1, 240, 24));
        // The root joint sits at trans (SMPL root convention: the pelvis offset added).
        assert!((k[0].pose[0][1] - 0.9).abs() < 0.5, "{:?}", k[0].pose[0]);
        assert!(k[0].check(120, 600).is_ok());
        assert!(k[0]
            .check(300, 600)
            .unwrap_err()
            .to_string()
            .contains("inside the seed"));
        assert!(k[0]
            .check(120, 100)
            .unwrap_err()
            .to_string()
            .contains("after the dance"));
        for (text, want) in [
            (
                format!(
                    r#"{{"keyframes": [{{"frame": 240, "pose_aa": {}, "trans": [0, 0.9, 0]}}]}}"#,
                    pose(69)
                ),
                "keyframe 1 (frame 240): pose_aa has 69 values",
            ),
            (r#"{"keyframes": []}"#.to_string(), "lists no keyframes"),
            (r#"{"keys": []}"#.to_string(), "not a keyframes file"),
        ] {
            write(&text);
            let e = KeyframeRequest::from_json(&path).unwrap_err().to_string();
            assert!(e.contains(want) && e.contains("k.json"), "{e}");
        }
        let e = KeyframeRequest::of_args(Some(&path), Some((&path, &[1]))).unwrap_err();
        assert!(e.to_string().contains("give one source"), "{e}");
        assert!(KeyframeRequest::of_args(None, None).unwrap().is_empty());
    }
}
