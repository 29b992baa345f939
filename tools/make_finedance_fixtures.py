#!/usr/bin/env python3
"""FineDance fixtures (motion/tests/fixtures/finedance/): the 6-D rotation representation as FineDance's
code reads it (PyTorch3D's `rotation_6d_to_matrix`, written out in numpy: the two halves Gram-Schmidt
orthonormalised are the first two rows, their cross product the third), and a short FineDance-layout
motion (3 frames of [3 translation + 52 x 6]) with its 60-fps SMPL axis-angles by scipy (every source
frame kept, scipy's Slerp at the half-way time between each pair, joints 22-23 the identity).

Usage (numpy + scipy):
    python3 tools/make_finedance_fixtures.py [--out motion/tests/fixtures/finedance]
"""
import argparse
import json
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation, Slerp


def rotation_6d_to_matrix(d6):
    a1, a2 = d6[..., :3], d6[..., 3:]
    b1 = a1 / np.linalg.norm(a1, axis=-1, keepdims=True)
    b2 = a2 - (b1 * a2).sum(-1, keepdims=True) * b1
    b2 = b2 / np.linalg.norm(b2, axis=-1, keepdims=True)
    b3 = np.cross(b1, b2)
    return np.stack((b1, b2, b3), axis=-2)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent.parent / "motion/tests/fixtures/finedance"))
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(42)

    # Free 6-D vectors: neither unit nor orthogonal halves, as a network outputs them.
    d6 = rng.normal(size=(16, 6))
    mats = rotation_6d_to_matrix(d6)

    # A 3-frame FineDance motion: rotations as the first two rows, translation in metres.
    frames = 3
    rots = Rotation.from_rotvec(rng.uniform(-1.2, 1.2, size=(frames * 52, 3)))
    m = rots.as_matrix().reshape(frames, 52, 3, 3)
    rows = np.concatenate(
        [rng.uniform(-1, 1, size=(frames, 3)), m[:, :, :2, :].reshape(frames, 52 * 6)], axis=1
    ).astype(np.float64)
    np.save(out / "motion.npy", np.ascontiguousarray(rows))

    # Expected 60-fps axis-angles of the 24 SMPL joints: 2T - 1 frames.
    poses = np.zeros((2 * frames - 1, 24, 3))
    for j in range(22):
        r = Rotation.from_matrix(rotation_6d_to_matrix(rows[:, 3 + 6 * j : 9 + 6 * j]))
        poses[:, j] = Slerp(np.arange(frames), r)(np.arange(2 * frames - 1) / 2.0).as_rotvec()
    trans = np.stack([np.interp(np.arange(2 * frames - 1) / 2.0, np.arange(frames), rows[:, k]) for k in range(3)], 1)
    json.dump(
        {
            "d6": d6.tolist(),
            "matrices": mats.reshape(-1, 9).tolist(),
            "frames": frames,
            "poses": poses.reshape(2 * frames - 1, 72).tolist(),
            "trans": trans.tolist(),
        },
        open(out / "expected.json", "w"),
        indent=1,
    )


if __name__ == "__main__":
    main()
