#!/usr/bin/env python3
"""bench/compare_branches.py (D-179): two continuations of the damped Table 5.5 rig over
645 -> 600 teeth/s whose points lie elsewhere on the same curve (first step 0.005 and
0.0035) are equal by interpolation (the state to 1e-6 of its scale, at least 3 points
compared each way); a copy of the first with one interior point's state moved by 1e-5 of
its scale, and one with a regular point marked as a fold, are not.

Usage: check_compare_branches.py TRAINSIM
"""
import os
import shutil
import subprocess
import sys
import tempfile

import h5py

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CMP = os.path.join(ROOT, "bench", "compare_branches.py")


def run(args):
    p = subprocess.run(args, capture_output=True, text=True)
    return p.returncode, p.stdout + p.stderr


def main():
    exe = os.path.abspath(sys.argv[1])
    out = tempfile.mkdtemp(prefix="trainsim_cmp_")
    files = []
    for ds in ("0.005", "0.0035"):
        h5 = os.path.join(out, f"b{ds}.h5")
        rc, text = run([exe, "continue", os.path.join(ROOT, "inputs", "sweep_ghm_mesh_frequency.nml"),
                        "--set", "shaft1.damping=500", "--set", "shaft3.damping=500",
                        "--param", "mesh.mesh_frequency=645:600", "--ds", ds, "--ds-max", "0.05", "-o", h5])
        if rc != 0:
            print(text)
            return 1
        files.append(h5)
    ok = True
    rc, text = run([sys.executable, CMP, files[0], files[1]])
    print(text)
    counts = [int(line.split(":")[1].split()[0]) for line in text.splitlines() if line.startswith("state,")]
    if rc != 0 or len(counts) != 2 or min(counts) < 3:
        print("FAIL: the two branches should compare equal with at least 3 states each way")
        ok = False
    moved = os.path.join(out, "moved.h5")
    shutil.copy(files[0], moved)
    with h5py.File(moved, "r+") as f:
        f["branch/z"][3, 0] += 1e-5
    rc, text = run([sys.executable, CMP, files[1], moved])
    print(text)
    if rc == 0:
        print("FAIL: a state moved by 1e-5 of its scale was not found")
        ok = False
    marked = os.path.join(out, "marked.h5")
    shutil.copy(files[0], marked)
    with h5py.File(marked, "r+") as f:
        f["runs/kind"][3] = 1
    rc, text = run([sys.executable, CMP, files[1], marked])
    print(text)
    if rc == 0:
        print("FAIL: an extra fold was not found")
        ok = False
    shutil.rmtree(out)
    print("ok" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
