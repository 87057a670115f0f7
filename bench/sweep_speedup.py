#!/usr/bin/python3
"""Sweep benchmark: serial against MPI ranks, and the manager's overhead per run.

    /usr/bin/python3 bench/sweep_speedup.py build/trainsim [--reps 3] [--cycles 1100]
                                             [--tiny 2000] [--only speedup|tiny]

1. Speed-up where runs dominate: the 27-run Fig. 5.11 sweep
   (inputs/sweep_ghm_mesh_frequency.nml) with `--cycles` mesh cycles per run (100 settle,
   the rest measured), serial and on 2 ranks, interleaved (serial, 2 ranks, serial, ...)
   `--reps` times, each from a fresh sweep file. Reports per configuration the median wall
   (whole process: mpirun's start-up included), runs/s, CPU seconds (user + sys of every
   process, from the children's rusage), and per pair the speed-up, with its median and
   range, and the CPU ratio (2 ranks / serial). Also the speed-up of the sweep phase alone
   (the "s elapsed" of trainsim's last progress line: from the first run handed out to
   the last recorded, without start-up, validation and MPI_Init/Finalize), and how well
   the hand-out keeps the ranks busy whatever the machine's load: that speed-up divided by
   the one the runs' own wall times allow, 2 * (sum of run walls, serial) / (sum, 2 ranks)
   (a run is slower when the two ranks share the cores with other processes).
2. The manager's overhead per run: `--tiny` runs of 5 RK4 steps each (the same rig,
   t_end = 4e-5 s), serially and on 2 and 4 (oversubscribed) ranks, interleaved. Reports the
   wall per run and the time per run not spent in runs:
   (wall * min(ranks, cores) - sum of /runs/wall_time) / runs.

Timings on a shared machine are noisy: the script prints the load average (uptime) before
and after, and compares configurations only within one interleaved run. With
`--wait-idle S` it waits (at most S seconds) before each round until no other process has
been running for 2 s (the running count of /proc/loadavg), and says how long it waited. Needs mpirun for
the MPI configurations (skipped without it). Not a test: it asserts nothing.
"""

import argparse
import os
import re
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

import h5py

HERE = os.path.dirname(os.path.abspath(__file__))
DECK = os.path.join(HERE, "..", "inputs", "sweep_ghm_mesh_frequency.nml")
MPI = ["--allow-run-as-root", "--oversubscribe"]


def load():
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


def running_others():
    """Processes running now, besides the one reading /proc/loadavg."""
    with open("/proc/loadavg") as f:
        return int(f.read().split()[3].split("/")[0]) - 1


def wait_idle(limit):
    """Wait until nothing else has run for 2 s (checked every 0.1 s), at most `limit` s."""
    t0 = time.perf_counter()
    quiet = 0
    while quiet < 20 and time.perf_counter() - t0 < limit:
        quiet = quiet + 1 if running_others() == 0 else 0
        time.sleep(0.1)
    return time.perf_counter() - t0, quiet >= 20


