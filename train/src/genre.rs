//! The genre-control stage as a trainer [`Family`] (SPEC §13.5, stage 3): the GPT of `genre.gpt_run` (and its
//! VQ-VAE) frozen, and two optimisers in turn on every batch: the generator group (GEN and the eq. 3
//! cross-attention sub-layers) on CE(own genre) + λ_adv·L_adv + λ_div·L_div, then the discriminator on a fresh
//! fake (new z, genre and Gumbel noise, from the updated generator). Fakes are the teacher-forced logits of the
//! GPT under a uniformly drawn genre g′, relaxed by Gumbel straight-through and multiplied into the frozen
//! codebook; reals are the codebook rows of the true tokens under the sequence's own genre.

use std::collections::HashSet;

use burn::module::{Module, ParamId};
use burn::tensor::{Device, Tensor, TensorData};
use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::windows::{Batch, SequenceSet, WindowSpec};
use qean_config::genre::{GenreConfig, Relax, XattnOn};
use qean_config::gpt::MLayout;
use qean_config::run::RunConfig;
use qean_io::error::{Error, Result};
use qean_models::control::genre::{disc_loss, gen_adv_loss, gumbel_relax, GenreGpt};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::family::{param_ids, Family, StepContext};
use crate::gpt::{cross_entropy, gpt_of, tensors, FrozenGpt, GptFamily, GptInputs};
use qean_checkpoint::checkpoint::Checkpoint;
use qean_checkpoint::gpt::normal_noise;

/// The `[genre]` table of a genre-control run.
pub fn genre_of_config(config: &RunConfig) -> &GenreConfig {
    config.genre_table()
}

/// The genre family: the GPT family's data (tokens of the frozen VQ-VAE), the frozen GPT and codebook.
#[derive(Default)]
pub struct GenreFamily {
    base: GptFamily,
    gpt: Option<FrozenGpt>,
    /// The frozen codebook, K × C row-major (C = `genre.code_dim`).
    codebook: Vec<f32>,
    code_dim: usize,
    /// Every sequence's genre (an index into the data's vocabulary, `genre.genres`).
    genres: std::collections::HashMap<String, usize>,
}

/// A batch: the GPT's tensors, the sequences' genres and the noise of both groups.
pub struct GenreInputs {
    pub gpt: GptInputs,
    pub genres: Vec<usize>,
    pub codebook: Tensor<2>,
    /// Per group (0 = generator, 1 = discriminator): z of the fake, its genre g′, Gumbel uniforms.
    pub fake: [Fake; 2],
    /// z of the own-genre cross-entropy (and of L_div's first sample).
    pub z_own: Tensor<2>,
    pub z_div: Tensor<2>,
    /// The music the own-genre cross-entropy hears: `gpt.music` with a share `genre.music_swap` of its
    /// rows taken from windows of another genre.
    pub ce_music: Tensor<3>,
}

/// For each window of a batch, whose music its own-genre cross-entropy hears: itself, or with probability
/// `share` a window of another genre drawn uniformly (itself when the batch has none).
pub fn swap_partners(genres: &[usize], share: f64, seed: u64) -> Vec<usize> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..genres.len())
        .map(|i| {
            if share <= 0.0 || !rng.random_bool(share) {
                return i;
            }
            let others: Vec<usize> = (0..genres.len())
                .filter(|&j| genres[j] != genres[i])
                .collect();
            if others.is_empty() {
                i
            } else {
                others[rng.random_range(0..others.len())]
            }
        })
        .collect()
}

/// The noise of one fake batch.
pub struct Fake {
    pub z: Tensor<2>,
    pub genres: Vec<usize>,
    pub uniform: Tensor<3>,
}

fn fake(b: usize, n: usize, c: &GenreConfig, codes: usize, seed: u64, device: &Device) -> Fake {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let genres = (0..b)
        .map(|_| rng.random_range(0..c.genres.count()))
        .collect();
    let uniform: Vec<f32> = (0..b * n * codes)
        .map(|_| rng.random_range(1e-6f32..1.0 - 1e-6))
        .collect();
    Fake {
        z: noise_tensor(seed ^ 0x7a, b, c.z_dim, device),
        genres,
        uniform: Tensor::from_data(TensorData::new(uniform, [b, n, codes]), device),
    }
}

fn noise_tensor(seed: u64, b: usize, z: usize, device: &Device) -> Tensor<2> {
    Tensor::from_data(TensorData::new(normal_noise(seed, b * z), [b, z]), device)
}

impl GenreFamily {
    /// The genre of each window's sequence.
    fn batch_genres(&self, batch: &Batch) -> Vec<usize> {
        batch
            .names
            .iter()
            .map(|n| {
                *self
                    .genres
                    .get(n)
                    .expect("load_set keeps only sequences with a genre")
            })
            .collect()
    }

