#!/usr/bin/env python3
"""`trainsim runup` (D-109): a speed ramp with the mesh's TE and force tracked in mesh orders,
against physics.

(a) A linear mesh (constant stiffness, contact held by the load, linear damping zeta = 0.05)
    excited by a one-harmonic static TE e = e1 cos(phi), the pinion on a prescribed speed ramp,
    the wheel free: m d'' + c d' + k d = k e + c e' (+ constants), m = J2/rb^2. Its steady
    response at mesh frequency W is T(W) e1, T = (k + iWc)/(k - mW^2 + iWc). Along a ramp
    (dW/dt = 2 pi R) the tracked order-1 amplitude differs from |T(W)| e1 by the sweep's lag, of
    first order in eta = (dW/dt)/(zeta w_n)^2: asserted below eta (of the peak) at every
    rate, and halving the rate halves it (ratio 1.8-2.2). With the first-order term of the
    slow-sweep expansion, a = T + i (dW/dt)(D' T' - m T)/D (D = k - mW^2 + iWc, ' = d/dW),
    what remains is of second order (the block's averaging too): it falls by more than 3
    when the rate halves, and is below eta/5 at the slowest rate. Order 2 (the change of
    order 1 across a block) stays below eta/10.
(b) The Table 5.5 rig (inputs/sweep_ghm_mesh_frequency.nml) with its shafts damped (200 lbf in
    s) and a linear mesh damping (18.1 lbf s/in, zeta ~ 0.1: the free vibration the ramp's
    start excites decays), run up from 560 to 645 teeth/s (above the jumps of 405-535) at 10
    teeth/s^2 against the same rig's brute-force sweep at 565..645: accelerating the driven
    inertias (100.987) takes (J alpha)/rb more mesh force, alpha = 2 pi R/32, so the run-up's
    mean mesh force is (T + J alpha)/rb (to 2e-3 once the shaft mode has rung down), and
    the mesh stays in contact, where the TE's order 1 is linear in the load: order-1 TE per
    unit mean mesh force equals the sweep's (per F_s) to 2e-3 (~2 eta of the mesh mode,
    eta = 2 pi R/(zeta w_n)^2 = 9e-4).
(c) Bad input: a negative rate, from = to, a range above what the output interval resolves,
    an element that is not a gear mesh, a train without a prescribed speed, an unknown key:
    exit 2, the file, line and key (or the option) named, no backtrace.
(d) plot_sweep.py draws a run-up file over a sweep file (same axes), and its order map.
(e) The static reference along the ramp (D-135): the linear mesh of (a) with a fan load on the
    wheel, T = 400 (w/w_n)^2 opposing (w_n = 78.54 rad/s, the top of the range), beside its
    constant 440.72: each block's static mesh force is the preload's steady rigid rotation at
    the block's midpoint, (440.72 + 400 (w/w_n)^2 + J2 alpha)/rb, w = 2 pi f/32 and alpha =
    2 pi R/32 (exact: the quadratic law at the rigid speed; 1e-9 is the preload's Newton
    tolerance), and Kv = force_max / static_force (to rounding). The block's rattle criterion
    (D-134) is J2 alpha / (force_mean rb) (r1 = r2): alpha is exact on a ramp, 1e-9 the
    rounding of the speed differences; no impacts, so no impact energy.

Usage: check_runup.py TRAINSIM   (cwd = repo root)
"""
import math
import os
import re
import subprocess
import sys
import tempfile

import h5py
import numpy as np

from clicheck import check, failures, finish

exe = os.path.abspath(sys.argv[1])


def runup(*args):
    return subprocess.run([exe, "runup", *args], capture_output=True, text=True, timeout=600)


def blocks(path, *names):
    with h5py.File(path, "r") as f:
        out = [f["parameters/values"][:, 0]]
        out += [f["elements"][n][:, 0] for n in names]
    return out


K, RB, J2, C = 234500.0, 3.7588, 0.987, 12.79914
M = J2 / RB ** 2
E1 = 1.0e-5
ZW = C / (2 * M)                       # zeta w_n
LIN = f"""&run  title = 'linear mesh, one-harmonic TE, run-up', t_end = 0.1, dt = 1.0e-5, integrator = 'rk4',
      output_interval = 1.0e-5, initial_state = 'preload' /
&node id = 'pinion', type = 'inertia', inertia = 1.0 /
&node id = 'wheel', type = 'inertia', inertia = {J2} /
&element id = 'mesh', type = 'spur_gear', stiffness = {K}, rb_driver = {RB}, rb_driven = {RB}, teeth = 32,
         contact_ratio = 1.6676, approach_angle = 0.1637, half_backlash = 0.005, two_pair_factor = 1.0,
         contact_law = 'linear', contact_damping = {C}, te_harmonics = {E1}, te_phases = 0 /
&load node = 'pinion', quantity = 'speed', kind = 'constant', value = 30.0 /
&load node = 'wheel', kind = 'constant', value = -440.7193 /
&initial node = 'all', speed = 30.0 /
&runup from = 200, to = 400, rate = 100 /
"""


