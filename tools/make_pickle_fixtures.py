#!/usr/bin/env python3
"""Regenerate motion/tests/fixtures/pickle/: small AIST++-style pickles and .npy files written by numpy itself,
one per pickle protocol (2-5), dtype, byte order and memory order, for the Rust readers' parity tests.

Usage: python3 tools/make_pickle_fixtures.py   (needs numpy; the numpy major version is recorded in the names)
"""
import json
import os
import pickle

import numpy as np

out = os.path.join(os.path.dirname(__file__), "..", "motion", "tests", "fixtures", "pickle")
os.makedirs(out, exist_ok=True)
np_major = int(np.__version__.split(".")[0])
rng = np.random.default_rng(0)
n = 5
poses = rng.normal(size=(n, 72))
trans = rng.normal(size=(n, 3))
expected = {"poses": poses.ravel().tolist(), "trans": trans.ravel().tolist(), "frames": n}

cases = {}
for proto in (2, 3, 4, 5):
    cases[f"proto{proto}_f64"] = dict(
        protocol=proto,
        d={"smpl_poses": poses, "smpl_trans": trans, "smpl_scaling": np.array([2.0]), "smpl_loss": np.float64(0.5)},
    )
cases["proto4_f32_24x3"] = dict(
    protocol=4,
    d={"smpl_poses": poses.astype(np.float32).reshape(n, 24, 3), "smpl_trans": trans.astype(np.float32),
       "smpl_scaling": np.array([2.0], dtype=np.float32)},
)
cases["proto4_fortran_bigendian"] = dict(
    protocol=4,
    d={"smpl_poses": np.asfortranarray(poses), "smpl_trans": trans.astype(">f8"), "smpl_scaling": np.array([2.0])},
)
cases["proto2_list_scaling"] = dict(
    protocol=2,
    d={"smpl_poses": poses, "smpl_trans": trans, "smpl_scaling": [2.0]},
)
for name, c in cases.items():
    with open(os.path.join(out, f"np{np_major}_{name}.pkl"), "wb") as f:
        pickle.dump(c["d"], f, protocol=c["protocol"])

np.save(os.path.join(out, f"np{np_major}_c_f32.npy"), poses.astype(np.float32))
np.save(os.path.join(out, f"np{np_major}_fortran_f64.npy"), np.asfortranarray(poses))
np.save(os.path.join(out, f"np{np_major}_bigendian_f8.npy"), poses.astype(">f8"))
with open(os.path.join(out, "expected.json"), "w") as f:
    json.dump(expected, f)
print("wrote", len(cases), "pickles and 3 npy files to", out)
