#!/usr/bin/python3
"""Work-precision of a peak under the adaptive integrators (issue 20 item 5, D-50):
the start-stop deck's peak mesh force (inputs/start_stop_two_clearances.nml, t_end 2 s,
energy tracking off, as tests/test_peaks.f90) against rtol, and against the RHS
evaluations it cost, for cvode-bdf, cvode-adams and arkode-dp.

    /usr/bin/python3 bench/peak_vs_rtol.py build/trainsim [--before OLD_TRAINSIM]
        [--csv docs/peak_vs_rtol.csv] [--png docs/peak_vs_rtol.png]

The reference is event-located RK4 at dt 1e-6 (1696.36954455 lbf; at dt 2e-6
1696.36954430: the two agree to 1.5e-10). With --before, the same runs of another
build (main before D-50) are drawn dashed. Each run takes 1-5 s in Release.
"""
import argparse
import csv
import os
import subprocess
import tempfile

import h5py
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DECK = os.path.join(ROOT, "inputs", "start_stop_two_clearances.nml")
RTOLS = [1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10]
METHODS = ["cvode-bdf", "cvode-adams", "arkode-dp"]


def run(exe, sets):
    """(peak mesh force, RHS evaluations) of one run of the deck."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "run.h5")
        args = [exe, "run", DECK, "-o", out, "--set", "run.t_end=2.0", "--set", "run.track_energy=false"]
        for s in sets:
            args += ["--set", s]
        subprocess.run(args, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        with h5py.File(out, "r") as f:
            return float(f["metrics/max_peak_force"][1]), int(f["run_stats"].attrs["rhs_evals"])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("exe")
    ap.add_argument("--before")
    ap.add_argument("--csv", default=os.path.join(ROOT, "docs", "peak_vs_rtol.csv"))
    ap.add_argument("--png", default=os.path.join(ROOT, "docs", "peak_vs_rtol.png"))
    ap.add_argument("--plot-only", action="store_true", help="draw the figure from the CSV, run nothing")
    a = ap.parse_args()
    if a.plot_only:
        rows = [dict(r, rtol=float(r["rtol"]), rel_err=float(r["rel_err"]), rhs_evals=int(r["rhs_evals"]))
                for r in csv.DictReader(open(a.csv))]
        ref = 1696.3695445505   # RK4 at dt 1e-6 (the runs' reference)
        plot(rows, ref, a.png)
        return
    ref, _ = run(a.exe, ["run.integrator=rk4", "run.dt=1e-6"])
    builds = [("after", a.exe)] + ([("before", a.before)] if a.before else [])
    rows = []
    for build, exe in builds:
        for m in METHODS:
            for r in RTOLS:
                f, nfe = run(exe, [f"run.integrator={m}", f"run.rtol={r}"])
                rows.append(dict(build=build, integrator=m, rtol=r, peak=f, rhs_evals=nfe,
                                 rel_err=abs(f - ref) / ref))
                print(f"{build:6s} {m:12s} rtol {r:.0e}: peak {f:.7f} lbf, rel. error {abs(f - ref) / ref:.2e}, "
                      f"{nfe} RHS", flush=True)
    with open(a.csv, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    plot(rows, ref, a.png)
    print(f"wrote {a.csv} and {a.png}")


def plot(rows, ref, png):
    color = {"cvode-bdf": "C3", "cvode-adams": "C2", "arkode-dp": "C1"}
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    for build, ls in (("after", "-"), ("before", "--")):
        for m in METHODS:
            pts = [r for r in rows if r["build"] == build and r["integrator"] == m]
            if not pts:
                continue
            lab = f"{m} ({'before D-50' if build == 'before' else 'D-50'})"
            err = [max(p["rel_err"], 1e-12) for p in pts]
            axes[0].loglog([p["rtol"] for p in pts], err, ls, marker="o", color=color[m], label=lab,
                           alpha=1.0 if build == "after" else 0.6)
            axes[1].loglog([p["rhs_evals"] for p in pts], err, ls, marker="o", color=color[m], label=lab,
                           alpha=1.0 if build == "after" else 0.6)
    for ax in axes:
        ax.axhline(1e-6, color="k", lw=0.8, ls=":")
        ax.set_ylabel("|peak - RK4| / RK4")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_xlabel("rtol")
    axes[0].invert_xaxis()
    axes[1].set_xlabel("RHS evaluations")
    axes[0].legend(fontsize=7)
    fig.suptitle(f"start-stop deck, peak mesh force (RK4 reference {ref:.5f} lbf)")
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == "__main__":
    main()
