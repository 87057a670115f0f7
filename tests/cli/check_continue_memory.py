#!/usr/bin/env python3
"""A branch whose orbits keep element memory is resumed from its own memory (D-150, D-154).

The Table 5.5 rig with damped shafts (500 lb in s/rad) continued from 405 down to 385
teeth/s: its first orbit is shot after a transient whose last impact leaves the mesh's
contact closed with yang_sun's D = 13 486 lbf s/in^2 (e = 0.990, V_i = 0.264 in/s;
test_periodic_memory), and the contact never opens along the branch, so every point is an
orbit of that D (D is the family's parameter, not in the state x). The branch file stores
the map's memory per point (/branch/memory, /branch/memory_held). A file stopped half-way
(its committed prefix, the rest pending, branch status -1: what a kill leaves, D-119;
kill -9 itself is cli_continue's) resumed with --resume must equal the uninterrupted
branch in every dataset, bit for bit. Before D-154 the resumed half started from the
deck's memory (D = 0): its states 1.8e-4 of the scale and its mesh p2p_range 3-4 % off.

Usage: check_continue_memory.py TRAINSIM
"""
import os
import shutil
import sys
import tempfile

import h5py
import numpy as np

from clicheck import check, datasets, finish, run

rig = os.path.abspath("inputs/gregory_harris_munro.nml")
args = ["continue", rig, "--set", "shaft1.damping=500", "--set", "shaft3.damping=500",
        "--param", "mesh.mesh_frequency=405:385", "--ds-max", "0.01"]


with tempfile.TemporaryDirectory() as tmp:
    full, part = os.path.join(tmp, "full.h5"), os.path.join(tmp, "part.h5")
    r = run(args + ["-o", full])
    check("uninterrupted 405 -> 385: exit 0", r.returncode == 0, r.stderr)
    a = datasets(full)
    n = int((a["runs/status"] != 0).sum())
    mem, held = a["branch/memory"][:n], a["branch/memory_held"][:n]
    print(f"     {n} points; memory (D, e, V_i) of the first: {mem[0]}")
    check("at least 8 points", n >= 8, n)
    check("every point holds the transient's memory: D = 13 486 (1e-3), held",
          abs(mem[0][0] - 13486.0) < 13.486 and (mem == mem[0]).all() and (held == 1).all(), (mem[0], held.T))
    shutil.copy(full, part)
    with h5py.File(part, "r+") as f:   # stopped half-way: the later slots pending, the branch running
        st = f["runs/status"][:]
        st[n // 2:] = 0
        f["runs/status"][:] = st
        f["branch/status"][0] = -1
    r = run(args + ["-o", part, "--resume"])
    check("resumed: exit 0", r.returncode == 0, r.stderr)
    b = datasets(part)
    differ = [k for k in a if k not in b or not np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind == "f")]
    dx = np.abs(a["branch/state"][:n] - b["branch/state"][:n]).max() / a["branch/scale"][0].max()
    print(f"     resumed after {n // 2} of {n} points: datasets differing {differ}, states {dx:.2e} of the scale")
    check("stopped and resumed: every dataset equal to the uninterrupted run's (bit for bit)", not differ, differ)

finish()
