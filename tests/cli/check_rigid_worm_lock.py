#!/usr/bin/python3
"""Rigid connections and the self-locking worm (issue 23 item 2, on D-81's constraints).

- `rigid_gear` (r1 wl = r2 wr) driven by a constant torque T on the left node: the left
  speed is T t / (J1 + J2 (r1/r2)^2) to 1e-12 relative (RK4 is exact on a constant
  acceleration), the speed ratio r2/r1 to 1e-12, at dt = 1e-3 s, three times the RK4 limit
  of an ideal_gear of k = 1e9 (the rigid run's step is not capped by a mesh mode).
- A stiff elastic `ideal_gear` converges to the rigid result as k grows (k = 1e5, 1e7,
  1e9): the largest error of the left speed over the run falls at least 5x per 100x of
  stiffness (the step load rings the undamped mesh mode at a speed amplitude ~ alpha /
  omega_n: 10x per 100x of k).
- `trainsim modes` merges a rigid gear's nodes: a shaft k behind it has the one elastic
  mode sqrt(k (1/(J2 + J1 (r2/r1)^2) + 1/J3)) / 2 pi (to 1e-6) and one rigid-body mode.
- `rigid_join`: two inertias one rigid body, T t / (J1 + J2) on both, bit for bit alike.
- A self-locking `worm_gear` (lead 3 deg, mu 0.1: eta_b < 0) back-driven by a constant
  torque on the wheel, the worm free: the worm does not turn (its angle stays 0 to
  1e-12 rad over 2 s), the wheel settles at the mesh's static deflection
  -|T| / (k r2^2) (to 1e-3 of it: the damped mesh mode has decayed by e^-40), the mesh
  force is |T| / r2.
- The same worm driven from the worm against the wheel's load: it moves, at the
  closed-form acceleration (T_m - |T_L| / (i eta_f)) / (J_w + J_wh / (i^2 eta_f)) over
  the second half of the run (after the start's stick-slip transient) to 2/(omega_n t/2)
  relative.
- The energy ledger closes on each to 1e-9 of its scale.

usage: check_rigid_worm_lock.py TRAINSIM_EXE
"""
import math
import os
import re
import tempfile

import h5py
import numpy as np

from clicheck import check, EXE, finish, run


def simulate(tmp, name, element, ja, jb, loads, t_end, dt):
    deck = os.path.join(tmp, name + '.nml')
    with open(deck, 'w') as f:
        f.write(f"&run title = '{name}', units = 'si', t_end = {t_end}, dt = {dt}, integrator = 'rk4', "
                f"output_interval = {max(dt, 1.0e-3)} /\n")
        f.write(f"&node id = 'a', type = 'inertia', inertia = {ja} /\n")
        f.write(f"&node id = 'b', type = 'inertia', inertia = {jb} /\n")
        f.write(f"&element id = 'g', left = 'a', right = 'b', {element} /\n")
        for node, value in loads:
            f.write(f"&load node = '{node}', kind = 'constant', value = {value} /\n")
    h5 = os.path.join(tmp, name + '.h5')
    r = run(['run', deck, '-o', h5])
    check(f'{name}: runs ({r.stderr.strip()[:300]})', r.returncode == 0)
    if r.returncode != 0:
        return None
    with h5py.File(h5) as f:
        e = f['energy'][()]
        scale = np.max(np.abs(e[:, :4]))
        worst = np.max(np.abs(e[:, 4]))
        check(f'{name}: energy ledger closes ({worst:.2e} <= 1e-9 x {scale:.3e})', worst <= 1e-9 * scale)
        return {'t': f['time'][()], 'theta': f['nodes/theta'][()], 'omega': f['nodes/omega'][()],
                'force': f['elements/force'][()] if 'elements/force' in f else None, 'energy': e,
                'deck': deck}


def rel(a, b):
    return abs(a - b) / abs(b)


