#!/usr/bin/env python3
"""Start-up of `trainsim run DECK --no-output` for one step, before -> after.

Writes the chains of bench/bench_startup.f90 (unit inertias, shafts k = 1e4; with
backlash a spur gear, half backlash 1e-3, as every 10th element; t_end = dt =
5e-3 s: one step) to a scratch directory and runs each TRAINSIM given on them,
timing the child's CPU time (user + system, from its own rusage by wait4: a
loaded machine inflates wall time, not this much) and its peak RSS. The figure
is the best of --rep runs at every size (the least RSS beside it); a
case is skipped for a binary once it has taken more than --cap seconds at a
smaller size (an O(n^2) start-up at 20 000 nodes takes minutes).

Usage (repository root, Release builds):
  /usr/bin/python3 bench/startup_cli.py /work/main/build/trainsim build/trainsim
"""
import argparse
import os
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
    """CPU seconds (user + system) and peak RSS (MB) of one run, from the child's own rusage."""
    proc = subprocess.Popen([exe, "run", deck, "--no-output"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    _, status, ru = os.wait4(proc.pid, 0)
    proc.returncode = os.waitstatus_to_exitcode(status)
    if proc.returncode != 0:
        raise subprocess.CalledProcessError(proc.returncode, [exe, "run", deck])
    return ru.ru_utime + ru.ru_stime, ru.ru_maxrss / 1024.0


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("trainsim", nargs="+")
    ap.add_argument("--rep", type=int, default=3)
    ap.add_argument("--cap", type=float, default=30.0)
    a = ap.parse_args()
    cases = [(200, True), (1000, False), (5000, False), (20000, False), (1000, True), (5000, True), (20000, True)]
    tmp = tempfile.mkdtemp(prefix="trainsim_startup_")
    print("CPU seconds of `trainsim run DECK --no-output` (one step), best of", a.rep, "(every size), and peak RSS")
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
            runs = [cpu_of(e, deck) for _ in range(a.rep)]
            t = min(r[0] for r in runs)
            rss = min(r[1] for r in runs)
            if t > a.cap:
                slow[e].add(b)
            ratio = ""
            if (e, b) in prev and n > 200:
                ratio = f" (x{t / prev[(e, b)]:.1f})"
            prev[(e, b)] = t
            row += f"{f'{t:.3f}{ratio} {rss:.0f} MB':>28}"
        print(row, flush=True)
        os.remove(deck)
    os.rmdir(tmp)


if __name__ == "__main__":
    main()
