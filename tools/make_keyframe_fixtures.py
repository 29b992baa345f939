#!/usr/bin/env python3
"""Parity fixtures for keyframes and in-betweening (SPEC §12.8): Euler angles, SLERP, Bézier least squares
and Roberts's keyframe DP on the shared AIST++ excerpt (softcat477's sample, 127 frames, 120 BPM assumed).

Reference: numpy + scipy (tested with numpy 1.26.4, scipy 1.17.1) and libnmfd 1.0.0.
    python3 -m venv /work/venv-scipy && /work/venv-scipy/bin/pip install "numpy<2" scipy libnmfd==1.0.0
(libnmfd's own requirements pin old jupyter/ipython; `pip install --no-deps libnmfd==1.0.0 tqdm soundfile
matplotlib` is enough for `libnmfd.core.nmfconv`.)
Run from the repo root:
    /work/venv-scipy/bin/python tools/make_keyframe_fixtures.py
Writes keyframes/tests/fixtures/:
  softcat_euler_xyz.npy      (127, 24, 3)  scipy Rotation.from_rotvec(pose).as_euler("XYZ"), not unwrapped
  softcat_slerp_even5.npy    (127, 24, 3, 3)  scipy Slerp per joint between the even keys 0, 30, 60, 90, 120
                             of the first measure, then the tail keys 120, 126 (matrices)
  softcat_dp_E_40_52.npy     (13, 13)  Roberts's chord error table on frames 40..52 of D_euler (75-D, unwrapped)
  bezier_lm.npy              (K, 2)  scipy least_squares(method="lm") θ for the (channel, pair) list in fixtures.json
  fixtures.json              keys (even, dp), the DP's cost, Bézier cases
  nmfd_V.npy                 (1025, 100) float32  |STFT| (centred, periodic Hann 2048, hop 512) of the first
                             100 frames of the Brahms WAV at its own rate
  nmfd_H.npy, nmfd_cost.npy  (3, 100), (30,)  libnmfd nmfd(V) from init_templates(random, T = 8) and H = 1
  nmfd_drums_W.npy           (1025, 3, 8)  the steps of libnmfd's initialize_drum_specific_nmfd_templates after
                             its STFT, with V[:, 0:30], V[:, 30:60], V[:, 60:100] as the kick, snare and hi-hat
                             spectrograms, then init_templates("drums")'s normalisation
  nmfd_drums_H.npy           (3, 100)  libnmfd nmfd(V) from those templates and H = 1
"""
import json

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation, Slerp

FIX = "keyframes/tests/fixtures"
SAMPLE = "../shared/data/aistpp/motions/softcat477_sample.json"


def load():
    d = json.load(open(SAMPLE))
    poses = np.asarray(d["smpl_poses"], dtype=np.float64).reshape(-1, 24, 3)
    trans = np.asarray(d["smpl_trans"], dtype=np.float64).reshape(-1, 3)
    return poses, trans


def d_euler(poses, trans):
    e = Rotation.from_rotvec(poses.reshape(-1, 3)).as_euler("XYZ").reshape(len(poses), 72)
    e = np.unwrap(e, axis=0)
    return np.concatenate([e, trans], axis=1)


def chord_table(x):
    """E[i, j] = max over i<k<j of the distance from [k | x_k] to the line through [i | x_i], [j | x_j]."""
    n = len(x)
    p = np.concatenate([np.arange(n, dtype=np.float64)[:, None], x], axis=1)
    e = np.zeros((n, n))
    for i in range(n):
        for j in range(i + 2, n):
            d = p[j] - p[i]
            v = p[i + 1:j] - p[i]
            r = v - np.outer(v @ d / (d @ d), d)
            e[i, j] = np.sqrt((r * r).sum(axis=1)).max()
    return e


def dp(e, count):
    n = len(e)
    s = np.full((count + 1, n), np.inf)
    arg = np.full((count + 1, n), -1)
    s[2, 1:] = e[0, 1:]
    for m in range(3, count + 1):
        for end in range(m - 1, n):
            vals = [max(s[m - 1, k], e[k, end]) for k in range(m - 2, end)]
            k = int(np.argmin(vals))  # first minimum
            s[m, end] = vals[k]
            arg[m, end] = k + m - 2
    keys = [n - 1]
    for m in range(count, 2, -1):
        keys.append(int(arg[m, keys[-1]]))
    keys.append(0)
    return keys[::-1], float(s[count, n - 1])


def cost(e, keys):
    return float(max(e[a, b] for a, b in zip(keys, keys[1:])))


def bezier_cases(x):
    """LM fits of the handles parameterisation on a few (channel, t1, t2) spans."""
    cases = [(0, 0, 30), (5, 30, 60), (17, 60, 90), (40, 90, 120), (73, 0, 60), (62, 120, 126), (30, 10, 13)]
    thetas = []
    for c, t1, t2 in cases:
        y = x[:, c]
        p0, p3 = y[t1], y[t2]
        s = (np.arange(t1, t2 + 1) - t1) / (t2 - t1)
        b = np.stack([(1 - s) ** 3, 3 * s * (1 - s) ** 2, 3 * s * s * (1 - s), s ** 3], axis=1)

        def resid(th):
            c1, c2 = p0 + th[0], p3 + th[1]
            return b @ np.array([p0, c1, c2, p3]) - y[t1:t2 + 1]

        def jac(th):
            return b[:, 1:3]

        d = p3 - p0
        r = least_squares(resid, x0=[d / 3, -d / 3], jac=jac, method="lm")
        thetas.append(r.x)
    return cases, np.array(thetas)


