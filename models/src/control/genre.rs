//! Genre control (SPEC §13.5, after MNET): the genre embedding network GEN (noise z and genre g → genre
//! tokens G), the eq. 3 cross-attention sub-layer that every M-Base block gains after its self-attention,
//! the multi-genre discriminator D, the Gumbel straight-through relaxation of the GPT's logits and the
//! eq. 4 adversarial losses. The GPT itself stays frozen in this stage.

use burn::module::{Module, Param};
use burn::nn::{
    Dropout, DropoutConfig, Initializer, LayerNorm, LayerNormConfig, Linear, LinearConfig,
};
use burn::tensor::activation::{gelu, softmax, softplus};
use burn::tensor::{Device, Tensor, TensorData};
use qean_config::genre::{GanLoss, GenreConfig, XattnOn};
use qean_config::gpt::GptConfig;

use crate::attention::{merge_heads, split_heads};
use crate::control::gpt::{music_token_dim, Gpt};

fn layer_norm(d: usize, device: &Device) -> LayerNorm {
    LayerNormConfig::new(d).with_epsilon(1e-5).init(device)
}

/// PyTorch's default Linear initialisation (MNET builds its layers with `nn.Linear`).
fn linear(d_in: usize, d_out: usize, bias: bool, device: &Device) -> Linear {
    LinearConfig::new(d_in, d_out).with_bias(bias).init(device)
}

/// A [B, count, 1] one-hot of the genres, for selecting one branch per row.
fn one_hot(genres: &[usize], count: usize, device: &Device) -> Tensor<3> {
    let mut v = vec![0f32; genres.len() * count];
    for (i, &g) in genres.iter().enumerate() {
        v[i * count + g] = 1.0;
    }
    Tensor::from_data(TensorData::new(v, [genres.len(), count, 1]), device)
}

/// GEN (MNET `MappingNet`): shared Linear(z → D) GELU Linear(D → D) GELU, then one of 10 branches
/// Linear(D → D) GELU Linear(D → n_g·D), reshaped to the genre tokens G [n_g, D].
#[derive(Module, Debug)]
pub struct MappingNet {
    pub shared_in: Linear,
    pub shared_out: Linear,
    pub branch_in: Vec<Linear>,
    pub branch_out: Vec<Linear>,
    tokens: usize,
}

impl MappingNet {
    pub fn new(
        z_dim: usize,
        d: usize,
        tokens: usize,
        genres: usize,
        device: &Device,
    ) -> MappingNet {
        MappingNet {
            shared_in: linear(z_dim, d, true, device),
            shared_out: linear(d, d, true, device),
            branch_in: (0..genres).map(|_| linear(d, d, true, device)).collect(),
            branch_out: (0..genres)
                .map(|_| linear(d, tokens * d, true, device))
                .collect(),
            tokens,
        }
    }

    /// G [B, n_g, D] for noise z [B, z] and one genre per row (every branch runs, as MNET's; the
    /// others' outputs are multiplied by zero).
    pub fn forward(&self, z: Tensor<2>, genres: &[usize]) -> Tensor<3> {
        let device = z.device();
        let h = gelu(self.shared_out.forward(gelu(self.shared_in.forward(z))));
        let all: Vec<Tensor<3>> = self
            .branch_in
            .iter()
            .zip(&self.branch_out)
            .map(|(a, b)| b.forward(gelu(a.forward(h.clone()))).unsqueeze_dim::<3>(1))
            .collect();
        let count = self.branch_in.len();
        let picked = (Tensor::cat(all, 1) * one_hot(genres, count, &device)).sum_dim(1);
        let [b, _, e] = picked.dims();
        picked.reshape([b, self.tokens, e / self.tokens])
    }
}

/// The eq. 3 cross-attention sub-layer: q = LN(x)·W_q, k = G·W_k, v = G·W_v (no biases); per head
/// softmax(q_h k_hᵀ/√d_h + B)·v_h; concat → W_o (+ bias) → dropout. W_o and its bias start at zero, so the
/// sub-layer starts as the identity of the residual stream [DECISION].
#[derive(Module, Debug)]
pub struct CrossAttention {
    pub ln: LayerNorm,
    pub query: Linear,
    pub key: Linear,
    pub value: Linear,
    pub out: Linear,
    /// B ∈ R^{n × n_g}, shared by the heads, randn-initialised (MNET's `pe`).
    pub bias: Param<Tensor<2>>,
    pub dropout: Dropout,
    heads: usize,
}

