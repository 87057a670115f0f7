#!/usr/bin/env python3
"""Rattle indices from the literature (D-134): Brosey's inertial criterion and the
impact energy of a gear mesh, against closed forms.

(a) Brosey, Seaman, Johnson & Hamilton (1986): a loose gear (the wheel, inertia J2, a constant
    drag torque T on it) meshed with a pinion on a prescribed speed Omega + A sin(nu t) rattles
    when J2 alpha_max (r1/r2) > T, alpha_max = A nu. The mesh is linear (constant stiffness,
    linear damping zeta = 0.05) and its mode (291 Hz) far above nu (10 Hz), so below the
    threshold the wheel follows the pinion quasi-statically. A drive period is 15 whole mesh
    cycles, and the window 10 drive periods: its mean mesh force (over the phase) is T/rb to
    the dynamic part of the mesh force, of order (nu/w_n)^2 A/Omega ~ 3e-5, and the sampled
    alpha_max (mean over a sample interval next to the peak) is A nu to (nu h)^2/6 = 1.6e-6. So at R = 0.5
    and 0.8: rattle_criterion = J2 A nu / T to 1e-4, no impact and no time out of contact; at
    R = 1.25 and 2 the wheel leaves the driving flank (impacts, rattle_open > 0) and the
    criterion is above 1 (its mean force is the drag's over a rattling window: within 5 %).
(b) One impact: two free gears (r1 = 2, r2 = 3, J1 = 0.5, J2 = 2), no loads, approaching
    along the line of action at V = r1 w1 - r2 w2 inside the backlash; the window ends before
    the rebound reaches the other flank. rattle_power x window = 1/2 m_eq V^2, m_eq =
    1/(r1^2/J1 + r2^2/J2) (V is exact in free flight: to 1e-12), rattle_energy = that over
    the window's mesh cycles.
(c) No drag at all (a wheel that never touches in the window): rattle_criterion is NaN
    (documented), the run exits 0, no crash.

Usage: check_rattle.py TRAINSIM
"""
import math
import os
import sys
import tempfile

import h5py
import numpy as np

from clicheck import check, run, finish

RB, J2, K, C, N = 3.7588, 0.987, 234500.0, 12.79914, 32
NU = 2 * math.pi * 10.0                 # the drive's fluctuation, rad/s
OMEGA = 2 * math.pi * 15 / (N * 0.1)    # 15 mesh cycles per drive period (0.1 s)
T = 100.0                               # drag torque on the wheel


def deck(amp, drag=T, t_end=1.302, settle=0.3):
    return f"""&run title = 'loose gear on a fluctuating drive', t_end = {t_end}, dt = 1.0e-5, integrator = 'rk4',
      output_interval = 5.0e-5, settle_time = {settle}, initial_state = 'preload' /
&node id = 'pinion', type = 'inertia', inertia = 1.0 /
&node id = 'wheel', type = 'inertia', inertia = {J2} /
&element id = 'mesh', type = 'spur_gear', stiffness = {K}, rb_driver = {RB}, rb_driven = {RB}, teeth = {N},
         contact_ratio = 1.6676, approach_angle = 0.1637, half_backlash = 0.005, two_pair_factor = 1.0,
         contact_law = 'linear', contact_damping = {C} /
&load node = 'pinion', quantity = 'speed', kind = 'sine', offset = {OMEGA!r}, amplitude = {amp!r}, frequency = 10.0 /
&load node = 'wheel', kind = 'constant', value = {-drag!r} /
&initial node = 'all', speed = {OMEGA!r} /
"""


def metrics(path, names):
    """The mesh's /metrics (the decks' only element) and their units."""
    with h5py.File(path, "r") as f:
        g = f["metrics"]
        return {n: g[n][0] for n in names}, {n: g[n].attrs.get("units", b"") for n in names}


