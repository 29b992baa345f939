//! Keyframe control (SPEC §13.6; seed 001): a keyframe pose becomes a token, overwrites the generated token
//! at its position, and the k tokens on each side are predicted again, in one pass per keyframe, by a model
//! that sees the future (mask attention) with the re-predicted positions masked. This file holds the index
//! arithmetic, the static clip a pose is tokenised from, and the re-prediction loop over any predictor; the
//! mask-attention weights and their training (stage 3b) are not here yet.

use qean_motion::pos72::{joints_to_pos72, Pos72Options};

/// Tokens re-predicted on each side of a keyframe (k = 6 [READ]).
pub const RADIUS: usize = 6;
/// Tokens per re-prediction window.
pub const WINDOW: usize = 32;
/// Frames of the static clip a keyframe pose is repeated over (8 d), and the token taken from its codes.
pub const STATIC_CLIP_FRAMES: usize = 64;
pub const STATIC_CLIP_TOKEN: usize = 4;

/// A keyframe on the token grid.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KeyToken {
    pub position: usize,
    pub token: usize,
}

/// Keyframes (frame, token) on the token grid of `rate` frames per token, ascending: p = ⌊f/d⌋; two keyframes
/// on one token count once and the later one (in the list) wins.
pub fn key_tokens(keys: &[(usize, usize)], rate: usize) -> Vec<KeyToken> {
    let mut out: Vec<KeyToken> = Vec::new();
    for &(frame, token) in keys {
        let position = frame / rate;
        match out.iter_mut().find(|k| k.position == position) {
            Some(k) => k.token = token,
            None => out.push(KeyToken { position, token }),
        }
    }
    out.sort_by_key(|k| k.position);
    out
}

/// The re-predicted positions (§13.6 "Index set"): ∪_p [p − k, p + k] ∩ [n_fixed, n) minus the keyframe
/// positions, ascending. A keyframe inside the seed (p < n_fixed) or past the sequence (p ≥ n) is an error.
pub fn kf_mask_positions(
    positions: &[usize],
    k: usize,
    n_fixed: usize,
    n: usize,
) -> Result<Vec<usize>, String> {
    if let Some(&p) = positions.iter().find(|&&p| p >= n || p < n_fixed) {
        return Err(format!(
            "a keyframe at token {p} is outside the generated tokens [{n_fixed}, {n})"
        ));
    }
    let mut masked = vec![false; n];
    for &p in positions {
        for m in masked
            .iter_mut()
            .take((p + k + 1).min(n))
            .skip(p.saturating_sub(k).max(n_fixed))
        {
            *m = true;
        }
    }
    for &p in positions {
        masked[p] = false;
    }
    Ok((0..n).filter(|&j| masked[j]).collect())
}

/// The window start for a keyframe at token p: s = clamp(p − window/2, 0, n − window) (0 when n < window).
pub fn kf_window(p: usize, n: usize, window: usize) -> usize {
    p.saturating_sub(window / 2).min(n.saturating_sub(window))
}

/// The static clip of one pose (24 joints): the pose held for [`STATIC_CLIP_FRAMES`] frames as pos72 rows
/// (zero root velocity), the VQ-VAE's input for the keyframe's token ([`STATIC_CLIP_TOKEN`] of its codes).
pub fn static_clip(pose: &[[f64; 3]], opts: &Pos72Options) -> Vec<f64> {
    assert_eq!(pose.len(), 24, "a pose is 24 joints");
    let joints: Vec<[f64; 3]> = (0..STATIC_CLIP_FRAMES)
        .flat_map(|_| pose.iter().copied())
        .collect();
    joints_to_pos72(&joints, opts)
}