with tempfile.TemporaryDirectory() as tmp:
    ja, jb, r1, r2, torque, t_end = 0.01, 0.04, 0.02, 0.04, 1.0, 0.2
    alpha = torque / (ja + jb * (r1 / r2)**2)
    res = simulate(tmp, 'rigid_gear', f"type = 'rigid_gear', rb_driver = {r1}, rb_driven = {r2}", ja, jb,
                   [('a', torque)], t_end, 1.0e-3)
    w_rigid = float('nan')
    if res is not None:
        w = res['omega'][-1]
        w_rigid = w[0]
        check(f'rigid_gear: left speed {w[0]:.15g} = T t / (J1 + J2 (r1/r2)^2) = {alpha * t_end:.15g} (1e-12)',
              rel(w[0], alpha * t_end) <= 1e-12)
        check(f'rigid_gear: speed ratio {w[0] / w[1]:.15g} = r2/r1 (1e-12)', rel(w[0] / w[1], r2 / r1) <= 1e-12)
    errs = []
    for k in (1.0e5, 1.0e7, 1.0e9):
        omega_n = math.sqrt(k * (r1**2 / ja + r2**2 / jb))
        dt = min(1.0e-4, 0.1 / omega_n)
        res = simulate(tmp, f'ideal_gear_k{k:.0e}', f"type = 'ideal_gear', rb_driver = {r1}, rb_driven = {r2}, "
                       f"stiffness = {k}", ja, jb, [('a', torque)], t_end, dt)
        if res is not None:
            errs.append(np.max(np.abs(res['omega'][:, 0] - alpha * res['t'])) / (alpha * t_end))
    if len(errs) == 3:
        check(f'stiff ideal_gear -> rigid_gear: largest error of the left speed over the run / alpha t_end {errs[0]:.2e}, {errs[1]:.2e}, '
              f'{errs[2]:.2e} falls >= 5x per 100x of k', errs[1] * 5 <= errs[0] and errs[2] * 5 <= errs[1])
    r = run(['run', os.path.join(tmp, 'ideal_gear_k1e+09.nml'), '--no-output', '--set', 'run.dt=1.0e-3'])
    check(f'the k = 1e9 ideal_gear at the rigid run\'s dt = 1e-3 is refused or fails (exit {r.returncode})',
          r.returncode != 0)

    # trainsim modes merges the rigid gear's nodes: one mode of the shaft on the merged inertia
    deck = os.path.join(tmp, 'modes.nml')
    with open(deck, 'w') as f:
        f.write("&run title = 'modes', units = 'si', t_end = 0.1, dt = 1.0e-3 /\n")
        for nid, j in (('a', ja), ('b', jb), ('c', 0.02)):
            f.write(f"&node id = '{nid}', type = 'inertia', inertia = {j} /\n")
        f.write(f"&element id = 'g', type = 'rigid_gear', left = 'a', right = 'b', rb_driver = {r1}, rb_driven = {r2} /\n")
        f.write("&element id = 's', type = 'shaft', left = 'b', right = 'c', stiffness = 100.0 /\n")
    r = run(['modes', deck])
    hz = [float(x) for x in re.findall(r'mode\s+\d+:\s+([0-9.]+) Hz', r.stdout)]
    want = math.sqrt(100.0 * (1.0 / (jb + ja * (r2 / r1)**2) + 1.0 / 0.02)) / (2 * math.pi)
    check(f'modes: the rigid gear merges its nodes: one elastic mode {hz} = {want:.6f} Hz (1e-6), one rigid-body',
          r.returncode == 0 and len(hz) == 1 and abs(hz[0] / want - 1) <= 1e-6 and r.stdout.count('rigid-body') == 1)

    res = simulate(tmp, 'rigid_join', "type = 'rigid_join'", ja, jb, [('a', torque)], t_end, 1.0e-3)
    if res is not None:
        w = res['omega'][-1]
        check(f'rigid_join: speed {w[0]:.15g} = T t / (J1 + J2) = {torque * t_end / (ja + jb):.15g} (1e-12), '
              'both nodes bit for bit', rel(w[0], torque * t_end / (ja + jb)) <= 1e-12 and w[0] == w[1])

    # the self-locking worm
    ratio, rw, jw, jwh, k, c = 30.0, 0.05, 1.0e-4, 0.05, 1.0e8, 2000.0
    gam, mu, an = 3.0, 0.1, 20.0
    ca, tg = math.cos(math.radians(an)), math.tan(math.radians(gam))
    eta_f, eta_b = (ca - mu * tg) / (ca + mu / tg), (ca - mu / tg) / (ca + mu * tg)
    check(f'the worm is self-locking: eta_b = {eta_b:.4f} <= 0 (tan g {tg:.4f} <= mu / cos an {mu / ca:.4f})',
          eta_b <= 0)
    worm = (f"type = 'worm_gear', ratio = {ratio}, wheel_radius = {rw}, lead_angle = {gam}, "
            f"friction_coefficient = {mu}, stiffness = {k}, contact_damping = {c}")
    t_load = -5.0
    res = simulate(tmp, 'worm_held', worm, jw, jwh, [('b', t_load)], 2.0, 1.0e-6)
    if res is not None:
        th = res['theta']
        check(f'worm held: the worm angle stays 0 (max |theta_worm| {np.max(np.abs(th[:, 0])):.2e} <= 1e-12)',
              np.max(np.abs(th[:, 0])) <= 1e-12)
        static = -abs(t_load) / (k * rw**2)
        decay = c * rw**2 / (2 * jwh) * 2.0
        check(f'worm held: the wheel settles at -|T|/(k r2^2) = {static:.6e} rad (got {th[-1, 1]:.6e}; '
              f'mode decayed by e^-{decay:.0f}; 1e-3)', rel(th[-1, 1], static) <= 1e-3)
        if res['force'] is not None:
            check(f'worm held: mesh force {res["force"][-1, 0]:.6g} = |T|/r2 = {abs(t_load) / rw:.6g} (1e-3)',
                  rel(abs(res['force'][-1, 0]), abs(t_load) / rw) <= 1e-3)
    t_motor, t_end = 0.6, 0.5
    res = simulate(tmp, 'worm_lifts', worm, jw, jwh, [('a', t_motor), ('b', t_load)], t_end, 1.0e-6)
    if res is not None:
        acc = (t_motor - abs(t_load) / (ratio * eta_f)) / (jw + jwh / (ratio**2 * eta_f))
        j_eff = 1.0 / (1.0 / jw + ratio**2 / jwh)
        omega_n = math.sqrt(k * (rw / ratio)**2 / j_eff)
        t, w = res['t'], res['omega'][:, 0]
        half = np.searchsorted(t, 0.5 * t_end)
        got = (w[-1] - w[half]) / (t[-1] - t[half])   # after the start's stick-slip transient
        check(f'worm driven from the worm: acceleration over the second half {got:.7g} = closed form {acc:.7g} '
              f'(rel {rel(got, acc):.2e} <= 2/(omega_n t/2) = {4 / (omega_n * t_end):.2e})',
              acc > 0 and rel(got, acc) <= 4 / (omega_n * t_end))

finish()
