//! A trained in-betweener at work (SPEC §12.4c "Inference"): segments rebuilt from their keys, keyframes
//! clamped to the input, rotations projected to SO(3), segments stitched at their shared keys.

use std::path::Path;

use burn::tensor::{Device, Tensor, TensorData};
use qean_checkpoint::checkpoint::{resolve, Checkpoint};
use qean_checkpoint::inbetween::base_225;
use qean_checkpoint::FamilyModel;
use qean_config::inbetween::{InbetweenConfig, Taper, Variant};
use qean_models::inbetween::{
    genre_index, genre_one_hot, genres, music_columns, taper_weights, Conditioning, Inbetweener,
    MOTION_DIM, MUSIC_DIM,
};
use qean_motion::{Layout, Motion};

use crate::{Error, Result};

/// A trained in-betweener on the CPU.
pub struct Trained {
    pub model: Inbetweener,
    pub config: InbetweenConfig,
    pub checkpoint: Checkpoint,
}

impl Trained {
    /// The newest checkpoint of a run (or a checkpoint directory), which must be an in-betweener.
    pub fn load(run: &Path) -> Result<Trained> {
        let checkpoint = resolve(run)?;
        let FamilyModel::Inbetween(model) = checkpoint.load_family(&Device::flex())? else {
            return Err(checkpoint.not_family("an in-betweener").into());
        };
        let config = checkpoint.config.inbetween();
        Ok(Trained {
            model,
            config,
            checkpoint,
        })
    }

    /// A label for reports: variant, checkpoint directory and weights hash.
    pub fn label(&self) -> String {
        format!(
            "{} ({}, params_hash {})",
            self.config.variant.name(),
            self.checkpoint.dir.display(),
            &self.checkpoint.state.params_hash[..12.min(self.checkpoint.state.params_hash.len())]
        )
    }
}

/// What a rebuild reads besides the motion.
pub struct Context<'a> {
    /// The music's 35-D features (frames × 35), aligned with the motion; needed by the music variants (for
    /// the drums variants, the drums stem's features).
    pub features: Option<&'a [f32]>,
    /// The dance's genre code (BR, PO, …); needed by the genre variant.
    pub genre: Option<&'a str>,
}

/// One segment to rebuild: inclusive frames [a, b] and its keys (absolute frames, sorted, a and b among
/// them). Frames between keys are regenerated; keys keep the input's values.
#[derive(Debug, Clone)]
pub struct Segment {
    pub a: usize,
    pub b: usize,
    pub keys: Vec<usize>,
}

/// Rebuild `segments` of `motion`: every segment in one padded batch, Ŷ = B + f(·), keys clamped, rotations
/// projected. Frames outside the segments and the keys are the input's, bit for bit.
pub fn rebuild(
    model: &Inbetweener,
    c: &InbetweenConfig,
    motion: &Motion,
    segments: &[Segment],
    ctx: &Context,
) -> Result<Motion> {
    let device = Device::flex();
    let rows = motion.to_layout(Layout::L225);
    let w = MOTION_DIM;
    if segments.is_empty() {
        return Ok(motion.clone());
    }
    let lens: Vec<usize> = segments.iter().map(|s| s.b - s.a + 1).collect();
    let t = *lens.iter().max().expect("non-empty");
    if t > c.max_len {
        return Err(Error::Invalid(format!(
            "a segment of {t} frames is longer than the in-betweener's {} (inbetween.max_len)",
            c.max_len
        )));
    }
    let (genre, features) = inputs(c, ctx)?;
    let (mut base, mut music, mut taper) = (Vec::new(), Vec::new(), Vec::new());
    for (s, &len) in segments.iter().zip(&lens) {
        let seg = &rows[s.a * w..(s.b + 1) * w];
        let rel: Vec<usize> = s.keys.iter().map(|k| k - s.a).collect();
        taper.extend(taper_weights(&rel, t, c.taper));
        let mut bi = base_225(seg, len, &rel, c.base);
        bi.extend(std::iter::repeat_n(0.0, (t - len) * w));
        base.extend(bi);
        if let Some(f) = features {
            let frames = f.len() / 35;
            for i in 0..t {
                // Past the music's end (or the segment's), its last row.
                let r = (s.a + i.min(len - 1)).min(frames.saturating_sub(1));
                let mut m = music_columns(&f[r * 35..(r + 1) * 35]);
                c.normalise_music(&mut m);
                music.extend(m);
            }
        }
    }
    let n = segments.len();
    let cond = Conditioning {
        music: features
            .map(|_| Tensor::<3>::from_data(TensorData::new(music, [n, t, MUSIC_DIM]), &device)),
        genre: genre.map(|g| genre_one_hot(c, &vec![Some(g); n], &device)),
        lengths: Some(lens.clone()),
        taper: (c.taper != Taper::None)
            .then(|| Tensor::<3>::from_data(TensorData::new(taper, [n, t, 1]), &device)),
    };
    let out: Vec<f32> = model
        .forward(
            Tensor::<3>::from_data(TensorData::new(base, [n, t, w]), &device),
            &cond,
        )
        .into_data()
        .try_to_vec::<f32>()
        .map_err(|e| Error::Invalid(format!("in-betweener output: {e:?}")))?;
    let mut result = rows.clone();
    for (i, s) in segments.iter().enumerate() {
        for f in s.a..=s.b {
            if s.keys.binary_search(&f).is_err() {
                let src = &out[(i * t + f - s.a) * w..(i * t + f - s.a + 1) * w];
                result[f * w..(f + 1) * w].copy_from_slice(src);
            }
        }
    }
    // Rotations projected to SO(3) on the way back; translations in the input's units.
    let rebuilt = Motion::from_layout(&result, Layout::L225).map_err(Error::Invalid)?;
    let mut out_motion = motion.clone();
    for s in segments {
        for f in s.a..=s.b {
            if s.keys.binary_search(&f).is_err() {
                out_motion.poses[f * 72..(f + 1) * 72]
                    .copy_from_slice(&rebuilt.poses[f * 72..(f + 1) * 72]);
                for k in 0..3 {
                    out_motion.trans[f * 3 + k] = rebuilt.trans[f * 3 + k] * motion.scaling;
                }
            }
        }
    }
    Ok(out_motion)
}

