#!/usr/bin/python3
"""A planetary stage running (issue 25): static load sharing against a hand calculation,
and the bundled start-stop deck's energy ledger and per-mesh events.

Usage (as CTest runs it, cwd = repo root):

    /usr/bin/python3 tests/check_planetary_runs.py <path to trainsim>

(a) Static load sharing (tests/planetary/load_sharing.nml: carrier and ring held, torque T
    on the sun, spur meshes of one stiffness in every zone). Each planet is a series of
    its sun mesh (k_s, half backlash b_s) and ring mesh (k_r, b_r): the planet's torque
    balance makes the two mesh forces equal, F_n, and with x = r_s theta_s (the sun's roll
    along the line of action) the meshes close once x exceeds g_n = b_sn + b_rn, then
        F_n = k_e (x - g_n),  k_e = k_s k_r / (k_s + k_r),  sum_n F_n = T / r_s
    (r_s = z_s m cos(phi)/2, the sun's base radius). Equal planets: F_n = T/(3 r_s) each;
    planet 2 with more backlash carries less, x solved over the planets in contact.
    The run's final mesh forces (/elements/force) against these to 1e-6 relative (the
    transient has decayed to e^-95; the rest is roundoff), and the load-sharing factor
    N max F_n / sum F_n: as computed from those forces, and as the run file's
    /metrics/load_sharing (D-96; the metrics window is the last millisecond, the static
    state) for every sun and ring mesh, to 1e-6 (equal planets: 1 to 1e-9); 0 for the
    dampers, which are in no set. A sweep of that deck (two ring backlashes: the gaps'
    differences, and so K, stay) has elements/load_sharing per run, the same figures.
(b) inputs/planetary_start_stop.nml (sun driven through a shaft in start-stop duty, ring
    held, three planets a third of a tooth apart, the carrier driving a load through a
    clearance coupling): every one of the six meshes has impacts (/metrics/impacts) and
    its own rows in the event table; the energy ledger closes: max |balance| <= 1e-7 of
    the energy scale (RK4 at dt = 2e-6 s, 1/6 of the RK4 limit of the stage's
    stiffest mode; the residual is the integration's error), as the gear-housing check asks.
"""
import math
import os
import subprocess
import sys
import tempfile

import h5py
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
EXE = sys.argv[1]
failures = []


def check(ok, text):
    print(("ok   " if ok else "FAIL ") + text)
    if not ok:
        failures.append(text)


def run(deck, out, *sets):
    args = [EXE, "run", deck, "-o", out]
    for s in sets:
        args += ["--set", s]
    p = subprocess.run(args, capture_output=True, text=True, timeout=600)
    check(p.returncode == 0, f"{os.path.basename(deck)} {' '.join(sets)} runs ({p.stderr.strip()[-300:]})")
    return p.returncode == 0


def hand_sharing(T, rs, ks, kr, gaps):
    """Static mesh forces of planets in parallel, each a series of two meshes with gap g."""
    ke = ks * kr / (ks + kr)
    on = list(range(len(gaps)))
    while True:
        x = (T / (rs * ke) + sum(gaps[i] for i in on)) / len(on)
        still = [i for i in on if x > gaps[i]]
        if still == on:
            break
        on = still
    return [ke * max(x - g, 0.0) for g in gaps]