impl CrossAttention {
    pub fn new(
        d: usize,
        heads: usize,
        n: usize,
        n_g: usize,
        dropout: f64,
        device: &Device,
    ) -> Self {
        CrossAttention {
            ln: layer_norm(d, device),
            query: linear(d, d, false, device),
            key: linear(d, d, false, device),
            value: linear(d, d, false, device),
            out: Linear {
                weight: Initializer::Zeros.init([d, d], device),
                bias: Some(Initializer::Zeros.init([d], device)),
            },
            bias: Initializer::Normal {
                mean: 0.0,
                std: 1.0,
            }
            .init([n, n_g], device),
            dropout: DropoutConfig::new(dropout).init(),
            heads,
        }
    }

    /// Eq. 3 before W_o: [B, L, D] for queries x [B, L, D] (L = streams × n_q positions, position j mod n_q
    /// takes row j of B) and genre tokens g [B, n_g, D].
    pub fn attend(&self, x: Tensor<3>, g: Tensor<3>, streams: usize) -> Tensor<3> {
        let l = x.dims()[1];
        let q = split_heads(self.query.forward(self.ln.forward(x)), self.heads);
        let k = split_heads(self.key.forward(g.clone()), self.heads);
        let v = split_heads(self.value.forward(g), self.heads);
        let d_h = q.dims()[3];
        let rows = self.bias.val().narrow(0, 0, l / streams);
        let rows = Tensor::cat(vec![rows; streams], 0);
        let scores = q
            .mul_scalar(1.0 / (d_h as f64).sqrt())
            .matmul(k.swap_dims(2, 3))
            + rows.unsqueeze::<4>();
        merge_heads(softmax(scores, 3).matmul(v))
    }

    /// The residual update W_o·eq. 3, after dropout.
    pub fn forward(&self, x: Tensor<3>, g: Tensor<3>, streams: usize) -> Tensor<3> {
        self.dropout
            .forward(self.out.forward(self.attend(x, g, streams)))
    }
}

/// What the M-Base gains: GEN and one cross-attention sub-layer per M-Base block.
#[derive(Module, Debug)]
pub struct GenreModule {
    pub gen: MappingNet,
    pub xattn: Vec<CrossAttention>,
    all_positions: bool,
}

impl GenreModule {
    pub fn new(g: &GptConfig, c: &GenreConfig, device: &Device) -> GenreModule {
        GenreModule {
            gen: MappingNet::new(c.z_dim, g.hidden, c.tokens, c.genres.count(), device),
            xattn: (0..g.base_layers)
                .map(|_| {
                    CrossAttention::new(g.hidden, g.heads, g.window, c.tokens, c.dropout, device)
                })
                .collect(),
            all_positions: c.xattn_on == XattnOn::All,
        }
    }

    /// Whether both M-Base streams query the genre tokens (`xattn_on = "all"`).
    pub fn all_positions(&self) -> bool {
        self.all_positions
    }
}

/// One non-causal discriminator layer (pre-LN): MNET attention (q/k/v without bias, output with bias,
/// a learned score bias B_D over the 2n positions) and a GELU feed-forward, dropout on both.
#[derive(Module, Debug)]
pub struct DiscLayer {
    pub ln1: LayerNorm,
    pub query: Linear,
    pub key: Linear,
    pub value: Linear,
    pub out: Linear,
    pub bias: Param<Tensor<2>>,
    pub ln2: LayerNorm,
    pub fc: Linear,
    pub fc_out: Linear,
    pub dropout: Dropout,
    heads: usize,
}

impl DiscLayer {
    fn new(c: &GenreConfig, positions: usize, device: &Device) -> DiscLayer {
        let d = c.disc_width;
        DiscLayer {
            ln1: layer_norm(d, device),
            query: linear(d, d, false, device),
            key: linear(d, d, false, device),
            value: linear(d, d, false, device),
            out: linear(d, d, true, device),
            bias: Initializer::Normal {
                mean: 0.0,
                std: 1.0,
            }
            .init([positions, positions], device),
            ln2: layer_norm(d, device),
            fc: linear(d, c.disc_ff, true, device),
            fc_out: linear(c.disc_ff, d, true, device),
            dropout: DropoutConfig::new(c.dropout).init(),
            heads: c.disc_heads,
        }
    }

