#!/usr/bin/env python3
"""`trainsim continue --switch-pd -o FILE` (docs/periodic.md "Period-doubling branch
switching"; D-122) on test_period_doubling's impact oscillator (J = 1 on a shaft to
ground, k = 100, c = 0.2, against a stiff stop 0.1 rad above its mean angle; torque
300 + 300 sin(2 pi f t)), continued in f from 8 Hz up: its period-doubling near 8.816 Hz
and the doubled branch from it, written to FILE.pd2:

- the doubled branch's file holds period_count 2 (the first's 1), its first point is the
  period-doubling point (kind 2);
- its orbits repeat over 2T and not over T: `trainsim run` from a stored state at its t0,
  on the period map's own grid (dt = T / ceil(T / dt)), returns to it after 2T to 1e-9 of
  the state scale (the corrector converges to 1e-10 of it; the run is the same discrete
  flow) and is at least 1e-4 away after T (another orbit: test_period_doubling measured
  1.1e-3 ... 1.9e-3 next to the point);
- killed (kill -9) half-way along the doubled branch, then resumed with
  `-o FILE.pd2.h5 --resume` and the first run's options (no --period-count, no
  --switch-pd): exit 0, every dataset equal to the uninterrupted run's, bit for bit.

Usage: check_continue_doubled.py TRAINSIM
"""
import math
import os
import subprocess
import sys
import tempfile

import h5py
import numpy as np

from clicheck import check, datasets, finish

exe = os.path.abspath(sys.argv[1])
RUN = "&run t_end = 1.0, dt = 2e-4, integrator = 'rk4', output_interval = 2e-4 /"
DECK = RUN + """
&node id='g', type='fixed' /
&node id='m', type='inertia', inertia=1.0 /
&element type='shaft', left='m', right='g', stiffness=100.0, damping=0.2 /
&element type='clearance_coupling', left='m', right='g', clearance=6.2, stiffness=10000.0, contact_damping=0 /
&load node='m', kind='sine', offset=300.0, amplitude=300.0, frequency=8.0 /
"""
OPTS = ["--param", "load#1.frequency=8:9.5", "--ds-max", "0.2"]


def run(*args):
    return subprocess.run([exe, *args], capture_output=True, text=True, timeout=300)


def returns(tmp, deck, lam, t0, period, x):
    """The run from x at t0 over 2T on the map's grid: its state after T and after 2T."""
    n = math.ceil(period / 2e-4)
    h = period / n
    text = DECK.replace(RUN, f"&run t_start = {t0!r}, t_end = {t0 + 2 * period!r}, dt = {h!r}, "
                             f"integrator = 'rk4', output_interval = {h!r} /").replace("frequency=8.0", f"frequency={lam!r}")
    text += f"&initial node = 'm', angle = {x[0]!r}, speed = {x[1]!r} /\n"
    path = os.path.join(tmp, "orbit.nml")
    open(path, "w").write(text)
    out = os.path.join(tmp, "orbit.h5")
    r = run("run", path, "-o", out)
    if r.returncode != 0:
        return None, None
    with h5py.File(out, "r") as f:
        th, om = f["nodes/theta"][:, 1], f["nodes/omega"][:, 1]
    return np.array([th[n], om[n]]), np.array([th[2 * n], om[2 * n]])


with tempfile.TemporaryDirectory() as tmp:
    deck = os.path.join(tmp, "impact.nml")
    open(deck, "w").write(DECK)
    full = os.path.join(tmp, "full.h5")
    r = run("continue", deck, *OPTS, "--switch-pd", "-o", full)
    check("continued and switched: exit 0", r.returncode == 0, r.stderr)
    pd2 = os.path.join(tmp, "full.pd2.h5")
    check("the doubled branch written to FILE.pd2.h5", os.path.exists(pd2))
    with h5py.File(full, "r") as f1, h5py.File(pd2, "r") as f2:
        k1, k2 = f1.attrs["period_count"], f2.attrs["period_count"]
        st = f2["runs/status"][:]
        n = int((st != 0).sum())
        lam, kind = f2["parameters/values"][:n, 0], f2["runs/kind"][:n]
        t0, period, xs, scale = f2["runs/t0"][:n], f2["runs/period"][:n], f2["branch/state"][:n], f2["branch/scale"][0]
    print(f"     period_count {k1} / {k2}; doubled branch: {n} points, {lam[0]:.9f} -> {lam[-1]:.6f} Hz")
    check("period_count 1 in the first file, 2 in the doubled branch's", (k1, k2) == ("1", "2"), (k1, k2))
    check("the doubled branch starts at the period-doubling point (kind 2)", n >= 10 and kind[0] == 2, kind[:3])
    for i in (1, n // 2, n - 1):
        after_t, after_2t = returns(tmp, deck, float(lam[i]), float(t0[i]), float(period[i]), xs[i])
        if after_t is None:
            check(f"the orbit at {lam[i]:.6f} Hz ran", False)
            continue
        r1, r2 = (float(np.max(np.abs(y - xs[i]) / scale)) for y in (after_t, after_2t))
        print(f"     {lam[i]:.6f} Hz: |x(t0 + T) - x| {r1:.2e}, |x(t0 + 2T) - x| {r2:.2e} of the scale")
        check(f"point {i}: the orbit repeats over 2T (1e-9 of the scale)", r2 <= 1e-9, r2)
        check(f"point {i}: and not over T (1e-4 of the scale)", r1 >= 1e-4, r1)
    # killed (kill -9) half-way along the doubled branch, then resumed from its own file
    killed = os.path.join(tmp, "killed.h5")
    env = dict(os.environ, GFORTRAN_UNBUFFERED_PRECONNECTED="y")
    p = subprocess.Popen([exe, "continue", deck, *OPTS, "--switch-pd", "-o", killed], stdout=subprocess.PIPE,
                         text=True, env=env)
    doubled, seen = False, 0
    for line in p.stdout:
        doubled = doubled or "period-doubled branch" in line
        seen += doubled and "stable" in line
        if seen == n // 2:
            p.kill()
            break
    p.wait()
    part = os.path.join(tmp, "killed.pd2.h5")
    with h5py.File(part, "r") as f:
        done = int((f["runs/status"][:] != 0).sum())
    check("killed half-way along the doubled branch", 0 < done < n, (done, n))
    r = run("continue", deck, *OPTS, "-o", part, "--resume")
    check("resumed without --period-count: exit 0", r.returncode == 0, r.stderr)
    a, b = datasets(pd2), datasets(part)
    differ = [k for k in a if k not in b or not np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind == "f")]
    print(f"     killed after {done} of {n} points; datasets differing from the uninterrupted run: {differ}")
    check("killed and resumed: every dataset equal to the uninterrupted doubled branch's", not differ, differ)
    r = run("continue", deck, *OPTS, "--period-count", "2", "-o", part, "--resume")
    check("resumed with --period-count 2 (other options): refused, exit 2", r.returncode == 2, r.stderr)

finish()
