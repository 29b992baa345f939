#!/usr/bin/env python3
"""PyTorch (CPU) peer of `qean bench`: Li et al.'s two-stream motion transformer (SPEC §11.5) at the paper's
size, with the reference code's training step and sampling loop (lijiaman/motion_transformer: full recompute
of the context for every generated frame, no KV cache).

    python bench/peer/tsmt_torch.py --what train|sample [--batch 32] [--steps 3] [--sequences 40]
        [--frames 30] [--threads N]

Prints one JSON object (what `qean bench` reads): `value` is seconds per step (train, median) or generated
frames per second (sample); also the parameter count (1,419,388 trainable, without the frozen position
tables: a check that the model is the same) and peak RSS. Weights and inputs are random (the timing does
not depend on them).
"""
import argparse
import json
import math
import time

import torch
from torch import nn
import torch.nn.functional as F

from rss import peak_rss_mb, reset_peak_rss

# bins C, coords n, embed D_E, pose D/H/d_k/L, audio D_a/H_a/d_ka/L_a, d_out, window W, seed frames
C, N, DE, D, H, DK, L, DA, HA, DKA, LA, DOUT, W, SEED = 300, 69, 10, 128, 4, 128, 4, 32, 2, 32, 2, 10, 480, 120


def sinusoid(rows, width):
    pos = torch.arange(rows, dtype=torch.float64)[:, None]
    i = torch.arange(width)[None, :]
    angle = pos / torch.pow(10000.0, (2 * (i // 2)).double() / width)
    table = torch.where(i % 2 == 0, torch.sin(angle), torch.cos(angle)).float()
    table[0] = 0.0
    return table


class Block(nn.Module):
    """Post-LN block: q/k/v heads of width dk, causal softmax attention, kernel-1 conv FFN of width D."""

    def __init__(self, d, h, dk, p=0.1):
        super().__init__()
        self.h, self.dk = h, dk
        self.q, self.k, self.v = nn.Linear(d, h * dk), nn.Linear(d, h * dk), nn.Linear(d, h * dk)
        self.o = nn.Linear(h * dk, d)
        self.ln1, self.ln2 = nn.LayerNorm(d), nn.LayerNorm(d)
        self.c1, self.c2 = nn.Conv1d(d, d, 1), nn.Conv1d(d, d, 1)
        self.drop = nn.Dropout(p)

    def forward(self, x, mask):
        b, t, _ = x.shape
        split = lambda y: y.view(b, t, self.h, self.dk).transpose(1, 2)
        q, k, v = split(self.q(x)), split(self.k(x)), split(self.v(x))
        s = (q @ k.transpose(-1, -2)) / math.sqrt(self.dk)
        s = s.masked_fill(mask, float("-inf"))
        z = (self.drop(torch.softmax(s, dim=-1)) @ v).transpose(1, 2).reshape(b, t, self.h * self.dk)
        x = self.ln1(x + self.drop(self.o(z)))
        y = self.c2(F.relu(self.c1(x.transpose(1, 2)))).transpose(1, 2)
        return self.ln2(x + self.drop(y))


class Stream(nn.Module):
    def __init__(self, d_in, d, h, dk, layers):
        super().__init__()
        self.inp = nn.Conv1d(d_in, d, 1)
        self.register_buffer("pe", sinusoid(W + 1, d))
        self.blocks = nn.ModuleList(Block(d, h, dk) for _ in range(layers))
        self.drop = nn.Dropout(0.1)

    def forward(self, x):
        t = x.shape[1]
        h = self.drop(self.inp(x.transpose(1, 2)).transpose(1, 2) + self.pe[1:t + 1])
        mask = torch.triu(torch.ones(t, t, dtype=torch.bool), diagonal=1)
        for blk in self.blocks:
            h = blk(h, mask)
        return h


class Tsmt(nn.Module):
    def __init__(self):
        super().__init__()
        self.pose_embed = nn.Embedding(C + 1, DE, padding_idx=C)
        self.pose = Stream(N * DE, D, H, DK, L)
        self.mfcc = nn.Linear(26, 30)
        self.beat = nn.Embedding(3, 30, padding_idx=2)
        self.audio = Stream(60, DA, HA, DKA, LA)
        self.fuse = nn.Linear(D + DA, N * DOUT)
        self.classifier = nn.Linear(DOUT, C)

    def forward(self, tokens, mfcc, beat):
        b, t, n = tokens.shape
        zx = self.pose(self.pose_embed(tokens).reshape(b, t, n * DE))
        za = self.audio(torch.cat([torch.tanh(self.mfcc(mfcc)), self.beat(beat)], dim=2))
        u = self.fuse(torch.cat([zx, za], dim=2)).view(b, t, n, DOUT)
        return self.classifier(u)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--what", choices=["train", "sample"], default="train")
    ap.add_argument("--batch", type=int, default=32)
    ap.add_argument("--steps", type=int, default=3, help="timed training steps (after one warm-up)")
    ap.add_argument("--sequences", type=int, default=40)
    ap.add_argument("--frames", type=int, default=30, help="generated frames per sequence")
    ap.add_argument("--threads", type=int, default=0, help="torch threads (0: torch's default)")
    args = ap.parse_args()
    if args.threads:
        torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    model = Tsmt()
    params = sum(p.numel() for p in model.parameters())
    result = {"name": f"PyTorch {torch.__version__.split('+')[0]}", "threads": torch.get_num_threads(),
              "what": args.what, "params": params}
    reset_peak_rss()
    if args.what == "train":
        opt = torch.optim.Adam(model.parameters(), lr=1e-4, eps=1e-8, weight_decay=1e-5)
        b = args.batch
        tokens = torch.randint(0, C, (b, W, N))
        mfcc = torch.randn(b, W, 26)
        beat = torch.randint(0, 2, (b, W))
        target = torch.randint(0, C, (b, W, N))

        def step():
            opt.zero_grad(set_to_none=True)
            logits = model(tokens, mfcc, beat)
            loss = F.cross_entropy(logits.reshape(-1, C), target.reshape(-1))
            loss.backward()
            torch.nn.utils.clip_grad_norm_(model.parameters(), 0.25)
            opt.step()
            return loss.item()

        step()
        times = []
        for _ in range(max(args.steps, 1)):
            t0 = time.perf_counter()
            step()
            times.append(time.perf_counter() - t0)
        sec = sorted(times)[len(times) // 2]
        result.update(value=sec, detail=f"TSMT paper ({params} parameters), batch {b}, window {W}, CE + "
                      f"backward + clip + Adam (L2), median of {args.steps} after a warm-up, "
                      f"{torch.get_num_threads()} threads")
    else:
        model.eval()
        n = args.sequences
        total = SEED + args.frames + 1
        tokens = torch.randint(0, C, (n, SEED, N))
        mfcc = torch.randn(n, total, 26)
        beat = torch.randint(0, 2, (n, total))
        with torch.inference_mode():
            model(tokens[:, :SEED], mfcc[:, 1:SEED + 1], beat[:, 1:SEED + 1])  # warm-up
            t0 = time.perf_counter()
            x = tokens
            for g in range(SEED, SEED + args.frames):
                start = max(0, g - W)
                logits = model(x[:, start:g], mfcc[:, start + 1:g + 1], beat[:, start + 1:g + 1])[:, -1]
                k = torch.multinomial(torch.softmax(logits.reshape(-1, C), dim=-1), 1).view(n, 1, N)
                x = torch.cat([x, k], dim=1)
            sec = time.perf_counter() - t0
        result.update(value=n * args.frames / sec, detail=f"TSMT paper ({params} parameters), {n} sequences in "
                      f"one batch, full recompute per frame, {args.frames} frames timed after a {SEED}-frame seed, "
                      f"{torch.get_num_threads()} threads")
    result["peak_rss_mb"] = peak_rss_mb()
    print(json.dumps(result))


if __name__ == "__main__":
    main()
