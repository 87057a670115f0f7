#!/usr/bin/python3
"""Peak RSS of `trainsim sweep` against the number of runs (issue 20, item 10).

usage: bench/sweep_memory.py TRAINSIM [--runs 1000 20000] [--limit 0.10]

Each sweep is the GHM rig of ../shared/repro/sweep-and-input/ghm_sweep20.nml (4 nodes,
3 elements) with 2 settling + 3 measured mesh cycles a run, so that the runs are short and
the memory that grows with the number of runs shows. The peak RSS is the kernel's
(ru_maxrss of the child). Prints one line per sweep and the growth of the largest over the
smallest; exits 1 if it is above --limit (10 %: a sweep of 10^5 runs on a cluster node
must not need more memory than one of 10^3). Not a timed test: 20 000 runs take about a
minute on the bench rig. Figures in docs/benchmarks.md.
"""
import argparse
import os
import resource
import subprocess
import sys
import tempfile

DECK = """&run  title = 'sweep memory benchmark', t_end = 0.02, dt = 8.0e-6, integrator = 'rk4',
      output_interval = 8.0e-6 /
&node id = 'n1', type = 'inertia', inertia = 100.0 /
&node id = 'n2', type = 'inertia', inertia = 0.987 /
&node id = 'n3', type = 'inertia', inertia = 0.987 /
&node id = 'n4', type = 'inertia', inertia = 100.0 /
&element id = 'shaft1', type = 'shaft', stiffness = 32000.0, damping = 0.0 /
&element id = 'mesh', type = 'spur_gear',
         stiffness = 234500.0, rb_driver = 3.7588, rb_driven = 3.7588, teeth = 32,
         contact_ratio = 1.6676, approach_angle = 0.1637, half_backlash = 0.005 /
&element id = 'shaft3', type = 'shaft', stiffness = 32000.0, damping = 0.0 /
&load node = 'n1', quantity = 'speed', kind = 'constant', value = 95.2295 /
&load node = 'n4', kind = 'constant', value = -798.8 /
&initial node = 'all', speed = 95.2295 /
&sweep parameter = 'mesh.mesh_frequency', from = 385, to = 645, count = {n} /
&sweep parameter = 'mesh.settle_cycles', values = 2 /
&sweep parameter = 'mesh.measure_cycles', values = 3 /
"""


def peak_rss_kib(cmd, cwd):
    """(peak RSS in KiB, wall s, exit status) of one child process."""
    import time
    t0 = time.monotonic()
    pid = os.fork()
    if pid == 0:
        os.chdir(cwd)
        fd = os.open(os.devnull, os.O_WRONLY)
        os.dup2(fd, 1)
        os.dup2(fd, 2)
        os.execv(cmd[0], cmd)
    _, status, ru = os.wait4(pid, 0)
    return ru.ru_maxrss, time.monotonic() - t0, os.waitstatus_to_exitcode(status)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("trainsim")
    ap.add_argument("--runs", type=int, nargs="+", default=[1000, 20000])
    ap.add_argument("--limit", type=float, default=0.10)
    a = ap.parse_args()
    exe = os.path.abspath(a.trainsim)
    res = {}
    with tempfile.TemporaryDirectory() as tmp:
        for n in a.runs:
            deck = os.path.join(tmp, f"s{n}.nml")
            with open(deck, "w") as f:
                f.write(DECK.format(n=n))
            rss, wall, rc = peak_rss_kib([exe, "sweep", deck, "-o", os.path.join(tmp, f"s{n}.h5")], tmp)
            if rc != 0:
                print(f"{n} runs: trainsim sweep exited {rc}")
                return 2
            res[n] = rss
            print(f"{n:6d} runs: peak RSS {rss / 1024:.1f} MiB, {wall:.1f} s ({wall / n * 1e3:.2f} ms a run)",
                  flush=True)
    lo, hi = min(a.runs), max(a.runs)
    growth = res[hi] / res[lo] - 1.0
    print(f"peak RSS of {hi} runs over {lo} runs: {growth * 100:+.1f} % "
          f"({(res[hi] - res[lo]) * 1024 / (hi - lo):.0f} bytes a run); limit {a.limit * 100:.0f} %")
    return 0 if growth <= a.limit else 1


if __name__ == "__main__":
    sys.exit(main())
