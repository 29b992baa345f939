//! How well does one token carry a keyframe's pose? (docs/control.md, "Keyframe control"): for the ground
//! truth's pose at generated frames 240 and 600 of every test + val sequence, the root-relative joint error
//! (cm) at that frame of the decoded tokens, with the keyframe's token p taken (a) from the ground truth's
//! own tokens (the VQ-VAE's ceiling), (b) as the static-clip token (§13.6 `static_clip`), (c) as the
//! `paste` token (the pose written into the decoded frames of tokens p − 4 .. p + 4 and encoded again), and
//! (d) the static-clip token repeated 8 times and decoded alone; then in another dance's tokens (the next
//! sequence's, as a generated dance is another dance), (e) with the static-clip token at p alone and (f)
//! with the k tokens on each side predicted again by a keyframe-control run's module.
//!
//!   cargo run --release -p qean-pipeline --example keyframe_token_study -- KEYFRAME_RUN DATA

use std::path::PathBuf;

use burn::tensor::{Device, Tensor, TensorData};
use qean_aistpp::dataset::{Dataset, Split};
use qean_checkpoint::checkpoint::resolve_in_run;
use qean_checkpoint::gpt::FrozenVq;
use qean_checkpoint::vqvae::{denormalise, pos72_options};
use qean_eval::keyframe_fidelity::pose_error;
use qean_eval::run_report::frames_of;
use qean_models::control::keyframe::{predict_window, refill, KeyToken};
use qean_models::vqvae::VqVae;
use qean_motion::fk::FkRoot;
use qean_motion::pos72::pos72_to_joints;

fn decoded_joints(vq: &FrozenVq, tokens: &[usize], origin: [f64; 3]) -> Vec<[f64; 3]> {
    let c = vq.checkpoint.config.vq_table();
    let mut rows = VqVae::host_rows(&vq.model.decode_tokens(tokens, 1, tokens.len()));
    denormalise(&mut rows, c);
    let rows: Vec<f64> = rows.iter().map(|&v| v as f64).collect();
    pos72_to_joints(&rows, origin, &pos72_options(c))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [run, data] = args.as_slice() else {
        return Err("usage: KEYFRAME_RUN DATA".into());
    };
    let ck = resolve_in_run(&PathBuf::from(run), None)?;
    let g = ck.config.gpt_table().clone();
    let k = ck.config.keyframe_table().clone();
    let vq = FrozenVq::load(&g, ck.run_dir().as_deref())?;
    let qean_checkpoint::FamilyModel::GptKeyframe(model) = ck.load_family(&Device::flex())? else {
        return Err("not a keyframe-control run".into());
    };
    let ds = Dataset::open(&PathBuf::from(data))?;
    let mut names = ds.split(Split::Test);
    names.extend(ds.split(Split::Val));
    let mut sums = [0.0f64; 8];
    let mut count = 0usize;
    let tokens_of = |name: &str| -> Result<Vec<usize>, Box<dyn std::error::Error>> {
        let m = ds.read_motion(name)?;
        Ok(vq.tokens(&m, m.frames / g.rate * g.rate)?)
    };
    for (i, name) in names.iter().enumerate() {
        let motion = ds.read_motion(name)?;
        let n = motion.frames / g.rate;
        let gt_tokens = vq.tokens(&motion, n * g.rate)?;
        let other_name = &names[(i + 1) % names.len()];
        let other = tokens_of(other_name)?;
        let other_music = qean_aistpp::feature_cache::load(
            &ds,
            &qean_aistpp::names::music_id_of(other_name).unwrap(),
        )?
        .0;
        let other_music = ck.config.recipe.model_audio(other_music, 35);
        let joints = motion.joints(FkRoot::Smpl);
        for off in [240usize, 600] {
            let f = 120 + off;
            let p = f / g.rate;
            if p + 5 > n {
                continue;
            }
            let key = frames_of(joints[f * 24..(f + 1) * 24].to_vec())[0];
            let err = |tokens: &[usize], at: usize| {
                let j = decoded_joints(&vq, tokens, joints[0]);
                pose_error(&frames_of(j[at * 24..(at + 1) * 24].to_vec())[0], &key)
            };
            let static_token = vq.static_tokens(&[&joints[f * 24..(f + 1) * 24]])?[0];
            let mut with_static = gt_tokens.clone();
            with_static[p] = static_token;
            let paste = vq.paste_token(&gt_tokens, p, &joints[f * 24..(f + 1) * 24])?;
            let mut with_paste = gt_tokens.clone();
            with_paste[p] = paste;
            let alone = vec![static_token; 8];
            if p + 5 > other.len() {
                continue;
            }
            let mut in_other = other.clone();
            in_other[p] = static_token;
            let pasted_token = vq.paste_token(&other, p, &joints[f * 24..(f + 1) * 24])?;
            let mut pasted = other.clone();
            pasted[p] = pasted_token;
            let predict = |token: usize| {
                refill(
                    &other,
                    &[KeyToken { position: p, token }],
                    (k.radius, 15, g.window),
                    |s, inputs| {
                        let w = 280;
                        let rows: Vec<f32> = other_music[s * w..(s + inputs.len()) * w].to_vec();
                        let rows = Tensor::<3>::from_data(
                            TensorData::new(rows, [1, inputs.len(), w]),
                            &Device::flex(),
                        );
                        predict_window(&model.gpt, &model.keyframe, inputs, rows, 1)
                    },
                )
            };
            let refilled = predict(static_token)?;
            let pasted_refilled = predict(pasted_token)?;
            let e = [
                err(&gt_tokens, f),
                err(&with_static, f),
                err(&with_paste, f),
                err(&alone, 4 * g.rate + f % g.rate),
                err(&in_other, f),
                err(&refilled, f),
                err(&pasted, f),
                err(&pasted_refilled, f),
            ];
            for (s, x) in sums.iter_mut().zip(e) {
                *s += x;
            }
            count += 1;
        }
    }
    println!("{count} keyframes; root-relative joint error at the keyframe frame (cm):");
    for (label, s) in [
        "ground truth's tokens (the VQ-VAE's ceiling)",
        "token p = the static-clip token",
        "token p = the paste token",
        "the static-clip token alone, 8 times",
        "in another dance's tokens: the static-clip token at p alone",
        "in another dance's tokens: p and the k tokens on each side predicted again",
        "in another dance's tokens: the paste token at p alone",
        "in another dance's tokens: the paste token, the k on each side predicted again",
    ]
    .iter()
    .zip(sums)
    {
        println!("  {label}: {:.1}", 100.0 * s / count.max(1) as f64);
    }
    Ok(())
}
