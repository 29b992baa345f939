#!/usr/bin/env python3
"""Parity fixture for keyframe control's index set (SPEC §13.11 test 12; §13.6 "Index set").

Keyframe frames f become tokens p = f // d (a token named twice counts once); the re-predicted set is
M = union over p of [p - k, p + k], intersected with [n_fixed, n), minus the keyframe positions, transcribed
with Python sets. A keyframe at p >= n or p < n_fixed is an error ("error": true). Cases: one keyframe, two
overlapping, at the seed's edge, at the sequence's end, two keyframes on one token, out of range.

Run from the repo root:
    python3 tools/make_keyframe_control_fixtures.py
Writes models/tests/fixtures/kf_mask_positions.json.
"""
import json

D = 8
CASES = [
    # (name, frames, k, n_fixed, n)
    ("single", [200], 6, 15, 40),
    ("overlapping", [160, 200], 6, 15, 40),
    ("seed edge", [128], 6, 15, 40),
    ("sequence end", [312], 6, 15, 40),
    ("same token", [200, 205], 6, 15, 40),
    ("far apart", [130, 400, 1000], 6, 15, 165),
    ("k 0", [200], 0, 15, 40),
    ("past the end", [320], 6, 15, 40),
    ("inside the seed", [100], 6, 15, 40),
]


def mask_positions(frames, k, n_fixed, n):
    keys = sorted({f // D for f in frames})
    if any(p >= n or p < n_fixed for p in keys):
        return keys, None
    m = set()
    for p in keys:
        m |= set(range(max(p - k, n_fixed), min(p + k, n - 1) + 1))
    return keys, sorted(m - set(keys))


def main():
    out = []
    for name, frames, k, n_fixed, n in CASES:
        keys, m = mask_positions(frames, k, n_fixed, n)
        out.append(
            {
                "name": name,
                "frames": frames,
                "k": k,
                "n_fixed": n_fixed,
                "n": n,
                "positions": keys,
                "masked": m,
                "error": m is None,
            }
        )
    with open("models/tests/fixtures/kf_mask_positions.json", "w") as f:
        json.dump(out, f, indent=1)
    print(f"{len(out)} cases")


if __name__ == "__main__":
    main()
