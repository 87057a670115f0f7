#!/usr/bin/env python3
"""`trainsim periodic` (docs/periodic.md) from the command line:

- the Table 5.5 rig (inputs/gregory_harris_munro.nml, 485 teeth/s): converges (exit 0),
  prints the multipliers; its shafts are undamped, so the end-inertia modes' multipliers lie
  on the unit circle (marginal) and the mesh's pair inside it; -o FILE holds the orbit's run
  (/run_stats, the metrics) and /periodic (converged, the stability, six multipliers: four
  within 1e-6 of the unit circle, two inside, the mesh period);
- the Table 7.1 train (inputs/two_clearance.nml) converges, restarting Newton after a
  longer transient where needed;
- from rest with --transient 0 (a zero state: the state scale's floor), a damped linear
  oscillator's orbit and multipliers equal the closed form;
- an accelerating free train has no periodic orbit: exit 1, the reason (M - I singular), no
  backtrace; no forcing period: exit 2 naming the deck; bad options: exit 2.

Usage: check_periodic.py TRAINSIM
"""
import math
import os
import re
import subprocess
import sys
import tempfile

import h5py

exe = os.path.abspath(sys.argv[1])
failed = 0


def check(what, ok, detail=""):
    global failed
    print(("ok   " if ok else "FAIL ") + what + ("" if ok else f"  [{detail}]"))
    if not ok:
        failed += 1


def run(*args, cwd=None):
    return subprocess.run([exe, "periodic", *args], capture_output=True, text=True, cwd=cwd, timeout=300)