with tempfile.TemporaryDirectory() as tmp:
    names = ["rattle_criterion", "rattle_energy", "rattle_power", "rattle_impacts", "rattle_open", "impacts",
             "force_mean"]
    for r_want in (0.5, 0.8, 1.25, 2.0):
        amp = r_want * T / (J2 * NU)
        d, out = os.path.join(tmp, f"b{r_want}.nml"), os.path.join(tmp, f"b{r_want}.h5")
        open(d, "w").write(deck(amp))
        p = run(["run", d, "-o", out])
        check(f"(a) R = {r_want}: run exits 0", p.returncode == 0, p.stderr[-300:])
        if p.returncode:
            continue
        m, _ = metrics(out, names)
        crit = float(m["rattle_criterion"])
        dev = crit / r_want - 1
        print(f"     R = {r_want}: criterion {crit:.8f} (rel. {dev:+.2e}), impacts {m['impacts']}, "
              f"open {m['rattle_open']:.3f}, mean force {m['force_mean']:.6f} (T/rb {T / RB:.6f})")
        if r_want < 1:
            check(f"(a) R = {r_want}: criterion = J2 A nu / T to 1e-4 ({dev:+.1e})", abs(dev) < 1e-4)
            check(f"(a) R = {r_want}: no rattle (0 impacts, never out of contact)",
                  m["impacts"] == 0 and m["rattle_open"] == 0.0)
        else:
            check(f"(a) R = {r_want}: criterion above 1 and J2 A nu / T to 5 % ({dev:+.1e})",
                  crit > 1 and abs(dev) < 0.05)
            check(f"(a) R = {r_want}: rattles (impacts {m['impacts']}, open {m['rattle_open']:.3f})",
                  m["impacts"] > 0 and m["rattle_open"] > 0)
            check(f"(a) R = {r_want}: impact energy and power > 0", m["rattle_energy"] > 0 and m["rattle_power"] > 0)

    # (b) one impact of known approach velocity
    r1, r2, j1, j2, b = 2.0, 3.0, 0.5, 2.0, 0.001
    w1, w2 = 10.0, 6.0                      # V = 20 - 18 = 2 in/s
    v = r1 * w1 - r2 * w2
    meq = 1 / (r1 ** 2 / j1 + r2 ** 2 / j2)
    t_hit = b / v                           # front flank at d = b
    t_end = t_hit + 2 * b / v * 0.5 + 0.002  # contact ~ pi/w_n = 0.9 ms, then half way back
    one = f"""&run title = 'one impact', t_end = {t_end!r}, dt = 1.0e-6, integrator = 'rk4', output_interval = 1.0e-5,
      settle_time = 1.0e-6 /
&node id = 'g1', type = 'inertia', inertia = {j1} /
&node id = 'g2', type = 'inertia', inertia = {j2} /
&element id = 'mesh', type = 'spur_gear', stiffness = 1.0e5, rb_driver = {r1}, rb_driven = {r2}, teeth = 20,
         contact_ratio = 1.6, approach_angle = 0.1, half_backlash = {b}, two_pair_factor = 1.0 /
&initial node = 'g1', speed = {w1} /
&initial node = 'g2', speed = {w2} /
"""
    d, out = os.path.join(tmp, "one.nml"), os.path.join(tmp, "one.h5")
    open(d, "w").write(one)
    p = run(["run", d, "-o", out])
    check("(b) one impact: run exits 0", p.returncode == 0, p.stderr[-300:])
    if p.returncode == 0:
        m, units = metrics(out, names + ["max_approach_velocity"])
        with h5py.File(out, "r") as f:
            t_final = float(f["run_stats"].attrs["t_final"])
        window = t_final - 1.0e-6
        e = float(m["rattle_power"]) * window
        want = 0.5 * meq * v * v
        print(f"     impacts {m['impacts']}, V {m['max_approach_velocity']!r}, energy {e!r} (1/2 m_eq V^2 {want!r}), "
              f"per cycle {m['rattle_energy']!r}, units {units['rattle_energy']!r} {units['rattle_power']!r}")
        check("(b) exactly one impact in the window", m["impacts"] == 1)
        check(f"(b) rattle_power x window = 1/2 m_eq V^2 to 1e-12 ({e / want - 1:+.1e})", abs(e / want - 1) < 1e-12)
        cycles = m["impacts"] / m["rattle_impacts"]
        check(f"(b) rattle_energy = 1/2 m_eq V^2 per mesh cycle ({cycles:.4f} cycles)",
              abs(m["rattle_energy"] * cycles / want - 1) < 1e-12)

    # (c) no drag: the wheel never touches in the window
    d, out = os.path.join(tmp, "nodrag.nml"), os.path.join(tmp, "nodrag.h5")
    open(d, "w").write(deck(0.0, drag=0.0, t_end=0.02, settle=0.001).replace("initial_state = 'preload' ", ""))
    p = run(["run", d, "-o", out])
    check("(c) no drag: run exits 0, no backtrace", p.returncode == 0 and "backtrace" not in p.stderr.lower(),
          p.stderr[-300:])
    if p.returncode == 0:
        m, _ = metrics(out, names)
        check(f"(c) no drag, no contact: rattle_criterion is NaN ({m['rattle_criterion']}), energy 0",
              math.isnan(m["rattle_criterion"]) and m["rattle_energy"] == 0 and m["impacts"] == 0)
finish(summary=True)
