#!/usr/bin/env python3
"""`trainsim continue` (docs/periodic.md "Continuation") from the command line, on the
Table 5.5 rig with damped shafts (500 lb in s/rad: the bundled rig's end-inertia modes are
undamped, marginal) from 645 down to 600 teeth/s:

- stopped by --points 4: exit 1, the reason (the budget) printed and in the branch file
  (HDF5, the sweep file's layout: /branch/status 3 and its message), four points committed;
  --resume with the same options adds nothing (the budget), with others it is refused;
- 645 to 560 teeth/s uninterrupted: the mesh frequency falling, every point stable;
- the same killed (kill -9) after 10 points: the file opens, its committed points are a
  prefix of the full branch; --resume then ends with every dataset equal to the
  uninterrupted run's, bit for bit;
- the last point's state equals the orbit `trainsim periodic --transient 0` finds at that
  frequency from the same yang_sun memory (D-150) (to 1e-7 of the state scale: both converge to 1e-10 of it, the continuation by its
  corrector, the shooting by Newton);
- bad --param, --resume without -o, --resume of an older layout (format_version 1): exit 2
  with the reason.

Usage: check_continue.py TRAINSIM
"""
import os
import re
import subprocess
import sys
import tempfile

import h5py
import numpy as np

from clicheck import check, failures, datasets, finish

exe = os.path.abspath(sys.argv[1])


rig = os.path.abspath("inputs/gregory_harris_munro.nml")
damped = ["--set", "shaft1.damping=500", "--set", "shaft3.damping=500"]


def run(*args):
    return subprocess.run([exe, *args], capture_output=True, text=True, timeout=300)


def rows(path):
    """(lambda, stable, max|mu|, x) of each committed point, the state scale, the statuses."""
    with h5py.File(path, "r") as f:
        st = f["runs/status"][:]
        n = int((st != 0).sum())
        lam = f["parameters/values"][:n, 0]
        out = [[float(lam[i]), int(f["runs/stable"][i]), float(f["runs/max_abs_multiplier"][i]),
                list(f["branch/state"][i])] for i in range(n)]
        return out, list(f["branch/scale"][0]), st


with tempfile.TemporaryDirectory() as tmp:
    f = os.path.join(tmp, "branch.h5")
    r = run("continue", rig, *damped, "--param", "mesh.mesh_frequency=645:600", "--points", "4", "-o", f)
    check("stopped by its budget: exit 1", r.returncode == 1, r.returncode)
    check("the reason is printed", "budget of 4 points" in r.stderr, r.stderr)
    check("no backtrace", "Backtrace" not in r.stderr)
    first, scale, st = rows(f)
    check("four points committed", len(first) == 4 and list(st) == [1, 1, 1, 1], st)
    with h5py.File(f, "r") as h:
        end, why = int(h["branch/status"][0]), h["branch/message"].asstr()[0]
    check("the branch file says why: status 3 (the budget) and the message", end == 3 and "budget of 4" in why,
          (end, why))
    r = run("continue", rig, *damped, "--param", "mesh.mesh_frequency=645:600", "--points", "4", "-o", f, "--resume")
    check("resumed at its budget: exit 1 again, nothing added", r.returncode == 1 and rows(f)[0] == first, r.stderr)
    r = run("continue", rig, *damped, "--param", "mesh.mesh_frequency=645:600", "-o", f, "--resume")
    check("resumed with other options: refused, exit 2", r.returncode == 2 and "holds another branch" in r.stderr,
          r.stderr)
    old = os.path.join(tmp, "old_layout.h5")
    with open(f, "rb") as src, open(old, "wb") as dst:
        dst.write(src.read())
    with h5py.File(old, "r+") as h:
        h.attrs.modify("format_version", "1")   # (its type kept: a branch file of the layout before D-134)
    r = run("continue", rig, *damped, "--param", "mesh.mesh_frequency=645:600", "--points", "4", "-o", old, "--resume")
    check("an older layout: refused, exit 2, both versions named",
          r.returncode == 2 and "layout is version 1, this trainsim writes 3" in r.stderr, r.stderr)
    full = os.path.join(tmp, "full.h5")
    r = run("continue", rig, *damped, "--param", "mesh.mesh_frequency=645:560", "-o", full)
    check("uninterrupted to 560: exit 0", r.returncode == 0, r.stderr)
    allr, scale, st = rows(full)
    lam = [p[0] for p in allr]
    check("the mesh frequency falls from 645 to below 560",
          lam[0] == 645 and lam[-1] < 560 and all(b < a for a, b in zip(lam, lam[1:])), lam)
    check("every point stable (max |mu| < 1)", all(p[1] == 1 and p[2] < 1 for p in allr))
    # killed half-way (kill -9 after 10 printed points), then --resume: the same file contents
    killed = os.path.join(tmp, "killed.h5")
    env = dict(os.environ, GFORTRAN_UNBUFFERED_PRECONNECTED="y")
    p = subprocess.Popen([exe, "continue", rig, *damped, "--param", "mesh.mesh_frequency=645:560", "-o", killed],
                         stdout=subprocess.PIPE, text=True, env=env)
    seen = 0
    for line in p.stdout:
        seen += "stable" in line
        if seen == 10:
            p.kill()
            break
    p.wait()
    part, _, st = rows(killed)
    check("after kill -9 the file opens; its committed points are a prefix of the full branch",
          0 < len(part) < len(allr) and all(a[0] == b[0] and a[3] == b[3] for a, b in zip(part, allr)), len(part))
    r = run("continue", rig, *damped, "--param", "mesh.mesh_frequency=645:560", "-o", killed, "--resume")
    check("resumed after the kill: exit 0", r.returncode == 0, r.stderr)
    a, b = datasets(full), datasets(killed)
    differ = [k for k in a if k not in b or not np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind == "f")]
    print(f"     killed after {len(part)} of {len(allr)} points; datasets differing from the uninterrupted run: {differ}")
    check("killed and resumed: every dataset equal to the uninterrupted run's (bit for bit)", not differ, differ)
    n = len(scale)
    x = allr[-1][3]
    # the branch's contact-keeping orbits keep the memory of its first point (the law's start,
    # D = 0: its transient at 645 has no impact); shooting without a transient starts from
    # the same memory (with one, the transient's last impact's D: another orbit, D-150)
    r = run("periodic", rig, *damped, "--set", f"mesh.mesh_frequency={lam[-1]!r}", "--transient", "0")
    check("trainsim periodic at the last point's frequency converges", r.returncode == 0, r.stderr)
    xs = [float(m.group(1)) for m in re.finditer(r"\):[ \t]+(\S+)", r.stdout.split("the orbit at t0")[1].split("Floquet")[0])][:n]
    dev = max(abs(a - b) / s for a, b, s in zip(x, xs, scale)) if len(xs) == n else 1.0
    print(f"     last point {lam[-1]:.6f} teeth/s: state vs trainsim periodic {dev:.2e} of the scale")
    check("the same orbit as shooting finds (1e-7 of the scale)", dev <= 1e-7, dev)
    r = run("continue", rig, "--param", "mesh.mesh_frequency=385")
    check("--param without FROM:TO: exit 2", r.returncode == 2 and "FROM:TO" in r.stderr, r.stderr)
    r = run("continue", rig, "--param", "mesh.mesh_frequency=385:645", "--resume")
    check("--resume without -o: exit 2", r.returncode == 2 and "--resume needs -o" in r.stderr, r.stderr)

finish()
