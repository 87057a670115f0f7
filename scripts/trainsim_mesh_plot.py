#!/usr/bin/python3
"""Plot a mesh excitation table written by `trainsim gear DECK -o TABLE`.

    trainsim_mesh_plot.py TABLE -o OUT.png|svg|pdf

Two panels against the roll position u (teeth): the mesh stiffness k c(u), and the
loaded (stiffness-weighted) and unloaded (first pair to touch) static transmission
error. `trainsim gear DECK --plot OUT.png` writes the table and runs this.
"""
import argparse
import sys

import numpy as np


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("table")
    ap.add_argument("-o", "--output", required=True)
    a = ap.parse_args(argv)
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("trainsim_mesh_plot: error: matplotlib is not installed", file=sys.stderr)
        return 2
    try:
        head = [l[1:].strip() for l in open(a.table) if l.startswith("#")]
        d = np.loadtxt(a.table, comments="#", ndmin=2)
    except OSError as e:
        print(f"trainsim_mesh_plot: error: cannot read {a.table}: {e}", file=sys.stderr)
        return 2
    if d.shape[0] == 0 or d.shape[1] != 6:
        print(f"trainsim_mesh_plot: error: {a.table} is not a mesh table (6 columns)", file=sys.stderr)
        return 2
    u, k, te, tu = d[:, 0], d[:, 2], d[:, 4], d[:, 5]
    fig, (ax1, ax2) = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
    ax1.plot(u, k, lw=1.0)
    ax1.set_ylabel("mesh stiffness k c(u)")
    ax1.set_title(head[0] if head else a.table, fontsize=10)
    ax2.plot(u, te, lw=1.0, label="loaded static TE (stiffness-weighted)")
    ax2.plot(u, tu, lw=1.0, ls="--", label="unloaded static TE")
    ax2.set_xlabel("roll position u (teeth)")
    ax2.set_ylabel("TE along the line of action")
    ax2.legend(fontsize=8)
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
    fig.tight_layout()
    fig.savefig(a.output)
    print(f"figure written to {a.output}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
