#!/usr/bin/python3
"""Fatigue inputs of `trainsim export`: fixed-bin impact spectra and rainflow counts.

- `--rainflow` (scripts/trainsim_rainflow.py) on the load history of ASTM E1049-85's
  worked example (§5.4.4, Fig. 6: -2, 1, -3, 5, -1, 3, -4, 4, -2) gives the standard's
  table: range 3: 0.5 cycle, 4: 1.5, 6: 0.5, 8: 1.0, 9: 0.5 (worked by hand in the
  script's docstring order: 3, 4 half; E-F 4 full; 8 half; then 9, 8, 6 half at the end).
  Also: a sine of 5 periods starting off its peak has 9 peak-to-valley swings, each range
  2, counted 4.5 cycles; plateaus and repeated values do not add reversals.
- `--spectrum --bins E0,...` of inputs/start_stop_two_clearances.nml (shortened to 1 s):
  two runs of the same deck give the same table (the run is deterministic); a run with a
  smaller backlash has the same bins (rows 1:1), so the designs compare row by row; the
  counts sum to /metrics/impacts, with a bin above the last edge.
- `--rainflow` of the same file: per element, twice the counted cycles = reversals - 1
  (every reversal is in one half cycle or one of a full cycle's two points), the largest
  range is max - min of the force over the window; `--rainflow --bins` sums to the same
  cycles.

usage: check_spectrum_rainflow.py TRAINSIM_EXE
"""
import csv
import io
import os
import subprocess
import sys
import tempfile

import h5py
import numpy as np

from clicheck import check, EXE, finish
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "scripts"))
from trainsim_rainflow import rainflow, reversals  # noqa: E402


def trainsim(*args):
    return subprocess.run([EXE] + list(args), capture_output=True, text=True, timeout=600)


def table(text):
    rows = list(csv.reader(io.StringIO(text)))
    return rows[0], rows[1:]


def by_range(cycles):
    out = {}
    for r, _, n, *_ in cycles:
        out[r] = out.get(r, 0.0) + n
    return out


# ASTM E1049-85 §5.4.4, the worked example
astm = by_range(rainflow([-2, 1, -3, 5, -1, 3, -4, 4, -2]))
check(f"ASTM E1049 example: ranges/cycles {sorted(astm.items())} = 3: 0.5, 4: 1.5, 6: 0.5, 8: 1.0, 9: 0.5",
      astm == {3.0: 0.5, 4.0: 1.5, 6.0: 0.5, 8.0: 1.0, 9.0: 0.5})
full = [c for c in rainflow([-2, 1, -3, 5, -1, 3, -4, 4, -2]) if c[2] == 1.0]
check(f"its one full cycle is E-F (-1, 3): range 4, mean 1 ({full})",
      len(full) == 1 and full[0][:2] == (4.0, 1.0) and full[0][3:] == (4, 5))
x = np.sin(np.linspace(0, 2 * np.pi * 5, 5 * 64 + 1) + 0.3)
cyc = rainflow(x)
tot = sum(n for r, _, n, *_ in cyc if r > 1.9)
check(f"5 periods of a sine from sin(0.3): the 9 swings between the peaks count {tot} cycles (4.5)", tot == 4.5)
check("... and twice all its cycles = its reversals - 1",
      2 * sum(c[2] for c in cyc) == len(reversals(x)) - 1)
check("plateaus and repeats add no reversal", list(reversals([0, 1, 1, 2, 2, 1, 0, 0, 3, 3])) == [0, 4, 7, 8])