    fn codebook(&self, device: &Device) -> Tensor<2> {
        let k = self.codebook.len() / self.code_dim;
        Tensor::from_data(
            TensorData::new(self.codebook.clone(), [k, self.code_dim]),
            device,
        )
    }

    /// Token latents of a fake: relaxed logits of the K codes (End dropped) times the codebook.
    fn fake_latents(
        &self,
        model: &GenreGpt,
        x: &GenreInputs,
        f: &Fake,
        c: &GenreConfig,
    ) -> Tensor<3> {
        let g = model.genre.gen.forward(f.z.clone(), &f.genres);
        let logits =
            model
                .gpt
                .genre_logits(x.gpt.tokens.clone(), x.gpt.music.clone(), &model.genre, g);
        let [b, n, k1] = logits.dims();
        let relaxed = gumbel_relax(
            logits.narrow(2, 0, k1 - 1),
            f.uniform.clone(),
            c.tau,
            c.relax == Relax::St,
        );
        relaxed
            .reshape([b * n, k1 - 1])
            .matmul(x.codebook.clone())
            .reshape([b, n, self.code_dim])
    }

    /// L_div = |z₁ − z₂|₁ / |GEN(z₁, g) − GEN(z₂, g)|₁, per row, averaged.
    fn diversity(&self, model: &GenreGpt, x: &GenreInputs) -> Tensor<1> {
        let a = model.genre.gen.forward(x.z_own.clone(), &x.genres);
        let b = model.genre.gen.forward(x.z_div.clone(), &x.genres);
        let [rows, t, d] = a.dims();
        let num = (x.z_own.clone() - x.z_div.clone()).abs().sum_dim(1);
        let den = (a - b)
            .abs()
            .reshape([rows, t * d])
            .sum_dim(1)
            .add_scalar(1e-8);
        (num / den).mean()
    }
}

impl Family for GenreFamily {
    type Model = GenreGpt;
    type Inputs = GenreInputs;

    /// The genre module and D fresh, the GPT from `genre.gpt_run` (frozen: no gradients).
    fn init(&self, config: &RunConfig, device: &Device) -> Result<GenreGpt> {
        let mut model = GenreGpt::new(
            gpt_of(config),
            genre_of_config(config),
            genre_of_config(config).code_dim,
            device,
        );
        if let Some(frozen) = &self.gpt {
            model.gpt = frozen.load(device)?.no_grad();
        }
        Ok(model)
    }

    /// Resolves the frozen GPT (its `[gpt]` sizes must equal this config's), takes its VQ-VAE run, loads
    /// that VQ-VAE's codebook; a resumed run must find the same GPT (its weights hash).
    fn prepare(
        &mut self,
        config: &mut RunConfig,
        dataset: &Dataset,
        train: Split,
        resume: Option<&Checkpoint>,
    ) -> Result<()> {
        let (set, genres) = dataset.genres("genre control")?;
        let mut c = genre_of_config(config).clone();
        c.genres = set;
        config.genre = Some(c.clone());
        self.genres = genres;
        let frozen = FrozenGpt::resolve(c.gpt_run.as_deref(), "genre", gpt_of(config))?;
        let g = gpt_of(config);
        if g.m_layout == MLayout::TwoStream && c.xattn_on == XattnOn::Music {
            // h^M is read at the token stream: a music position's update reaches it only through the
            // self-attention of a later block, so the last block's sub-layer never has an effect.
            if g.base_layers == 1 {
                return Err(Error::msg(
                    "genre.xattn_on = \"music\" with a one-block two-stream M-Base cannot change the output \
                     (the music stream reaches the motion tokens only in later blocks): set genre.xattn_on = \"all\"",
                ));
            }
            tracing::warn!(
                "genre.xattn_on = \"music\": the last M-Base block's cross-attention cannot reach the output and stays at zero"
            );
        }
        frozen.adopt(config)?;
        self.base.prepare(config, dataset, train, resume)?;
        let vq = self
            .base
            .frozen_vq()
            .expect("the GPT family loaded its VQ-VAE");
        let [k, dim] = vq.model.codebook.val().dims();
        if dim != c.code_dim {
            return Err(Error::at(
                &vq.checkpoint.dir,
                format!(
                    "the VQ-VAE's codes are {dim}-D, genre.code_dim is {} (D reads them as latents)",
                    c.code_dim
                ),
            ));
        }
        self.codebook = vq
            .model
            .codebook
            .val()
            .into_data()
            .convert::<f32>()
            .try_to_vec::<f32>()
            .map_err(|e| Error::msg(format!("codebook: {e:?}")))?;
        debug_assert_eq!(self.codebook.len(), k * dim);
        self.code_dim = dim;
        frozen.confirm(resume, "genre")?;
        self.gpt = Some(frozen);
        Ok(())
    }