    fn forward(&self, x: Tensor<3>) -> Tensor<3> {
        let l = x.dims()[1];
        let h = self.ln1.forward(x.clone());
        let q = split_heads(self.query.forward(h.clone()), self.heads);
        let k = split_heads(self.key.forward(h.clone()), self.heads);
        let v = split_heads(self.value.forward(h), self.heads);
        let d_h = q.dims()[3];
        let b = self.bias.val().narrow(0, 0, l).narrow(1, 0, l);
        let scores = q
            .mul_scalar(1.0 / (d_h as f64).sqrt())
            .matmul(k.swap_dims(2, 3))
            + b.unsqueeze::<4>();
        let att = merge_heads(self.dropout.forward(softmax(scores, 3)).matmul(v));
        let x = x + self.dropout.forward(self.out.forward(att));
        let h = gelu(self.fc.forward(self.ln2.forward(x.clone())));
        x + self.dropout.forward(self.fc_out.forward(h))
    }
}

/// D(x, g, y) (MNET `DanceDiscriminator`, at token rate): latents [B, n, C] and music tokens [B, n, 280]
/// projected to D_d and concatenated along time (latents first), the layers, time mean, Linear GELU, and
/// one logit per genre of which head g is the output.
#[derive(Module, Debug)]
pub struct Discriminator {
    pub latent_in: Linear,
    pub music_in: Linear,
    pub layers: Vec<DiscLayer>,
    pub pool: Linear,
    /// The 10 genre heads Linear(D_d → 1), as one Linear(D_d → 10).
    pub heads: Linear,
    use_music: bool,
}

impl Discriminator {
    pub fn new(g: &GptConfig, c: &GenreConfig, code_dim: usize, device: &Device) -> Self {
        let d = c.disc_width;
        Discriminator {
            latent_in: linear(code_dim, d, true, device),
            music_in: linear(music_token_dim(g), d, true, device),
            layers: (0..c.disc_layers)
                .map(|_| DiscLayer::new(c, 2 * g.window, device))
                .collect(),
            pool: linear(d, d, true, device),
            heads: linear(d, c.genres.count(), true, device),
            use_music: c.disc_music,
        }
    }

    /// Every genre head's logit [B, 10].
    pub fn all_heads(&self, latents: Tensor<3>, music: Tensor<3>) -> Tensor<2> {
        let x = self.latent_in.forward(latents);
        let mut x = if self.use_music {
            Tensor::cat(vec![x, self.music_in.forward(music)], 1)
        } else {
            x
        };
        for layer in &self.layers {
            x = layer.forward(x);
        }
        let pooled = x.mean_dim(1).squeeze_dim::<2>(1);
        self.heads.forward(gelu(self.pool.forward(pooled)))
    }

    /// D(x, g, y) [B]: head g of each row.
    pub fn forward(&self, latents: Tensor<3>, music: Tensor<3>, genres: &[usize]) -> Tensor<1> {
        let device = latents.device();
        let all = self.all_heads(latents, music);
        let count = all.dims()[1];
        (all * one_hot(genres, count, &device).squeeze_dim::<2>(2))
            .sum_dim(1)
            .reshape([genres.len()])
    }
}

/// The genre stage's model: the frozen GPT, the genre module and D (one checkpoint holds all three; the
/// sampler keeps the first two).
#[derive(Module, Debug)]
pub struct GenreGpt {
    pub gpt: Gpt,
    pub genre: GenreModule,
    pub disc: Discriminator,
}

impl GenreGpt {
    pub fn new(g: &GptConfig, c: &GenreConfig, code_dim: usize, device: &Device) -> GenreGpt {
        GenreGpt {
            gpt: Gpt::new(g, device),
            genre: GenreModule::new(g, c, device),
            disc: Discriminator::new(g, c, code_dim, device),
        }
    }
}

