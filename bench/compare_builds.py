#!/usr/bin/python3
"""Compare two trainsim builds' results on every bundled deck, bit for bit.

    /usr/bin/python3 bench/compare_builds.py OLD_TRAINSIM NEW_TRAINSIM [--work DIR] [--integrator NAME ...]

A developer's check for changes that must not change results (the hot path, the
observer, the output): runs every deck under inputs/, verification/ and tests/decks/
(sweep decks are skipped) with both executables, each deck once as written and once
per --integrator given, and compares the files' /metrics, /events and /states
datasets (every numeric dataset of the file).
Datasets named with --new NAME (e.g. --new metrics/kv) may be in the new build's
files only: a change that adds outputs and must not change the others.
A difference in the run statistics (e.g. fewer RHS evaluations) is printed, not counted. Prints one line per run: `same` (every value bit
for bit), or the largest difference and where. Exit status 1 if any run differs or
fails with one build and not the other.
"""
import argparse
import glob
import os
import subprocess
import sys

import h5py
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(exe, deck, out, sets):
    args = [exe, "run", deck, "-o", out]
    for s in sets:
        args += ["--set", s]
    p = subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    return p.returncode


def datasets(path):
    """Every numeric dataset of a run file (samples, states, energy, events, metrics): name -> array."""
    found = {}

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and obj.dtype.kind in "fiub":
            found[name] = obj[()]
    with h5py.File(path, "r") as f:
        f.visititems(visit)
    return found


def stats(path):
    """The run statistics but the wall time (counts: steps, RHS evaluations, events)."""
    with h5py.File(path, "r") as f:
        return {k: v for k, v in f["run_stats"].attrs.items() if k != "wall_time"}


def compare(a, b, new=()):
    """(same?, text): the largest difference between two files' datasets (`new`: names only b may have)."""
    da, db = datasets(a), datasets(b)
    db = {k: v for k, v in db.items() if k in da or k not in new}
    if set(da) != set(db):
        return False, f"datasets differ: {sorted(set(da) ^ set(db))}"
    worst, where = 0.0, ""
    for k in sorted(da):
        x, y = np.asarray(da[k]), np.asarray(db[k])
        if x.shape != y.shape:
            return False, f"{k}: shape {x.shape} against {y.shape}"
        if x.dtype.kind == "f":
            same = (x == y) | (np.isnan(x) & np.isnan(y))
        else:
            same = x == y
        if not np.all(same):
            d = float(np.max(np.abs(x.astype(float) - y.astype(float))[~same]))
            if d >= worst:
                worst, where = d, k
            if worst == 0.0:
                worst, where = float("nan"), k
    if where:
        return False, f"max |difference| {worst:.3e} in {where}"
    sa, sb = stats(a), stats(b)
    counts = ", ".join(f"{k} {sa[k]} -> {sb[k]}" for k in sorted(sa) if k in sb and sa[k] != sb[k])
    return True, "same" + (f" (run_stats: {counts})" if counts else "")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--work", default="/tmp/trainsim-compare-builds")
    ap.add_argument("--integrator", action="append", default=[])
    ap.add_argument("--new", dest="new_only", action="append", default=[], help="a dataset only the new build writes")
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    decks = sorted(glob.glob(os.path.join(ROOT, "inputs", "*.nml")) +
                   glob.glob(os.path.join(ROOT, "verification", "*", "*.nml")) +
                   glob.glob(os.path.join(ROOT, "tests", "decks", "*.nml")))
    bad = 0
    for deck in decks:
        with open(deck, encoding="utf-8") as f:
            if "&sweep" in f.read().lower():
                continue
        for integ in [None] + a.integrator:
            sets = [] if integ is None else [f"run.integrator={integ}"]
            name = os.path.splitext(os.path.basename(deck))[0] + ("" if integ is None else "-" + integ)
            outs = [os.path.join(a.work, f"{name}.{w}.h5") for w in ("old", "new")]
            rcs = [run(exe, deck, out, sets) for exe, out in zip((a.old, a.new), outs)]
            if rcs[0] != rcs[1]:
                bad += 1
                print(f"{name:45s} exit {rcs[0]} against {rcs[1]}")
                continue
            if rcs[0] != 0:
                print(f"{name:45s} both exit {rcs[0]}")
                continue
            same, text = compare(*outs, new=set(a.new_only))
            bad += not same
            print(f"{name:45s} {text}")
    print(f"{bad} run(s) differ")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