def transfer(w):
    return (K + 1j * w * C) / (K - M * w * w + 1j * w * C)


with tempfile.TemporaryDirectory() as tmp:
    # (a) the linear mesh at three rates
    deck = os.path.join(tmp, "lin.nml")
    open(deck, "w").write(LIN)
    err0, err1, errf = {}, {}, {}
    for rate in (100.0, 50.0, 25.0):
        out = os.path.join(tmp, f"lin_{rate:g}.h5")
        r = runup(deck, "--rate", str(rate), "-o", out)
        check(f"(a) run-up at {rate:g} teeth/s^2 exits 0", r.returncode == 0, r.stderr[-300:])
        if r.returncode:
            continue
        x, te, fo, o2 = blocks(out, "te_order_1", "force_order_1", "te_order_2")
        w = 2 * np.pi * x
        wd = 2 * np.pi * rate
        t = transfer(w)
        h = 1e-4 * w
        dt_ = (transfer(w + h) - transfer(w - h)) / (2 * h)
        d = K - M * w * w + 1j * w * C
        a1 = 1j * wd * ((-2 * M * w + 1j * C) * dt_ - M * t) / d
        peak = np.max(np.abs(t)) * E1
        err0[rate] = np.max(np.abs(te - np.abs(t) * E1)) / peak
        err1[rate] = np.max(np.abs(te - np.abs(t + a1) * E1)) / peak
        fa = np.abs((K + 1j * w * C) * (t - 1)) * E1
        errf[rate] = np.max(np.abs(fo - fa)) / np.max(fa)
        eta = wd / ZW ** 2
        print(f"     rate {rate:5g}: {len(x)} blocks {x[0]:.1f}..{x[-1]:.1f} teeth/s, eta {eta:.4f}; |A1 - |T| e1| "
              f"{err0[rate]:.3e}, first-order residual {err1[rate]:.3e}, force {errf[rate]:.3e} (of the peak); "
              f"order 2 <= {np.max(o2) / peak:.1e}")
        check(f"(a) {rate:g}: TE order 1 = steady response to below eta = {eta:.4f} of the peak "
              f"({err0[rate]:.4f})", err0[rate] < eta)
        check(f"(a) {rate:g}: force order 1 = steady response to below eta ({errf[rate]:.4f})", errf[rate] < eta)
        if rate == 25.0:
            check(f"(a) {rate:g}: first-order residual below eta/5 ({err1[rate]:.2e} < {eta / 5:.2e})",
                  err1[rate] < eta / 5)
        # a linear mesh under one harmonic responds at order 1 only; what shows at order 2 is the
        # change of the order-1 amplitude and phase across a block, of first order in eta too
        check(f"(a) {rate:g}: order 2 below eta/10 of the peak ({np.max(o2) / peak:.1e})", np.max(o2) < eta / 10 * peak)
    if len(err0) == 3:
        for hi, lo in ((100.0, 50.0), (50.0, 25.0)):
            q0, qf, q1 = err0[hi] / err0[lo], errf[hi] / errf[lo], err1[hi] / err1[lo]
            check(f"(a) rate {hi:g} -> {lo:g}: the steady-response error halves (ratio {q0:.3f}, force {qf:.3f}: "
                  "first order)", 1.8 < q0 < 2.2 and 1.8 < qf < 2.2)
            check(f"(a) rate {hi:g} -> {lo:g}: the first-order residual falls by more than 3 ({q1:.2f}: second order)",
                  q1 > 3.0)

    # (b) the Table 5.5 rig against its brute-force sweep, above the jumps
    damp = ["--set", "shaft1.damping=200", "--set", "shaft3.damping=200", "--set", "mesh.contact_law=linear",
            "--set", "mesh.contact_damping=18.1"]
    src = open("inputs/sweep_ghm_mesh_frequency.nml").read()
    sweep_deck = os.path.join(tmp, "rig_sweep.nml")
    open(sweep_deck, "w").write(src.replace("from = 385, to = 645, count = 27", "from = 565, to = 645, count = 9"))
    sw = os.path.join(tmp, "rig_sweep.h5")
    p = subprocess.run([exe, "sweep", sweep_deck, "-o", sw, *damp], capture_output=True, text=True, timeout=600)
    check("(b) the rig's sweep 565..645 exits 0", p.returncode == 0, p.stderr[-300:])
    ru = os.path.join(tmp, "rig_runup.h5")
    rate = 10.0
    r = runup("inputs/sweep_ghm_mesh_frequency.nml", "--from", "560", "--to", "645", "--rate", str(rate), *damp, "-o", ru)
    check("(b) the rig's run-up 560 -> 645 at 10 teeth/s^2 exits 0", r.returncode == 0, r.stderr[-300:])
    if p.returncode == 0 and r.returncode == 0:
        with h5py.File(sw, "r") as f:
            j = [s.decode() if isinstance(s, bytes) else s for s in f["elements/ids"][:]].index("mesh")
            xs = f["parameters/values"][:, 0]
            ys = f["elements/te_order_1"][:, j]
            fs = f["elements/static_force"][:, j]
            settled = f["runs/settled"][:]
            imp_s = f["elements/impacts"][:, j]
        x, te, fm, imp, kv = blocks(ru, "te_order_1", "force_mean", "impacts", "kv")
        alpha = 2 * math.pi * rate / 32
        want = (798.8 + (100.0 + 0.987) * alpha) / RB
        # the ramp's start rings the end inertia on the shafts (12.6 rad/s, decay ~0.5/s): averaged
        # over the last 4 s of the ramp (8 of its periods)
        tail = x > 605
        dev = abs(np.mean(fm[tail]) / want - 1)
        check(f"(b) mean mesh force (T + J alpha)/rb = {want:.3f} lbf over 605..645 teeth/s (rel. {dev:.1e})",
              dev < 2e-3)
        check("(b) no impacts in the run-up or the sweep there (the mesh stays in contact)",
              imp.sum() == 0 and imp_s.sum() == 0 and np.all(settled == 1))
        yi = np.interp(xs, x, te)
        fi = np.interp(xs, x, fm)
        rel = (yi / fi) / (ys / fs) - 1
        for k in range(len(xs)):
            print(f"     {xs[k]:.0f} teeth/s: sweep {ys[k]:.5e} in at F_s {fs[k]:.3f}; run-up {yi[k]:.5e} in at "
                  f"{fi[k]:.3f} lbf; per unit load {rel[k]:+.2e}")
        check(f"(b) order-1 TE per unit mean mesh force = the sweep's to 2e-3 (max {np.max(np.abs(rel)):.1e})",
              np.max(np.abs(rel)) < 2e-3)
        check(f"(b) Kv of each block from the static reference > 1 ({kv.min():.3f}..{kv.max():.3f})",
              np.all(kv > 1.0))

    # (c) bad input
    rig = "inputs/gregory_harris_munro.nml"

    def refused(what, args, pattern, deck_text=None):
        d = rig
        if deck_text is not None:
            d = os.path.join(tmp, "bad.nml")
            open(d, "w").write(deck_text)
        r = runup(d, *args, "-o", os.path.join(tmp, "bad.h5"))
        ok = r.returncode == 2 and re.search(pattern, r.stderr) is not None and "backtrace" not in r.stderr.lower()
        check(f"(c) {what}: exit 2, {pattern!r}", ok, f"exit {r.returncode}: {r.stderr.strip()[-300:]}")

    refused("negative rate (option)", ["--from", "300", "--to", "400", "--rate", "-5"],
            r"option --rate -5\S*: error: the ramp rate must be > 0")
    refused("from = to (option)", ["--from", "300", "--to", "300", "--rate", "5"], r"option --to 300: error: .*range")
    refused("a range above what the output interval resolves", ["--from", "300", "--to", "20000", "--rate", "5"],
            r"option --to 20000: error: .*samples a mesh cycle.*at least 10")
    refused("no range at all", [], r"gregory_harris_munro.nml: error: a run-up needs its range")
    base = open(rig).read()
    refused("&runup rate < 0 (deck)", [], r"bad\.nml:\d+: &runup.*'rate'.*error: the ramp rate must be > 0",
            base + "&runup from = 300, to = 400, rate = -5 /\n")
    refused("&runup from = to (deck)", [], r"bad\.nml:\d+: &runup.*'to'.*error: a run-up needs a range",
            base + "&runup from = 300, to = 300, rate = 5 /\n")
    refused("&runup mesh not a gear (deck)", [], r"bad\.nml:\d+: &runup.*'mesh'.*'shaft1' is not a gear mesh",
            base + "&runup mesh = 'shaft1', from = 300, to = 400, rate = 5 /\n")
    refused("&runup unknown key (deck)", [], r"bad\.nml:\d+: error: &runup #1: unknown key 'rates'",
            base + "&runup from = 300, to = 400, rates = 5 /\n")
    refused("two &runup groups", [], r"bad\.nml:\d+: &runup.*at most one",
            base + "&runup from = 300, to = 400, rate = 5 /\n&runup from = 300, to = 400, rate = 5 /\n")
    refused("a torque-driven train (no prescribed speed): the &load group that drives it named",
            ["--from", "300", "--to", "400", "--rate", "5"],
            r"bad\.nml:\d+: &load #1, key 'quantity' \(not given: 'torque'\): error: the train of 'mesh' is driven "
            r"by a torque here \(node 'n1'.*a run-up prescribes the mesh frequency against time",
            base.replace("quantity = 'speed', kind = 'constant', value = 95.2286", "kind = 'constant', value = 798.8"))
    r = subprocess.run([exe, "run", os.path.join(tmp, "bad.nml"), "--no-output"], capture_output=True, text=True)
    open(os.path.join(tmp, "ok.nml"), "w").write(base + "&runup from = 300, to = 400, rate = 5 /\n")
    r = subprocess.run([exe, "run", os.path.join(tmp, "ok.nml"), "--no-output"], capture_output=True, text=True)
    check("trainsim run of a deck with &runup ignores it (a note), exit 0",
          r.returncode == 0 and "&runup group; run ignores it" in r.stderr, r.stderr[-300:])

    # (d) the figure: a run-up over a sweep, and its order map
    if os.path.exists(ru) and os.path.exists(sw):
        png, npz = os.path.join(tmp, "over.png"), os.path.join(tmp, "over.npz")
        p = subprocess.run(["/usr/bin/python3", "scripts/plot_sweep.py", ru, sw, "--metric", "mesh.te_order_1",
                            "--out", png, "--data", npz], capture_output=True, text=True)
        z = np.load(npz) if p.returncode == 0 else {}
        check("(d) plot_sweep.py draws the run-up over the sweep on one axis",
              p.returncode == 0 and "f0_runup_y" in z and "f1_b0_y" in z, p.stderr[-300:])
        p = subprocess.run(["/usr/bin/python3", "scripts/plot_sweep.py", ru, "--te-spectrum", "mesh", "--out", png],
                           capture_output=True, text=True)
        check("(d) plot_sweep.py --te-spectrum of a run-up file", p.returncode == 0, p.stderr[-300:])

    # (e) the static reference along the ramp: a speed-dependent load
    WN, TN, T0, RATE = 2 * math.pi * 400 / 32, 400.0, 440.7193, 100.0
    fan = LIN + f"&load node = 'wheel', speed_law = 'quadratic', w_nominal = {WN!r}, value = {-TN} /\n"
    deck = os.path.join(tmp, "fan.nml")
    open(deck, "w").write(fan)
    out = os.path.join(tmp, "fan.h5")
    r = runup(deck, "--rate", str(RATE), "-o", out)
    check("(e) run-up with a fan load exits 0", r.returncode == 0, r.stderr[-300:])
    if r.returncode == 0:
        x, fs, kv, fmax, crit, fm, en, pw = blocks(out, "static_force", "kv", "force_max", "rattle_criterion",
                                                   "force_mean", "rattle_energy", "rattle_power")
        with h5py.File(out, "r") as f:
            version = f.attrs["format_version"]
        alpha = 2 * math.pi * RATE / 32
        want = (T0 + TN * (2 * math.pi * x / 32 / WN) ** 2 + J2 * alpha) / RB
        dev = np.max(np.abs(fs / want - 1))
        print(f"     {len(x)} blocks {x[0]:.1f}..{x[-1]:.1f} teeth/s: static force {fs[0]:.4f}..{fs[-1]:.4f} lbf "
              f"(closed form {want[0]:.4f}..{want[-1]:.4f}, largest rel. {dev:.1e})")
        check(f"(e) static force of every block = (T0 + T(w) + J2 alpha)/rb to 1e-9 ({dev:.1e}); "
              f"{fs[-1] / fs[0]:.3f} times the first block's at the last", dev < 1e-9 and fs[-1] / fs[0] > 1.4)
        check("(e) Kv = force_max / static_force of the block", np.max(np.abs(kv * fs / fmax - 1)) < 1e-14)
        dc = np.max(np.abs(crit / (J2 * alpha / (fm * RB)) - 1))
        check(f"(e) rattle_criterion = J2 alpha / (force_mean rb) per block to 1e-9 ({dc:.1e}); no impact energy",
              dc < 1e-9 and np.all(en == 0) and np.all(pw == 0))
        check(f"(e) run-up format_version 2 ({version})", str(version) in ("2", "b'2'"))

print("FAILED: %d check(s)" % len(failures) if failures else "all checks passed")
finish()
