#!/usr/bin/env python3
"""Root drift of evaluated dances (docs/control.md, "Feet on the floor").

For each run directory given, reads the dances `qean eval --run R` wrote (R/eval/*/generated/*.joints.npy,
seed frames first) and the ground truth of the same sequences in DATA/motions, and prints the mean over
sequences of, for the generated frames only: the root's horizontal displacement from the first generated
frame to the last (m), the length of its horizontal path (m), and its largest height change (m) — and the
same for the ground truth over the same frames.

    python3 tools/root_drift.py --data qean-demo/data [--seed-frames 120] RUN [RUN ...]
"""
import argparse
import glob
import os
import pickle

import numpy as np


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, help="the AIST++-layout dataset the runs were evaluated on")
    ap.add_argument("--seed-frames", type=int, default=120)
    ap.add_argument("runs", nargs="+")
    a = ap.parse_args()
    s = a.seed_frames
    disp = lambda x: float(np.linalg.norm(x[-1, [0, 2]] - x[0, [0, 2]]))
    path = lambda x: float(np.linalg.norm(np.diff(x[:, [0, 2]], axis=0), axis=1).sum())
    height = lambda x: float(np.abs(x[:, 1] - x[0, 1]).max())
    for run in a.runs:
        files = sorted(glob.glob(os.path.join(run, "eval", "*", "generated", "*.joints.npy")))
        if not files:
            raise SystemExit(f"{run}: no eval/*/generated/*.joints.npy (run `qean eval --run {run}` first)")
        rows = []
        for f in files:
            name = os.path.basename(f).split(".")[0]
            with open(os.path.join(a.data, "motions", name + ".pkl"), "rb") as fh:
                gt = pickle.load(fh)
            scale = float(np.asarray(gt.get("smpl_scaling", [1.0])).ravel()[0])
            gen = np.load(f)[s:, 0, :]
            truth = (np.asarray(gt["smpl_trans"]) / scale)[s : s + len(gen)]
            rows.append([disp(gen), path(gen), height(gen), disp(truth), path(truth), height(truth)])
        m = np.mean(rows, axis=0)
        print(
            f"{run}: {len(rows)} dances; generated: displacement {m[0]:.2f} m, path {m[1]:.2f} m, "
            f"height change {m[2]:.2f} m; ground truth: {m[3]:.2f} m, {m[4]:.2f} m, {m[5]:.2f} m"
        )


if __name__ == "__main__":
    main()