# (a) static load sharing
T, KS, KR = 2000.0, 3.0e6, 4.0e6
RS = 22 * (2.0 / 25.4) * math.cos(math.radians(20.0)) / 2
deck = os.path.join(ROOT, "tests", "planetary", "load_sharing.nml")
with tempfile.TemporaryDirectory() as d:
    for name, bs in [("equal planets", [0.004] * 3), ("planet 2 with more backlash", [0.004, 0.0044, 0.004])]:
        out = os.path.join(d, "ls.h5")
        if not run(deck, out, "planetary#1.sun_backlash=" + ",".join(map(str, bs))):
            continue
        with h5py.File(out) as f:
            ids = list(f["elements"].attrs["ids"])
            force = f["elements/force"][-1]
            share = f["metrics/load_sharing"][:]
        fs = [force[ids.index(f"ps_sun_planet{n}")] for n in (1, 2, 3)]
        fr = [force[ids.index(f"ps_ring_planet{n}")] for n in (1, 2, 3)]
        gaps = [b / 2 + 0.004 / 2 for b in bs]
        want = hand_sharing(T, RS, KS, KR, gaps)
        for n in range(3):
            check(abs(fs[n] - want[n]) <= 1e-6 * max(want), f"{name}: sun mesh {n + 1} force {fs[n]:.9g} = {want[n]:.9g}")
            # the ring mesh pushes the planet back on the rear face: the same force, negative
            check(abs(-fr[n] - want[n]) <= 1e-6 * max(want), f"{name}: ring mesh {n + 1} force {fr[n]:.9g} = -{want[n]:.9g}")
        lsf, lsf_want = 3 * max(fs) / sum(fs), 3 * max(want) / sum(want)
        check(abs(lsf - lsf_want) <= 1e-6, f"{name}: load-sharing factor {lsf:.6f} = {lsf_want:.6f}")
        tol = 1e-9 if name.startswith("equal") else 1e-6
        for mesh in ("sun", "ring"):
            ks = [share[ids.index(f"ps_{mesh}_planet{n}")] for n in (1, 2, 3)]
            check(all(abs(k - lsf_want) <= tol for k in ks),
                  f"{name}: /metrics/load_sharing of the {mesh} meshes {ks[0]:.9f} = {lsf_want:.9f} (to {tol:g})")
        others = [share[i] for i, s in enumerate(ids) if not s.startswith("ps_")]
        check(len(others) == 4 and all(k == 0.0 for k in others), "load_sharing is 0 for the dampers (no set)")
    # the sweep file: elements/load_sharing per run (K depends on the gaps' differences only)
    with open(deck) as src:
        text = src.read().replace("sun_backlash = 0.004,", "sun_backlash = 0.004, 0.0044, 0.004,")
    sw = os.path.join(d, "sw.nml")
    with open(sw, "w") as dst:
        dst.write(text + "&sweep parameter = 'planetary#1.ring_backlash', values = 0.004, 0.005 /\n")
    out = os.path.join(d, "sw.h5")
    p = subprocess.run([EXE, "sweep", sw, "-o", out], capture_output=True, text=True, timeout=600)
    check(p.returncode == 0, f"a sweep of the stage runs ({p.stderr.strip()[-300:]})")
    if p.returncode == 0:
        with h5py.File(out) as f:
            ids = list(f["elements/ids"].asstr()[:])
            share = f["elements/load_sharing"][:]
        want = hand_sharing(T, RS, KS, KR, [b / 2 + 0.004 / 2 for b in (0.004, 0.0044, 0.004)])
        lsf_want = 3 * max(want) / sum(want)
        meshes = [i for i, s in enumerate(ids) if s.startswith("ps_")]
        check(share.shape == (2, len(ids)) and len(meshes) == 6
              and all(abs(share[r, i] - lsf_want) <= 1e-6 for r in (0, 1) for i in meshes)
              and all(share[r, i] == 0.0 for r in (0, 1) for i in range(len(ids)) if i not in meshes),
              f"sweep file: elements/load_sharing {share[0, meshes[0]]:.9f}, {share[1, meshes[0]]:.9f} = "
              f"{lsf_want:.9f} in both runs, 0 for the dampers")
        if name.startswith("equal"):
            check(abs(fs[0] - T / (3 * RS)) <= 1e-6 * fs[0], f"equal planets carry T/(3 r_s) = {T / (3 * RS):.6f}")
        else:
            check(fs[1] < 0.7 * fs[0], f"the planet with more backlash carries less ({fs[1]:.1f} < {fs[0]:.1f})")

# (b) the bundled deck
deck = os.path.join(ROOT, "inputs", "planetary_start_stop.nml")
with tempfile.TemporaryDirectory() as d:
    out = os.path.join(d, "pss.h5")
    if run(deck, out):
        with h5py.File(out) as f:
            ids = list(f["elements"].attrs["ids"])
            impacts = f["metrics/impacts"][:]
            ev_el = f["events/element"][:]
            ev_kind = f["events/kind_name"].asstr()[:]
            e = f["energy"][:]
            names = list(f["energy"].attrs["names"])
        meshes = [i for i, s in enumerate(ids) if s.startswith("stage_")]
        check(len(meshes) == 6, f"six meshes ({len(meshes)})")
        for i in meshes:
            rows = ev_el == i + 1
            kinds = set(ev_kind[rows])
            check(impacts[i] > 0 and any(k.startswith("contact") for k in kinds),
                  f"{ids[i]}: {impacts[i]} impacts, {rows.sum()} event rows ({', '.join(sorted(kinds))})")
        bal = e[:, names.index("balance")]
        scale = max(np.max(np.abs(e[:, names.index(k)])) for k in ("kinetic", "potential", "dissipated", "input"))
        check(np.max(np.abs(bal)) <= 1e-7 * scale,
              f"energy ledger closed: max |balance| {np.max(np.abs(bal)):.3e} <= 1e-7 x {scale:.4g}")

