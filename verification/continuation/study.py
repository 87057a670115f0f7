#!/usr/bin/env python3
"""The Fig. 5.11 and Table 7.1 frequency responses by continuation (`trainsim continue`),
against the settled brute-force sweep (`trainsim sweep`) of the same decks, and the cost
of each (issue 27 item 5 and its benchmark; README.md here, docs/benchmarks.md
"Continuation").

Both bundled decks are undamped but for the impacts, so their periodic orbits are
marginal (end-inertia modes on the unit circle, docs/periodic.md): no orbit is isolated
and no brute-force run settles to it. Both are studied with a small shaft damping, given
by --damping (lb in s/rad, default 500 on the rig's two shafts and on the Table 7.1
train's three): the largest |mu| off the contact-loss band is then 0.997-0.998 (rig).

For each settled sweep run, the branch's value of the metric at that frequency is taken
from the stable stretches of the branch that span it, by a cubic through the four nearest
points (its error estimated by the difference to the quadratic through three); the
largest relative difference sweep - branch is reported with that estimate. The metric's
extremes are the trajectory's turning points in both (D-48, D-143), not the samples; the
"sampling" column, (2 pi f dt_out)^2 / 8, is the bound of sample extremes, kept in the
check's tolerance as before. Comparison to 1e-6 at the branch's own points, the sweep
settled to 1e-11: equal_sweep.py.

The cost: the CPU time of `trainsim continue` over the range (every orbit, stable and
unstable, folds located, metrics of every orbit) against the CPU time of the sweep whose
runs settle to the orbit to --settle-tol (default 1e-8: the state then within about
tol / (1 - |mu|) = 4e-6 of the orbit at |mu| = 0.9975).

Usage: study.py TRAINSIM [--case fig5_11|table7_1] [--from F --to T --count N] [--start S]
                 [--quick] [--out DIR] [--check TOL]
--start S: two continuations from S, one to each end of the range (the first orbit shot
from the deck's start at S, as a brute-force run there starts), compared together;
--quick: the case's cheap sub-range (the CTests); --check TOL: exit 1 unless every
settled sweep run equals the branch to TOL + 10x the interpolation estimate.
"""
import argparse
import os
import re
import resource
import subprocess
import sys
import tempfile

import h5py
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
CASES = {
    "fig5_11": dict(deck="inputs/sweep_ghm_mesh_frequency.nml", key="mesh.mesh_frequency", element="mesh",
                    shafts=["shaft1", "shaft3"], damping=500.0, lam=(645.0, 385.0), count=27,
                    quick=dict(lam=(645.0, 600.0), count=5)),
    "table7_1": dict(deck="inputs/sweep_two_clearance.nml", key="mesh1.mesh_frequency", element="mesh1",
                     shafts=["shaft1", "shaft3", "shaft5"], damping=500.0, lam=(640.0, 260.0), count=23,
                     dt_out=2.5e-5, quick=dict(lam=(450.0, 484.5454545454545), count=3), sweep_sets=["--set", "mesh1.settle_cycles=100", "--set", "mesh1.measure_cycles=60",
                                 "--set", "mesh1.settle_max_cycles=40000"]),
}


def cpu_of(cmd, log):
    """Run cmd; its CPU seconds (user + system of the child) and its exit status."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with open(log, "w") as f:
        rc = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT).returncode
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), rc


def sweep_deck(case, lam0, lam1, count, tol, out):
    """The case's sweep deck with its range, settle_tol and a settle budget for that tol."""
    text = open(os.path.join(ROOT, case["deck"])).read()
    text = re.sub(r"(parameter = '%s', from = )[0-9.]+(, to = )[0-9.]+(, count = )[0-9]+" % re.escape(case["key"]),
                  lambda m: f"{m.group(1)}{min(lam0, lam1)}{m.group(2)}{max(lam0, lam1)}{m.group(3)}{count}", text)
    text = re.sub(r"settle_tol = [0-9.eE+-]+", f"settle_tol = {tol:g}", text)
    text = re.sub(r"(settle_max_cycles', values = )[0-9]+", r"\g<1>40000", text)
    if not re.search(r"^&run[^!]*settle_tol", text, re.M | re.S):
        text = re.sub(r"^&run ", f"&run settle_tol = {tol:g}, ", text, count=1, flags=re.M)
    path = os.path.join(out, "sweep.nml")
    open(path, "w").write(text)
    return path


