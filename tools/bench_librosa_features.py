#!/usr/bin/env python3
"""Time librosa 0.8.1 (+ resampy 0.2.2) on the 35-D FACT feature of one track: the peer benchmark for
`cargo run --release -p qean-data --example bench_features`.

    /work/venv-librosa/bin/python tools/bench_librosa_features.py [PATH] [REPEATS]

Imports and numba's first-call compilation (a warm-up on 1 s of audio) are excluded; each repeat times
librosa.load(path, sr=30720) and the feature computation separately (mint's cache_audio_features).
"""
import statistics
import sys
import time

import numpy as np
import librosa

SR = 30720
HOP = 512


def features(y, start_bpm=120.0):
    env = librosa.onset.onset_strength(y, sr=SR)
    mfcc = librosa.feature.mfcc(y, sr=SR, n_mfcc=20).T
    chroma = librosa.feature.chroma_cens(y, sr=SR, hop_length=HOP, n_chroma=12).T
    peaks = librosa.onset.onset_detect(onset_envelope=env.flatten(), sr=SR, hop_length=HOP)
    peak_onehot = np.zeros_like(env, dtype=np.float32)
    peak_onehot[peaks] = 1.0
    tempo, beats = librosa.beat.beat_track(
        onset_envelope=env, sr=SR, hop_length=HOP, start_bpm=start_bpm, tightness=100
    )
    beat_onehot = np.zeros_like(env, dtype=np.float32)
    beat_onehot[beats] = 1.0
    return np.concatenate([env[:, None], mfcc, chroma, peak_onehot[:, None], beat_onehot[:, None]], axis=-1)


def main():
    path = sys.argv[1] if len(sys.argv) > 1 else "../shared/data/music/Kevin_MacLeod_-_Vibe_Ace.wav"
    repeats = int(sys.argv[2]) if len(sys.argv) > 2 else 3
    # Warm-up: numba JIT of resampy and librosa's jitted helpers.
    y, _ = librosa.load(path, sr=SR, duration=1.0)
    features(y)
    loads, feats = [], []
    cpu0 = time.process_time()
    for _ in range(repeats):
        t0 = time.perf_counter()
        y, _ = librosa.load(path, sr=SR)
        t1 = time.perf_counter()
        f = features(y)
        t2 = time.perf_counter()
        loads.append(t1 - t0)
        feats.append(t2 - t1)
    cpu = (time.process_time() - cpu0) / repeats
    tot = [a + b for a, b in zip(loads, feats)]
    dur = len(y) / SR
    print(f"librosa {librosa.__version__}: {path} ({dur:.2f} s, {f.shape[0]} frames)")
    print(f"load+resample: median {statistics.median(loads):.3f} s, min {min(loads):.3f} s")
    print(f"features:      median {statistics.median(feats):.3f} s, min {min(feats):.3f} s")
    print(f"total:         median {statistics.median(tot):.3f} s, min {min(tot):.3f} s per track; "
          f"CPU {cpu:.2f} s per track")


if __name__ == "__main__":
    main()
