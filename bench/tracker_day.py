#!/usr/bin/env python3
"""Cost of the tracker deck's day: inputs/tracker_azimuth.nml run to the end of its
target table (a day compressed 300x: 181 targets, 180 start-stop moves, 145 s of
simulated time), unattended.

Runs `trainsim run inputs/tracker_azimuth.nml --set run.t_end=T -o OUT` (T: the last
target's time plus 0.8 s unless --t-end), times the child's CPU time (getrusage) and
wall time, and reports from the run's summary and history: steps, RHS evaluations,
events (all, and target_reached: the moves completed), the energy residual, the cost per
simulated second and per move. The history (OUT) is what docs/tracker_azimuth.py plots.

Usage (repository root, a Release build):
  /usr/bin/python3 bench/tracker_day.py build/trainsim [-o tracker_day.h5] [--t-end T]
"""
import argparse
import re
import resource
import subprocess
import time

import h5py
import numpy as np


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("trainsim")
    ap.add_argument("-o", "--output", default="tracker_day.h5")
    ap.add_argument("--t-end", type=float, default=None)
    args = ap.parse_args()
    targets = np.loadtxt("inputs/tracker_targets.txt")
    t_end = args.t_end if args.t_end else float(targets[-1, 0]) + 0.8
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    w0 = time.time()
    r = subprocess.run([args.trainsim, "run", "inputs/tracker_azimuth.nml", "--set", f"run.t_end={t_end}",
                        "-o", args.output], capture_output=True, text=True)
    wall = time.time() - w0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if r.returncode != 0:
        print(r.stdout[-2000:], r.stderr[-2000:])
        raise SystemExit(f"trainsim exited {r.returncode}")
    m = re.search(r"steps (\d+), RHS evaluations (\d+)", r.stdout)
    steps, rhs = (int(m.group(1)), int(m.group(2))) if m else (0, 0)
    m = re.search(r"max \|residual\|\s+(\S+) \(energy scale\s+(\S+)", r.stdout)
    resid, scale = (float(m.group(1)), float(m.group(2))) if m else (float("nan"), float("nan"))
    with h5py.File(args.output) as f:
        kinds = f["events/kind_name"][:]
        n_events = len(kinds)
        reached = int(np.sum(kinds == b"target_reached"))
    due = int(np.sum(targets[:, 0] < t_end))
    print(f"tracker day: t_end {t_end:.1f} s simulated, {due} targets due, {reached} reached (events target_reached)")
    print(f"  cpu {cpu:.1f} s, wall {wall:.1f} s; steps {steps}, RHS evaluations {rhs}, events {n_events}")
    print(f"  per simulated second: cpu {cpu / t_end:.3f} s, {steps / t_end:.0f} steps, {n_events / t_end:.0f} events")
    print(f"  per move: cpu {cpu / max(1, reached):.3f} s")
    print(f"  energy residual {resid:.3e} of the scale {scale:.3e}")


if __name__ == "__main__":
    main()
