#!/usr/bin/env python3
"""Peer of `qean bench` (metrics): Bailando's evaluation protocol in numpy/scipy on the same synthetic set.

    VENV/bin/python bench/peer/metrics_numpy.py METRIC_SET.json

METRIC_SET.json is written by `qean bench` (qean_eval::synthetic::SyntheticSet: per sequence a base pose and
sine waves per joint and axis, rebuilt here into the same frames). The formulas are those of
tools/crosscheck_metrics.py (Bailando's kinetic.py, manual_new.py, metrics_new.py and
beat_align_score.py, with mint's BeatAlign variant), imported from it, so the peer computes what our
`evaluate` computes: features of every generated and reference sequence, normalisation, FID_k, FID_g,
Dist_k, Dist_g (generated and ground truth), BeatAlign in both variants for the generated sequences and
their ground-truth namesakes. Bailando loops over joints in Python; the cross-check vectorises over
joints where the arithmetic is unchanged, so this peer is faster than Bailando's own code.

The last output line is the JSON `qean bench` reads (value: seconds per evaluation, building the joint
arrays excluded).
"""
import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
import crosscheck_metrics as ref  # noqa: E402
from rss import peak_rss_mb  # noqa: E402

SEED, LENGTH = 120, 1200


def joints(seq):
    t = np.arange(seq["frames"]) / 60.0
    base = np.array(seq["base"])  # [24, 3]
    wave = np.array(seq["wave"])  # [24, 3, 3]: amplitude, frequency, phase
    amp, freq, phase = wave[..., 0], wave[..., 1], wave[..., 2]
    return base[None] + amp[None] * np.sin(2 * np.pi * freq[None] * t[:, None, None] + phase[None])


def evaluate(gens, refs, beats):
    """The default protocol of qean-eval: reference mode, zero-start positions, manual_new, Bailando
    BeatAlign on the generated segment (mint's variant computed alongside, as ours does)."""
    tau = 1 / 120
    prep = lambda x: x - x[:1, :1]
    gk, gm, rk, rm = [], [], [], []
    for _, x in gens:
        seg = prep(x[SEED:SEED + LENGTH])
        gk.append(ref.kinetic_features(seg, True))
        gm.append(ref.manual_features(seg, False, tau))
    for _, x in refs:
        x = prep(x)
        rk.append(ref.kinetic_features(x, True))
        rm.append(ref.manual_features(x, False, tau))
    gk, gm, rk, rm = map(np.stack, (gk, gm, rk, rm))
    rk, gk = ref.normalize(rk, gk)
    rm, gm = ref.normalize(rm, gm)
    out = {"fid_k": ref.calc_fid(gk, rk)[0], "fid_g": ref.calc_fid(gm, rm)[0],
           "div_k": ref.avg_distance(gk), "div_g": ref.avg_distance(gm),
           "gt_div_k": ref.avg_distance(rk), "gt_div_g": ref.avg_distance(rm)}
    by_name = {}
    for name, x in refs:
        by_name.setdefault(name, x)
    bb, bm, gb, gmint = [], [], [], []
    for name, x in gens:
        music = ref.onehot(beats, len(x) + 1)
        x = x[:SEED + LENGTH]
        bb.append(ref.ba_bailando(x[SEED:], music[SEED:]))
        bm.append(ref.ba_mint(music[SEED:len(x)], ref.motion_peak_onehot(x)[SEED:]))
        gt = by_name.get(name)
        if gt is not None:
            gmusic = ref.onehot(beats, len(gt) + 1)
            gb.append(ref.ba_bailando(gt, gmusic))
            gmint.append(ref.ba_mint(gmusic[:len(gt)], ref.motion_peak_onehot(gt)))
    mean = lambda v: float(np.mean([s for s in v if s is not None]))
    out.update(beat_align=mean(bb), beat_align_mint=mean(bm), gt_beat_align=mean(gb), gt_beat_align_mint=mean(gmint))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("set_json")
    args = ap.parse_args()
    spec = json.loads(Path(args.set_json).read_text())
    gens = [(s["name"], joints(s)) for s in spec["generated"]]
    refs = [(s["name"], joints(s)) for s in spec["reference"]]
    longest = max(len(x) for _, x in gens + refs)
    beats = list(range(spec["beat_offset"], longest + 1, spec["beat_period"]))
    t0 = time.perf_counter()
    out = evaluate(gens, refs, beats)
    sec = time.perf_counter() - t0
    frames = sum(len(x) for _, x in refs)
    print(json.dumps({k: float(v) for k, v in out.items()}))
    print(json.dumps({
        "name": f"numpy {np.__version__} protocol",
        "value": sec,
        "peak_rss_mb": peak_rss_mb(),
        "detail": f"{len(gens)} generated vs {len(refs)} reference ({frames} frames), one thread",
    }))


if __name__ == "__main__":
    main()
