#!/usr/bin/env python3
"""The cost of the Fig. 5.11 frequency response by continuation against the settled
brute-force sweep at equal answers, as ratios measured in one run (docs/benchmarks.md
"Continuation", D-133).

For each shaft damping given (default 500 and 50 lb in s/rad on shaft1 and shaft3: the
bundled rig is undamped and no brute-force run settles to its marginal orbits):

- the continuation: `trainsim continue` over 645 -> 385 teeth/s (every orbit, stable and
  unstable, the folds located to ~1e-9, every element metric of each orbit), as
  verification/continuation/study.py runs it;
- "old": the deck's 27 frequencies, each run from the deck's start, settled to 1e-8
  (what the benchmark compared before; it finds neither the jumps nor, inside the
  hysteresis band, more than one of the coexisting orbits);
- "equal answers": what the continuation gives, by brute force -- a down sweep and an up
  sweep over the 27 frequencies with the state carried from run to run (`continuation =
  'down'/'up'`, D-43), every run settled to 1e-8, so that both stable branches of the
  hysteresis are met; then every bracket of consecutive frequencies across which the
  metric changes by more than --jump (relative) is refined: a sweep in the same
  direction over the same frequencies up to the bracket's near end, then 9 frequencies
  inside it (the state carried through the chain, as a rig is run up or down), until
  the change inside a bracket is smooth (below --jump) or the bracket is narrower than
  --resolution (default 0.01 teeth/s): a jump located to that resolution.

Equal answers are checked, not assumed: every settled run of the up and down sweeps
against the branch's stable stretches at its frequency (the metric mesh p2p_range, the
closest stable stretch; the sampling bound of the extremes, (2 pi f dt_out)^2/8, is
printed beside it), and every located jump against the branch's folds (the fold lies
in the bracket, widened by the resolution).

Usage: continuation_vs_sweep.py TRAINSIM [--damping D ...] [--resolution R] [--jump J]
"""
import argparse
import os
import re
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                                "verification", "continuation"))
import study  # noqa: E402

CASE = study.CASES["fig5_11"]
TOL = 1e-8


def carried_deck(values, direction, out, name):
    """The case's sweep deck over `values` with the state carried in `direction`."""
    path = study.sweep_deck(CASE, 645.0, 385.0, 27, TOL, out)
    text = open(path).read()
    vals = ", ".join(f"{v:.6f}" for v in values)
    text, n = re.subn(r"(parameter = '%s', )from = [0-9.]+, to = [0-9.]+, count = [0-9]+" % re.escape(CASE["key"]),
                      lambda m: f"{m.group(1)}values = {vals}, continuation = '{direction}'", text)
    assert n == 1, "the deck's mesh_frequency &sweep group was not found"
    p = os.path.join(out, name + ".nml")
    open(p, "w").write(text)
    return p


def run_sweep(exe, deck, sets, out, name):
    """CPU seconds and (lam, value, settled) in run order of the sweep of `deck`."""
    h5 = os.path.join(out, name + ".h5")
    if os.path.exists(h5):
        os.remove(h5)
    cpu, rc = study.cpu_of([exe, "sweep", deck, *sets, "-o", h5, "--progress", "100000"],
                           os.path.join(out, name + ".log"))
    if rc != 0:
        raise SystemExit(f"sweep {name} failed (exit {rc}): see {out}/{name}.log")
    lam, val, settled, _ = study.read_sweep(h5, CASE["key"], "p2p_range", CASE["element"])
    return cpu, lam, val, settled


def ordered(lam, val, settled, direction):
    o = np.argsort(lam)
    if direction == "down":
        o = o[::-1]
    return lam[o], val[o], settled[o]


def jumps(lam, val, thr):
    """Brackets (i, i + 1) in run order across which the metric changes by more than thr."""
    return [i for i in range(len(lam) - 1)
            if abs(val[i + 1] - val[i]) > thr * min(abs(val[i]), abs(val[i + 1]))]


def locate(exe, sets, out, grid, direction, a, b, thr, res, tag, cpu):
    """Refine the bracket (a, b) (a met first in `direction`) down to `res`: (lo, hi) or None
    if the change there is smooth. cpu: a list the sweeps' CPU seconds are appended to."""
    level = 0
    while abs(b - a) > res:
        level += 1
        head = [g for g in grid if (g >= a if direction == "down" else g <= a)]
        inner = list(np.linspace(a, b, 11)[1:-1])
        c, lam, val, settled = run_sweep(exe, carried_deck(head + inner + [b], direction, out, f"{tag}_{level}"),
                                         sets, out, f"{tag}_{level}")
        cpu.append(c)
        lam, val, settled = ordered(lam, val, settled, direction)
        k = list(lam).index(min(lam, key=lambda x: abs(x - a)))
        seg_l, seg_v = lam[k:], val[k:]
        j = jumps(seg_l, seg_v, thr)
        if not j:
            return None
        a, b = seg_l[j[0]], seg_l[j[0] + 1]
    return (min(a, b), max(a, b))


