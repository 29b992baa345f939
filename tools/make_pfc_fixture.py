#!/usr/bin/env python3
"""The PFC parity fixture (eval/tests/fixtures/pfc.json): EDGE's physical foot-contact score
(`eval/eval_pfc.py` of EDGE, Tseng et al. 2023) written out in numpy, on the real AIST++ excerpt.

The excerpt (shared/data/aistpp/motions/softcat477_sample.json) goes through the SPEC 3.3 forward
kinematics of tools/crosscheck_metrics.py (y up, 60 fps). Scored:
- `ours`: every frame at 60 fps, y up;
- `edge`: every second frame at 30 fps, y up;
- `edge_z_up`: the same frames turned to z up (x, y, z) -> (x, -z, y), scored with z up at 30 fps, as
  EDGE's own script scores its files (must equal `edge`);
- `sliding`: the excerpt with every joint pushed sideways by 0.2 mm * t^1.5 (feet that slide), ours;
- `still`: the first pose held for 60 frames (0: nothing accelerates).

Usage (numpy + scipy):
    python3 tools/make_pfc_fixture.py [--shared DIR] [--out eval/tests/fixtures/pfc.json]
"""
import argparse
import json
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from crosscheck_metrics import REPO, forward_kinematics  # noqa: E402


def edge_pfc(joint3d, fps, up_dir):
    """EDGE's per-sequence score (before x 1e4), its steps in order; a zero peak gives 0, not NaN."""
    flat_dirs = [i for i in range(3) if i != up_dir]
    dt = 1 / fps
    root_v = (joint3d[1:, 0, :] - joint3d[:-1, 0, :]) / dt
    root_a = (root_v[1:] - root_v[:-1]) / dt
    root_a[:, up_dir] = np.maximum(root_a[:, up_dir], 0)
    root_a = np.linalg.norm(root_a, axis=-1)
    scaling = root_a.max()
    if scaling == 0:
        return 0.0
    root_a /= scaling
    feet = joint3d[:, [7, 10, 8, 11]]
    foot_v = np.linalg.norm(feet[2:, :, flat_dirs] - feet[1:-1, :, flat_dirs], axis=-1)
    left = np.minimum(foot_v[:, 0], foot_v[:, 1])
    right = np.minimum(foot_v[:, 2], foot_v[:, 3])
    return float((left * right * root_a).mean())


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--shared", type=Path, default=Path(os.environ.get("QEAN_SHARED_DIR", REPO.parent / "shared")))
    ap.add_argument("--out", type=Path, default=REPO / "eval/tests/fixtures/pfc.json")
    args = ap.parse_args()
    if not (args.shared / "data").exists():
        args.shared = Path("/work/shared")
    sample = json.loads((args.shared / "data/aistpp/motions/softcat477_sample.json").read_text())
    skeleton = json.loads((args.shared / "data/skeleton/smpl_skeleton_edge.json").read_text())
    poses = np.array(sample["smpl_poses"])
    trans = np.array(sample["smpl_trans"]) / np.array(sample["smpl_scaling"])[0]
    x = forward_kinematics(poses, trans, skeleton)
    half = x[::2]
    z_up = np.stack([half[..., 0], -half[..., 2], half[..., 1]], axis=-1)
    t = np.arange(len(x), dtype=float)
    sliding = x.copy()
    sliding[..., 0] += 2e-4 * t[:, None] ** 1.5
    still = np.repeat(x[:1], 60, axis=0)
    expected = {
        "ours": 1e4 * edge_pfc(x, 60, 1),
        "edge": 1e4 * edge_pfc(half, 30, 1),
        "edge_z_up": 1e4 * edge_pfc(z_up, 30, 2),
        "sliding": 1e4 * edge_pfc(sliding, 60, 1),
        "still": 1e4 * edge_pfc(still, 60, 1),
    }
    assert abs(expected["edge"] - expected["edge_z_up"]) <= 1e-12 * abs(expected["edge"])
    fixture = {
        "source": "softcat477_sample.json through SPEC 3.3 FK (smpl root; tools/crosscheck_metrics.py); EDGE's "
                  "eval_pfc.py formula in numpy (tools/make_pfc_fixture.py); values x 1e4",
        "sliding_shift": "x += 2e-4 * t^1.5 (t = frame index) on every joint",
        "expected": expected,
    }
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(fixture, indent=1) + "\n")
    print(f"wrote {args.out}: {expected}")


if __name__ == "__main__":
    main()
