#!/usr/bin/env python3
"""Frequency response of a branch from `trainsim continue -o BRANCH.h5` (docs/periodic.md
"The branch file"): an element metric of each periodic orbit (default p2p_range; `disp`:
the displacement extremes) against the parameter, stable parts solid, unstable parts
dashed, folds (o), period-doubling (s), Neimark-Sacker (^) and grazing points (d) marked,
where a stretch ended (a failed point: its reason in the file) a dotted line; with
--sweep FILE.h5 the settled brute-force sweep's points of the same metric overlaid
(plot_sweep.py's reader).

Several branch files (e.g. two continuations from one start, one to each end) are drawn
together.

Usage: plot_branch.py BRANCH.h5 [BRANCH2.h5 ...] [--element ID] [--metric NAME|disp]
                      [--sweep SWEEP.h5] [-o FIG]
"""
import argparse
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

KINDS = {1: ("fold", "o"), 2: ("period-doubling", "s"), 3: ("Neimark-Sacker", "^"), 4: ("grazing", "d")}


def read_branch(path, metric):
    """The committed points of a branch file (HDF5, docs/periodic.md "The branch file"):
    parameter name, lambda, kind, stable, segment, status, and METRIC (ELEMENT.NAME, or
    NAME of every element: a 2-D array), the element ids."""
    import h5py
    with h5py.File(path, "r") as f:
        if f.attrs.get("format") != "trainsim-branch":
            sys.exit(f"{path}: not a trainsim branch file")
        st = f["runs/status"][:]
        n = int((st != 0).sum())
        if n == 0:
            sys.exit(f"{path}: no point in the branch file")
        ids = list(f["elements/ids"].asstr()[:])
        name = metric.split(".")[-1]
        if f"elements/{name}" not in f:
            sys.exit(f"no metric '{name}'; metrics: {', '.join(k for k in f['elements'] if k not in ('ids', 'types'))}")
        d = dict(param=f["parameters/names"].asstr()[0], lam=f["parameters/values"][:n, 0],
                 kind=f["runs/kind"][:n], stable=f["runs/stable"][:n], segment=f["runs/segment"][:n],
                 status=st[:n], reason=f["runs/reason"][:n], y=f[f"elements/{name}"][:n, :], ids=ids)
    return d


def read_branches(paths, metric):
    """read_branch of each file, joined: points in sequence, segments numbered apart."""
    d, off = None, 0
    for path in paths:
        r = read_branch(path, metric)
        r["segment"] = r["segment"] + off
        off = int(r["segment"].max()) + 1
        if d is None:
            d = r
            continue
        for k in ("lam", "kind", "stable", "segment", "status", "y"):
            d[k] = np.concatenate([d[k], r[k]])
    return d


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("branch", nargs="+")
    ap.add_argument("--element", help="element id (default: the last element with a nonzero swing)")
    ap.add_argument("--metric", default="p2p_range",
                    help="the element metric drawn (default p2p_range; disp: disp_min and disp_max)")
    ap.add_argument("--sweep", help="a sweep file to overlay")
    ap.add_argument("-o", "--output", default=None)
    a = ap.parse_args(argv)
    names = ["disp_max", "disp_min"] if a.metric == "disp" else [a.metric]
    reads = [read_branches(a.branch, m) for m in names]
    d = reads[0]
    ids, lam, kind, stable = d["ids"], d["lam"], d["kind"], d["stable"]
    ok, seg, param = d["status"] == 1, d["segment"], d["param"]
    if a.element:
        if a.element not in ids:
            sys.exit(f"no element '{a.element}'; elements: {', '.join(ids)}")
        e = ids.index(a.element)
    else:
        swing = np.nanmax(d["y"], axis=0) - np.nanmin(d["y"], axis=0)
        e = int(np.nonzero(swing > 0)[0][-1]) if (swing > 0).any() else len(ids) - 1
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for j, r in enumerate(reads):
        y = r["y"][:, e]
        colour = f"C{j}"
        for i in range(len(lam) - 1):   # a segment is stable when both its ends are
            if not (ok[i] and ok[i + 1]) or seg[i] != seg[i + 1]:
                continue
            st = stable[i] == 1 and stable[i + 1] == 1
            ax.plot(lam[i:i + 2], y[i:i + 2], "-" if st else "--", color=colour, lw=1.4)
        for k, (label, mark) in KINDS.items():
            sel = (kind == k) & ok
            if sel.any():
                ax.plot(lam[sel], y[sel], mark, color="k", mfc="none", ms=7, label=label if j == 0 else None)
    bad = ~ok
    if bad.any():
        for x in lam[bad]:
            ax.axvline(x, color="C3", lw=0.6, ls=":")
        ax.plot([], [], ":", color="C3", label="a stretch ended (reason in /runs/reason)")
    if a.sweep:
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        import plot_sweep
        for j, m in enumerate(names):
            sw = plot_sweep.read(a.sweep, f"{ids[e]}.{m}", param or None)
            good = sw["status"] == 1   # (1 ok: docs/sweeps.md)
            ax.plot(sw["x"][good], sw["y"][good], "x", color="C3", ms=5, label="brute-force sweep" if j == 0 else None)
    ax.plot([], [], "-", color="k", label="stable")
    ax.plot([], [], "--", color="k", label="unstable")
    ax.set_xlabel(param or "parameter")
    ax.set_ylabel(f"{ids[e]}: {a.metric} over the orbit")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    out = a.output or os.path.splitext(a.branch[0])[0] + ".png"
    fig.savefig(out, dpi=120)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
