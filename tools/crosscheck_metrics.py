#!/usr/bin/env python3
"""Cross-check qean-eval against an independent numpy/scipy reimplementation of the reference protocol.

The reference protocol (SPEC §7) is Bailando's `utils/metrics_new.py`, `utils/features/kinetic.py`,
`utils/features/manual_new.py` (+ `features/utils.py`) and `utils/beat_align_score.py`, with mint
PR-41's `tools/calculate_beat_scores.py` for the mint BeatAlign variant. This script follows their
formulas step by step (scipy `sqrtm`, `gaussian_filter`, `argrelextrema`, the float32 feature
storage, the acceleration precedence bug), written for this project, vectorised over joints/frames
only where the reference's per-element arithmetic is unchanged by it.

Inputs are built here: the real AIST++ excerpt (shared/data/aistpp/motions/softcat477_sample.json,
SMPL parameters) through a small SMPL forward kinematics (SPEC §3.3, `smpl` root), then perturbed
(time warps, noise, mirroring, rotations, amplitude changes, loops) into ~100 reference and 40
generated sequences (seed 120 + generated frames), with synthetic music beats per music ID.
Both sides read the same .npy files; the Rust side is the `qean-eval` binary.

Usage (venv outside the repo with numpy + scipy):
    cargo build --release -p qean-eval -j 2
    /work/venv-eval/bin/python tools/crosscheck_metrics.py [--out /tmp/qean-crosscheck] [--shared DIR]
Exit status 1 if any metric differs by more than --tol (default 0.5 %).

    /work/venv-eval/bin/python tools/crosscheck_metrics.py --write-fixture eval/tests/fixtures/reference_metrics.json
regenerates the small committed fixture that `eval/tests/parity.rs` checks in CI (features, BeatAlign and
FID of the real excerpt computed by the formulas below).
"""

import argparse
import json
import os
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
from scipy import linalg
from scipy.ndimage import gaussian_filter
from scipy.signal import argrelextrema
from scipy.spatial.transform import Rotation

REPO = Path(__file__).resolve().parent.parent
J0 = np.array([-0.00217368, -0.24078917, 0.02858379])  # SMPL-male rest pelvis (SPEC §3.3)
SEED = 120
SMPL_NAMES = ["root", "lhip", "rhip", "belly", "lknee", "rknee", "spine", "lankle", "rankle",
              "chest", "ltoes", "rtoes", "neck", "linshoulder", "rinshoulder", "head", "lshoulder",
              "rshoulder", "lelbow", "relbow", "lwrist", "rwrist", "lhand", "rhand"]
LEGACY_NAMES = ["root", "lhip", "lknee", "lankle", "ltoes", "rhip", "rknee", "rankle", "rtoes",
                "belly", "spine", "chest", "neck", "head", "linshoulder", "lshoulder", "lelbow",
                "lwrist", "rinshoulder", "rshoulder", "relbow", "rwrist"]
# Left/right joint pairs for mirroring (SMPL order).
MIRROR = [0, 2, 1, 3, 5, 4, 6, 8, 7, 9, 11, 10, 12, 14, 13, 15, 17, 16, 19, 18, 21, 20, 23, 22]


# ----------------------------------------------------------------------------- inputs

def forward_kinematics(poses, trans, skeleton):
    """SPEC §3.3: G_i = G_parent R_i; p_i = p_parent + G_parent o_i; p_0 = trans + J0."""
    parents = skeleton["parents"]
    offsets = np.array(skeleton["offsets"])
    t = poses.shape[0]
    rots = Rotation.from_rotvec(poses.reshape(-1, 3)).as_matrix().reshape(t, 24, 3, 3)
    g = np.zeros((t, 24, 3, 3))
    p = np.zeros((t, 24, 3))
    g[:, 0] = rots[:, 0]
    p[:, 0] = trans + J0
    for i in range(1, 24):
        q = parents[i]
        g[:, i] = g[:, q] @ rots[:, i]
        p[:, i] = p[:, q] + np.einsum("tab,b->ta", g[:, q], offsets[i])
    return p


def resample(x, speed, length):
    """Linear time warp of a looped (forward, backward) copy of x, `length` frames at `speed`."""
    loop = np.concatenate([x, x[::-1][1:-1]])
    src = (np.arange(length) * speed) % len(loop)
    i0 = np.floor(src).astype(int)
    i1 = (i0 + 1) % len(loop)
    w = (src - i0)[:, None, None]
    return (1 - w) * loop[i0] + w * loop[i1]


