#!/usr/bin/env python3
"""The damped Table 5.5 rig's folds by continuation (issue 27; D-181): the whole Fig. 5.11
branch (shaft1 and shaft3 damped 500 lb in s/rad, 645 -> 385 teeth/s, the benchmark's
command) has exactly two folds, at 392.427597 and 534.170542 teeth/s to 1e-6, each
corrected to a residual below tol/100 = 1e-12 (a fold's lambda is a turning point: a point
off the curve by the corrector's tolerance 1e-10 sat up to 5e-6 teeth/s from it).

Usage: check_continue_folds.py TRAINSIM
"""
import os
import subprocess
import sys
import tempfile

import h5py
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FOLDS = [392.427597, 534.170542]


def main():
    exe = os.path.abspath(sys.argv[1])
    out = tempfile.mkdtemp(prefix="trainsim_folds_")
    h5 = os.path.join(out, "branch.h5")
    p = subprocess.run([exe, "continue", os.path.join(ROOT, "inputs", "sweep_ghm_mesh_frequency.nml"),
                        "--set", "shaft1.damping=500", "--set", "shaft3.damping=500",
                        "--param", "mesh.mesh_frequency=645:385", "--restarts", "3", "--ds-max", "0.05",
                        "-o", h5], capture_output=True, text=True)
    print(p.stdout.splitlines()[-2] if p.stdout.count("\n") > 1 else p.stdout)
    with h5py.File(h5, "r") as f:
        st = f["runs/status"][:]
        n = int((st != 0).sum())
        kind, lam, res = f["runs/kind"][:n], f["parameters/values"][:n, 0], f["runs/residual"][:n]
        maps = int(f["runs/maps"][n - 1])
    folds = np.where(kind == 1)[0]
    ok = len(folds) == 2
    print(f"{n} points, {maps} period maps; folds: " +
          ", ".join(f"{lam[i]:.9f} (residual {res[i]:.1e})" for i in folds))
    if ok:
        for i, want in zip(folds, FOLDS):
            if abs(lam[i] - want) > 1e-6:
                print(f"FAIL: fold at {lam[i]:.9f}, not {want} to 1e-6")
                ok = False
            if not res[i] <= 1e-12:
                print(f"FAIL: the fold at {lam[i]:.9f} has residual {res[i]:.2e} > 1e-12")
                ok = False
    else:
        print("FAIL: not two folds")
    print("ok" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
