#!/usr/bin/python3
"""A 1 000-run sweep of small runs: in-process from Python (trainsim.sweep, through
libtrainsim_c) against starting one `trainsim run` process per run (docs/benchmarks.md
"Python package: in-process runs against processes").

    PYTHONPATH=build/python /usr/bin/python3 bench/python_vs_processes.py build/trainsim
        [--runs 1000] [--steps 250] [--reps 3]

The runs: the GHM rig (inputs/gregory_harris_munro.nml) with run.t_end = steps * 8e-6 s
(250 RK4 steps: a small run), half_backlash swept over `runs` values. In-process: one
trainsim.sweep call (metrics only, no series). Processes: `trainsim run DECK --no-output
--set run.t_end=... --set mesh.half_backlash=...` one after another (metrics printed,
no history file), from Python's subprocess. Interleaved `reps` times; medians reported
with the load average. Also the cost of one Python call per run beyond the run itself:
(in-process wall - sum of the runs' own wall times) / runs. Not a test: asserts nothing.
"""
import argparse
import os
import statistics
import subprocess
import sys
import time

import numpy as np

import trainsim


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("exe")
    ap.add_argument("--runs", type=int, default=1000)
    ap.add_argument("--steps", type=int, default=250)
    ap.add_argument("--reps", type=int, default=3)
    a = ap.parse_args()
    deck = os.path.join(os.path.dirname(__file__), "..", "inputs", "gregory_harris_munro.nml")
    t_end = a.steps * 8e-6
    backlash = np.linspace(0.004, 0.006, a.runs)
    print(f"load average before: {os.getloadavg()}")
    py_walls, proc_walls, run_walls = [], [], []
    for rep in range(a.reps):
        t0 = time.perf_counter()
        table = trainsim.sweep(deck, {"mesh.half_backlash": backlash}, set={"run.t_end": t_end})
        py_walls.append(time.perf_counter() - t0)
        run_walls.append(float(np.sum(table["run.wall_time"])))
        assert all(table["status"] == 1)
        t0 = time.perf_counter()
        for b in backlash:
            subprocess.run([a.exe, "run", deck, "--no-output", "--set", f"run.t_end={t_end!r}",
                            "--set", f"mesh.half_backlash={b!r}"], check=True, stdout=subprocess.DEVNULL,
                           stderr=subprocess.DEVNULL)
        proc_walls.append(time.perf_counter() - t0)
        print(f"rep {rep + 1}: in-process {py_walls[-1]:.2f} s, processes {proc_walls[-1]:.2f} s")
    py, pr, rw = statistics.median(py_walls), statistics.median(proc_walls), statistics.median(run_walls)
    n = a.runs
    print(f"{n} runs of {a.steps} RK4 steps (GHM rig), median of {a.reps}:")
    print(f"  in-process (trainsim.sweep): {py:.2f} s = {1e3 * py / n:.2f} ms/run")
    print(f"  {n} trainsim run processes:   {pr:.2f} s = {1e3 * pr / n:.2f} ms/run")
    print(f"  ratio processes / in-process: {pr / py:.1f}")
    print(f"  the runs' own wall (sum of run.wall_time): {rw:.2f} s; Python + interface per run: "
          f"{1e3 * (py - rw) / n:.3f} ms")
    print(f"load average after: {os.getloadavg()}")


if __name__ == "__main__":
    sys.exit(main())