def perturb(base, rng, length, noise):
    speed = rng.uniform(0.6, 1.7)
    x = resample(base, speed, length)
    if rng.random() < 0.5:
        x = x[:, MIRROR] * np.array([-1.0, 1.0, 1.0])
    mean_pose = x.mean(axis=0, keepdims=True)
    x = mean_pose + rng.uniform(0.7, 1.4) * (x - mean_pose)
    ang = rng.uniform(-np.pi, np.pi)
    rot = Rotation.from_euler("y", ang).as_matrix()
    x = x @ rot.T
    x = x + rng.normal(0, 0.5, 3) * np.array([1, 0.1, 1]) + np.linspace(0, 1, length)[:, None, None] * rng.normal(0, 0.3, 3)
    # Smoothly varying per-joint offsets and white noise.
    phase = rng.uniform(0, 2 * np.pi, (1, 24, 3))
    freq = rng.uniform(0.2, 2.0, (1, 24, 3))
    tt = np.arange(length)[:, None, None] / 60.0
    x = x + rng.uniform(0, 0.05) * np.sin(2 * np.pi * freq * tt + phase)
    x = x + rng.normal(0, noise, x.shape)
    return x


def music_beats(rng, frames):
    bpm = rng.uniform(80, 135)
    period = 3600.0 / bpm
    start = rng.uniform(0, period)
    beats = np.round(start + period * np.arange(int(frames / period) + 1) + rng.normal(0, 1.0, int(frames / period) + 1))
    return sorted({int(b) for b in beats if 0 <= b < frames})


def build_inputs(shared, out, rng):
    sample = json.loads((shared / "data/aistpp/motions/softcat477_sample.json").read_text())
    skeleton = json.loads((shared / "data/skeleton/smpl_skeleton_edge.json").read_text())
    poses = np.array(sample["smpl_poses"])
    trans = np.array(sample["smpl_trans"]) / np.array(sample["smpl_scaling"])[0]
    base = forward_kinematics(poses, trans, skeleton)
    genres = ["BR", "PO", "LO", "MH", "LH", "HO", "WA", "KR", "JS", "JB"]
    ref_names = [f"g{genres[i % 10]}_sBM_cAll_d{i % 30:02d}_m{genres[i % 10]}{(i // 10) % 6}_ch{i:02d}"
                 for i in range(100)]
    (out / "ref").mkdir(parents=True, exist_ok=True)
    (out / "gen").mkdir(parents=True, exist_ok=True)
    refs, gens = {}, {}
    for name in ref_names:
        x = perturb(base, rng, int(rng.integers(300, 900)), noise=rng.uniform(0.0, 0.004))
        refs[name] = x
        np.save(out / "ref" / f"{name}.npy", x)
    for name in ref_names[:40]:
        # Seed = the GT's first 120 frames, then a different (noisier) motion.
        gt = refs[name]
        gen = perturb(base, rng, int(rng.integers(200, 700)), noise=rng.uniform(0.002, 0.01))
        gen = gen - gen[:1, :1] + gt[SEED - 1:SEED, :1]
        x = np.concatenate([gt[:SEED], gen])
        gens[name] = x
        np.save(out / "gen" / f"{name}.npy", x)
    beats = {}
    for name in ref_names:
        mid = name.split("_")[-2]
        if mid not in beats:
            beats[mid] = music_beats(rng, 1100)
    (out / "beats.json").write_text(json.dumps(beats))
    return gens, refs, beats


# ----------------------------------------------------------------------------- reference formulas

