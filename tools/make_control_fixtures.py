#!/usr/bin/env python3
"""Parity fixtures for the multi-modal control system (SPEC §13.11 test 5): the EMA quantiser step.

`ema_step` below transcribes T2M-GPT's `QuantizeEMAReset` (models/quantize_cnn.py: `_tile`, `init_codebook`,
`quantize`, `update_codebook`) in float32 numpy, with the portable SplitMix64 stream of SPEC §13.12 in place of
torch's RNG, the usage test before the division (SPEC's guard) and the options `randperm` (candidates
shuffled, Bailando/Jukebox) and `reset_stats`. Reference: numpy (tested with 1.26.4).

Run from the repo root:
    /work/venv-scipy/bin/python tools/make_control_fixtures.py
Writes models/tests/fixtures/ema_*.json: per case the options, the z batches (N × C) and after each step the
indices, perplexity, codebook, code_sum and code_count.
"""
import json

import numpy as np

FIX = "models/tests/fixtures"
MASK = (1 << 64) - 1


class SplitMix64:
    def __init__(self, seed):
        self.state = seed & MASK

    def next_u64(self):
        self.state = (self.state + 0x9E3779B97F4A7C15) & MASK
        z = self.state
        z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & MASK
        z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & MASK
        return z ^ (z >> 31)

    def uniform(self):
        return (self.next_u64() >> 11) * 2.0 ** -53

    def normal(self):
        u1, u2 = self.uniform(), self.uniform()
        return np.sqrt(-2.0 * np.log(1.0 - u1)) * np.cos(2.0 * np.pi * u2)

    def permutation(self, n):
        p = list(range(n))
        for i in range(n - 1, 0, -1):
            j = self.next_u64() % (i + 1)
            p[i], p[j] = p[j], p[i]
        return p


def tile(x, k, rng, randperm):
    n, c = x.shape
    if n < k:
        reps = (k + n - 1) // n
        std = 0.01 / np.sqrt(c)
        out = np.tile(x, (reps, 1))
        noise = np.array([[rng.normal() * std for _ in range(c)] for _ in range(out.shape[0])])
        out = (out + noise.astype(np.float32)).astype(np.float32)
    else:
        out = x.copy()
    if randperm:
        out = out[rng.permutation(out.shape[0])]
    return out[:k]


def ema_step(state, z, rng, mu, randperm, reset_stats):
    k, c = state["codebook"].shape
    mu = np.float32(mu)
    if not state["init"]:
        cand = tile(z, k, rng, randperm)
        state["codebook"] = cand.copy()
        state["code_sum"] = cand.copy()
        state["code_count"] = np.ones(k, dtype=np.float32)
        state["init"] = True
    d = ((z[:, None, :].astype(np.float64) - state["codebook"][None, :, :].astype(np.float64)) ** 2).sum(-1)
    idx = d.argmin(axis=1)  # numpy: the first minimum, i.e. the lowest code
    counts = np.zeros(k, dtype=np.float32)
    sums = np.zeros((k, c), dtype=np.float32)
    for row, i in zip(z, idx):
        counts[i] += np.float32(1.0)
        sums[i] += row
    cand = tile(z, k, rng, randperm)
    one = np.float32(1.0)
    state["code_count"] = (mu * state["code_count"] + (one - mu) * counts).astype(np.float32)
    state["code_sum"] = (mu * state["code_sum"] + (one - mu) * sums).astype(np.float32)
    for i in range(k):
        if state["code_count"][i] >= 1.0:
            state["codebook"][i] = state["code_sum"][i] / state["code_count"][i]
        else:
            state["codebook"][i] = cand[i]
            if reset_stats:
                state["code_sum"][i] = cand[i]
                state["code_count"][i] = one
    p = counts.astype(np.float64) / len(idx)
    perplexity = float(np.exp(-(p * np.log(p + 1e-7)).sum()))
    return idx, perplexity


def case(name, k, c, n, steps, seed, randperm=False, reset_stats=False, z_fn=None):
    data_rng = np.random.default_rng(seed)
    rng = SplitMix64(seed)
    state = {"codebook": np.zeros((k, c), np.float32), "code_sum": np.zeros((k, c), np.float32),
             "code_count": np.zeros(k, np.float32), "init": False}
    out = {"codes": k, "dim": c, "mu": 0.99, "randperm": randperm, "reset_stats": reset_stats,
           "seed": seed, "steps": []}
    for s in range(steps):
        z = z_fn(s, data_rng) if z_fn else data_rng.standard_normal((n, c)).astype(np.float32)
        idx, perplexity = ema_step(state, z, rng, 0.99, randperm, reset_stats)
        out["steps"].append({
            "z": z.ravel().tolist(), "indices": idx.tolist(), "perplexity": perplexity,
            "codebook": state["codebook"].ravel().tolist(), "code_sum": state["code_sum"].ravel().tolist(),
            "code_count": state["code_count"].tolist(),
        })
    with open(f"{FIX}/ema_{name}.json", "w") as f:
        json.dump(out, f)
    last = out["steps"][-1]
    print(name, "perplexity", round(last["perplexity"], 4), "min count", min(last["code_count"]))


def main():
    # N ≥ K: no randomness at all.
    case("n_ge_k", k=8, c=4, n=24, steps=5, seed=1)
    # N < K: tiled candidates with noise.
    case("n_lt_k", k=16, c=4, n=6, steps=4, seed=2)
    # randperm: shuffled candidates.
    case("randperm", k=8, c=4, n=12, steps=4, seed=3, randperm=True)
    # A code unused in the batch is reset (count 0.99 < 1 → candidate row k).
    def clusters(step, r):
        z = np.concatenate([r.normal(0.0, 0.01, (5, 3)), r.normal(5.0, 0.01, (5, 3))]).astype(np.float32)
        z[1], z[3] = z[0], z[2]  # codes 1 and 3 start as copies of 0 and 2: ties go to 0 and 2
        return z
    case("reset", k=4, c=3, n=10, steps=3, seed=4, z_fn=clusters)
    case("reset_stats", k=4, c=3, n=10, steps=3, seed=4, reset_stats=True, z_fn=clusters)


if __name__ == "__main__":
    main()
