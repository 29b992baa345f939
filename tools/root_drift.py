#!/usr/bin/env python3
"""Root drift of evaluated dances (docs/control.md, "Feet on the floor").

For each evaluation given (an eval directory R/eval/step-N[-TAG], or a run directory R: its newest untagged
R/eval/step-N), reads the dances `qean eval --run R` wrote (generated/*.joints.npy, seed frames first) and the
ground truth of the same sequences in DATA/motions (dances with no such sequence, e.g. of an unpaired
protocol, are skipped and counted), and prints the mean over
sequences of, for the generated frames only: the root's horizontal displacement from the first generated
frame to the last (m), the length of its horizontal path (m), and its largest height change (m) — and the
same for the ground truth over the same frames.

    python3 tools/root_drift.py --data qean-demo/data [--seed-frames 120] RUN_OR_EVAL_DIR [...]
"""
import argparse
import glob
import os
import pickle
import re

import numpy as np


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, help="the AIST++-layout dataset the runs were evaluated on")
    ap.add_argument("--seed-frames", type=int, default=120)
    ap.add_argument("evals", nargs="+", metavar="RUN_OR_EVAL_DIR")
    a = ap.parse_args()
    s = a.seed_frames
    disp = lambda x: float(np.linalg.norm(x[-1, [0, 2]] - x[0, [0, 2]]))
    path = lambda x: float(np.linalg.norm(np.diff(x[:, [0, 2]], axis=0), axis=1).sum())
    height = lambda x: float(np.abs(x[:, 1] - x[0, 1]).max())
    for given in a.evals:
        run = given
        if os.path.isdir(os.path.join(given, "eval")):
            steps = [d for d in os.listdir(os.path.join(given, "eval")) if re.fullmatch(r"step-[0-9]+", d)]
            if not steps:
                raise SystemExit(f"{given}: no eval/step-N (run `qean eval --run {given}` first)")
            run = os.path.join(given, "eval", max(steps, key=lambda d: int(d[5:])))
        files = sorted(glob.glob(os.path.join(run, "generated", "*.joints.npy")))
        if not files:
            raise SystemExit(f"{run}: no generated/*.joints.npy")
        rows, skipped = [], 0
        for f in files:
            name = os.path.basename(f).split(".")[0]
            truth_file = os.path.join(a.data, "motions", name + ".pkl")
            if not os.path.exists(truth_file):
                skipped += 1
                continue
            with open(truth_file, "rb") as fh:
                gt = pickle.load(fh)
            scale = float(np.asarray(gt.get("smpl_scaling", [1.0])).ravel()[0])
            gen = np.load(f)[s:, 0, :]
            truth = (np.asarray(gt["smpl_trans"]) / scale)[s : s + len(gen)]
            rows.append([disp(gen), path(gen), height(gen), disp(truth), path(truth), height(truth)])
        if not rows:
            raise SystemExit(f"{run}: no dance has a ground-truth sequence in {a.data}/motions")
        m = np.mean(rows, axis=0)
        print(
            f"{run}: {len(rows)} dances ({skipped} without ground truth skipped); generated: displacement {m[0]:.2f} m, path {m[1]:.2f} m, "
            f"height change {m[2]:.2f} m; ground truth: {m[3]:.2f} m, {m[4]:.2f} m, {m[5]:.2f} m"
        )


if __name__ == "__main__":
    main()
