//! Edit a dance (SPEC §12.7): keep some poses, set others, regenerate the rest of chosen ranges from the
//! anchors. Frames outside every range are copied bit for bit; edited poses are used exactly.

use crate::bezier::{self, BezierSettings, MeanTheta, ThetaSource};
use crate::slerp;
use qean_motion::Motion;
use serde::{Deserialize, Serialize};

/// Which frames inside the ranges stay as they are.
#[derive(Debug, Clone, PartialEq)]
pub enum Keep {
    /// Nothing but the range ends (and edited frames).
    Ends,
    /// N even keys per measure (§12.3a).
    Grid(usize),
    /// N DP keys per measure (§12.3e).
    Dp(usize),
    /// N onset keys per measure (§12.3b, needs the music).
    Onset(usize),
    /// These frames.
    Frames(Vec<usize>),
}

impl Keep {
    fn parse(v: &serde_json::Value) -> Result<Keep, String> {
        match v {
            serde_json::Value::Null => Ok(Keep::Ends),
            serde_json::Value::Array(a) => a
                .iter()
                .map(|x| {
                    x.as_u64().map(|f| f as usize).ok_or_else(|| {
                        format!("\"keep\" frames must be non-negative integers, got {x}")
                    })
                })
                .collect::<Result<Vec<_>, _>>()
                .map(Keep::Frames),
            serde_json::Value::String(s) => {
                let (kind, n) = s.split_once(':').ok_or_else(|| {
                    format!("\"keep\": expected \"grid:N\", \"dp:N\" or \"onset:N\", got {s:?}")
                })?;
                let n: usize = n
                    .trim()
                    .parse()
                    .ok()
                    .filter(|n| *n >= 2)
                    .ok_or_else(|| format!("\"keep\": N must be an integer ≥ 2 in {s:?}"))?;
                match kind.trim() {
                    "grid" => Ok(Keep::Grid(n)),
                    "dp" => Ok(Keep::Dp(n)),
                    "onset" => Ok(Keep::Onset(n)),
                    other => Err(format!(
                        "\"keep\": unknown keyframe rule {other:?} (expected grid, dp or onset)"
                    )),
                }
            }
            other => Err(format!(
                "\"keep\" must be a rule string or a list of frames, got {other}"
            )),
        }
    }
}

/// A new pose for one frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PoseEdit {
    pub frame: usize,
    pub pose_aa: Vec<f64>,
    /// Root translation as stored in the input (before division by the scaling); `None` keeps the input's.
    pub trans: Option<[f64; 3]>,
}