    fn draw_spec(&self, config: &RunConfig) -> WindowSpec {
        self.base.draw_spec(config)
    }

    /// The GPT family's token windows; every sequence must name its genre (AIST++ `gBR…`).
    fn load_set(
        &self,
        dataset: &Dataset,
        split: Split,
        spec: WindowSpec,
        config: &RunConfig,
    ) -> Result<SequenceSet> {
        let set = self.base.load_set(dataset, split, spec, config)?;
        if let Some(s) = set
            .sequences
            .iter()
            .find(|s| !self.genres.contains_key(&s.name))
        {
            return Err(Error::at(
                dataset.motion_path(&s.name),
                "genre control needs every dance's genre (an AIST++ name such as gBR_sBM_cAll_d04_mBR0_ch02, a \
                 FineDance label_json/ file); this sequence has none",
            ));
        }
        Ok(set)
    }

    fn inputs(
        &self,
        drawn: Batch,
        _model: &GenreGpt,
        device: &Device,
        ctx: &StepContext,
    ) -> GenreInputs {
        let (g, c) = (gpt_of(ctx.config), genre_of_config(ctx.config));
        let genres = self.batch_genres(&drawn);
        let b = genres.len();
        let seed = ctx.rng_seed;
        let gpt = tensors(&drawn, g, g.m_pkeep, seed, device);
        let partners = swap_partners(&genres, c.music_swap, seed ^ 0x7377_6170);
        let ce_music = if partners.iter().enumerate().all(|(i, &j)| i == j) {
            gpt.music.clone()
        } else {
            let idx: Vec<i64> = partners.iter().map(|&j| j as i64).collect();
            gpt.music
                .clone()
                .select(0, Tensor::from_data(TensorData::new(idx, [b]), device))
        };
        GenreInputs {
            gpt,
            genres,
            codebook: self.codebook(device),
            fake: [
                fake(b, g.window, c, g.codes, seed ^ 0x6765_6e31, device),
                fake(b, g.window, c, g.codes, seed ^ 0x6765_6e32, device),
            ],
            z_own: noise_tensor(seed ^ 0x6f77_6e00, b, c.z_dim, device),
            z_div: noise_tensor(seed ^ 0x6469_7600, b, c.z_dim, device),
            ce_music,
        }
    }

    fn loss(&self, model: &GenreGpt, inputs: GenreInputs, config: &RunConfig) -> Tensor<1> {
        self.group_loss(model, &inputs, 0, config)
    }

    fn param_groups(&self, model: &GenreGpt) -> Vec<HashSet<ParamId>> {
        vec![param_ids(&model.genre), param_ids(&model.disc)]
    }

    /// Group 0 (GEN + cross-attention): CE on the own genre (over `ce_music`: the own music unless
    /// `genre.music_swap`) + λ_adv·L_G,adv + λ_div·L_div. Group 1 (D):
    /// L_D on the real latents (own genre) and a fresh, detached fake.
    fn group_loss(
        &self,
        model: &GenreGpt,
        x: &GenreInputs,
        group: usize,
        config: &RunConfig,
    ) -> Tensor<1> {
        let c = genre_of_config(config);
        let music = x.gpt.music.clone();
        if group == 0 {
            let g = model.genre.gen.forward(x.z_own.clone(), &x.genres);
            let logits =
                model
                    .gpt
                    .genre_logits(x.gpt.tokens.clone(), x.ce_music.clone(), &model.genre, g);
            let mut loss = cross_entropy(logits, x.gpt.targets.clone());
            let f = &x.fake[0];
            let fake = self.fake_latents(model, x, f, c);
            let d_fake = model.disc.forward(fake, music, &f.genres);
            loss = loss + gen_adv_loss(d_fake, c.gan_loss).mul_scalar(c.lambda_adv);
            if c.lambda_div > 0.0 {
                loss = loss + self.diversity(model, x).mul_scalar(c.lambda_div);
            }
            return loss;
        }
        let f = &x.fake[1];
        let fake = self.fake_latents(model, x, f, c).detach();
        let [b, n] = x.gpt.targets.dims();
        let real = x
            .codebook
            .clone()
            .select(0, x.gpt.targets.clone().reshape([b * n]))
            .reshape([b, n, self.code_dim]);
        let d_real = model.disc.forward(real, music.clone(), &x.genres);
        let d_fake = model.disc.forward(fake, music, &f.genres);
        disc_loss(d_real, d_fake, c.gan_loss)
    }