# (c) the rigid form (mesh = 'rigid': constraint rows) against Willis, and the elastic form
# (ideal meshes of stiffness k) converging to it
STAGE = """&run t_end = 0.3, dt = 2.0e-6, integrator = 'rk4', output_interval = 1.0e-3 /
&planetary id = 'ps', planets = 3, teeth_sun = 22, teeth_planet = 29, teeth_ring = 80,
   module = 2.0, mesh = '{mesh}', sun = 'sun', ring = 'ring', carrier = 'carrier', planet_inertia = 0.003 /
&node id = 'sun', type = '{sun}', inertia = 0.01 /
&node id = 'ring', type = '{ring}', inertia = 0.5 /
&node id = 'carrier', type = '{carrier}', inertia = 0.3 /
{loads}
"""
DAMPERS = "".join(f"&element id = 'd{n}', type = 'damper', left = 'ps_planet{n}', right = 'carrier', damping = 50.0 /\n"
                  for n in (1, 2, 3)) + "&element id = 'ds', type = 'damper', left = 'sun', right = 'carrier', damping = 20.0 /\n"


def stage(held, loads, mesh="rigid"):
    types = {m: ("fixed" if m == held else "inertia") for m in ("sun", "ring", "carrier")}
    text = STAGE.format(mesh=mesh, loads=loads, **types)
    return text.replace("type = 'fixed', inertia = 0.5", "type = 'fixed'").replace(
        "type = 'fixed', inertia = 0.01", "type = 'fixed'").replace("type = 'fixed', inertia = 0.3", "type = 'fixed'")


def speeds(text, d, name):
    deck, out = os.path.join(d, name + ".nml"), os.path.join(d, name + ".h5")
    with open(deck, "w") as f:
        f.write(text)
    if not run(deck, out):
        return None
    with h5py.File(out) as f:
        ids = list(f["nodes"].attrs["ids"])
        return {k: (f["nodes/omega"][:, ids.index(k)], f["nodes/theta"][:, ids.index(k)]) for k in ("sun", "ring", "carrier")}


ZS, ZR = 22, 80
with tempfile.TemporaryDirectory() as d:
    # every held member: a torque on one free member, a load on the other
    for held, loads in [("ring", "&load node = 'sun', kind = 'constant', value = 200.0 /\n"
                                 "&load node = 'carrier', kind = 'constant', value = -500.0 /"),
                        ("sun", "&load node = 'ring', kind = 'constant', value = 200.0 /\n"
                                "&load node = 'carrier', kind = 'constant', value = -150.0 /"),
                        ("carrier", "&load node = 'sun', kind = 'constant', value = 50.0 /\n"
                                    "&load node = 'ring', kind = 'constant', value = 100.0 /")]:
        w = speeds(stage(held, loads), d, "rigid_" + held)
        if w is None:
            continue
        ws, wr, wc = (w[k][0][1:] for k in ("sun", "ring", "carrier"))
        resid = np.max(np.abs((ws - wc) * ZS + (wr - wc) * ZR)) / (ZR * np.max(np.abs([ws, wr, wc])))
        # the constraint solve holds the rows to roundoff (D-81): 1e-9 over 150 000 steps
        check(resid <= 1e-9 and np.max(np.abs([ws, wr, wc])) > 1.0,
              f"rigid, {held} held: Willis (w_s - w_c) z_s + (w_r - w_c) z_r = 0 to {resid:.2e}")
    # ring held, the elastic stage with dampers (same in both forms) against the rigid one:
    # the carrier's lag is the meshes' wind-up under the load, proportional to 1/k
    loads = ("&load node = 'sun', kind = 'constant', value = 200.0 /\n"
             "&load node = 'carrier', kind = 'constant', value = -500.0 /\n" + DAMPERS)
    rig = speeds(stage("ring", loads), d, "rigid_damped")
    errs = []
    for k in (1e6, 1e7, 1e8):
        text = stage("ring", loads, mesh="ideal").replace(
            "mesh = 'ideal',", f"mesh = 'ideal', sun_mesh_stiffness = {k}, ring_mesh_stiffness = {k},")
        el = speeds(text, d, f"elastic_{k:g}")
        if el is None or rig is None:
            continue
        errs.append(abs(el["carrier"][1][-1] - rig["carrier"][1][-1]))
    if len(errs) == 3:
        r1, r2 = errs[0] / errs[1], errs[1] / errs[2]
        check(8.0 <= r1 <= 12.0 and 8.0 <= r2 <= 12.0,
              f"elastic -> rigid as 1/k: carrier angle errors {errs[0]:.3e}, {errs[1]:.3e}, {errs[2]:.3e} "
              f"(ratios {r1:.2f}, {r2:.2f} per decade of k)")

print(f"{'FAILED' if failures else 'passed'}: {len(failures)} failure(s)")
sys.exit(1 if failures else 0)