/// SPEC §13.9's closed forms: (GEN, cross-attention, D).
pub fn genre_params(g: &GptConfig, c: &GenreConfig, code_dim: usize) -> (usize, usize, usize) {
    let (d, n, ng) = (g.hidden, g.window, c.tokens);
    let genres = c.genres.count();
    let gen = c.z_dim * d + d + d * d + d + genres * (d * d + d + d * ng * d + ng * d);
    let xattn = g.base_layers * (4 * d * d + 3 * d + n * ng);
    let (dd, f) = (c.disc_width, c.disc_ff);
    let disc = (code_dim + music_token_dim(g) + 2) * dd
        + c.disc_layers * (4 * dd * dd + 6 * dd + 4 * n * n + 2 * f * dd + f)
        + dd * dd
        + dd
        + genres * (dd + 1);
    (gen, xattn, disc)
}

/// Fake token latents' relaxation: y_soft = softmax((ℓ + γ)/τ) with γ = −ln(−ln U) from `uniform` (same
/// shape as the logits, values in (0, 1)); `hard` returns onehot(argmax y_soft) − sg(y_soft) + y_soft, whose
/// forward is one-hot and whose gradient is softmax's.
pub fn gumbel_relax(logits: Tensor<3>, uniform: Tensor<3>, tau: f64, hard: bool) -> Tensor<3> {
    let gumbel = uniform.log().neg().log().neg();
    let soft = softmax((logits + gumbel).div_scalar(tau), 2);
    if !hard {
        return soft;
    }
    let dims = soft.dims();
    let max = soft.clone().max_dim(2).expand(dims);
    let onehot = soft.clone().greater_equal(max).float();
    onehot - soft.clone().detach() + soft
}

/// −log σ(x) = softplus(−x).
fn neg_log_sigmoid(x: Tensor<1>) -> Tensor<1> {
    softplus(x.neg(), 1.0)
}

/// The discriminator's loss (eq. 4 or hinge) from its logits on real and fake rows.
pub fn disc_loss(real: Tensor<1>, fake: Tensor<1>, kind: GanLoss) -> Tensor<1> {
    match kind {
        GanLoss::Nsgan => (neg_log_sigmoid(real) + neg_log_sigmoid(fake.neg())).mean(),
        GanLoss::Hinge => (real.neg().add_scalar(1.0).clamp_min(0.0).mean()
            + fake.add_scalar(1.0).clamp_min(0.0).mean())
        .mul_scalar(0.5),
    }
}