def branch_at(br, lam, element):
    """The branch's metric at lam on each stable stretch spanning it: [(value, estimate)]."""
    out = []
    ok, st, seg, x, y = br["ok"], br["stable"], br["segment"], br["lam"], br["y"][:, element]
    for i in range(len(x) - 1):
        if not (ok[i] and ok[i + 1] and st[i] and st[i + 1] and seg[i] == seg[i + 1]):
            continue
        if not min(x[i], x[i + 1]) <= lam <= max(x[i], x[i + 1]):
            continue
        j = [k for k in range(max(0, i - 1), min(len(x), i + 3)) if ok[k] and st[k] and seg[k] == seg[i]]
        if len(j) < 3:
            out.append((y[i] + (y[i + 1] - y[i]) * (lam - x[i]) / (x[i + 1] - x[i]), abs(y[i + 1] - y[i])))
            continue
        xs, ys = x[j] - lam, y[j]
        c3 = np.polyfit(xs, ys, min(3, len(j) - 1))
        c2 = np.polyfit(xs[:3] if len(j) > 3 else xs, ys[:3] if len(j) > 3 else ys, 2)
        out.append((np.polyval(c3, 0.0), abs(np.polyval(c3, 0.0) - np.polyval(c2, 0.0))))
    return out


def merge_branches(brs):
    """Branches as one: their points in sequence, each branch's segments numbered apart."""
    out, off = {}, 0
    for br in brs:
        seg = br["segment"] + off
        off = int(seg.max()) + 1 if len(seg) else off
        for k in ("lam", "ok", "stable", "kind", "reason", "y"):
            out[k] = np.concatenate([out[k], br[k]]) if k in out else br[k]
        out["segment"] = np.concatenate([out["segment"], seg]) if "segment" in out else seg
    out.update(ids=brs[0]["ids"], end=max(b["end"] for b in brs), maps=sum(b["maps"] for b in brs))
    return out


def read_branch(path, metric):
    with h5py.File(path, "r") as f:
        st = f["runs/status"][:]
        n = int((st != 0).sum())
        return dict(lam=f["parameters/values"][:n, 0], ok=st[:n] == 1, stable=f["runs/stable"][:n] == 1,
                    segment=f["runs/segment"][:n], kind=f["runs/kind"][:n], reason=f["runs/reason"][:n],
                    y=f[f"elements/{metric}"][:n, :], ids=list(f["elements/ids"].asstr()[:]),
                    end=int(f["branch/status"][0]), maps=int(f["runs/maps"][n - 1]))


