#!/usr/bin/python3
"""The gear-rating metrics of a helical gear (issue 26 items 1 and 5; D-103 - D-105, D-128):
its `mesh_period_angle` 2 pi / N gives it the spur gear's static reference, Kv, mesh orders
and rattle indices. The Table 5.5 rig of check_gear_metrics.py with the spur mesh replaced by
a helical one (linear contact law, mesh damping CM, shaft damping CS):

(a) A face contact ratio m_F = 1 (face width p_tb / tan zeta_b): the total length of the
    lines of contact, eq. (6.1), is m_p F / cos zeta_b at every mesh position, so the mesh
    is linear with the constant stiffness k_m = (E/17.6) L_c. Under the load torque T and a
    harmonic torque T1 on the driven gear at the mesh frequency W:
    - the static mesh force is T / r_b and the loaded static TE b + F_s / k_m at every one
      of the 24 static positions (1e-12; p-p 0 to 1e-12 of the mean);
    - the TE and mesh-force amplitudes at mesh order 1 are the closed-form response of the
      3-DOF train (complex solve of K - W^2 M + i W C), to 1e-4 (window leakage and
      settle_tol 1e-5, as check_gear_metrics.py); orders 2..4 below 1e-3 of order 1;
    - Kv = 1 + |F_1| / F_s (the mesh force is F_s + |F_1| cos(W t + q), its largest
      sample within (W dt)^2/8 = 2.8e-5 of |F_1| of the peak), to the window's mean
      force's distance from F_s (the slow modes of the 100 lb in s^2 inertias, settled to
      5e-4 of F_s as in check_gear_metrics.py) plus 1e-4 of |F_1|;
    - the spur gear with the same constant stiffness k_m (two_pair_factor 1) in the same
      rig gives the same Kv and orders to 1e-10 (the same equations; the helical gear's
      L_c times E/17.6 rounds differently from the spur's one number).
(b) m_F = 0.5: L_c(e) varies (piecewise linear, continuous) between L_min and L_max, so
    the loaded static TE b + F_s/(k L_c) lies in [b + F_s/(k L_max), b + F_s/(k L_min)]
    (1e-12), and its range over 24 positions a mesh cycle reaches each end to within
    the change of 1/L_c over 1/48 of a cycle (|dL_c/de| / 48).
(c) A light load (F_s < |F_1|) with the harmonic torque: the mesh rattles: rattle_impacts =
    impacts / measured cycles, rattle_open = time out of contact x f / measured cycles
    (the definitions, D-105; the window is whole cycles of the held speed, 2e-4).

    /usr/bin/python3 tests/check_helical_metrics.py TRAINSIM
"""
import math
import os
import subprocess
import sys
import tempfile

import h5py
import numpy as np

from rig_response import check, finish, harmonic_mesh_response

EXE = sys.argv[1]


B, RB, N, MP, T_LOAD = 0.005, 3.7588, 32, 1.6676, 798.8
ZETA = 15.0
K_TARGET = 234500.0             # the spur rig's mesh stiffness, lbf/in
CM, CS = 18.1, 200.0
PTB = 2 * math.pi * RB / N


def contact_length(e, mp, mf):
    """eq. (6.1)"""
    def term(m):
        n = math.floor(m - e)
        return (n + 1) * (m - e - 0.5 * n)
    return PTB * (term(mp + mf) - term(mf) - term(mp)) / math.sin(math.radians(ZETA))


def mesh_group(kind, mf, youngs):
    face = mf * PTB / math.tan(math.radians(ZETA))
    if kind == "helical":
        return (f"&element id = 'mesh', type = 'helical_gear', rb_driver = {RB}, rb_driven = {RB}, teeth = {N}, "
                f"profile_contact_ratio = {MP}, base_helix_angle = {ZETA}, face_width = {face!r}, "
                f"approach_angle = 0.1637, half_backlash = {B}, youngs_modulus = {youngs!r}, "
                f"contact_law = 'linear', contact_damping = {CM} /\n")
    km = youngs / 17.6 * MP * face / math.cos(math.radians(ZETA))
    return (f"&element id = 'mesh', type = 'spur_gear', stiffness = {km!r}, rb_driver = {RB}, rb_driven = {RB}, "
            f"teeth = {N}, contact_ratio = {MP}, approach_angle = 0.1637, half_backlash = {B}, "
            f"two_pair_factor = 1.0, contact_law = 'linear', contact_damping = {CM} /\n")