    /// Teacher-forced cross-entropy with the genre module on each sequence's own genre (z from seed 0).
    fn validation_loss(
        &self,
        model: &GenreGpt,
        set: &SequenceSet,
        config: &RunConfig,
        device: &Device,
    ) -> f64 {
        let (g, c) = (gpt_of(config), genre_of_config(config));
        crate::family::mean_over_first_windows(set, config.train.batch_size, |batch| {
            let genres = self.batch_genres(&batch);
            let z = noise_tensor(0, genres.len(), c.z_dim, device);
            let x = tensors(&batch, g, 1.0, 0, device);
            let gz = model.genre.gen.forward(z, &genres);
            cross_entropy(
                model.gpt.genre_logits(x.tokens, x.music, &model.genre, gz),
                x.targets,
            )
        })
    }

    /// The frozen GPT's and VQ-VAE's checkpoints and weights hashes (a resume checks the GPT's).
    fn checkpoint_state(&self) -> Option<serde_json::Value> {
        self.gpt.as_ref()?.stage_state(self.base.checkpoint_state())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::tensor::Distribution;
    use qean_config::gpt::GptConfig;
    use qean_models::params::named_parameters;

    /// Share 0 keeps every window's own music; share 1 gives every window a partner of another genre
    /// where the batch has one; the draw is the seed's.
    #[test]
    fn swap_partners_pick_another_genre() {
        let genres = [0, 0, 1, 2, 2, 2];
        assert_eq!(swap_partners(&genres, 0.0, 7), vec![0, 1, 2, 3, 4, 5]);
        for seed in 0..20 {
            let p = swap_partners(&genres, 1.0, seed);
            assert!(
                p.iter().enumerate().all(|(i, &j)| genres[i] != genres[j]),
                "{p:?}"
            );
            assert_eq!(p, swap_partners(&genres, 1.0, seed));
        }
        assert_eq!(swap_partners(&[3, 3, 3], 1.0, 1), vec![0, 1, 2]);
        let half: usize = (0..200)
            .map(|s| {
                let p = swap_partners(&genres, 0.5, s);
                p.iter().enumerate().filter(|(i, &j)| *i != j).count()
            })
            .sum();
        assert!(
            (480..720).contains(&half),
            "{half} of 1200 swapped at share 0.5"
        );
    }

    /// One generator-group update moves the genre module (W_o leaves zero) and nothing else, even with the
    /// GPT's parameters marked no-grad.
    #[test]
    fn a_group_update_moves_only_its_group() {
        let device = Device::flex().autodiff();
        let g = GptConfig::tiny();
        let c = GenreConfig::tiny();
        let mut model = GenreGpt::new(&g, &c, 64, &device);
        model.gpt = model.gpt.no_grad();
        let n = g.window;
        let tokens = Tensor::<2, burn::tensor::Int>::from_data(
            TensorData::new((0..n as i64).collect::<Vec<_>>(), [1, n]),
            &device,
        );
        let music = Tensor::<3>::random([1, n, 280], Distribution::Normal(0.0, 1.0), &device);
        let z = Tensor::<2>::random([1, 16], Distribution::Normal(0.0, 1.0), &device);
        let gz = model.genre.gen.forward(z, &[2]);
        let loss = model
            .gpt
            .genre_logits(tokens, music, &model.genre, gz)
            .powi_scalar(2)
            .mean()
            .reshape([1]);
        let before = named_parameters(&model);
        let mut optim = crate::trainer::adam(&RunConfig::default());
        let keep = param_ids(&model.genre);
        let (after, _) =
            crate::trainer::apply_group_update(model, &mut optim, loss, &keep, 1e-3, 0.0);
        // The discriminator's group after it leaves the generator's update in place.
        let x = Tensor::<3>::random([1, n, 64], Distribution::Normal(0.0, 1.0), &device);
        let y = Tensor::<3>::random([1, n, 280], Distribution::Normal(0.0, 1.0), &device);
        let d_loss = after
            .disc
            .forward(x, y, &[1])
            .powi_scalar(2)
            .mean()
            .reshape([1]);
        let mut d_optim = crate::trainer::adam(&RunConfig::default());
        let d_keep = param_ids(&after.disc);
        let (after, _) =
            crate::trainer::apply_group_update(after, &mut d_optim, d_loss, &d_keep, 1e-3, 0.0);
        let after = named_parameters(&after);
        let moved: Vec<&str> = before
            .iter()
            .zip(&after)
            .filter(|(a, b)| a.values != b.values)
            .map(|(a, _)| a.name.as_str())
            .collect();
        assert!(moved.contains(&"genre.xattn.0.out.weight"), "{moved:?}");
        assert!(moved.contains(&"disc.pool.weight"), "{moved:?}");
        assert!(moved.iter().all(|n| !n.starts_with("gpt.")), "{moved:?}");
    }
}
