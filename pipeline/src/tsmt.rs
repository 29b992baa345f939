//! TSMT dances from a checkpoint (SPEC §11.8): the seed quantised with the run's bins, the songs'
//! MFCC + Δ rows and beats, the KV-cached categorical sampler, then decoding (§11.2), the root
//! (`drop`: the last seed frame's; `delta`: integrated) and inverse kinematics (§11.3) to SMPL
//! rotations, exported like every other dance (pkl, joints .npy, BVH, previews).

use std::path::Path;

use qean_checkpoint::checkpoint::Checkpoint;
use qean_checkpoint::tsmt::heard_audio;
use qean_checkpoint::FamilyModel;
use qean_config::tsmt::{TsmtConfig, TsmtDecode};
use qean_io::error::{Error, Result};
use qean_models::tsmt::coarse::{upsample, Grid};
use qean_models::tsmt::sample::{generate as sample_tokens, TsmtAudio, TsmtSampling};
use qean_models::tsmt::{coords_to_joints, pose_coords, Bins};
use qean_motion::fk::FkRoot;
use qean_motion::ik::motion_from_joints;
use qean_motion::motion::Motion;
use qean_motion::skeleton::NUM_JOINTS;

use crate::generate::{export_motion, GenerateOptions, Generated, Song};

/// The sampling settings of a TSMT run with `opts`' overrides.
pub fn sampling(t: &TsmtConfig, opts: &GenerateOptions) -> TsmtSampling {
    sampling_with(
        t,
        opts.temperature,
        opts.top_k,
        opts.decode,
        opts.sample_seed,
    )
}

/// The run's sampling settings with a temperature, top-k, decoding (None: the run's) and draw seed.
pub fn sampling_with(
    t: &TsmtConfig,
    temperature: Option<f64>,
    top_k: Option<usize>,
    decode: Option<TsmtDecode>,
    seed: u64,
) -> TsmtSampling {
    let run = TsmtSampling::of_config(t, seed);
    TsmtSampling {
        temperature: temperature.unwrap_or(run.temperature),
        top_k: top_k.unwrap_or(run.top_k),
        decode: decode.unwrap_or(run.decode),
        ..run
    }
}

/// The run's bins (stored in its config, never refitted).
pub fn run_bins(ck: &Checkpoint) -> Result<Bins> {
    ck.config
        .tsmt
        .as_ref()
        .and_then(Bins::from_config)
        .ok_or_else(|| Error::at(&ck.dir, "the TSMT checkpoint's config has no bins"))
}

/// The dance of one row: the seed motion as given, then `frames` generated frames from the rollout's
/// positions (in bin units, [`qean_models::tsmt::sample::Rollout`], on `grid`: every frame when its step
/// is one), decoded, interpolated to 60 fps, rooted, smoothed over time with σ = `smooth_sigma` frames
/// (0: not) and turned into rotations by IK.
pub fn decode_dance(
    t: &TsmtConfig,
    bins: &Bins,
    seed: &Motion,
    (positions, grid): (&[f64], &Grid),
    (frames, smooth_sigma): (usize, f64),
) -> Motion {
    let n = t.coords();
    let coords = bins.decode_positions(positions);
    let real = if grid.step == 1 {
        coords[seed.frames * n..(seed.frames + frames) * n].to_vec()
    } else {
        upsample(
            grid,
            &coords,
            n,
            (seed.frames, seed.frames + frames),
            t.upsample,
        )
    };
    let seed_joints = seed.joints(FkRoot::Smpl);
    let start = seed_joints[(seed.frames - 1) * NUM_JOINTS];
    let mut joints = coords_to_joints(&real, t.root_mode, start);
    qean_motion::smooth::gaussian_smooth(&mut joints, 0, smooth_sigma);
    let tail = motion_from_joints(&joints, t.ik, FkRoot::Smpl);
    let mut poses = seed.poses.clone();
    poses.extend_from_slice(&tail.poses);
    let mut trans: Vec<f64> = seed.trans.iter().map(|x| x / seed.scaling).collect();
    trans.extend_from_slice(&tail.trans);
    Motion::new(poses, trans, 1.0).expect("whole frames")
}

/// Generated frames for a song: `frames`, or fewer when the music ends first (the frame predicted
/// at step g hears music frame g).
pub fn generated_len(frames: usize, seed_frames: usize, music_frames: usize) -> usize {
    frames.min(music_frames.saturating_sub(seed_frames))
}