def rig(mesh, f_mesh, load, extra, settle, measure, budget):
    w = 2 * math.pi * f_mesh / N
    return (f"&run title = 'helical rig, metrics', t_end = 1, dt = 8.0e-6, integrator = 'rk4', "
            f"output_interval = 8.0e-6, settle_tol = 1.0e-5, initial_state = 'preload' /\n"
            "&node id = 'n1', type = 'inertia', inertia = 100.0 /\n"
            "&node id = 'n2', type = 'inertia', inertia = 0.987 /\n"
            "&node id = 'n3', type = 'inertia', inertia = 0.987 /\n"
            "&node id = 'n4', type = 'inertia', inertia = 100.0 /\n"
            f"&element id = 'shaft1', type = 'shaft', stiffness = 32000.0, damping = {CS} /\n" + mesh +
            f"&element id = 'shaft3', type = 'shaft', stiffness = 32000.0, damping = {CS} /\n"
            f"&load node = 'n1', quantity = 'speed', kind = 'constant', value = {w} /\n"
            f"&load node = 'n4', kind = 'constant', value = {-load} /\n" + extra +
            f"&initial node = 'all', speed = {w} /\n"
            f"&sweep parameter = 'mesh.mesh_frequency', values = {f_mesh} /\n"
            f"&sweep parameter = 'mesh.settle_cycles', values = {settle} /\n"
            f"&sweep parameter = 'mesh.measure_cycles', values = {measure} /\n"
            f"&sweep parameter = 'mesh.settle_max_cycles', values = {budget} /\n")


