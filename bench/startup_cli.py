#!/usr/bin/env python3
"""Start-up of `trainsim run DECK --no-output` for one step, before -> after.

Writes the chains of bench/bench_startup.f90 (unit inertias, shafts k = 1e4; with
backlash a spur gear, half backlash 1e-3, as every 10th element; t_end = dt =
5e-3 s: one step) to a scratch directory and runs each TRAINSIM given on them,
timing the child's CPU time (user + system, from getrusage: a loaded machine
inflates wall time, not this much). The figure is the best of --rep runs; a
case is skipped for a binary once it has taken more than --cap seconds at a
smaller size (an O(n^2) start-up at 20 000 nodes takes minutes).

Usage (repository root, Release builds):
  /usr/bin/python3 bench/startup_cli.py /work/main/build/trainsim build/trainsim
"""
import argparse
import os
import resource
import subprocess
import tempfile


def chain(n, backlash, dt=5e-3):
    lines = [f"&run title = 'bench: start-up', t_end = {dt}, dt = {dt}, integrator = 'rk4', track_energy = .false. /"]
    lines += [f"&node id = 'n{i}', type = 'inertia', inertia = 1.0 /" for i in range(1, n + 1)]
    for i in range(1, n):
        if backlash and i % 10 == 0:
            lines.append(f"&element id = 'e{i}', type = 'spur_gear', stiffness = 1.0e4, rb_driver = 1.0, "
                         "rb_driven = 1.0, teeth = 32, contact_ratio = 1.6, approach_angle = 0.1, half_backlash = 1.0e-3 /")
        else:
            lines.append(f"&element id = 'e{i}', type = 'shaft', stiffness = 1.0e4 /")
    lines.append("&initial node = 'n1', speed = 1.0 /")
    return "\n".join(lines) + "\n"


def cpu_of(exe, deck):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run([exe, "run", deck, "--no-output"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("trainsim", nargs="+")
    ap.add_argument("--rep", type=int, default=3)
    ap.add_argument("--cap", type=float, default=30.0)
    a = ap.parse_args()
    cases = [(200, True), (1000, False), (5000, False), (20000, False), (1000, True), (5000, True), (20000, True)]
    tmp = tempfile.mkdtemp(prefix="trainsim_startup_")
    print("CPU seconds of `trainsim run DECK --no-output` (one step), best of", a.rep)
    print(f"{'chain':>18}" + "".join(f"{os.path.basename(os.path.dirname(os.path.dirname(os.path.abspath(e)))) + ':' + os.path.basename(e):>28}" for e in a.trainsim))
    slow = {e: set() for e in a.trainsim}
    prev = {}
    for n, b in cases:
        deck = os.path.join(tmp, f"chain_{n}_{'backlash' if b else 'shafts'}.nml")
        with open(deck, "w") as f:
            f.write(chain(n, b))
        row = f"{str(n) + (', backlash' if b else ', shafts'):>18}"
        for e in a.trainsim:
            if b in slow[e]:
                row += f"{'skipped':>28}"
                continue
            t = min(cpu_of(e, deck) for _ in range(a.rep if n < 20000 else 1))
            if t > a.cap:
                slow[e].add(b)
            ratio = ""
            if (e, b) in prev and n > 200:
                ratio = f" (x{t / prev[(e, b)]:.1f})"
            prev[(e, b)] = t
            row += f"{f'{t:.3f}{ratio}':>28}"
        print(row, flush=True)
        os.remove(deck)
    os.rmdir(tmp)


if __name__ == "__main__":
    main()