def nmfd_fixture():
    from scipy.io import wavfile
    import libnmfd.core.nmfconv as nmfconv
    from libnmfd.core.nmfconv import init_activations, init_templates, nmfd

    nmfconv.tnrange = lambda n, desc=None: range(n)  # its notebook progress bar needs ipywidgets

    rate, y = wavfile.read("../shared/data/music/Brahms_Hungarian_Dance_5.wav")
    y = y.astype(np.float64)
    if y.ndim == 2:
        y = y.mean(axis=1)
    y = y / np.abs(y).max()
    frames = 100
    y = y[: 512 * (frames - 1) + 1]
    padded = np.pad(y, 1024, mode="reflect")
    win = 0.5 - 0.5 * np.cos(2 * np.pi * np.arange(2048) / 2048)
    spec = np.stack([np.abs(np.fft.rfft(padded[512 * t:512 * t + 2048] * win)) for t in range(frames)], axis=1)
    v = spec.astype(np.float32)
    np.save(f"{FIX}/nmfd_V.npy", v)
    v = v.astype(np.float64)
    w0 = init_templates(num_comp=3, num_bins=v.shape[0], num_template_frames=8, strategy="random")
    h0 = init_activations(num_comp=3, num_frames=v.shape[1], strategy="uniform")
    _, h, _, cost, _ = nmfd(V=v, num_comp=3, num_frames=v.shape[1], num_iter=30, num_template_frames=8,
                            init_W=w0, init_H=h0)
    np.save(f"{FIX}/nmfd_H.npy", h)
    np.save(f"{FIX}/nmfd_cost.npy", cost)
    print("nmfd: H max", float(h.max()), "cost", float(cost[0]), "->", float(cost[-1]))

    # nmfd_init = drums: libnmfd's per-class template learning (its code, minus reading and STFT-ing
    # the sample files), on three column ranges of V standing in for the kick, snare and hi-hat samples.
    learnt = []
    for a, b in [(0, 30), (30, 60), (60, 100)]:
        a_class = v[:, a:b]
        w_init = init_templates(num_comp=1, num_bins=a_class.shape[0], strategy="random")
        h_init = init_activations(num_comp=1, num_frames=a_class.shape[1], strategy="uniform")
        w_cls, _, _, _, _ = nmfd(V=a_class, num_comp=1, num_frames=a_class.shape[1], num_iter=30,
                                 num_template_frames=8, init_W=w_init, init_H=h_init)
        learnt.append(np.array(w_cls).squeeze(0).copy())
    eps = np.finfo(float).eps
    for k in range(3):
        learnt[k] /= eps + learnt[k].sum()
    np.save(f"{FIX}/nmfd_drums_W.npy", np.stack(learnt, axis=1))
    _, h, _, _, _ = nmfd(V=v, num_comp=3, num_frames=v.shape[1], num_iter=30, num_template_frames=8,
                         init_W=learnt, init_H=init_activations(num_comp=3, num_frames=v.shape[1],
                                                                strategy="uniform"))
    np.save(f"{FIX}/nmfd_drums_H.npy", h)
    print("nmfd drums: H max", float(h.max()))


def main():
    nmfd_fixture()
    poses, trans = load()
    frames = len(poses)
    euler = Rotation.from_rotvec(poses.reshape(-1, 3)).as_euler("XYZ").reshape(frames, 24, 3)
    np.save(f"{FIX}/softcat_euler_xyz.npy", euler)

    keys = [0, 30, 60, 90, 120, 126]
    slerped = np.zeros((frames, 24, 3, 3))
    for j in range(24):
        rots = Rotation.from_rotvec(poses[keys, j])
        slerped[:, j] = Slerp(keys, rots)(np.arange(frames)).as_matrix()
    np.save(f"{FIX}/softcat_slerp_even5.npy", slerped)

    x = d_euler(poses, trans)
    np.save(f"{FIX}/softcat_dp_E_40_52.npy", chord_table(x[40:53]))
    e = chord_table(x[0:121])
    dp_keys, dp_cost = dp(e, 5)
    even = [0, 30, 60, 90, 120]

    cases, thetas = bezier_cases(x)
    np.save(f"{FIX}/bezier_lm.npy", thetas)
    out = {
        "bpm": 120,
        "first_measure": [0, 120],
        "even_keys_n5": even,
        "even_cost_n5": cost(e, even),
        "dp_keys_n5": dp_keys,
        "dp_cost_n5": dp_cost,
        "dp_keys_n3": dp(e, 3)[0],
        "dp_keys_n9": dp(e, 9)[0],
        "bezier_cases": [list(c) for c in cases],
    }
    json.dump(out, open(f"{FIX}/fixtures.json", "w"), indent=1)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