/// What a batch of TSMT rollouts needs besides the checkpoint.
pub struct TsmtRollouts<'a> {
    /// Seed motion of each row (all the run's `seed_frames` long).
    pub seeds: &'a [Motion],
    /// The music of each row as 35-D features (frames × 35) and its frame count.
    pub music: &'a [(&'a [f32], usize)],
    /// Generated frames per row (each cut where its music ends).
    pub frames: usize,
    pub sampling: TsmtSampling,
    pub backend: qean_models::backend::Backend,
    /// σ in frames of the temporal filter on the decoded joints (0 = off).
    pub smooth_sigma: f64,
}

/// Samples every row in one batch and returns each row's dance (seed + generated frames) as SMPL
/// rotations.
pub fn sample_motions(
    ck: &Checkpoint,
    r: &TsmtRollouts,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Vec<Motion>> {
    let t = ck.config.tsmt();
    let bins = run_bins(ck)?;
    let device = qean_models::backend::device(r.backend).map_err(|e| Error::msg(e.to_string()))?;
    let FamilyModel::Tsmt(model) = ck.load_family(&device)? else {
        return Err(ck.not_family("a TSMT"));
    };
    let n = t.coords();
    // The model's grid: every frame, or every `frame_step`-th ending on the seed's last frame.
    let seed_frames = r.seeds.first().map_or(1, |s| s.frames);
    let grid = Grid::ending_at(seed_frames, t.frame_step);
    let seeds: Vec<Vec<u16>> = r
        .seeds
        .iter()
        .map(|m| {
            grid.rows(
                &bins.encode(&pose_coords(&m.joints(FkRoot::Smpl), t.root_mode)),
                n,
            )
        })
        .collect();
    let lengths: Vec<usize> = r
        .music
        .iter()
        .zip(r.seeds)
        .map(|((_, frames), seed)| generated_len(r.frames, seed.frames, *frames))
        .collect();
    let audio: Vec<TsmtAudio> = r
        .music
        .iter()
        .map(|(data, frames)| {
            let (mfcc, beats) = heard_audio(data, *frames, &ck.config.recipe);
            grid.audio(&TsmtAudio {
                mfcc,
                beats,
                frames: *frames,
            })
        })
        .collect();
    // Coarse frames up to one at or after each dance's last frame.
    let coarse_seed = grid.count(seed_frames);
    let steps = |l: usize| grid.count(seed_frames + l + grid.step - 1) - coarse_seed;
    let longest = lengths.iter().map(|&l| steps(l)).max().unwrap_or(0);
    let rows = sample_tokens(
        &model,
        &device,
        &seeds,
        &audio,
        longest,
        &r.sampling,
        progress,
        None,
    );
    Ok(rows
        .iter()
        .zip(r.seeds)
        .zip(&lengths)
        .map(|((rollout, seed), &l)| {
            let used = &rollout.positions[..(coarse_seed + steps(l)) * n];
            decode_dance(&t, &bins, seed, (used, &grid), (l, r.smooth_sigma))
        })
        .collect())
}

/// Dances for `songs` (one batch) from `seed`, written to `out`.
pub fn generate(
    ck: &Checkpoint,
    songs: &[Song],
    seed: &Motion,
    opts: &GenerateOptions,
    out: &Path,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<Vec<Generated>> {
    for s in songs {
        let l = generated_len(opts.frames, seed.frames, s.features.frames);
        if l < opts.frames {
            tracing::warn!(
                "{}: the music ends after {} frames: generating {l} frames instead of {}",
                s.path.display(),
                s.features.frames,
                opts.frames
            );
        }
    }
    let seeds = vec![seed.clone(); songs.len()];
    let music: Vec<(&[f32], usize)> = songs
        .iter()
        .map(|s| (s.features.data.as_slice(), s.features.frames))
        .collect();
    let motions = sample_motions(
        ck,
        &TsmtRollouts {
            seeds: &seeds,
            music: &music,
            frames: opts.frames,
            sampling: sampling(&ck.config.tsmt(), opts),
            backend: opts.backend,
            smooth_sigma: opts.smooth_sigma.unwrap_or(ck.config.tsmt().smooth_sigma),
        },
        progress,
    )?;
    let mut written = Vec::new();
    for (song, motion) in songs.iter().zip(&motions) {
        written.push(export_motion(out, song, motion, seed.frames, opts.render)?);
    }
    Ok(written)
}
