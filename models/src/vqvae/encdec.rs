//! The VQ-VAE's convolutional encoder and decoder (SPEC §13.2.2, after T2M-GPT `models/encdec.py` and
//! `models/resnet.py`): no normalisation, ReLU, pre-activation residual blocks with dilations 3^(depth−1)…1,
//! down_t stride-2 convolutions down and nearest ×2 upsampling + conv up. Tensors are [B, channels, T].

use burn::module::Module;
use burn::nn::conv::{Conv1d, Conv1dConfig, ConvTranspose1d, ConvTranspose1dConfig};
use burn::nn::{Initializer, PaddingConfig1d};
use burn::tensor::activation::relu;
use burn::tensor::{Device, Tensor};
use qean_config::vqvae::{Dilations, VqConfig, VqDecoder};

use qean_motion::pos72::POS72;

/// PyTorch's default conv init, U(±1/√(C_in·k)) for weight and bias (SPEC §13.2.2: set explicitly).
pub(crate) fn conv(
    c_in: usize,
    c_out: usize,
    k: usize,
    stride: usize,
    dilation: usize,
    pad: usize,
    device: &Device,
) -> Conv1d {
    let bound = 1.0 / ((c_in * k) as f64).sqrt();
    Conv1dConfig::new(c_in, c_out, k)
        .with_stride(stride)
        .with_dilation(dilation)
        .with_padding(PaddingConfig1d::Explicit(pad, pad))
        .with_initializer(Initializer::Uniform {
            min: -bound,
            max: bound,
        })
        .init(device)
}

/// x + Conv1d(k1)(ReLU(Conv1d(k3, dilation δ, pad δ)(ReLU(x)))).
#[derive(Module, Debug)]
pub struct ResBlock {
    pub conv1: Conv1d,
    pub conv2: Conv1d,
}

impl ResBlock {
    fn new(width: usize, dilation: usize, device: &Device) -> Self {
        ResBlock {
            conv1: conv(width, width, 3, 1, dilation, dilation, device),
            conv2: conv(width, width, 1, 1, 1, 0, device),
        }
    }

    fn forward(&self, x: Tensor<3>) -> Tensor<3> {
        let h = self.conv1.forward(relu(x.clone()));
        x + self.conv2.forward(relu(h))
    }
}

/// `depth` blocks with the dilations of `order`.
fn res_stack(width: usize, depth: usize, order: Dilations, device: &Device) -> Vec<ResBlock> {
    let mut d: Vec<usize> = (0..depth).map(|i| 3usize.pow(i as u32)).collect();
    if order == Dilations::Decreasing {
        d.reverse();
    }
    d.into_iter()
        .map(|x| ResBlock::new(width, x, device))
        .collect()
}

fn run_stack(blocks: &[ResBlock], mut x: Tensor<3>) -> Tensor<3> {
    for b in blocks {
        x = b.forward(x);
    }
    x
}

/// One downsampling stage: Conv1d(k4, s2, p1) then a residual stack.
#[derive(Module, Debug)]
pub struct Down {
    pub conv: Conv1d,
    pub stack: Vec<ResBlock>,
}

/// [B, T, 72] → z [B, T/2^down_t, C].
#[derive(Module, Debug)]
pub struct Encoder {
    pub input: Conv1d,
    pub down: Vec<Down>,
    pub output: Conv1d,
}

impl Encoder {
    pub fn new(c: &VqConfig, device: &Device) -> Self {
        let w = c.width;
        Encoder {
            input: conv(POS72, w, 3, 1, 1, 1, device),
            down: (0..c.down_t)
                .map(|_| Down {
                    conv: conv(w, w, 4, 2, 1, 1, device),
                    stack: res_stack(w, c.depth, c.enc_dilations, device),
                })
                .collect(),
            output: conv(w, c.code_dim, 3, 1, 1, 1, device),
        }
    }