rig = os.path.abspath("inputs/gregory_harris_munro.nml")
with tempfile.TemporaryDirectory() as tmp:
    out = os.path.join(tmp, "orbit.h5")
    r = run(rig, "-o", out)
    check("the rig's orbit converges (exit 0)", r.returncode == 0, r.stderr[-300:])
    check("it says converged", re.search(r"^converged to \S+ <= 1\.00E-10", r.stdout, re.M) is not None, r.stdout[-500:])
    check("undamped shafts: marginal", "marginal: the largest |mu|" in r.stdout, r.stdout[-800:])
    with h5py.File(out) as f:
        g = f["periodic"]
        check("/periodic says converged", g.attrs["converged"] == 1)
        check("/periodic says marginal", g.attrs["stability"] in ("marginal", b"marginal"), g.attrs["stability"])
        mod = g["multipliers_abs"][:]
        check("six multipliers, four within 1e-6 of the unit circle, two inside",
              len(mod) == 6 and sum(abs(m - 1) <= 1e-6 for m in mod) == 4 and sum(m < 0.99 for m in mod) == 2,
              list(mod))
        check("the orbit's run is in the file (metrics, run statistics)", "run_stats" in f and "metrics" in f,
              list(f.keys()))
        check("the period is the mesh period", abs(g.attrs["period"] - 2 * 3.141592653589793 / (32 * 95.2286)) < 1e-15,
              g.attrs["period"])
    # the Table 7.1 train: Newton starts again after a longer transient until it converges
    out2 = os.path.join(tmp, "two.h5")
    r = run(os.path.abspath("inputs/two_clearance.nml"), "-o", out2)
    check("the Table 7.1 train's orbit converges (exit 0)", r.returncode == 0, r.stderr[-300:])
    with h5py.File(out2) as f:
        g = f["periodic"]
        check("its residual is within the tolerance", g.attrs["residual"] <= 1e-10, g.attrs["residual"])
        check("ten multipliers (five free inertias)", len(g["multipliers_abs"][:]) == 10)
        check("the transient before the last start is recorded", g.attrs["transient_periods"] >= 10 and
              g.attrs["newton_starts"] >= 1, (g.attrs["transient_periods"], g.attrs["newton_starts"]))
    # no orbit: a free train driven by a mean torque accelerates
    acc = os.path.join(tmp, "acc.nml")
    with open(acc, "w") as fh:
        fh.write("&run t_end = 1.0, dt = 1e-3, integrator = 'rk4', output_interval = 1e-3 /\n"
                 "&node id = 'a', type = 'inertia', inertia = 1.0 /\n"
                 "&node id = 'b', type = 'inertia', inertia = 1.0 /\n"
                 "&element id = 's', type = 'shaft', left = 'a', right = 'b', stiffness = 100.0, damping = 1.0 /\n"
                 "&load node = 'a', kind = 'sine', offset = 5.0, amplitude = 10.0, frequency = 2.0 /\n")
    r = run(acc, "-o", os.path.join(tmp, "acc.h5"))
    check("no orbit: exit 1", r.returncode == 1, r.returncode)
    check("no orbit: the reason", "no periodic orbit found: M - I is singular" in r.stderr, r.stderr)
    check("no orbit: no backtrace, no file", "Backtrace" not in r.stderr and not os.path.exists(os.path.join(tmp, "acc.h5")))
    # the rounding floor: a tolerance below it is the budget's/stall's message, exit 1
    r = run(rig, "--tol", "1e-300")
    check("a tolerance below the rounding floor: exit 1 with the reason",
          r.returncode == 1 and "rounding floor" in r.stderr, r.stderr[-300:])
    nof = os.path.join(tmp, "nof.nml")
    with open(nof, "w") as fh:
        fh.write("&run t_end = 1.0, dt = 1e-3 /\n&node id = 'a', type = 'inertia', inertia = 1.0 /\n"
                 "&node id = 'g', type = 'fixed' /\n"
                 "&element id = 's', type = 'shaft', left = 'a', right = 'g', stiffness = 100.0, damping = 1.0 /\n")
    r = run(nof)
    check("no forcing period: exit 2 naming the deck", r.returncode == 2 and "nof.nml" in r.stderr and
          "no forcing period" in r.stderr, r.stderr)
    # from rest with no transient: a damped disk on a shaft to ground under 60 + 50 sin(8 t)
    # (J = 1, c = 2, k = 100); the orbit at t0 = 0 is the steady state of the linear
    # oscillator, angle f0/k + q and speed W p (p = a d/(d^2 + e^2), q = -a e/(d^2 + e^2),
    # d = k - J W^2, e = c W), its two multipliers have |mu| = exp(-c T/(2 J)); RK4 at
    # dt = 1e-4 (omega_n dt = 1e-3): to 1e-8
    rest = os.path.join(tmp, "rest.nml")
    with open(rest, "w") as fh:
        fh.write("&run t_end = 1.0, dt = 1e-4, integrator = 'rk4', output_interval = 1e-4 /\n"
                 "&node id = 'g', type = 'fixed' /\n&node id = 'm', type = 'inertia', inertia = 1.0 /\n"
                 "&element id = 's', type = 'shaft', left = 'm', right = 'g', stiffness = 100.0, damping = 2.0 /\n"
                 "&load node = 'm', kind = 'sine', offset = 60.0, amplitude = 50.0, frequency = 1.2732395447351628 /\n")
    r = run(rest, "--transient", "0", "-o", os.path.join(tmp, "rest.h5"))
    check("from rest, --transient 0: converges (exit 0), no trap", r.returncode == 0 and "Backtrace" not in r.stderr,
          r.stderr[-300:])
    if r.returncode == 0:
        w, d, e = 8.0, 100.0 - 64.0, 2.0 * 8.0
        p, q = 50.0 * d / (d * d + e * e), -50.0 * e / (d * d + e * e)
        with h5py.File(os.path.join(tmp, "rest.h5")) as f:
            g = f["periodic"]
            x, sc, mod = g["state"][:], g["scale"][:], g["multipliers_abs"][:]
        want = [60.0 / 100.0 + q, w * p]
        check("... the orbit is the linear oscillator's steady state to 1e-8",
              len(x) == 2 and max(abs(x - want)) <= 1e-8 * max(abs(v) for v in want), (list(x), want))
        check("... a finite, positive scale", all(0 < v < 1e300 for v in sc), list(sc))
        mu = math.exp(-2.0 * (2 * math.pi / w) / 2.0)
        check(f"... |mu| = exp(-cT/2J) = {mu:.6f} to 1e-6", all(abs(m - mu) <= 1e-6 for m in mod), list(mod))
    for bad in (["--period-count", "0"], ["--bogus"], ["--tol", "2"], []):
        r = run(*([rig] if bad != [] else []), *bad)
        check(f"bad arguments {bad}: exit 2 with a message", r.returncode == 2 and "error" in r.stderr, r.stderr)

print("failed" if failed else "all passed")
sys.exit(1 if failed else 0)