/// A parsed and checked edits.json.
#[derive(Debug, Clone, PartialEq)]
pub struct EditSpec {
    /// Inclusive, sorted, disjoint.
    pub regenerate: Vec<(usize, usize)>,
    pub keep: Keep,
    pub edits: Vec<PoseEdit>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSpec {
    regenerate: Vec<(i64, i64)>,
    #[serde(default)]
    keep: serde_json::Value,
    #[serde(default)]
    edits: Vec<RawEdit>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEdit {
    frame: i64,
    pose_aa: Vec<f64>,
    #[serde(default)]
    trans: Option<Vec<f64>>,
}

impl EditSpec {
    /// Parse edits.json text and check it against a motion of `frames` frames.
    pub fn parse(text: &str, frames: usize) -> Result<EditSpec, String> {
        let raw: RawSpec = serde_json::from_str(text).map_err(|e| e.to_string())?;
        if raw.regenerate.is_empty() {
            return Err("\"regenerate\" lists no ranges".into());
        }
        let in_motion = |f: i64, what: &str| -> Result<usize, String> {
            if f < 0 || f as usize >= frames {
                Err(format!(
                    "{what} {f} is outside the motion (frames 0..{})",
                    frames - 1
                ))
            } else {
                Ok(f as usize)
            }
        };
        let mut ranges = Vec::new();
        for &(a, b) in &raw.regenerate {
            if a > b {
                return Err(format!("range [{a}, {b}] is reversed"));
            }
            ranges.push((in_motion(a, "range start")?, in_motion(b, "range end")?));
        }
        ranges.sort_unstable();
        for w in ranges.windows(2) {
            if w[1].0 <= w[0].1 {
                return Err(format!(
                    "ranges [{}, {}] and [{}, {}] overlap",
                    w[0].0, w[0].1, w[1].0, w[1].1
                ));
            }
        }
        let keep = Keep::parse(&raw.keep)?;
        if let Keep::Frames(f) = &keep {
            for &k in f {
                in_motion(k as i64, "keyframe")?;
            }
        }
        let mut edits = Vec::new();
        for e in raw.edits {
            let frame = in_motion(e.frame, "edited frame")?;
            if e.pose_aa.len() != 72 {
                return Err(format!(
                    "edit of frame {frame}: pose_aa has {} values, expected 72 (24 joints × axis-angle)",
                    e.pose_aa.len()
                ));
            }
            let trans = match e.trans {
                None => None,
                Some(t) if t.len() == 3 => Some([t[0], t[1], t[2]]),
                Some(t) => {
                    return Err(format!(
                        "edit of frame {frame}: trans has {} values, expected 3",
                        t.len()
                    ))
                }
            };
            if e.pose_aa
                .iter()
                .chain(trans.iter().flatten())
                .any(|v| !v.is_finite())
            {
                return Err(format!("edit of frame {frame}: non-finite value"));
            }
            if !ranges.iter().any(|&(a, b)| a <= frame && frame <= b) {
                return Err(format!(
                    "edited frame {frame} is in no \"regenerate\" range"
                ));
            }
            edits.push(PoseEdit {
                frame,
                pose_aa: e.pose_aa,
                trans,
            });
        }
        Ok(EditSpec {
            regenerate: ranges,
            keep,
            edits,
        })
    }
}

/// A caller's in-betweener: the edited motion and one range's anchors → the motion with the range rebuilt.
pub type Rebuild<'a> = &'a dyn Fn(&Motion, &[usize]) -> Result<Motion, String>;

/// How the regenerated frames are drawn.
pub enum Method<'a> {
    Slerp,
    /// Bézier curves with this mean θ.
    Bezier(&'a MeanTheta, BezierSettings),
    /// A learnt in-betweener (e.g. a trained transformer, which this crate does not know).
    Learnt(Rebuild<'a>),
}

/// One range's anchors and its error against the input.
#[derive(Debug, Clone, Serialize)]
pub struct RangeReport {
    pub range: (usize, usize),
    pub anchors: Vec<usize>,
    /// Rotation-matrix MSE of the range against the input (informational).
    pub mse_rotmat: f64,
}

/// Apply the edits: `kept` are the frames kept inside the ranges (already resolved from `spec.keep`).
pub fn apply(
    motion: &Motion,
    spec: &EditSpec,
    kept: &[usize],
    method: &Method,
) -> Result<(Motion, Vec<RangeReport>), String> {
    let mut edited = motion.clone();
    for e in &spec.edits {
        edited.poses[e.frame * 72..e.frame * 72 + 72].copy_from_slice(&e.pose_aa);
        if let Some(t) = e.trans {
            edited.trans[e.frame * 3..e.frame * 3 + 3].copy_from_slice(&t);
        }
    }
    let mut out = edited.clone();
    let mut reports = Vec::new();
    for &(a, b) in &spec.regenerate {
        let mut anchors: Vec<usize> = vec![a, b];
        anchors.extend(kept.iter().copied().filter(|&k| a < k && k < b));
        anchors.extend(
            spec.edits
                .iter()
                .map(|e| e.frame)
                .filter(|&f| a <= f && f <= b),
        );
        anchors.sort_unstable();
        anchors.dedup();
        let rebuilt = match method {
            Method::Slerp => slerp::inbetween(&edited, &anchors),
            Method::Bezier(mean, settings) => {
                bezier::inbetween(&edited, &anchors, ThetaSource::Mean(mean), settings)
            }
            Method::Learnt(rebuild) => rebuild(&edited, &anchors)?,
        };
        out.poses[a * 72..(b + 1) * 72].copy_from_slice(&rebuilt.poses[a * 72..(b + 1) * 72]);
        out.trans[a * 3..(b + 1) * 3].copy_from_slice(&rebuilt.trans[a * 3..(b + 1) * 3]);
        let mse_rotmat = crate::mse::mse(
            &motion.slice(a, b + 1),
            &out.slice(a, b + 1),
            crate::mse::MseSpace::Rotmat,
        );
        reports.push(RangeReport {
            range: (a, b),
            anchors,
            mse_rotmat,
        });
    }
    Ok((out, reports))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn random_motion(frames: usize) -> Motion {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let poses = (0..frames * 72)
            .map(|_| rng.random_range(-0.8..0.8))
            .collect();
        let trans = (0..frames * 3)
            .map(|_| rng.random_range(-1.0..1.0))
            .collect();
        Motion::new(poses, trans, 1.0).unwrap()
    }

    #[test]
    fn outside_copied_edits_exact_and_keep_all_is_identity() {
        let m = random_motion(60);
        let pose: Vec<f64> = (0..72).map(|i| 0.01 * i as f64).collect();
        let text = format!(
            r#"{{"regenerate": [[40, 55], [5, 20]], "keep": [10], "edits": [{{"frame": 15, "pose_aa": {pose:?}, "trans": [0.1, 0.9, 0.2]}}]}}"#
        );
        let spec = EditSpec::parse(&text, 60).unwrap();
        assert_eq!(spec.regenerate, vec![(5, 20), (40, 55)]);
        let Keep::Frames(kept) = spec.keep.clone() else {
            panic!()
        };
        let (out, reports) = apply(&m, &spec, &kept, &Method::Slerp).unwrap();
        for t in (0..5).chain(21..40).chain(56..60) {
            assert_eq!(
                out.poses[t * 72..t * 72 + 72],
                m.poses[t * 72..t * 72 + 72],
                "{t}"
            );
            assert_eq!(out.trans[t * 3..t * 3 + 3], m.trans[t * 3..t * 3 + 3]);
        }
        assert_eq!(out.poses[15 * 72..16 * 72], pose[..]);
        assert_eq!(out.trans[45..48], [0.1, 0.9, 0.2]);
        assert_eq!(reports[0].anchors, vec![5, 10, 15, 20]);
        assert_eq!(out.poses[10 * 72..11 * 72], m.poses[10 * 72..11 * 72]);
        // Every frame kept: the input comes back.
        let all: Vec<usize> = (0..60).collect();
        let (same, _) = apply(
            &m,
            &EditSpec {
                edits: vec![],
                ..spec.clone()
            },
            &all,
            &Method::Slerp,
        )
        .unwrap();
        assert_eq!(same, m);
        // A two-key range with SLERP is §12.4a between its ends.
        let two = EditSpec::parse(r#"{"regenerate": [[12, 30]]}"#, 60).unwrap();
        let (o, _) = apply(&m, &two, &[], &Method::Slerp).unwrap();
        let direct = slerp::inbetween(&m, &[12, 30]);
        assert_eq!(o.poses[12 * 72..31 * 72], direct.poses[12 * 72..31 * 72]);
    }

    #[test]
    fn bad_specs_say_what_is_wrong() {
        let err = |t: &str| EditSpec::parse(t, 50).unwrap_err();
        assert!(err(r#"{"regenerate": [[10, 5]]}"#).contains("reversed"));
        assert!(err(r#"{"regenerate": [[0, 20], [15, 30]]}"#).contains("overlap"));
        assert!(err(r#"{"regenerate": [[0, 50]]}"#).contains("outside the motion"));
        assert!(err(r#"{"regenerate": [[0, 20]], "keep": [3, 70]}"#).contains("keyframe 70"));
        assert!(err(r#"{"regenerate": [[0, 20]], "keep": "zigzag:3"}"#)
            .contains("unknown keyframe rule"));
        assert!(err(
            r#"{"regenerate": [[0, 20]], "edits": [{"frame": 3, "pose_aa": [0.0, 1.0]}]}"#
        )
        .contains("72"));
        let pose = format!("{:?}", vec![0.0; 72]);
        let outside = format!(
            r#"{{"regenerate": [[0, 20]], "edits": [{{"frame": 30, "pose_aa": {pose}}}]}}"#
        );
        assert!(err(&outside).contains("in no"));
        assert!(err(r#"{"regenerate": []}"#).contains("no ranges"));
        assert!(err(r#"{"regenerate": [[0, 20]], "extra": 1}"#).contains("unknown field"));
    }
}