with tempfile.TemporaryDirectory() as tmp:
    deck = os.path.join(ROOT, "inputs", "start_stop_two_clearances.nml")
    runs = {}
    for name, extra in (("a", []), ("a_again", []), ("b", ["--set", "mesh.half_backlash=0.003"])):
        h5 = os.path.join(tmp, name + ".h5")
        r = trainsim("run", deck, "-o", h5, "--set", "run.t_end=1.0", *extra)
        check(f"start-stop run {name} ({r.stderr.strip()[-200:]})", r.returncode == 0)
        if r.returncode != 0:
            sys.exit(1)
        runs[name] = h5
    edges = "0,100,200,500,1000,2000,5000"
    tabs = {}
    for name, h5 in runs.items():
        r = trainsim("export", h5, "--spectrum", "--bins", edges, "--velocity-bins", "0,0.5,1,2,5")
        check(f"export --spectrum --bins of {name} exits 0 ({r.stderr.strip()[:200]})", r.returncode == 0)
        tabs[name] = table(r.stdout)
    check("two runs of the deck, same bins: the same spectrum, row for row", tabs["a"] == tabs["a_again"])
    ha, ra = tabs["a"]
    hb, rb = tabs["b"]
    check("another design (half_backlash 0.003 in), same bins: the same element/measure/bin rows",
          [x[:5] for x in ra] == [x[:5] for x in rb] and len(ra) > 0)
    lows = [x[3] for x in ra if x[0] == "mesh" and x[1] == "peak_force"]
    check(f"the force bins are the given edges with a bin below and above: {lows}",
          lows == ["-inf", "0.0", "100.0", "200.0", "500.0", "1000.0", "2000.0", "5000.0"])
    with h5py.File(runs["a"]) as f:
        ids = list(f["elements"].attrs["ids"])
        impacts = {e: int(f["metrics/impacts"][i]) for i, e in enumerate(ids)}
        force = {e: f["elements/force"][:, i] for i, e in enumerate(ids)}
    for e, n in impacts.items():
        if n == 0:
            continue
        s = sum(int(x[5]) for x in ra if x[0] == e and x[1] == "peak_force")
        check(f"fixed-bin spectrum of {e} sums to its {n} impacts", s == n)
    changed = any(a[5] != b[5] for a, b in zip(ra, rb))
    check("the two designs' counts differ somewhere (the comparison says something)", changed)

    r = trainsim("export", runs["a"], "--rainflow")
    check(f"export --rainflow exits 0 ({r.stderr.strip()[:200]})", r.returncode == 0)
    head, rows = table(r.stdout)
    check(f"rainflow header {head}", head[:5] == ["element_id", "unit", "range", "mean", "cycles"])
    for e in ids:
        mine = [x for x in rows if x[0] == e]
        n2 = 2 * sum(float(x[4]) for x in mine)
        nrev = len(reversals(force[e]))
        check(f"{e}: 2 x {n2 / 2:g} cycles = {nrev} reversals - 1", n2 == nrev - 1)
        big = max(float(x[2]) for x in mine) if mine else 0.0
        span = float(force[e].max() - force[e].min())
        check(f"{e}: largest range {big:.6g} = max - min of the force {span:.6g}", big == span)
    r = trainsim("export", runs["a"], "--rainflow", "--element", "mesh", "--bins", edges)
    head, binned = table(r.stdout)
    tot = sum(float(x[4]) for x in binned)
    check(f"--rainflow --bins for mesh: {len(binned)} rows (7 bins + below + above), {tot:g} cycles as unbinned",
          len(binned) == 8 and tot == sum(float(x[4]) for x in rows if x[0] == "mesh") and
          all(x[0] == "mesh" for x in binned))
    for bad, what in ((["--spectrum", "--bins", "5,1"], "decreasing edges"),
                      (["--spectrum", "--bins", "0,a"], "non-numeric edge"),
                      (["--rainflow", "--bins", "10"], "a count for --rainflow"),
                      (["--rainflow", "--element", "nope"], "unknown element")):
        r = trainsim("export", runs["a"], *bad)
        check(f"{what}: exit 2 with a message ({r.stderr.strip()[:120]})",
              r.returncode == 2 and "error" in r.stderr and "Traceback" not in r.stderr)

finish()
