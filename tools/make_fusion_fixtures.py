#!/usr/bin/env python3
"""Parity fixture for text control's fusion weights (SPEC §13.11 test 14; §13.7 "Schedule").

The music weight w_j of tokens j = 0..n for a text interval [s, e) with a ramp of r tokens, transcribed from
SPEC §13.7 in numpy: 1 outside the interval; inside, u = min(j - s + 1, e - j), t = min(u / (r + 1), 1) and
linear 1 - t, cosine (1 + cos(pi t)) / 2, step 0. Cases: every schedule, an interval long enough to reach 0, a
short one that never does, r = 0, an interval at the sequence's end and one of a single token.

Run from the repo root:
    python3 tools/make_fusion_fixtures.py
Writes models/tests/fixtures/fusion_weights.json.
"""
import json

import numpy as np

CASES = [
    # (n, s, e, r)
    (40, 15, 30, 4),
    (40, 20, 26, 4),  # 6 tokens < 2r + 2: never 0
    (40, 18, 27, 0),
    (32, 25, 32, 4),  # up to the end
    (20, 17, 18, 4),  # one token
    (64, 16, 48, 8),
]


def weights(n, s, e, r, schedule):
    j = np.arange(n, dtype=np.float64)
    u = np.minimum(j - s + 1, e - j)
    t = np.minimum(u / (r + 1), 1.0)
    inside = (j >= s) & (j < e)
    if schedule == "linear":
        w = 1.0 - t
    elif schedule == "cosine":
        w = (1.0 + np.cos(np.pi * t)) / 2.0
    else:
        w = np.zeros(n)
    return np.where(inside, w, 1.0)


def main():
    out = []
    for n, s, e, r in CASES:
        for schedule in ["linear", "cosine", "step"]:
            out.append(
                {
                    "n": n,
                    "s": s,
                    "e": e,
                    "ramp": r,
                    "schedule": schedule,
                    "w": weights(n, s, e, r, schedule).tolist(),
                }
            )
    with open("models/tests/fixtures/fusion_weights.json", "w") as f:
        json.dump(out, f)
    print(f"{len(out)} cases")


if __name__ == "__main__":
    main()