/// The generator's adversarial term from D's logits on fake rows.
pub fn gen_adv_loss(fake: Tensor<1>, kind: GanLoss) -> Tensor<1> {
    match kind {
        GanLoss::Nsgan => neg_log_sigmoid(fake).mean(),
        GanLoss::Hinge => fake.mean().neg(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use burn::tensor::Distribution;

    #[test]
    fn parameter_counts_equal_the_spec() {
        let device = Device::flex();
        for (g, c, code_dim, want) in [
            (
                GptConfig::tiny(),
                GenreConfig::tiny(),
                64,
                (88_448, 33_184, 95_562),
            ),
            (
                GptConfig::paper(),
                GenreConfig::paper(),
                512,
                (12_599_808, 14_169_792, 23_271_178),
            ),
        ] {
            let m = GenreGpt::new(&g, &c, code_dim, &device);
            let xattn: usize = m.genre.xattn.iter().map(|x| x.num_params()).sum();
            assert_eq!((m.genre.gen.num_params(), xattn, m.disc.num_params()), want);
            assert_eq!(genre_params(&g, &c, code_dim), want);
        }
    }

    fn values<const D: usize>(t: Tensor<D>) -> Vec<f32> {
        t.into_data().convert::<f32>().try_to_vec::<f32>().unwrap()
    }

    /// §13.11 test 10: with one genre token eq. 3 returns G·W_v at every query, whatever B is.
    #[test]
    fn one_genre_token_returns_g_for_any_bias() {
        let device = Device::flex();
        let mut xa = CrossAttention::new(16, 4, 8, 1, 0.0, &device);
        let x = Tensor::<3>::random([2, 8, 16], Distribution::Normal(0.0, 1.0), &device);
        let g = Tensor::<3>::random([2, 1, 16], Distribution::Normal(0.0, 1.0), &device);
        let want = xa.value.forward(g.clone()).expand([2, 8, 16]);
        for scale in [0.0, 1.0, 50.0] {
            xa.bias = Param::from_tensor(xa.bias.val().mul_scalar(scale));
            let got = xa.attend(x.clone(), g.clone(), 1);
            let diff: f32 = (got - want.clone()).abs().max().into_scalar();
            assert!(diff < 1e-6, "scale {scale}: {diff}");
        }
        // Zero-initialised W_o: the residual update is exactly zero.
        let update = values(xa.forward(x, g, 1));
        assert!(update.iter().all(|v| *v == 0.0));
    }

    /// §13.11 test 10: with W_o and its bias at zero (as initialised) the genre module leaves the stage-2
    /// logits bit-equal, whichever positions query G; a non-zero W_o changes them.
    #[test]
    fn zero_initialised_genre_module_is_a_no_op() {
        let device = Device::flex();
        let g = GptConfig {
            dropout: 0.0,
            ..GptConfig::tiny()
        };
        for xattn_on in [XattnOn::Music, XattnOn::All] {
            let c = GenreConfig {
                dropout: 0.0,
                xattn_on,
                ..GenreConfig::tiny()
            };
            let mut m = GenreGpt::new(&g, &c, 64, &device);
            let n = g.window;
            let tokens = Tensor::<2, burn::tensor::Int>::from_data(
                TensorData::new((0..n as i64).map(|i| (i * 5) % 128).collect(), [1, n]),
                &device,
            );
            let music = Tensor::<3>::random([1, n, 280], Distribution::Normal(0.0, 1.0), &device);
            let z = Tensor::<2>::random([1, 16], Distribution::Normal(0.0, 1.0), &device);
            let gz = m.genre.gen.forward(z, &[3]);
            let plain = values(m.gpt.music_logits(tokens.clone(), music.clone()));
            let with =
                values(
                    m.gpt
                        .genre_logits(tokens.clone(), music.clone(), &m.genre, gz.clone()),
                );
            assert_eq!(plain, with);
            m.genre.xattn[0].out.weight = Param::from_tensor(Tensor::random(
                [64, 64],
                Distribution::Normal(0.0, 0.1),
                &device,
            ));
            let moved = values(m.gpt.genre_logits(tokens, music, &m.genre, gz));
            assert_ne!(plain, moved);
        }
    }

    /// Eq. 3 with several genre tokens equals a direct transcription (per head, B added to the scores).
    #[test]
    fn cross_attention_matches_a_direct_transcription() {
        let device = Device::flex();
        let (d, heads, n, ng) = (8, 2, 4, 3);
        let xa = CrossAttention::new(d, heads, n, ng, 0.0, &device);
        let x = Tensor::<3>::random([1, n, d], Distribution::Normal(0.0, 1.0), &device);
        let g = Tensor::<3>::random([1, ng, d], Distribution::Normal(0.0, 1.0), &device);
        let got = values(xa.attend(x.clone(), g.clone(), 1));
        let q = values(xa.query.forward(xa.ln.forward(x)));
        let k = values(xa.key.forward(g.clone()));
        let v = values(xa.value.forward(g));
        let b = values(xa.bias.val());
        let d_h = d / heads;
        for i in 0..n {
            for h in 0..heads {
                let s: Vec<f64> = (0..ng)
                    .map(|j| {
                        (0..d_h)
                            .map(|u| (q[i * d + h * d_h + u] * k[j * d + h * d_h + u]) as f64)
                            .sum::<f64>()
                            / (d_h as f64).sqrt()
                            + b[i * ng + j] as f64
                    })
                    .collect();
                let m = s.iter().cloned().fold(f64::MIN, f64::max);
                let e: Vec<f64> = s.iter().map(|v| (v - m).exp()).collect();
                let z: f64 = e.iter().sum();
                for u in 0..d_h {
                    let want: f64 = (0..ng)
                        .map(|j| e[j] / z * v[j * d + h * d_h + u] as f64)
                        .sum();
                    let have = got[i * d + h * d_h + u] as f64;
                    assert!((have - want).abs() < 1e-5, "{have} vs {want}");
                }
            }
        }
    }

    /// GEN selects branch g: its output equals branch g run by hand.
    #[test]
    fn gen_selects_the_genre_branch() {
        let device = Device::flex();
        let gen = MappingNet::new(4, 8, 2, 10, &device);
        let z = Tensor::<2>::random([3, 4], Distribution::Normal(0.0, 1.0), &device);
        let genres = [7, 0, 3];
        let got = values(gen.forward(z.clone(), &genres));
        let h = gelu(gen.shared_out.forward(gelu(gen.shared_in.forward(z))));
        for (row, &g) in genres.iter().enumerate() {
            let want = values(
                gen.branch_out[g]
                    .forward(gelu(gen.branch_in[g].forward(h.clone())))
                    .narrow(0, row, 1),
            );
            assert_eq!(&got[row * 16..(row + 1) * 16], &want[..]);
        }
    }

    /// D's output is head g of its genre heads and nothing else.
    #[test]
    fn discriminator_output_is_head_g() {
        let device = Device::flex();
        let g = GptConfig::tiny();
        let c = GenreConfig {
            dropout: 0.0,
            ..GenreConfig::tiny()
        };
        let d = Discriminator::new(&g, &c, 64, &device);
        let x = Tensor::<3>::random([2, 16, 64], Distribution::Normal(0.0, 1.0), &device);
        let y = Tensor::<3>::random([2, 16, 280], Distribution::Normal(0.0, 1.0), &device);
        let all = values(d.all_heads(x.clone(), y.clone()));
        for genres in [[2, 9], [5, 5]] {
            let out = values(d.forward(x.clone(), y.clone(), &genres));
            assert_eq!(out, vec![all[genres[0]], all[10 + genres[1]]]);
        }
    }

    /// §13.11 test 11: the Gumbel straight-through forward is one-hot and its gradient equals the
    /// Gumbel softmax's.
    #[test]
    fn gumbel_straight_through_is_one_hot_with_the_softmax_gradient() {
        let device = Device::flex().autodiff();
        let logits = Tensor::<3>::random([2, 3, 5], Distribution::Normal(0.0, 1.0), &device);
        let u = Tensor::<3>::random([2, 3, 5], Distribution::Uniform(0.01, 0.99), &device);
        let w = Tensor::<3>::random([2, 3, 5], Distribution::Normal(0.0, 1.0), &device);
        let grad_of = |hard: bool| {
            let l = logits.clone().require_grad();
            let y = gumbel_relax(l.clone(), u.clone(), 0.7, hard);
            let out = values(y.clone());
            let grads = (y * w.clone()).sum().backward();
            (out, values(l.grad(&grads).unwrap()))
        };
        let (hard, g_hard) = grad_of(true);
        let (soft, g_soft) = grad_of(false);
        for (row, s) in hard.chunks(5).zip(soft.chunks(5)) {
            assert_eq!(row.iter().filter(|v| **v == 1.0).count(), 1);
            assert_eq!(row.iter().filter(|v| **v == 0.0).count(), 4);
            let argmax = (0..5).max_by(|&a, &b| s[a].total_cmp(&s[b])).unwrap();
            assert_eq!(row[argmax], 1.0);
        }
        for (a, b) in g_hard.iter().zip(&g_soft) {
            assert!((a - b).abs() < 1e-6, "{a} vs {b}");
        }
    }

    /// §13.11 test 11: the GAN losses on fixed logits.
    #[test]
    fn gan_losses_on_fixed_logits() {
        let device = Device::flex();
        let t = |v: Vec<f32>| Tensor::<1>::from_data(TensorData::new(v, [2]), &device);
        let (real, fake) = (vec![2.0f32, -1.0], vec![0.5f32, -3.0]);
        let sp = |x: f64| (1.0 + x.exp()).ln();
        let ns_d = ((sp(-2.0) + sp(1.0)) + (sp(0.5) + sp(-3.0))) / 2.0;
        let ns_g = (sp(-0.5) + sp(3.0)) / 2.0;
        let hinge_d = 0.5 * ((0.0 + 2.0) / 2.0 + (1.5 + 0.0) / 2.0);
        let hinge_g = -(0.5 - 3.0) / 2.0;
        let got = |x: Tensor<1>| x.into_scalar::<f32>() as f64;
        assert!(
            (got(disc_loss(t(real.clone()), t(fake.clone()), GanLoss::Nsgan)) - ns_d).abs() < 1e-6
        );
        assert!((got(gen_adv_loss(t(fake.clone()), GanLoss::Nsgan)) - ns_g).abs() < 1e-6);
        assert!((got(disc_loss(t(real), t(fake.clone()), GanLoss::Hinge)) - hinge_d).abs() < 1e-6);
        assert!((got(gen_adv_loss(t(fake), GanLoss::Hinge)) - hinge_g).abs() < 1e-6);
    }
}