def one_damping(exe, d, out, res, thr):
    sets = [s for sh in CASE["shafts"] for s in ("--set", f"{sh}.damping={d:g}")]
    deck = os.path.join(study.ROOT, CASE["deck"])
    branch = os.path.join(out, "branch.h5")
    if os.path.exists(branch):
        os.remove(branch)
    c_cpu, c_rc = study.cpu_of([exe, "continue", deck, *sets, "--param", f"{CASE['key']}=645:385",
                                "--restarts", "3", "--ds-max", "0.05", "-o", branch], os.path.join(out, "continue.log"))
    br = study.read_branch(branch, "p2p_range")
    e = br["ids"].index(CASE["element"])
    folds = sorted(set(round(x, 6) for x in br["lam"][(br["kind"] == 1) & br["ok"]]))
    print(f"damping {d:g}: continuation exit {c_rc}, {len(br['lam'])} points, {br['maps']} maps, "
          f"CPU {c_cpu:.2f} s; folds {folds}")
    # old: 27 runs from the deck's start (a file of an earlier run would be refused)
    if os.path.exists(os.path.join(out, "fixed.h5")):
        os.remove(os.path.join(out, "fixed.h5"))
    old_cpu, old_rc = study.cpu_of([exe, "sweep", study.sweep_deck(CASE, 645.0, 385.0, 27, TOL, out), *sets,
                               "-o", os.path.join(out, "fixed.h5"), "--progress", "100000"],
                              os.path.join(out, "fixed.log"))
    if old_rc != 0:
        raise SystemExit(f"the 27-run sweep failed (exit {old_rc}): see {out}/fixed.log")
    grid = list(np.linspace(385.0, 645.0, 27))
    cpu, located, worst, n_on, n_off = [], [], 0.0, 0, 0
    for direction in ("down", "up"):
        g = sorted(grid, reverse=(direction == "down"))
        c, lam, val, settled = run_sweep(exe, carried_deck(g, direction, out, direction), sets, out, direction)
        cpu.append(c)
        lam, val, settled = ordered(lam, val, settled, direction)
        for x, v, s in zip(lam, val, settled):
            cands = study.branch_at(br, x, e)
            if s != 1 or not cands:
                n_off += 1
                continue
            b, _ = min(cands, key=lambda cc: abs(cc[0] - v))
            rel = abs(v - b) / abs(v)
            if rel > 0.05:
                n_off += 1
                print(f"  {direction} {x:8.3f}: sweep {v:.6e}, no stable stretch of the branch near it ({b:.6e})")
                continue
            n_on += 1
            worst = max(worst, rel)
        for i in jumps(lam, val, thr):
            spent = []
            r = locate(exe, sets, out, g, direction, lam[i], lam[i + 1], thr, res, f"{direction}_{i}", spent)
            cpu += spent
            if r is None:
                print(f"  {direction}: {lam[i]:.2f} -> {lam[i + 1]:.2f} smooth when refined ({sum(spent):.2f} s)")
                continue
            inside = [f for f in folds if r[0] - res <= f <= r[1] + res]
            located.append((direction, r, inside, sum(spent)))
            print(f"  {direction} jump located in [{r[0]:.4f}, {r[1]:.4f}] teeth/s ({len(spent)} sweeps, "
                  f"{sum(spent):.2f} s); the branch's fold there: {inside if inside else 'NONE (not on the branch)'}")
    eq_cpu = sum(cpu)
    print(f"  up/down sweeps: {n_on} settled runs on the branch's stable stretches (largest rel. diff "
          f"{worst:.2e}), {n_off} not; {len(cpu)} sweeps, CPU {eq_cpu:.2f} s")
    # the part of it that gives the continuation's answers: the two sweeps and the refinement of
    # the jumps that are the branch's folds (the others locate jumps the branch does not hold)
    matched = eq_cpu - sum(c for _, _, inside, c in located if not inside)
    return dict(d=d, c=c_cpu, old=old_cpu, eq=eq_cpu, matched=matched, worst=worst, located=located, folds=folds,
                points=len(br["lam"]), maps=br["maps"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trainsim")
    ap.add_argument("--damping", type=float, nargs="+", default=[500.0, 50.0])
    ap.add_argument("--resolution", type=float, default=0.01, help="teeth/s a jump is located to")
    ap.add_argument("--jump", type=float, default=0.2, help="relative change between neighbours taken as a jump")
    ap.add_argument("--out")
    a = ap.parse_args()
    exe = os.path.abspath(a.trainsim)
    rows = []
    for d in a.damping:
        out = os.path.join(a.out or tempfile.mkdtemp(prefix="trainsim_cvs_"), f"d{d:g}")
        os.makedirs(out, exist_ok=True)
        rows.append(one_damping(exe, d, out, a.resolution, a.jump))
    print(f"\n{'damping':>8} {'continue s':>11} {'old sweep s':>12} {'old ratio':>10} {'up/down+jumps s':>16} "
          f"{'ratio':>7} {'of it for folds s':>20} {'ratio':>7} {'jumps at a fold / all':>22}")
    for r in rows:
        ok = sum(1 for _, _, inside, _ in r["located"] if inside)
        print(f"{r['d']:8g} {r['c']:11.2f} {r['old']:12.2f} {r['old'] / r['c']:10.2f} {r['eq']:16.2f} "
              f"{r['eq'] / r['c']:7.2f} {r['matched']:20.2f} {r['matched'] / r['c']:7.2f} "
              f"{ok:>12d} / {len(r['located'])}")


if __name__ == "__main__":
    main()
