#!/usr/bin/env python3
"""`trainsim continue` (docs/periodic.md "Continuation") from the command line, on the
Table 5.5 rig with damped shafts (500 lb in s/rad: the bundled rig's end-inertia modes are
undamped, marginal) from 645 down to 600 teeth/s:

- stopped by --points 4: exit 1, the reason (the budget), four rows in the branch file;
- --resume: continues from the last row to below 600 teeth/s, exit 0, the first four rows
  as they were, the mesh frequency falling, every point stable (max |mu| < 1);
- the last point's state equals the orbit `trainsim periodic` finds at that frequency
  (to 1e-7 of the state scale: both converge to 1e-10 of it, the continuation by its
  corrector, the shooting by Newton);
- bad --param, --resume without -o: exit 2 with the reason.

Usage: check_continue.py TRAINSIM
"""
import os
import re
import subprocess
import sys
import tempfile

exe = os.path.abspath(sys.argv[1])
failed = 0


def check(what, ok, detail=""):
    global failed
    print(("ok   " if ok else "FAIL ") + what + ("" if ok else f"  [{detail}]"))
    if not ok:
        failed += 1


rig = os.path.abspath("inputs/gregory_harris_munro.nml")
damped = ["--set", "shaft1.damping=500", "--set", "shaft3.damping=500"]


def run(*args):
    return subprocess.run([exe, *args], capture_output=True, text=True, timeout=300)


def rows(path):
    out, scale = [], None
    with open(path) as f:
        for line in f:
            if line.startswith("# scale"):
                scale = [float(v) for v in line.split()[2:]]
            if line.startswith("#") or line.startswith("lambda"):
                continue
            out.append([float(v) for v in line.strip().rstrip(",").split(",")])
    return out, scale


with tempfile.TemporaryDirectory() as tmp:
    f = os.path.join(tmp, "branch.csv")
    r = run("continue", rig, *damped, "--param", "mesh.mesh_frequency=645:600", "--points", "4", "-o", f)
    check("stopped by its budget: exit 1", r.returncode == 1, r.returncode)
    check("the reason is printed", "budget of 4 points" in r.stderr, r.stderr)
    check("no backtrace", "Backtrace" not in r.stderr)
    first, scale = rows(f)
    check("four rows", len(first) == 4, len(first))
    r = run("continue", rig, *damped, "--param", "mesh.mesh_frequency=645:600", "-o", f, "--resume")
    check("resumed to the end: exit 0", r.returncode == 0, r.stderr)
    check("says it resumed", "resumed after 4 stored points" in r.stdout, r.stdout[:300])
    allr, scale = rows(f)
    check("more rows", len(allr) > 4, len(allr))
    check("the first four as they were", allr[:4] == first)
    lam = [p[0] for p in allr]
    check("the mesh frequency falls from 645 to below 600",
          lam[0] == 645 and lam[-1] < 600 and all(b < a for a, b in zip(lam, lam[1:])), lam)
    check("every point stable (max |mu| < 1)", all(p[4] == 1 and p[5] < 1 for p in allr))
    n = len(scale)
    ne = int(open(f).read().split("# elements ")[1].split()[0])
    x = allr[-1][10 + 2 * ne:10 + 2 * ne + n]
    r = run("periodic", rig, *damped, "--set", f"mesh.mesh_frequency={lam[-1]!r}")
    check("trainsim periodic at the last point's frequency converges", r.returncode == 0, r.stderr)
    xs = [float(m.group(1)) for m in re.finditer(r"\):[ \t]+(\S+)", r.stdout.split("the orbit at t0")[1].split("Floquet")[0])][:n]
    dev = max(abs(a - b) / s for a, b, s in zip(x, xs, scale)) if len(xs) == n else 1.0
    print(f"     last point {lam[-1]:.6f} teeth/s: state vs trainsim periodic {dev:.2e} of the scale")
    check("the same orbit as shooting finds (1e-7 of the scale)", dev <= 1e-7, dev)
    r = run("continue", rig, "--param", "mesh.mesh_frequency=385")
    check("--param without FROM:TO: exit 2", r.returncode == 2 and "FROM:TO" in r.stderr, r.stderr)
    r = run("continue", rig, "--param", "mesh.mesh_frequency=385:645", "--resume")
    check("--resume without -o: exit 2", r.returncode == 2 and "--resume needs -o" in r.stderr, r.stderr)

sys.exit(1 if failed else 0)