    pub fn forward(&self, x: Tensor<3>) -> Tensor<3> {
        let mut h = relu(self.input.forward(x.swap_dims(1, 2)));
        for d in &self.down {
            h = run_stack(&d.stack, d.conv.forward(h));
        }
        self.output.forward(h).swap_dims(1, 2)
    }
}

/// One upsampling stage: a residual stack, then nearest ×2 and Conv1d(k3) (or ConvTranspose1d(4, 2, 1)).
#[derive(Module, Debug)]
pub struct Up {
    pub stack: Vec<ResBlock>,
    pub conv: Option<Conv1d>,
    pub transpose: Option<ConvTranspose1d>,
}

/// z [B, n, C] → [B, n·2^down_t, 72].
#[derive(Module, Debug)]
pub struct Decoder {
    pub input: Conv1d,
    pub up: Vec<Up>,
    /// Conv1d(W→W, k3) + ReLU before the output (absent with `decoder = "bailando"`).
    pub pre_output: Option<Conv1d>,
    pub output: Conv1d,
}

impl Decoder {
    pub fn new(c: &VqConfig, device: &Device) -> Self {
        let w = c.width;
        let bailando = c.decoder == VqDecoder::Bailando;
        Decoder {
            input: conv(c.code_dim, w, 3, 1, 1, 1, device),
            up: (0..c.down_t)
                .map(|_| Up {
                    stack: res_stack(w, c.depth, Dilations::Decreasing, device),
                    conv: (!bailando).then(|| conv(w, w, 3, 1, 1, 1, device)),
                    transpose: bailando.then(|| {
                        let bound = 1.0 / ((w * 4) as f64).sqrt();
                        ConvTranspose1dConfig::new([w, w], 4)
                            .with_stride(2)
                            .with_padding(1)
                            .with_initializer(Initializer::Uniform {
                                min: -bound,
                                max: bound,
                            })
                            .init(device)
                    }),
                })
                .collect(),
            pre_output: (!bailando).then(|| conv(w, w, 3, 1, 1, 1, device)),
            output: conv(w, POS72, 3, 1, 1, 1, device),
        }
    }

    pub fn forward(&self, z: Tensor<3>) -> Tensor<3> {
        let mut h = relu(self.input.forward(z.swap_dims(1, 2)));
        for u in &self.up {
            h = run_stack(&u.stack, h);
            h = match (&u.conv, &u.transpose) {
                (Some(c), _) => c.forward(upsample2(h)),
                (None, Some(t)) => t.forward(h),
                (None, None) => unreachable!("every stage has one of the two"),
            };
        }
        if let Some(p) = &self.pre_output {
            h = relu(p.forward(h));
        }
        self.output.forward(h).swap_dims(1, 2)
    }
}

/// Nearest-neighbour ×2 along time: [B, W, T] → [B, W, 2T].
fn upsample2(x: Tensor<3>) -> Tensor<3> {
    let [b, w, t] = x.dims();
    x.unsqueeze_dim::<4>(3)
        .repeat_dim(3, 2)
        .reshape([b, w, 2 * t])
}

/// Parameters by SPEC §13.9's closed forms (the `upsample` decoder).
pub fn encoder_params(c: &VqConfig) -> usize {
    let (i, w, cd, depth, down) = (POS72, c.width, c.code_dim, c.depth, c.down_t);
    3 * i * w + w + down * (4 * w * w + w + depth * (4 * w * w + 2 * w)) + 3 * w * cd + cd
}

/// The decoder's closed form (`upsample`).
pub fn decoder_params(c: &VqConfig) -> usize {
    let (i, w, cd, depth, down) = (POS72, c.width, c.code_dim, c.depth, c.down_t);
    3 * cd * w
        + w
        + down * (depth * (4 * w * w + 2 * w) + 3 * w * w + w)
        + 3 * w * w
        + w
        + 3 * w * i
        + i
}
