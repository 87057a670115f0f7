#!/usr/bin/env python3
"""Frequency response of a branch from `trainsim continue -o BRANCH` (docs/periodic.md
"Continuation"): an element's displacement extremes over each periodic orbit against the
parameter, stable parts solid, unstable parts dashed, folds (o), period-doubling (s), grazing (x) and
Neimark-Sacker points (^) marked; with --sweep FILE.h5 the settled brute-force sweep's
points of the same metric overlaid (plot_sweep.py's reader).

Usage: plot_branch.py BRANCH [--element ID] [--sweep SWEEP.h5 [--metric ID.disp_max]] [-o FIG]
"""
import argparse
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

KINDS = {1: ("fold", "o"), 2: ("period-doubling", "s"), 3: ("Neimark-Sacker", "^"), 4: ("grazing", "x")}


def read_branch(path):
    head, rows = {}, []
    with open(path) as f:
        for line in f:
            if line.startswith("#"):
                parts = line[1:].split()
                if parts:
                    head[parts[0]] = parts[1:]
            elif not line.startswith("lambda") and line.strip():
                rows.append([float(v) for v in line.strip().rstrip(",").split(",")])
    if not rows:
        sys.exit(f"{path}: no point in the branch file")
    return head, np.array(rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("branch")
    ap.add_argument("--element", help="element id (default: the last element with a nonzero swing)")
    ap.add_argument("--sweep", help="a sweep file to overlay")
    ap.add_argument("--metric", help="the sweep's metric (default ELEMENT.disp_max)")
    ap.add_argument("-o", "--output", default=None)
    a = ap.parse_args(argv)
    head, r = read_branch(a.branch)
    ids = head["elements"][1:]
    ne = len(ids)
    param = head.get("trainsim", [""])[-1]
    lam, kind, stable = r[:, 0], r[:, 3].astype(int), r[:, 4].astype(int)
    dmin, dmax = r[:, 10:10 + ne], r[:, 10 + ne:10 + 2 * ne]
    if a.element:
        if a.element not in ids:
            sys.exit(f"no element '{a.element}'; elements: {', '.join(ids)}")
        e = ids.index(a.element)
    else:
        swing = np.ptp(dmax, axis=0)
        e = int(np.nonzero(swing > 0)[0][-1]) if (swing > 0).any() else ne - 1
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for y, name in ((dmax[:, e], "max"), (dmin[:, e], "min")):
        for i in range(len(lam) - 1):   # a segment is stable when both its ends are
            st = stable[i] == 1 and stable[i + 1] == 1
            ax.plot(lam[i:i + 2], y[i:i + 2], "-" if st else "--", color="C0" if name == "max" else "C1", lw=1.4)
        for k, (label, mark) in KINDS.items():
            sel = kind == k
            if sel.any():
                ax.plot(lam[sel], y[sel], mark, color="k", mfc="none", ms=7,
                        label=label if name == "max" else None)
    if a.sweep:
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        import plot_sweep
        d = plot_sweep.read(a.sweep, a.metric or f"{ids[e]}.disp_max", param or None)
        ok = d["status"] == 0
        ax.plot(d["x"][ok], d["y"][ok], "x", color="C3", ms=5, label="brute-force sweep")
    ax.plot([], [], "-", color="k", label="stable")
    ax.plot([], [], "--", color="k", label="unstable")
    ax.set_xlabel(param or "parameter")
    ax.set_ylabel(f"{ids[e]}: displacement extremes over the orbit")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    out = a.output or os.path.splitext(a.branch)[0] + ".png"
    fig.savefig(out, dpi=120)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