/// Keyframe re-prediction (§13.6 "Inference" steps 2–4) with `predict`: the keyframe tokens overwrite
/// `tokens`; then, for each keyframe in ascending position, the window from [`kf_window`] goes to
/// `predict(start, inputs)` with inputs `Some(token)`, or `None` (the Mask token) at the masked positions,
/// and its per-position picks are written back at the window's masked positions. A masked position stays
/// Mask in every window's input (as in training); where windows overlap, the later keyframe's pick stands
/// (our reading). Positions outside the masked set keep their tokens.
pub fn refill(
    tokens: &[usize],
    keys: &[KeyToken],
    (k, n_fixed, window): (usize, usize, usize),
    mut predict: impl FnMut(usize, &[Option<usize>]) -> Vec<usize>,
) -> Result<Vec<usize>, String> {
    let n = tokens.len();
    let positions: Vec<usize> = keys.iter().map(|key| key.position).collect();
    let masked = kf_mask_positions(&positions, k, n_fixed, n)?;
    let mut is_masked = vec![false; n];
    for &m in &masked {
        is_masked[m] = true;
    }
    let mut out = tokens.to_vec();
    for key in keys {
        out[key.position] = key.token;
    }
    let inputs: Vec<Option<usize>> = (0..n).map(|j| (!is_masked[j]).then_some(out[j])).collect();
    for key in keys {
        let s = kf_window(key.position, n, window);
        let e = (s + window).min(n);
        let picks = predict(s, &inputs[s..e]);
        if picks.len() != e - s {
            return Err(format!(
                "the predictor returned {} tokens for a window of {}",
                picks.len(),
                e - s
            ));
        }
        for (j, &pick) in (s..e).zip(&picks) {
            if is_masked[j] {
                out[j] = pick;
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mask_positions_cover_both_sides_and_skip_keys_and_seed() {
        // One keyframe at 20, k 6: 14..=26 without 20.
        let m = kf_mask_positions(&[20], 6, 10, 40).unwrap();
        assert_eq!(m, (14..=26).filter(|&j| j != 20).collect::<Vec<_>>());
        // Near the seed (n_fixed 15) and the end (n 30): clipped.
        assert_eq!(
            kf_mask_positions(&[16], 6, 15, 30).unwrap(),
            vec![15, 17, 18, 19, 20, 21, 22]
        );
        assert_eq!(
            kf_mask_positions(&[28], 6, 15, 30).unwrap(),
            vec![22, 23, 24, 25, 26, 27, 29]
        );
        // Overlapping: one union, both keys left out; the seed's tokens never.
        let m = kf_mask_positions(&[20, 24], 6, 15, 40).unwrap();
        assert_eq!(m.len(), (15..=30).count() - 2);
        assert!(kf_mask_positions(&[40], 6, 15, 40).is_err());
        assert!(kf_mask_positions(&[10], 6, 15, 40).is_err());
    }

    #[test]
    fn keys_on_one_token_count_once_the_later_wins() {
        let k = key_tokens(&[(200, 5), (90, 7), (203, 9)], 8);
        assert_eq!(
            k,
            vec![
                KeyToken {
                    position: 11,
                    token: 7
                },
                KeyToken {
                    position: 25,
                    token: 9
                }
            ]
        );
    }

    #[test]
    fn windows_clamp_to_the_sequence() {
        assert_eq!(kf_window(40, 100, 32), 24);
        assert_eq!(kf_window(5, 100, 32), 0);
        assert_eq!(kf_window(95, 100, 32), 68);
        assert_eq!(kf_window(10, 20, 32), 0);
    }

    #[test]
    fn the_static_clip_stands_still() {
        let pose: Vec<[f64; 3]> = (0..24)
            .map(|j| [0.1 * j as f64, 0.9, -0.02 * j as f64])
            .collect();
        let clip = static_clip(&pose, &Pos72Options::default());
        assert_eq!(clip.len(), STATIC_CLIP_FRAMES * 72);
        for row in clip.chunks(72) {
            assert_eq!(&row[..3], &[0.0; 3], "root velocity");
            assert_eq!(row, &clip[..72], "every frame the same");
        }
    }

    /// SPEC §13.11 test 13: only masked positions change, and a predictor that knows the original
    /// sequence gives it back.
    #[test]
    fn refill_changes_only_masked_positions_and_a_perfect_predictor_restores() {
        let original: Vec<usize> = (0..60).map(|j| (j * 7 + 3) % 128).collect();
        let keys = key_tokens(&[(8 * 25, original[25]), (8 * 31, original[31])], 8);
        let perfect = |s: usize, w: &[Option<usize>]| original[s..s + w.len()].to_vec();
        let generated: Vec<usize> = (0..60).map(|j| (j * 11) % 128).collect();
        let mut mixed = generated.clone();
        mixed[..15].copy_from_slice(&original[..15]);
        let mut outside = mixed.clone();
        for (j, t) in outside.iter_mut().enumerate() {
            if !(19..=37).contains(&j) {
                *t = original[j];
            }
        }
        let restored = refill(&outside, &keys, (RADIUS, 15, WINDOW), perfect).unwrap();
        assert_eq!(restored, original);
        // A predictor that always says 0: exactly the masked positions become 0, keys take their tokens.
        let zeros = refill(&mixed, &keys, (RADIUS, 15, WINDOW), |_, w| vec![0; w.len()]).unwrap();
        let masked = kf_mask_positions(&[25, 31], RADIUS, 15, 60).unwrap();
        for j in 0..60 {
            let want = match j {
                25 | 31 => original[j],
                _ if masked.contains(&j) => 0,
                _ => mixed[j],
            };
            assert_eq!(zeros[j], want, "token {j}");
        }
        // The predictor sees Mask (None) exactly at the masked positions of its window.
        let mut seen = Vec::new();
        refill(&mixed, &keys, (RADIUS, 15, WINDOW), |s, w| {
            seen.push((s, w.iter().filter(|x| x.is_none()).count()));
            vec![0; w.len()]
        })
        .unwrap();
        assert_eq!(seen, vec![(9, masked.len()), (15, masked.len())]);
    }
}