/// The genre index and music features the variant needs, from `ctx`; an error naming what is missing.
fn inputs<'a>(
    c: &InbetweenConfig,
    ctx: &Context<'a>,
) -> Result<(Option<usize>, Option<&'a [f32]>)> {
    let genre = match (c.variant, ctx.genre) {
        (Variant::Genre, Some(g)) => Some(genre_index(c, g).ok_or_else(|| {
            Error::Invalid(format!(
                "genre {g:?} is not one the genre in-betweener knows ({})",
                genres(c).join(" ")
            ))
        })?),
        (Variant::Genre, None) => {
            return Err(Error::Invalid(
                "the genre in-betweener needs the dance's genre (an AIST++ name or --genre)".into(),
            ))
        }
        _ => None,
    };
    let features = match (c.variant.has_audio(), ctx.features) {
        (true, Some(f)) => Some(f),
        (true, None) => {
            return Err(Error::Invalid(format!(
                "the {} in-betweener needs the music",
                c.variant.name()
            )))
        }
        (false, _) => None,
    };
    Ok((genre, features))
}

/// Segments from keyframes over measures: each measure [a, b] with the keys inside it.
pub fn measure_segments(measures: &[(usize, usize)], keys: &[usize]) -> Vec<Segment> {
    measures
        .iter()
        .map(|&(a, b)| {
            let mut k: Vec<usize> = keys.iter().copied().filter(|&f| a <= f && f <= b).collect();
            k.extend([a, b]);
            k.sort_unstable();
            k.dedup();
            Segment { a, b, keys: k }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_are_clamped_and_frames_outside_untouched() {
        let m = Motion::read_pkl(
            &qean_io::testdata::shared_dir()
                .join("aistpp/motions/softcat477_sample_with_scaling.pkl"),
        )
        .unwrap();
        let c = InbetweenConfig {
            dropout: 0.0,
            ..InbetweenConfig::tiny()
        };
        let device = Device::flex();
        device.seed(11);
        let mut model = Inbetweener::new(&c, &device);
        // A large output layer, so the prediction moves far from the base.
        model.output.weight = model.output.weight.map(|w| w.mul_scalar(50.0));
        let keys = vec![10, 40, 70, 100];
        let seg = [Segment {
            a: 10,
            b: 100,
            keys: keys.clone(),
        }];
        let ctx = Context {
            features: None,
            genre: None,
        };
        let out = rebuild(&model, &c, &m, &seg, &ctx).unwrap();
        for t in (0..=10).chain(40..=40).chain(70..=70).chain(100..m.frames) {
            assert_eq!(
                out.poses[t * 72..(t + 1) * 72],
                m.poses[t * 72..(t + 1) * 72],
                "frame {t}"
            );
            assert_eq!(out.trans[t * 3..(t + 1) * 3], m.trans[t * 3..(t + 1) * 3]);
        }
        assert_ne!(out.poses[55 * 72..56 * 72], m.poses[55 * 72..56 * 72]);
        // Projected rotations: every axis-angle has an angle within [0, π].
        for r in out.poses.chunks_exact(3) {
            let angle = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
            assert!(angle.is_finite() && angle <= std::f64::consts::PI + 1e-9);
        }
    }
}