def kinetic_features(pos, bug, frame_time=1.0 / 60, window=2):
    """kinetic.py + features/utils.py, all 24 joints at once (the per-joint loops are independent)."""
    t = len(pos)
    ke_h = np.zeros(24)
    ke_v = np.zeros(24)
    ee = np.zeros(24)
    for i in range(1, t):
        vel = np.zeros((24, 3))
        n = 0
        for j in range(-window, window + 1):
            if i + j - 1 < 0 or i + j >= t:
                continue
            vel += pos[i + j] - pos[i + j - 1]
            n += 1
        h = np.stack([vel[:, 0], vel[:, 2]], axis=1) / (n * frame_time)
        ke_h += np.linalg.norm(h, axis=1) ** 2
        ke_v += np.linalg.norm(vel[:, 1:2] / (n * frame_time), axis=1) ** 2
        acc = np.zeros((24, 3))
        n = 0
        for j in range(-window, window + 1):
            if i + j - 1 < 0 or i + j + 1 >= t:
                continue
            v2 = (pos[i + j + 1] - pos[i + j]) / frame_time
            if bug:
                v1 = pos[i + j] - pos[i + j - 1] / frame_time
            else:
                v1 = (pos[i + j] - pos[i + j - 1]) / frame_time
            acc += (v2 - v1) / frame_time
            n += 1
        ee += np.linalg.norm(acc / n, axis=1)
    feats = np.stack([ke_h, ke_v, ee], axis=1) / (t - 1.0)
    return np.array(feats.reshape(-1), dtype=np.float32)