def read_sweep(path, key, metric, element):
    with h5py.File(path, "r") as f:
        names = list(f["parameters/names"].asstr()[:])
        lam = f["parameters/values"][:, names.index(key)]
        ids = list(f["elements/ids"].asstr()[:])
        return lam, f[f"elements/{metric}"][:, ids.index(element)], f["runs/settled"][:], f["runs/steps"][:]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("trainsim")
    ap.add_argument("--case", default="fig5_11", choices=sorted(CASES))
    ap.add_argument("--from", dest="lam0", type=float)
    ap.add_argument("--to", dest="lam1", type=float)
    ap.add_argument("--count", type=int)
    ap.add_argument("--start", type=float, help="continue from here to both ends of the range")
    ap.add_argument("--also", type=float, action="append", default=[],
                    help="a further start (repeatable): two more continuations from it, one to each end "
                         "(a second branch: e.g. where settled sweep runs land on another orbit)")
    ap.add_argument("--damping", type=float)
    ap.add_argument("--settle-tol", type=float, default=1e-8)
    ap.add_argument("--metric", default="p2p_range")
    ap.add_argument("--restarts", type=int, default=3)
    ap.add_argument("--ds-max", default="0.05", help="the continuation's largest step (default 0.05)")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--check", type=float)
    ap.add_argument("--dt-out", type=float, default=8.0e-6, help="the decks' output interval (s)")
    ap.add_argument("--out")
    a = ap.parse_args(argv)
    case = CASES[a.case]
    lam0, lam1 = case["lam"]
    count = case["count"]
    start = a.start
    if a.quick:
        (lam0, lam1), count = case["quick"]["lam"], case["quick"]["count"]
        start = case["quick"].get("start", start)
    lam0 = a.lam0 if a.lam0 is not None else lam0
    lam1 = a.lam1 if a.lam1 is not None else lam1
    count = a.count or count
    damping = a.damping if a.damping is not None else case["damping"]
    out = a.out or tempfile.mkdtemp(prefix="trainsim_cont_")
    os.makedirs(out, exist_ok=True)
    exe = os.path.abspath(a.trainsim)
    sets = [s for sh in case["shafts"] for s in ("--set", f"{sh}.damping={damping:g}")]
    deck = os.path.join(ROOT, case["deck"])
    if os.path.exists(os.path.join(out, "sweep.h5")):
        os.remove(os.path.join(out, "sweep.h5"))
    legs = [(lam0, lam1, "branch")] if start is None else [(start, lam1, "branch_a"), (start, lam0, "branch_b")]
    for k, s2 in enumerate(a.also):
        legs += [(s2, lam1, f"also{k + 1}_a"), (s2, lam0, f"also{k + 1}_b")]
    c_cpu, c_rc, brs = 0.0, 0, []
    for l0, l1, name in legs:
        branch = os.path.join(out, name + ".h5")
        if os.path.exists(branch):
            os.remove(branch)
        cpu, rc = cpu_of([exe, "continue", deck, *sets, "--param", f"{case['key']}={l0:g}:{l1:g}",
                          "--restarts", str(a.restarts), "--ds-max", a.ds_max, "-o", branch],
                         os.path.join(out, name + ".log"))
        c_cpu, c_rc = c_cpu + cpu, max(c_rc, rc)
        brs.append(read_branch(branch, a.metric))
        print(f"  branch {l0:g} -> {l1:g}: {name}.h5, exit {rc}, end status {brs[-1]['end']}")
    s_cpu, s_rc = cpu_of([exe, "sweep", sweep_deck(case, lam0, lam1, count, a.settle_tol, out), *sets,
                          *case.get("sweep_sets", []),
                          "-o", os.path.join(out, "sweep.h5"), "--progress", "100000"], os.path.join(out, "sweep.log"))
    br = merge_branches(brs)
    e = br["ids"].index(case["element"])
    lam, val, settled, steps = read_sweep(os.path.join(out, "sweep.h5"), case["key"], a.metric, case["element"])
    print(f"{a.case}: damping {damping:g} lb in s/rad on {', '.join(case['shafts'])}; {case['key']} "
          f"{lam0:g} -> {lam1:g}" + (f" (continued from {start:g} to both ends)" if start is not None else ""))
    print(f"continuation: exit {c_rc}, end status {br['end']}, {len(br['lam'])} points "
          f"({int((~br['ok']).sum())} failed: reasons {sorted(set(br['reason'][~br['ok']].tolist()))}), "
          f"{br['maps']} period maps, CPU {c_cpu:.2f} s")
    for k, name in ((1, "fold"), (2, "period-doubling"), (3, "Neimark-Sacker"), (4, "grazing")):
        sel = (br["kind"] == k) & br["ok"]
        if sel.any():
            print(f"  {name}: " + ", ".join(f"{v:.6f}" for v in br["lam"][sel]))
    print(f"sweep: exit {s_rc}, {len(lam)} runs, {int((settled == 1).sum())} settled to {a.settle_tol:g}, "
          f"{int(steps.sum())} steps, CPU {s_cpu:.2f} s")
    worst, bad = 0.0, []
    dt_out = case.get("dt_out", a.dt_out)
    print(f"  {'lambda':>10} {'sweep':>13} {'branch':>13} {'rel diff':>9} {'interp est':>10} {'sampling':>9}")
    for x, v, s in zip(lam, val, settled):
        cands = branch_at(br, x, e)
        if s != 1 or not cands:
            print(f"  {x:10.3f} {v:13.6e} {'(not settled)' if s != 1 else '(no stable stretch)':>13}")
            continue
        b, est = min(cands, key=lambda c: abs(c[0] - v))
        rel, rest = abs(v - b) / abs(v), est / abs(v)
        samp = (2.0 * np.pi * x * dt_out) ** 2 / 8.0
        other = rel > 0.05   # (a coexisting orbit the branch does not hold: the fixed start found another)
        if not other:
            worst = max(worst, rel)
        print(f"  {x:10.3f} {v:13.6e} {b:13.6e} {rel:9.2e} {rest:10.2e} {samp:9.2e}" +
              ("  another orbit" if other else ""))
        if other:
            continue
        if a.check is not None and rel > a.check + 10.0 * rest + samp:
            bad.append(x)
    print(f"largest relative difference sweep - branch: {worst:.2e} (runs on the branch's orbits)")
    print(f"cost ratio sweep / continuation (CPU): {s_cpu / max(c_cpu, 1e-9):.2f}")
    if a.check is not None:
        ok = not bad and c_rc in (0, 1) and (settled == 1).sum() > 0
        print(("ok" if ok else "FAIL") + f": every settled run equals the branch to {a.check:g} + 10x the "
              f"interpolation estimate + the sampling bound" + (f" (not at {bad})" if bad else ""))
        return 0 if ok else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