def timed(cmd, cwd):
    """Wall and CPU (user + sys of the process and its descendants) of one command."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    r = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        sys.exit(f"failed ({r.returncode}): {' '.join(cmd)}\n{r.stderr}")
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    el = re.findall(r"runs done.*?, ([0-9.]+) s elapsed", r.stderr)
    timed.elapsed = float(el[-1]) if el else float("nan")
    return wall, cpu


def sweep_cmd(exe, ranks, deck, out):
    base = [exe, "sweep", deck, "-o", out]
    if ranks == 1:
        return base
    return [shutil.which("mpirun"), *MPI, "-np", str(ranks), *base]


def run_walls(path):
    with h5py.File(path, "r") as f:
        return float(f["runs/wall_time"][:].sum()), f["runs/rank"][:]


def interleaved(exe, deck, configs, reps, tmp, idle=0.0):
    """{ranks: [(wall, cpu, sum of run walls, ranks of the runs, sweep phase wall), ...]} over `reps` rounds."""
    out = {r: [] for r in configs}
    for i in range(reps):
        if idle > 0:
            waited, ok = wait_idle(idle)
            print(f"  round {i + 1}: waited {waited:.1f} s for an idle machine" + ("" if ok else " (not idle)"),
                  f"load {load()}", flush=True)
        for ranks in configs:
            h5 = os.path.join(tmp, f"s{ranks}_{i}.h5")
            wall, cpu = timed(sweep_cmd(exe, ranks, deck, h5), tmp)
            rw, rk = run_walls(h5)
            out[ranks].append((wall, cpu, rw, rk, timed.elapsed))
            os.remove(h5)
            print(f"  round {i + 1}, {ranks} rank(s): {wall:.3f} s wall, {cpu:.3f} s CPU", flush=True)
    return out


def speedup(exe, args, tmp, have_mpi):
    with open(DECK) as f:
        text = f.read()
    measure = args.cycles - 100
    text, k = re.subn(r"(parameter = 'mesh.measure_cycles', values = )\d+", rf"\g<1>{measure}", text)
    assert k == 1, "the deck's measure_cycles group moved"
    deck = os.path.join(tmp, "fig5_11.nml")
    with open(deck, "w") as f:
        f.write(text)
    configs = [1, 2] if have_mpi else [1]
    print(f"\n27-run Fig. 5.11 sweep, {args.cycles} mesh cycles per run, {args.reps} interleaved rounds")
    res = interleaved(exe, deck, configs, args.reps, tmp, args.wait_idle)
    print(f"\n| ranks | wall (median, range) | runs/s | CPU (median) | run wall (sum, median) |")
    print("|---|---|---|---|---|")
    for r in configs:
        walls = [x[0] for x in res[r]]
        cpus = [x[1] for x in res[r]]
        print(f"| {r} | {statistics.median(walls):.3f} s ({min(walls):.3f}-{max(walls):.3f}) | "
              f"{27 / statistics.median(walls):.1f} | {statistics.median(cpus):.3f} s | "
              f"{statistics.median([x[2] for x in res[r]]):.3f} s |")
    if have_mpi:
        sp = [a[0] / b[0] for a, b in zip(res[1], res[2])]
        cr = [b[1] / a[1] for a, b in zip(res[1], res[2])]
        ph = [a[4] / b[4] for a, b in zip(res[1], res[2])]
        ef = [x / (2 * a[2] / b[2]) for x, a, b in zip(ph, res[1], res[2])]
        print(f"\nspeed-up on 2 ranks (per round): {', '.join(f'{x:.3f}' for x in sp)}; "
              f"median {statistics.median(sp):.3f} (range {min(sp):.3f}-{max(sp):.3f})")
        print(f"sweep phase alone (no start-up): speed-up median {statistics.median(ph):.3f} "
              f"(range {min(ph):.3f}-{max(ph):.3f})")
        print(f"... over what the runs' wall times allow (busy ranks): median {statistics.median(ef):.3f} "
              f"(range {min(ef):.3f}-{max(ef):.3f})")
        print(f"CPU 2 ranks / serial: median {statistics.median(cr):.3f} (range {min(cr):.3f}-{max(cr):.3f})")
        print("runs per rank (last round): " +
              ", ".join(f"rank {k}: {int((res[2][-1][3] == k).sum())}" for k in sorted(set(res[2][-1][3]))))


def tiny(exe, args, tmp, have_mpi):
    with open(DECK) as f:
        text = f.read()
    text = re.sub(r"&sweep[^/]*/\n", "", text)
    text = text.replace("t_end = 0.02,", "t_end = 4.0e-5,")
    text += (f"&sweep parameter = 'mesh.half_backlash', from = 0.004, to = 0.006, count = {args.tiny} /\n")
    deck = os.path.join(tmp, "tiny.nml")
    with open(deck, "w") as f:
        f.write(text)
    configs = [1, 2, 4] if have_mpi else [1]
    cores = os.cpu_count() or 1
    print(f"\n{args.tiny} tiny runs (5 RK4 steps each), {args.reps} interleaved rounds; {cores} cores")
    res = interleaved(exe, deck, configs, args.reps, tmp, args.wait_idle)
    start = {}
    if have_mpi:
        for r in configs[1:]:
            start[r] = statistics.median(
                [timed([shutil.which("mpirun"), *MPI, "-np", str(r), exe, "--version"], tmp)[0] for _ in range(3)])
    print("\n| ranks | wall (median) | wall per run | not in runs, per run | run wall (sum) | runs per rank |")
    print("|---|---|---|---|---|---|")
    n = args.tiny
    for r in configs:
        walls = [x[0] for x in res[r]]
        i = walls.index(statistics.median(walls)) if len(walls) % 2 else 0
        wall, _, rw, rk, _ = res[r][i]   # (wall, cpu, run walls, ranks, sweep phase)
        over = (wall * min(r, cores) - rw) / n
        per_rank = " / ".join(str(int((rk == k).sum())) for k in sorted(set(rk.tolist())))
        print(f"| {r} | {wall:.3f} s | {wall / n * 1e3:.2f} ms | {over * 1e3:.2f} ms | {rw:.3f} s | {per_rank} |")
    for r, t in start.items():
        print(f"mpirun -np {r} trainsim --version: {t:.3f} s (start-up, included above)")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("trainsim")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--cycles", type=int, default=1100, help="mesh cycles per run (100 settle + the rest)")
    ap.add_argument("--tiny", type=int, default=2000, help="number of tiny runs")
    ap.add_argument("--only", choices=("speedup", "tiny"))
    ap.add_argument("--wait-idle", type=float, default=0.0, metavar="S",
                    help="before each round, wait up to S s for no other running process")
    args = ap.parse_args()
    exe = os.path.abspath(args.trainsim)
    have_mpi = shutil.which("mpirun") is not None
    print(f"load average before: {load()}")
    with tempfile.TemporaryDirectory() as tmp:
        if have_mpi:
            r = subprocess.run([shutil.which("mpirun"), *MPI, "-np", "2", exe, "sweep", "/nonexistent.nml"],
                               capture_output=True, text=True, cwd=tmp)
            if "built without MPI" in r.stderr:
                print("trainsim was built without MPI: serial figures only")
                have_mpi = False
        if args.only in (None, "speedup"):
            speedup(exe, args, tmp, have_mpi)
        if args.only in (None, "tiny"):
            tiny(exe, args, tmp, have_mpi)
    print(f"\nload average after: {load()}")


if __name__ == "__main__":
    main()