with tempfile.TemporaryDirectory() as d:
    def run_mesh(text, name):
        """The deck's one-run sweep: the mesh's metrics and whether it settled."""
        deck, o = os.path.join(d, name + ".nml"), os.path.join(d, name + ".h5")
        open(deck, "w").write(text)
        p = subprocess.run([EXE, "sweep", deck, "-o", o], capture_output=True, text=True)
        check(p.returncode == 0, f"{name}: sweep exits 0 ({p.stderr.strip()[-200:]})")
        if p.returncode != 0:
            return {}, 0
        with h5py.File(o, "r") as f:
            e = f["elements"]
            return {k: e[k][0, 1] for k in e if k not in ("ids", "types")}, f["runs/settled"][0]

    # (a) m_F = 1: constant length of the lines of contact
    lc = MP * (PTB / math.tan(math.radians(ZETA))) / math.cos(math.radians(ZETA))
    youngs = 17.6 * K_TARGET / lc
    km_lin = youngs / 17.6 * lc
    check(abs(contact_length(0.3, MP, 1.0) / lc - 1) < 1e-14 and abs(contact_length(0.8, MP, 1.0) / lc - 1) < 1e-14,
          f"eq. (6.1) with m_F = 1: L_c = m_p F / cos zeta_b = {lc:.6f} in at every e")
    FM, T1 = 300.0, 60.0
    harmonic = f"&load node = 'n3', kind = 'sine', amplitude = {T1}, frequency = {FM} /\n"
    m, st = run_mesh(rig(mesh_group("helical", 1.0, youngs), FM, T_LOAD, harmonic, 300, 60, 3000), "helical_harmonic")
    check(st == 1, "helical, harmonic load: settled")
    F_S = T_LOAD / RB
    check(abs(m.get("static_force", 0) / F_S - 1) < 1e-12,
          f"static mesh force {m.get('static_force', 0):.10g} = T/r_b = {F_S:.10g} lbf (1e-12)")
    te_s = B + F_S / km_lin
    check(abs(m.get("static_te_mean", 0) / te_s - 1) < 1e-12 and abs(m.get("static_te_p2p", 1)) < 1e-12 * te_s,
          f"loaded static TE {m.get('static_te_mean', 0):.12e} = b + F_s/k_m = {te_s:.12e} in, p-p "
          f"{m.get('static_te_p2p', 1):.1e}")
    te, fa = harmonic_mesh_response(km_lin, CM, RB, 2 * math.pi * FM, T1, CS)
    check(abs(m.get("te_order_1", 0) / te - 1) < 1e-4, f"TE at mesh order 1 {m.get('te_order_1', 0):.8e} in = "
          f"closed form {te:.8e} (rel. {m.get('te_order_1', 0) / te - 1:.1e})")
    check(abs(m.get("force_order_1", 0) / fa - 1) < 1e-4, f"mesh force at order 1 {m.get('force_order_1', 0):.6f} lbf "
          f"= closed form {fa:.6f} (rel. {m.get('force_order_1', 0) / fa - 1:.1e})")
    hi = max(m.get("te_order_2", 1), m.get("te_order_3", 1), m.get("te_order_4", 1))
    check(hi < 1e-3 * te, f"orders 2..4 of the TE below 1e-3 of order 1 ({hi:.1e} in)")
    kv = 1 + fa / F_S   # the force swings |F_1| about its mean, F_s once settled
    dev = abs(m.get("force_mean", 0) - F_S)
    check(dev < 5e-4 * F_S, f"mean mesh force {m.get('force_mean', 0):.6f} = F_s to 5e-4 ({dev / F_S:.1e})")
    check(abs(m.get("kv", 0) * F_S - kv * F_S) <= dev + 1e-4 * fa,
          f"Kv {m.get('kv', 0):.8f} = 1 + |F_1|/F_s = {kv:.8f}: |Kv F_s - F_s - |F_1|| = "
          f"{abs(m.get('kv', 0) - kv) * F_S:.2e} lbf <= |mean - F_s| + 1e-4 |F_1| = {dev + 1e-4 * fa:.2e}")
    s, st_s = run_mesh(rig(mesh_group("spur", 1.0, youngs), FM, T_LOAD, harmonic, 300, 60, 3000), "spur_harmonic")
    for key in ("kv", "static_force", "te_order_1", "force_order_1"):
        a, b = m.get(key, 0.0), s.get(key, 1.0)
        check(st_s == 1 and abs(a / b - 1) < 1e-10,
              f"{key}: helical {a:.15g} = the spur pair with k_m = {km_lin:.6f} {b:.15g} (rel. {a / b - 1:.1e})")

    # (b) m_F = 0.5: the static TE follows 1/L_c
    m, st = run_mesh(rig(mesh_group("helical", 0.5, youngs), FM, T_LOAD, "", 30, 20, 300), "helical_varying")
    kl = youngs / 17.6
    es = np.linspace(0.0, 1.0, 200001)
    lcs = np.array([contact_length(e, MP, 0.5) for e in es])
    lo, hi = B + F_S / (kl * lcs.max()), B + F_S / (kl * lcs.min())
    slope = np.abs(np.diff(1.0 / lcs)).max() / (es[1] - es[0]) * F_S / kl / 48.0
    te_max = m.get("static_te_mean", 0) + 0.0
    tmin = m.get("static_te_mean", 0)
    p2p = m.get("static_te_p2p", 0)
    check(abs(m.get("static_force", 0) / F_S - 1) < 1e-12, f"m_F = 0.5: static mesh force = T/r_b (1e-12)")
    check(lo * (1 - 1e-12) <= tmin <= hi * (1 + 1e-12),
          f"m_F = 0.5: static TE mean {tmin:.9e} in [b + F/(k L_max), b + F/(k L_min)] = [{lo:.9e}, {hi:.9e}]")
    check(hi - lo - 2 * slope <= p2p <= (hi - lo) * (1 + 1e-12),
          f"m_F = 0.5: static TE p-p {p2p:.6e} = F/k (1/L_min - 1/L_max) = {hi - lo:.6e} to the grid's "
          f"{2 * slope:.1e}")

    # (c) a light load (F_s 2.7 lbf) under the harmonic torque (|F_1| ~ 15 lbf): the mesh rattles
    m, st = run_mesh(rig(mesh_group("helical", 1.0, youngs), FM, 10.0, harmonic, 300, 60, 3000), "helical_rattle")
    imp = m.get("impacts", 0)
    check(imp > 0, f"lightly loaded helical mesh under the harmonic torque strikes ({imp} impacts in 60 cycles, settled {st})")
    check(abs(m.get("rattle_impacts", -1) - imp / 60.0) <= 2e-4 * imp / 60.0,
          f"rattle_impacts {m.get('rattle_impacts', -1):.6f} = impacts / 60 cycles = {imp / 60.0:.6f}")
    want = m.get("time_out_of_contact", 0) * FM / 60.0
    check(0 < want < 1 and abs(m.get("rattle_open", -1) - want) < 1e-6,
          f"rattle_open {m.get('rattle_open', -1):.6f} = time out of contact x f / 60 = {want:.6f}")

finish()
