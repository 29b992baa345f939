#!/usr/bin/env python3
"""PyTorch (CPU) peer of `qean bench`: mint's FACT (SPEC §4.1-4.2) with the same shapes, one Adam training
step and the batched autoregressive sampling loop (SPEC §6), timed the way qean times its own.

    python bench/peer/fact_torch.py --size mint|tiny --what train|sample [--batch 16] [--steps 3]
        [--frames 1200] [--sequences 40] [--threads N]

Prints one JSON object (what `qean bench` reads): `value` is seconds per step (train, median) or generated
frames per second (sample); also the parameter count (120,406,977 at mint size: a check that the model is the same) and peak RSS. Weights are random (the
timing does not depend on them). Sampling uses the same shortcut as qean: only the first output token is
read, so the last cross-modal layer computes queries, the MLP and the output head for token 0 alone.
"""
import argparse
import json
import math
import time

import torch
from torch import nn
import torch.nn.functional as F

from rss import peak_rss_mb, reset_peak_rss

SIZES = {
    # hidden, heads, ffn, motion layers, audio layers, cross layers
    "mint": (800, 10, 3072, 2, 2, 12),
    "tiny": (80, 8, 320, 2, 1, 2),
}
MOTION_DIM, AUDIO_DIM, MOTION_LEN, AUDIO_LEN, TARGET = 225, 35, 120, 240, 20


class Block(nn.Module):
    """Pre-LN layer: fused bias-free qkv, scores scaled by hidden^-1/2 (mint's quirk), tanh GELU MLP."""

    def __init__(self, c, heads, ffn):
        super().__init__()
        self.c, self.h = c, heads
        self.ln1, self.ln2 = nn.LayerNorm(c, eps=1e-5), nn.LayerNorm(c, eps=1e-5)
        self.qkv = nn.Linear(c, 3 * c, bias=False)
        self.out = nn.Linear(c, c)
        self.fc1, self.fc2 = nn.Linear(c, ffn), nn.Linear(ffn, c)

    def heads(self, t):
        b, n, _ = t.shape
        return t.view(b, n, self.h, self.c // self.h).transpose(1, 2)

    def forward(self, x, first_only=False):
        b, n, c = x.shape
        q, k, v = self.qkv(self.ln1(x)).split(c, dim=2)
        if first_only:
            x, q = x[:, :1], q[:, :1]
        q, k, v = self.heads(q), self.heads(k), self.heads(v)
        att = torch.softmax(q @ k.transpose(-1, -2) / math.sqrt(c), dim=-1)
        y = (att @ v).transpose(1, 2).reshape(b, q.shape[2], c)
        x = x + self.out(y)
        return x + self.fc2(F.gelu(self.fc1(self.ln2(x)), approximate="tanh"))


class Fact(nn.Module):
    def __init__(self, c, heads, ffn, lm, la, lc):
        super().__init__()
        self.motion_embed, self.audio_embed = nn.Linear(MOTION_DIM, c), nn.Linear(AUDIO_DIM, c)
        self.motion_pos = nn.Parameter(torch.randn(MOTION_LEN, c) * 0.02)
        self.audio_pos = nn.Parameter(torch.randn(AUDIO_LEN, c) * 0.02)
        self.motion = nn.ModuleList(Block(c, heads, ffn) for _ in range(lm))
        self.audio = nn.ModuleList(Block(c, heads, ffn) for _ in range(la))
        self.cross = nn.ModuleList(Block(c, heads, ffn) for _ in range(lc))
        self.output = nn.Linear(c, MOTION_DIM)

    def forward(self, motion, audio, first_only=False):
        m = self.motion_embed(motion) + self.motion_pos
        for blk in self.motion:
            m = blk(m)
        a = self.audio_embed(audio) + self.audio_pos
        for blk in self.audio:
            a = blk(a)
        x = torch.cat([m, a], dim=1)
        for i, blk in enumerate(self.cross):
            x = blk(x, first_only=first_only and i == len(self.cross) - 1)
        return self.output(x)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--size", choices=SIZES, default="tiny")
    ap.add_argument("--what", choices=["train", "sample"], default="train")
    ap.add_argument("--batch", type=int, default=16)
    ap.add_argument("--steps", type=int, default=3, help="timed training steps (after one warm-up)")
    ap.add_argument("--sequences", type=int, default=40)
    ap.add_argument("--frames", type=int, default=1200, help="generated frames per sequence")
    ap.add_argument("--threads", type=int, default=0, help="torch threads (0: torch's default)")
    args = ap.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    model = Fact(*SIZES[args.size])
    params = sum(p.numel() for p in model.parameters())
    result = {"name": f"PyTorch {torch.__version__.split('+')[0]}", "threads": torch.get_num_threads(),
              "size": args.size, "what": args.what, "params": params}
    reset_peak_rss()
    if args.what == "train":
        opt = torch.optim.Adam(model.parameters(), lr=1e-4, eps=1e-8)
        b = args.batch
        motion = torch.randn(b, MOTION_LEN, MOTION_DIM)
        audio = torch.randn(b, AUDIO_LEN, AUDIO_DIM)
        target = torch.randn(b, TARGET, MOTION_DIM)

        def step():
            opt.zero_grad(set_to_none=True)
            loss = F.mse_loss(model(motion, audio)[:, :TARGET], target)
            loss.backward()
            opt.step()
            return loss.item()

        step()
        times = []
        for _ in range(max(args.steps, 1)):
            t0 = time.perf_counter()
            step()
            times.append(time.perf_counter() - t0)
        sec = sorted(times)[len(times) // 2]
        result.update(value=sec, detail=f"FACT {args.size} ({params} parameters), batch {b}, Adam, "
                      f"median of {args.steps} after a warm-up, {torch.get_num_threads()} threads")
    else:
        model.eval()
        n = args.sequences
        motion = torch.randn(n, MOTION_LEN, MOTION_DIM)
        audio = torch.randn(n, AUDIO_LEN + args.frames, AUDIO_DIM)
        with torch.inference_mode():
            if args.size == "tiny":  # warm-up pass, as qean's (skipped at mint size: minutes per pass)
                model(motion, audio[:, :AUDIO_LEN], first_only=True)
            t0 = time.perf_counter()
            x = motion
            for i in range(args.frames):
                y = model(x, audio[:, i:i + AUDIO_LEN], first_only=True)[:, :1]
                x = torch.cat([x[:, 1:], y], dim=1)
            sec = time.perf_counter() - t0
        result.update(value=n * args.frames / sec, detail=f"FACT {args.size} ({params} parameters), {n} sequences "
                      f"in one batch, {args.frames} frame(s) timed, {torch.get_num_threads()} threads")
    result["peak_rss_mb"] = peak_rss_mb()
    print(json.dumps(result))


if __name__ == "__main__":
    main()
