#!/usr/bin/env python3
"""Peer of `qean bench` (features): librosa 0.8.1 (+ resampy 0.2.2) computing the 35-D FACT feature of one
track, as mint's cache_audio_features does. Also the peer of
`cargo run --release -p qean-audio --example bench_features` (a stage breakdown of ours).

    VENV/bin/python bench/peer/features_librosa.py PATH [--repeats N]
    VENV/bin/python bench/peer/features_librosa.py PATH PATH ... [--repeats N]   # dataset mode

Dataset mode (several paths: `qean bench`'s features-dataset) loops over the tracks one after the other, as
mint's cache_audio_features loops over AIST++'s music, and reports seconds per track (the loop's time over
the track count, median over repeats).

VENV: librosa 0.8.1 with resampy 0.2.2 (SPEC §2.8; tools/make_audio_fixtures.py shows the install line).
Imports and numba's first-call compilation (a warm-up on 1 s of audio) are excluded; each repeat times
librosa.load(path, sr=30720) and the feature computation. The last output line is the JSON `qean bench`
reads (value: median seconds per track).
"""
import argparse
import json
import statistics
import sys
import time
from pathlib import Path

import librosa

from rss import peak_rss_mb, reset_peak_rss

# The feature itself is the fixture generator's (mint's cache_audio_features), so the peer times exactly
# what the parity fixtures compare against.
sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "tools"))
from make_audio_fixtures import SR, features  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("path", nargs="+")
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    if len(args.path) > 1:
        return dataset_mode(args)
    args.path = args.path[0]
    # Warm-up: numba JIT of resampy and librosa's jitted helpers.
    y, _ = librosa.load(args.path, sr=SR, duration=1.0)
    features(y, 120.0)
    reset_peak_rss()
    loads, feats = [], []
    cpu0 = time.process_time()
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        y, _ = librosa.load(args.path, sr=SR)
        t1 = time.perf_counter()
        f = features(y, 120.0)[0]
        t2 = time.perf_counter()
        loads.append(t1 - t0)
        feats.append(t2 - t1)
    cpu = (time.process_time() - cpu0) / args.repeats
    tot = [a + b for a, b in zip(loads, feats)]
    dur = len(y) / SR
    print(f"librosa {librosa.__version__}: {args.path} ({dur:.2f} s, {f.shape[0]} frames)")
    print(f"load+resample: median {statistics.median(loads):.3f} s, min {min(loads):.3f} s")
    print(f"features:      median {statistics.median(feats):.3f} s, min {min(feats):.3f} s")
    print(f"total:         median {statistics.median(tot):.3f} s, min {min(tot):.3f} s per track; "
          f"CPU {cpu:.2f} s per track")
    print(json.dumps({
        "name": f"librosa {librosa.__version__}",
        "value": statistics.median(tot),
        "peak_rss_mb": peak_rss_mb(),
        "detail": f"librosa.load(sr=30720) + features, median of {args.repeats}; "
                  f"load {statistics.median(loads):.2f} s, features {statistics.median(feats):.2f} s",
    }))


def dataset_mode(args):
    y, _ = librosa.load(args.path[0], sr=SR, duration=1.0)
    features(y, 120.0)
    reset_peak_rss()
    per_track = []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        for path in args.path:
            y, _ = librosa.load(path, sr=SR)
            features(y, 120.0)
        per_track.append((time.perf_counter() - t0) / len(args.path))
    value = statistics.median(per_track)
    print(f"librosa {librosa.__version__}: {len(args.path)} tracks, median {value:.3f} s per track")
    print(json.dumps({
        "name": f"librosa {librosa.__version__}",
        "value": value,
        "peak_rss_mb": peak_rss_mb(),
        "detail": f"{len(args.path)} tracks one after the other (librosa.load(sr=30720) + features), "
                  f"{1 / value:.2f} tracks/s, median of {args.repeats}",
    }))


if __name__ == "__main__":
    main()
