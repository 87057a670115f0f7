#!/usr/bin/python3
"""A self-locking worm holding a wheel that rattles in its backlash under a reversing load
(issue 23; the tracker day's event flood, D-91).

The worm (lead 3.58 deg, mu 0.08: eta_b = -0.36, self-locking) sits on a torsion spring to
ground and is pushed by a constant 0.1 N m (the tracker's motor key, wound up by the
holding brake); the wheel carries a load of -10 + 20 sin(2 pi 2 t) N m, so it reverses 8
times in 2 s and crosses the mesh's 0.1 mm backlash each time. While the mesh force
passes the spring's torque the worm's holding torque passes the edge of its band (the
worm driven on, forward); before D-91 the worm was then stuck and released at once, more
than 200 times within 1e-4 s (main at 923258e: "event flood at t = 0.0241 s", cvode-bdf).

Runs it under cvode-bdf (rtol 1e-6, the tracker's), rk4 (dt 1e-5, omega_mesh dt = 0.11)
and, without backlash (the faces coincide), cvode-bdf, and checks on each:
- it runs to its end (exit 0, no flood);
- the wheel rattles: at least 8 contacts on each face (one a load reversal) with backlash;
- bounded events: at most 150 events per load reversal (each crossing of the backlash is a
  separation, a contact and the impacts that follow it, a few dozen while the contact
  damping takes the bounce energy; the flood was over 200 within 1e-4 s), and never more
  than 50 within any 1e-4 s;
- the worm held does not move: between a stick of the worm and its next slip or the mesh
  opening, every recorded worm angle equals the angle at the stick to 1e-12 rad (D-81 holds
  its speed at exactly 0);
- the energy ledger closes to the integrator's tolerance: max |residual| <= 1e-4 of the
  energy scale under cvode-bdf (100 rtol: the ledger's dissipation is integrated with the
  states, whose global error is tens of rtol), <= 1e-6 under rk4 (measured 1.5e-7).

usage: check_worm_rattle.py TRAINSIM_EXE
"""
import os
import subprocess
import tempfile

import h5py
import numpy as np

from clicheck import check, EXE, finish


DECK = """&run title = 'worm rattle', units = 'si', t_end = 2.0, dt = {dt}, integrator = '{integ}', rtol = 1.0e-6,
     output_interval = 1.0e-3 /
&node id = 'worm', type = 'inertia', inertia = 5.0e-5 /
&node id = 'wheel', type = 'inertia', inertia = 4.0e-3 /
&node id = 'ground', type = 'fixed' /
&element id = 'spring', type = 'shaft', left = 'worm', right = 'ground', stiffness = 2.0, damping = 2.0e-3 /
&element id = 'mesh', type = 'worm_gear', left = 'worm', right = 'wheel', ratio = 50, wheel_radius = 0.05,
         lead_angle = 3.576334374997351, pressure_angle = 20, friction_coefficient = 0.08,
         stiffness = 2.0e8, contact_damping = 1.0e3, backlash = {backlash} /
&load node = 'worm', kind = 'constant', value = 0.1 /
&load node = 'wheel', kind = 'sine', offset = -10.0, amplitude = 20.0, frequency = 2.0 /
"""
REVERSALS = 8          # sign changes of -10 + 20 sin(4 pi t) over 2 s


def case(tmp, name, integ, dt, backlash, tol):
    deck = os.path.join(tmp, name + '.nml')
    with open(deck, 'w') as f:
        f.write(DECK.format(dt=dt, integ=integ, backlash=backlash))
    h5 = os.path.join(tmp, name + '.h5')
    r = subprocess.run([EXE, 'run', deck, '-o', h5], capture_output=True, text=True, timeout=600)
    check(f'{name}: runs to its end (exit {r.returncode}; {r.stderr.strip()[-240:]})', r.returncode == 0)
    if r.returncode != 0:
        return
    with h5py.File(h5) as f:
        t = f['time'][()]
        theta_worm = f['nodes/theta'][()][:, 0]
        kinds = [k.decode() for k in f['events/kind_name'][()]]
        ev_t = f['events/time'][()]
        ev_el = f['events/element'][()]
        ev_th = f['events/theta_left'][()]
        energy = f['energy'][()]
    mesh = ev_el == 2                                   # elements: spring 1, mesh 2
    front = sum(1 for k, m in zip(kinds, mesh) if m and k == 'contact_front')
    rear = sum(1 for k, m in zip(kinds, mesh) if m and k == 'contact_rear')
    if backlash > 0:
        check(f'{name}: the wheel rattles: {front} front and {rear} rear contacts >= {REVERSALS}',
              front >= REVERSALS and rear >= REVERSALS)
    n = len(kinds)
    densest = max(np.searchsorted(ev_t, ev_t + 1.0e-4, side='right') - np.arange(n)) if n else 0
    check(f'{name}: {n} events, {n / REVERSALS:.1f} per load reversal <= 150; at most {densest} within 1e-4 s '
          f'<= 50', n <= 150 * REVERSALS and densest <= 50)
    # the worm held: from each stick to the next slip or opening of the mesh
    worst, holds = 0.0, 0
    idx = [i for i in range(n) if mesh[i]]
    for a, i in enumerate(idx):
        if kinds[i] != 'stick':
            continue
        t_end = t[-1] + 1.0
        for j in idx[a + 1:]:
            if kinds[j] in ('slip_forward', 'slip_backward', 'separation'):
                t_end = ev_t[j]
                break
        inside = (t > ev_t[i]) & (t < t_end)
        if np.any(inside):
            holds += 1
            worst = max(worst, float(np.max(np.abs(theta_worm[inside] - ev_th[i]))))
    check(f'{name}: the worm held does not move: {holds} holds over output samples, largest change of its angle '
          f'{worst:.1e} rad <= 1e-12', holds >= 1 and worst <= 1.0e-12)
    scale = np.max(np.abs(energy[:, :4]))
    resid = np.max(np.abs(energy[:, 4]))
    check(f'{name}: energy ledger closes ({resid:.2e} <= {tol:.0e} x {scale:.3e})', resid <= tol * scale)


with tempfile.TemporaryDirectory() as tmp:
    case(tmp, 'cvode_backlash', 'cvode-bdf', 1.0e-4, 1.0e-4, 1.0e-4)
    case(tmp, 'rk4_backlash', 'rk4', 1.0e-5, 1.0e-4, 1.0e-6)
    case(tmp, 'cvode_no_backlash', 'cvode-bdf', 1.0e-4, 0.0, 1.0e-4)

finish(summary=True)
