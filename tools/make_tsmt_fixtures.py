#!/usr/bin/env python3
"""Parity fixtures for TSMT (SPEC §11): the audio deltas of §11.4.

Reference: scipy (any recent version; librosa 0.8.1's `feature.delta` is
`scipy.signal.savgol_filter(data, width, polyorder=order, deriv=order, axis=-1, mode='interp')`).
    python3 -m venv /work/venv-scipy && /work/venv-scipy/bin/pip install "numpy<2" scipy
Run from the repo root:
    /work/venv-scipy/bin/python tools/make_tsmt_fixtures.py
It reads the librosa feature fixture audio/tests/fixtures/vibe_ace_wav_feat35.npy (made by
tools/make_audio_fixtures.py) and writes audio/tests/fixtures/vibe_ace_wav_delta13.npy: the deltas
(width 9, order 1, interp) of its MFCC columns 1..13, frames x 13, float64.
"""
import numpy as np
from scipy.signal import savgol_filter

FIX = "audio/tests/fixtures"


def main():
    feat = np.load(f"{FIX}/vibe_ace_wav_feat35.npy")
    mfcc = feat[:, 1:14].astype(np.float64).T  # 13 x T, librosa's layout
    delta = savgol_filter(mfcc, 9, polyorder=1, deriv=1, axis=-1, mode="interp")
    np.save(f"{FIX}/vibe_ace_wav_delta13.npy", np.ascontiguousarray(delta.T))
    print("frames", delta.shape[1], "max |delta|", float(np.abs(delta).max()))


if __name__ == "__main__":
    main()
