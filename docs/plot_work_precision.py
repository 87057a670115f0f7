#!/usr/bin/env python3
"""Draw docs/work_precision.png from docs/work_precision.csv (written by
build/bench/bench_work_precision > docs/work_precision.csv)."""
import csv
import sys
from collections import defaultdict

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

src = sys.argv[1] if len(sys.argv) > 1 else "docs/work_precision.csv"
out = sys.argv[2] if len(sys.argv) > 2 else "docs/work_precision.png"
rows = list(csv.DictReader(open(src)))
cases = sorted({r["case"] for r in rows}, key=lambda c: [r["case"] for r in rows].index(c))
metrics = [("err_p2p", "peak-to-peak TE"), ("err_impact_times", "first 10 impact times"),
           ("err_peak_torque", "peak shaft torque")]
style = {"rk4-thesis": ("k", "s"), "rk4": ("C0", "o"), "cvode-bdf": ("C3", "^"), "cvode-adams": ("C2", "v"),
         "arkode-dp": ("C1", "D"), "arkode-verner": ("C4", "P")}
fig, axes = plt.subplots(len(cases), len(metrics), figsize=(13, 3.6 * len(cases)), squeeze=False)
for i, case in enumerate(cases):
    for j, (key, label) in enumerate(metrics):
        ax = axes[i][j]
        series = defaultdict(list)
        for r in rows:
            if r["case"] != case:
                continue
            e = float(r[key])
            if e < 0:          # no impacts in this case
                continue
            series[r["integrator"]].append((int(r["rhs_evals"]), max(e, 1e-13), r["setting"]))
        for integ, pts in series.items():
            pts.sort()
            c, m = style.get(integ, ("C5", "x"))
            ax.loglog([p[0] for p in pts], [p[1] for p in pts], marker=m, color=c, label=integ)
        ax.axhline(1e-4, color="grey", lw=0.8, ls="--")
        ax.set_title(f"{case}: {label}", fontsize=10)
        ax.set_xlabel("RHS evaluations")
        ax.set_ylabel("relative error vs reference")
        ax.grid(True, which="both", alpha=0.3)
        if not series:
            ax.text(0.5, 0.5, "no impacts", transform=ax.transAxes, ha="center")
        if i == 0 and j == 0:
            ax.legend(fontsize=8)
fig.suptitle("trainsim work-precision (reference: event-located RK4, dt = 5e-7 s; dashed: 1e-4)")
fig.tight_layout()
fig.savefig(out, dpi=90)
print("wrote", out)