def manual_features(pos, legacy, tau):
    """manual_new.py (or the legacy fairmotion naming), each predicate evaluated for all frames."""
    names = LEGACY_NAMES if legacy else SMPL_NAMES
    if legacy:
        ls, le, rs = [0.00121265, 0.37817603, 0.03681623], [0.19911349, 0.23680794, -0.01807022], [-0.45181984, 0.2225595, -0.04357424]
        lh, rh = [0.05640767, -0.32306919, 0.01091971], [-0.10574003, -0.7149903, 0.01019822]
    else:
        ls, le, rs = [1.99113488e-01, 2.36807942e-01, -1.80702247e-02], [4.54445392e-01, 2.21158922e-01, -4.10167128e-02], [-1.91692337e-01, 2.36928746e-01, -1.23055102e-02]
        lh, rh = [5.64076714e-02, -3.23069185e-01, 1.09197125e-02], [-6.24834076e-02, -3.31302464e-01, 1.50412619e-02]
    dist = lambda a, b: np.linalg.norm(np.array(a) - np.array(b))
    hl, sw, hw = dist(ls, le), dist(ls, rs), dist(lh, rh)
    cur, prev = pos[1:], pos[:-1]
    n = len(cur)

    def at(j):
        if j == "y_unit":
            return np.tile([0.0, 1.0, 0.0], (n, 1))
        if j == "minus_y_unit":
            return np.tile([0.0, -1.0, 0.0], (n, 1))
        if j == "zero":
            return np.zeros((n, 3))
        if j == "y_min":
            return np.stack([np.zeros(n), cur[:, :, 1].min(axis=1), np.zeros(n)], axis=1)
        return cur[:, names.index(j)]

    def pv(j):
        return prev[:, names.index(j)]

    dot = lambda a, b: np.sum(a * b, axis=1)
    nrm = lambda a: np.linalg.norm(a, axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        def move(j1, j2, j3, j4, th):  # velocity_direction_above_threshold(j1, j1p, j2, j2p, j3, j3p)
            vel = at(j3) - at(j1) - (pv(j3) - pv(j1))
            d = at(j2) - at(j1)
            return dot(vel, d) / nrm(d) / tau > th

        def nmove(j1, j2, j3, j4, th):  # ..._normal(j1, j1p, j2, j3, j4, j4p)
            vel = at(j4) - at(j1) - (pv(j4) - pv(j1))
            d = np.cross(at(j3) - at(j1), at(j2) - at(j1))
            return dot(vel, d) / nrm(d) / tau > th

        def plane(a, b, c, p, th):
            cr = np.cross(at(c) - at(a), at(b) - at(a))
            return dot(cr, at(p) - at(a)) / nrm(cr) > th

        def nplane(n1, n2, a, p, th):
            nm = at(n2) - at(n1)
            return dot(nm, at(p) - at(a)) / nrm(nm) > th

        def angle(j1, j2, k1, k2, rng):
            j, k = at(j2) - at(j1), at(k2) - at(k1)
            ang = np.degrees(np.arccos(dot(j, k) / (nrm(j) * nrm(k))))
            return (ang > rng[0]) & (ang < rng[1])

        def fast(j, th):
            return nrm(at(j) - pv(j)) / tau > th

        f = [
            nmove("neck", "rhip", "lhip", "rwrist", 1.8 * hl), nmove("neck", "lhip", "rhip", "lwrist", 1.8 * hl),
            nplane("chest", "neck", "neck", "rwrist", 0.2 * hl), nplane("chest", "neck", "neck", "lwrist", 0.2 * hl),
            move("belly", "chest", "chest", "rwrist", 1.8 * hl), move("belly", "chest", "chest", "lwrist", 1.8 * hl),
            angle("relbow", "rshoulder", "relbow", "rwrist", [0, 110]), angle("lelbow", "lshoulder", "lelbow", "lwrist", [0, 110]),
            nplane("lshoulder", "rshoulder", "lwrist", "rwrist", 2.5 * sw),
            move("lwrist", "rwrist", "rwrist", "lwrist", 1.4 * hl),
            move("rwrist", "root", "lwrist", "root", 1.4 * hl), move("lwrist", "root", "rwrist", "root", 1.4 * hl),
            fast("rwrist", 2.5 * hl), fast("lwrist", 2.5 * hl),
            plane("root", "lhip", "ltoes", "rankle", 0.38 * hl), plane("root", "rhip", "rtoes", "lankle", 0.38 * hl),
            nplane("zero", "y_unit", "y_min", "rankle", 1.2 * hl), nplane("zero", "y_unit", "y_min", "lankle", 1.2 * hl),
            nplane("lhip", "rhip", "lankle", "rankle", 2.1 * hw),
            angle("rknee", "rhip", "rknee", "rankle", [0, 110]), angle("lknee", "lhip", "lknee", "lankle", [0, 110]),
            fast("rankle", 2.5 * hl), fast("lankle", 2.5 * hl),
            angle("neck", "root", "rshoulder", "relbow", [25, 180]), angle("neck", "root", "lshoulder", "lelbow", [25, 180]),
            angle("neck", "root", "rhip", "rknee", [50, 180]), angle("neck", "root", "lhip", "lknee", [50, 180]),
            plane("rankle", "neck", "lankle", "root", 0.5 * hl),
            angle("neck", "root", "zero", "y_unit", [70, 110]),
            nplane("zero", "minus_y_unit", "y_min", "rwrist", -1.2 * hl),
            nplane("zero", "minus_y_unit", "y_min", "lwrist", -1.2 * hl),
            fast("root", 2.3 * hl),
        ]
    return np.array(np.stack(f, axis=1), dtype=np.float32).mean(axis=0)


def normalize(feat, feat2):
    mean = feat.mean(axis=0)
    std = feat.std(axis=0)
    return (feat - mean) / (std + 1e-10), (feat2 - mean) / (std + 1e-10)


def calc_fid(kps_gen, kps_gt):
    """metrics_new.py calc_fid; the complex result (Bailando keeps it when the imaginary part is
    small) is reported by its real part, with the imaginary trace printed."""
    mu1, mu2 = kps_gen.mean(axis=0), kps_gt.mean(axis=0)
    s1, s2 = np.cov(kps_gen, rowvar=False), np.cov(kps_gt, rowvar=False)
    diff = mu1 - mu2
    covmean, _ = linalg.sqrtm(s1.dot(s2), disp=False)
    if not np.isfinite(covmean).all():
        off = np.eye(s1.shape[0]) * 1e-5
        covmean = linalg.sqrtm((s1 + off).dot(s2 + off))
    imag = 0.0
    if np.iscomplexobj(covmean):
        imag = float(np.trace(covmean).imag)
        covmean = covmean.real
    return float(diff.dot(diff) + np.trace(s1) + np.trace(s2) - 2 * np.trace(covmean)), imag


def avg_distance(f):
    n = f.shape[0]
    d = 0.0
    for i in range(n):
        for j in range(i + 1, n):
            d += np.linalg.norm(f[i] - f[j])
    return d / ((n * n - n) / 2)


def onehot(beats, frames):
    x = np.zeros(frames, dtype=bool)
    b = [i for i in beats if i < frames]
    x[b] = True
    return x


def ba_bailando(joints, music_onehot):
    """beat_align_score.py: calc_db, get_mb(length=len(v)), BA."""
    kv = np.mean(np.sqrt(np.sum((joints[1:] - joints[:-1]) ** 2, axis=2)), axis=1)
    kv = gaussian_filter(kv, 5)
    motion = argrelextrema(kv, np.less)
    music = np.nonzero(music_onehot[:len(kv)])[0]
    if len(music) == 0:
        return None
    if len(motion[0]) == 0:
        return 0.0
    return sum(np.exp(-np.min((motion[0] - b) ** 2) / 2 / 9) for b in music) / len(music)


def motion_peak_onehot(joints):
    velocity = np.zeros_like(joints, dtype=np.float32)
    velocity[1:] = joints[1:] - joints[:-1]
    envelope = np.sum(np.linalg.norm(velocity, axis=2), axis=1)
    idx = argrelextrema(envelope, np.less, axis=0, order=10)
    peak = np.zeros_like(envelope, dtype=bool)
    peak[idx] = 1
    return peak


def ba_mint(music_onehot, motion_onehot, sigma=3):
    if motion_onehot.sum() == 0:
        return 0.0
    mus = np.where(music_onehot)[0]
    if len(mus) == 0:
        return None
    scores = []
    for m in np.where(motion_onehot)[0]:
        d = np.abs(mus - m).astype(np.float32)
        scores.append(np.exp(-d[np.argmin(d)] ** 2 / 2 / sigma ** 2))
    return sum(scores) / len(scores)


def reference_metrics(gens, refs, beats, cfg):
    bug = cfg["metrics_mode"] == "reference"
    tau = 1 / 120 if bug else 1 / 60
    legacy = cfg["geometric"] == "legacy_fairmotion"
    zero = cfg["positions"] == "zero_start"
    prep = lambda x: x - x[:1, :1] if zero else x
    gk, gm, rk, rm = [], [], [], []
    for x in gens.values():
        seg = x[SEED:SEED + 1200]
        gk.append(kinetic_features(prep(seg), bug))
        gm.append(manual_features(prep(seg), legacy, tau))
    for x in refs.values():
        rk.append(kinetic_features(prep(x), bug))
        rm.append(manual_features(prep(x), legacy, tau))
    gk, gm, rk, rm = map(np.stack, (gk, gm, rk, rm))
    rk, gk = normalize(rk, gk)
    rm, gm = normalize(rm, gm)
    out = {}
    out["fid_k"], imk = calc_fid(gk, rk)
    out["fid_g"], img = calc_fid(gm, rm)
    out["div_k"], out["div_g"] = avg_distance(gk), avg_distance(gm)
    out["gt_div_k"], out["gt_div_g"] = avg_distance(rk), avg_distance(rm)
    full = cfg["ba_segment"] == "full"
    bb, bm, gb, gm_ = [], [], [], []
    track = 2400
    for name, x in gens.items():
        music = onehot(beats[name.split("_")[-2]], track)
        x = x[:SEED + 1200]
        if full:
            bb.append(ba_bailando(x, music))
            bm.append(ba_mint(music, motion_peak_onehot(x)))
        else:
            bb.append(ba_bailando(x[SEED:], music[SEED:]))
            bm.append(ba_mint(music[SEED:], motion_peak_onehot(x)[SEED:]))
        gt = refs[name]
        gb.append(ba_bailando(gt, music))
        gm_.append(ba_mint(music[:len(gt)], motion_peak_onehot(gt)))
    mean = lambda v: float(np.mean([s for s in v if s is not None]))
    out["beat_align_bailando"], out["beat_align_mint"] = mean(bb), mean(bm)
    out["gt_beat_align_bailando"], out["gt_beat_align_mint"] = mean(gb), mean(gm_)
    return out, (imk, img)


# ----------------------------------------------------------------------------- committed fixture

def write_fixture(shared, path):
    sample = json.loads((shared / "data/aistpp/motions/softcat477_sample.json").read_text())
    skeleton = json.loads((shared / "data/skeleton/smpl_skeleton_edge.json").read_text())
    poses = np.array(sample["smpl_poses"])
    trans = np.array(sample["smpl_trans"]) / np.array(sample["smpl_scaling"])[0]
    x = forward_kinematics(poses, trans, skeleton)
    music = [5, 25, 47, 70, 91, 110, 126]
    seed = 30
    zs = x - x[:1, :1]
    track = onehot(music, 200)
    exp = {
        "kinetic_reference_zero_start": kinetic_features(zs, True).tolist(),
        "kinetic_corrected_zero_start": kinetic_features(zs, False).tolist(),
        "kinetic_reference_absolute": kinetic_features(x, True).tolist(),
        "geometric_manual_new_reference": manual_features(zs, False, 1 / 120).tolist(),
        "geometric_manual_new_corrected": manual_features(zs, False, 1 / 60).tolist(),
        "geometric_legacy_reference": manual_features(zs, True, 1 / 120).tolist(),
        "gt_ba_bailando": ba_bailando(x, track),
        "gt_ba_mint": ba_mint(track[:len(x)], motion_peak_onehot(x)),
        "gen_ba_bailando": ba_bailando(x[seed:], track[seed:]),
        "gen_ba_mint": ba_mint(track[seed:], motion_peak_onehot(x)[seed:]),
    }
    rng = np.random.default_rng(5)
    a = rng.normal(0, 1, (12, 5)) * [1, 2, 0.5, 1, 3]
    b = rng.normal(0.3, 1, (30, 5)) @ rng.normal(0, 1, (5, 5))
    exp["fid_scipy"] = calc_fid(a, b)[0]
    fixture = {
        "source": "softcat477_sample.json through SPEC 3.3 FK (smpl root); values from tools/crosscheck_metrics.py "
                  "(numpy/scipy reimplementation of Bailando/mint metric code); float32 as the reference stores them",
        "music_beats": music,
        "seed_frames": seed,
        "fid_a": a.tolist(),
        "fid_b": b.tolist(),
        "expected": {k: (float(v) if np.isscalar(v) else v) for k, v in exp.items()},
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(fixture, indent=1) + "\n")
    print(f"wrote {path}")


# ----------------------------------------------------------------------------- main

def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", type=Path, default=Path("/tmp/qean-crosscheck"))
    ap.add_argument("--shared", type=Path, default=Path(os.environ.get("QEAN_SHARED_DIR", REPO.parent / "shared")))
    ap.add_argument("--bin", type=Path, default=REPO / "target/release/qean-eval")
    ap.add_argument("--tol", type=float, default=0.005)
    ap.add_argument("--seed", type=int, default=20261123)
    ap.add_argument("--write-fixture", type=Path, help="write the committed parity fixture here and exit")
    args = ap.parse_args()
    # scipy >= 1.16 deprecates sqrtm's `disp`, which the reference passes; the call is kept as written.
    warnings.filterwarnings("ignore", category=DeprecationWarning)
    if not (args.shared / "data").exists():
        args.shared = Path("/work/shared")
    if args.write_fixture:
        write_fixture(args.shared, args.write_fixture)
        return
    rng = np.random.default_rng(args.seed)
    gens, refs, beats = build_inputs(args.shared, args.out, rng)
    print(f"inputs: {len(gens)} generated (seed {SEED} + 200..700 frames), {len(refs)} reference "
          f"(300..900 frames), {len(beats)} music IDs, in {args.out}")
    configs = [
        dict(metrics_mode="reference", positions="zero_start", geometric="manual_new", ba_segment="generated"),
        dict(metrics_mode="corrected", positions="mint_absolute", geometric="legacy_fairmotion", ba_segment="full"),
    ]
    keys = ["fid_k", "fid_g", "div_k", "div_g", "gt_div_k", "gt_div_g", "beat_align_bailando",
            "beat_align_mint", "gt_beat_align_bailando", "gt_beat_align_mint"]
    worst = 0.0
    for cfg in configs:
        ref, imag = reference_metrics(gens, refs, beats, cfg)
        out_json = args.out / f"rust_{cfg['metrics_mode']}.json"
        cmd = [str(args.bin), "--generated", str(args.out / "gen"), "--reference", str(args.out / "ref"),
               "--beats", str(args.out / "beats.json"), "--seed-frames", str(SEED), "--json", str(out_json)]
        for k, v in cfg.items():
            cmd += ["--" + k.replace("_", "-"), v]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        (ours,) = json.loads(out_json.read_text())["reports"]
        print(f"\n{', '.join(f'{k}={v}' for k, v in cfg.items())}  "
              f"(scipy sqrtm imaginary trace: FID_k {imag[0]:.2e}, FID_g {imag[1]:.2e})")
        print(f"{'metric':<24}{'numpy reference':>18}{'qean-eval':>18}{'rel. error':>12}")
        for k in keys:
            a, b = ref[k], ours[k]
            rel = abs(a - b) / max(abs(a), 1e-12)
            worst = max(worst, rel)
            print(f"{k:<24}{a:>18.6f}{b:>18.6f}{rel:>12.2e}")
    print(f"\nworst relative error {worst:.2e} (tolerance {args.tol:.1e}): {'PASS' if worst <= args.tol else 'FAIL'}")
    sys.exit(0 if worst <= args.tol else 1)


if __name__ == "__main__":
    main()
