#!/usr/bin/python3
"""Lossy and worm gears (issue 23 item 2) and `trainsim worm`, against closed forms.

- `trainsim worm`: the lead angle, friction angle and the two efficiencies against hand
  computation (eta_f = (cos an - mu tan g)/(cos an + mu cot g), eta_b = (cos an - mu cot g)/
  (cos an + mu tan g), tan g = z1/q); mu = 0 gives 1 and 1; self-locking exactly when
  tan g <= mu / cos an (either side of the threshold); its fragment pastes into a deck that
  runs; bad values exit 2 naming the option; extreme values end with exit 0 or 2.
- `lossy_gear`, power flowing forward (torque on the left node) and backward (torque on
  the right node), from rest through a stiff damped mesh: the driving node's speed at t_end
  is the rigid closed form alpha t (alpha = T / (J_drv + J_drn i^2 / eta), i the speed
  ratio driving/driven), to 2/(omega_n t_end) relative (the step-load transient of the
  mesh mode omega_n, damped); the energy dissipated is (1 - eta)/eta times the driven
  node's kinetic energy (the power balance of the efficiency) to within twice the mesh's
  elastic energy (what the contact damping can take from the transient) plus 1e-9; the
  energy ledger closes to 1e-9 of its scale (RK4, dt far below the mesh period).
- `worm_gear` back-driven (a torque on the wheel, the worm free) above the self-locking
  limit: the wheel accelerates at T / (J_wheel + J_worm i^2 / eta_b), eta_b from the
  lead angle and friction as above; the same checks.
- Bad deck values exit 2 naming file, line and key: an efficiency above 1 or not
  positive, a lead angle outside (0, 90) deg, a negative friction coefficient.

usage: check_lossy_worm.py TRAINSIM_EXE
"""
import math
import os
import re
import tempfile

import h5py
import numpy as np

from clicheck import check, EXE, finish, run


def value(out, label):
    m = re.search(re.escape(label) + r'\s+([-+0-9.Ee]+)', out)
    return float(m.group(1)) if m else float('nan')


def efficiencies(gamma, alpha_n, mu):
    ca, tg = math.cos(alpha_n), math.tan(gamma)
    return (ca - mu * tg) / (ca + mu / tg), (ca - mu / tg) / (ca + mu * tg)


# ---------------------------------------------------------------- trainsim worm
base = ['worm', '--starts', '1', '--teeth', '40', '--module', '4', '--diameter-factor', '10']
w = run(base + ['--friction', '0.05'])
check('worm exits 0', w.returncode == 0)
g = math.atan(0.1)
ef, eb = efficiencies(g, math.radians(20.0), 0.05)
check(f'lead angle {value(w.stdout, "lead angle gamma")} = atan(0.1) = {math.degrees(g):.5f} deg (5 digits)',
      abs(value(w.stdout, 'lead angle gamma') - math.degrees(g)) < 1e-4)
check(f"friction angle = atan(0.05/cos 20) = {math.degrees(math.atan(0.05 / math.cos(math.radians(20)))):.5f} deg",
      abs(value(w.stdout, "friction angle rho'") - math.degrees(math.atan(0.05 / math.cos(math.radians(20))))) < 1e-4)
check(f'eta_f {value(w.stdout, "forward efficiency eta_f")} = {ef:.5f}, eta_b {value(w.stdout, "backward efficiency eta_b")}'
      f' = {eb:.5f} (hand: 0.64923, 0.46543)',
      abs(value(w.stdout, 'forward efficiency eta_f') - 0.64923) < 1e-5
      and abs(value(w.stdout, 'backward efficiency eta_b') - 0.46543) < 1e-5 and abs(ef - 0.64923) < 1e-5)
check('ratio 40 = z2/z1', value(w.stdout, 'ratio i = z2/z1') == 40.0)
w0 = run(['worm', '--starts', '4', '--teeth', '40', '--module', '4', '--diameter-factor', '10', '--friction', '0'])
check('mu = 0: both efficiencies 1', value(w0.stdout, 'forward efficiency eta_f') == 1.0
      and value(w0.stdout, 'backward efficiency eta_b') == 1.0)
mu_star = math.cos(math.radians(20.0)) * 0.1     # tan gamma = mu / cos alpha_n at the limit
for mu, locking in ((mu_star * 0.99, False), (mu_star * 1.01, True)):
    s = run(base + ['--friction', f'{mu:.6f}'])
    check(f'mu = {mu:.6f} ({"above" if locking else "below"} mu* = {mu_star:.6f}): self-locking {locking}',
          s.returncode == 0 and (('self-locking: yes' in s.stdout) == locking))
for extra, phrase in ((['--friction', '-0.1'], '--friction'), (['--friction', '0.05', '--pressure-angle', '0.35'],
                                                               'radians'),
                      (['--friction', '0.05', '--starts', '1.5'], '--starts')):
    args = list(base)
    if '--starts' in extra:
        args[2] = extra[extra.index('--starts') + 1]
        extra = extra[:extra.index('--starts')]
    s = run(args + extra)
    check(f'worm {" ".join(extra)}: exit 2 naming "{phrase}"', s.returncode == 2 and phrase in s.stderr)
crash = ['Backtrace', 'runtime error', 'SIGFPE', 'SIGSEGV', 'Floating point exception', 'Error termination']
bad = []
for opt in ['--starts', '--teeth', '--module', '--diameter-factor', '--friction', '--pressure-angle']:
    for v in ['1e300', '-1e300', '1e-300', '0', '-1', '1e999', 'nan', 'abc']:
        args = base + ['--friction', '0.05']
        if opt in args:
            args[args.index(opt) + 1] = v
        else:
            args += [opt, v]
        s = run(args)
        if s.returncode not in (0, 2) or any(c in s.stderr for c in crash):
            bad.append(f'{opt} {v}: exit {s.returncode} {s.stderr[-200:]}')
check('worm: 6 options x 8 extreme values end with exit 0 or 2, no crash', not bad)
for b in bad[:10]:
    print('      ', b)


# ---------------------------------------------------------------- runs
def simulate(tmp, name, element, j_left, j_right, load_node, torque, t_end=0.5):
    deck = os.path.join(tmp, name + '.nml')
    with open(deck, 'w') as f:
        f.write(f"&run title = '{name}', units = 'si', t_end = {t_end}, dt = 1.0e-5, integrator = 'rk4', "
                "output_interval = 1.0e-3 /\n")
        f.write(f"&node id = 'a', type = 'inertia', inertia = {j_left} /\n")
        f.write(f"&node id = 'b', type = 'inertia', inertia = {j_right} /\n")
        f.write(f"&element id = 'g', left = 'a', right = 'b', {element} /\n")
        f.write(f"&load node = '{load_node}', kind = 'constant', value = {torque} /\n")
    h5 = os.path.join(tmp, name + '.h5')
    r = run(['run', deck, '-o', h5])
    check(f'{name}: runs ({r.stderr.strip()[:200]})', r.returncode == 0)
    if r.returncode != 0:
        return None
    with h5py.File(h5) as f:
        kinds = f['events/kind'][()]
        v_i = f['events/approach_velocity'][()][(kinds == 1) | (kinds == 2)]
        return {'t': f['time'][()], 'omega': f['nodes/omega'][()], 'energy': f['energy'][()], 'v_i': v_i}


def power_balance(name, res, drv, drn, j_drv, j_drn, ratio, eta, torque, k_line, r_line, t_end=0.5):
    """ratio: driving speed / driven speed; k_line r_line^2: the mesh's torsional stiffness
    seen from the driving node."""
    if res is None:
        return
    alpha = torque / (j_drv + j_drn / ratio**2 / eta)
    j_eff = 1.0 / (1.0 / j_drv + ratio**2 / j_drn)
    omega_n = math.sqrt(k_line * r_line**2 / j_eff)
    w_end = res['omega'][-1]
    tol = 2.0 / (omega_n * t_end)
    got = w_end[drv]
    check(f'{name}: driving speed {got:.7g} = alpha t {alpha * t_end:.7g} (rel {abs(got / (alpha * t_end) - 1):.2e} '
          f'<= 2/(omega_n t) = {tol:.2e})', abs(got / (alpha * t_end) - 1) <= tol)
    e = res['energy'][-1]
    ke_drn = 0.5 * j_drn * w_end[drn]**2
    want = (1 - eta) / eta * ke_drn
    # impacts across a backlash dissipate at most the relative motion's energy at each
    # onset, 1/2 m V_i^2 along the line (m: the driving inertia seen there, r_line^2 / j_eff)
    impacts = np.sum(0.5 * j_eff / r_line**2 * res['v_i']**2)
    allow = 2.0 * e[1] + impacts + 1e-9 * abs(e[3])
    check(f'{name}: dissipated {e[2]:.7g} = (1-eta)/eta KE_driven {want:.7g} (|diff| {abs(e[2] - want):.2e} <= '
          f'2 PE + impacts + 1e-9 input = {allow:.2e})', abs(e[2] - want) <= allow)
    scale = np.max(np.abs(res['energy'][:, :4]))
    worst = np.max(np.abs(res['energy'][:, 4]))
    check(f'{name}: energy ledger closes ({worst:.2e} <= 1e-9 x {scale:.3e})', worst <= 1e-9 * scale)


with tempfile.TemporaryDirectory() as tmp:
    k, r1, r2, ja, jb, c = 1.0e7, 0.02, 0.04, 0.01, 0.04, 200.0
    lossy = (f"type = 'lossy_gear', rb_driver = {r1}, rb_driven = {r2}, stiffness = {k}, "
             f"efficiency_forward = 0.8, efficiency_backward = 0.6, contact_damping = {c}")
    res = simulate(tmp, 'lossy_forward', lossy, ja, jb, 'a', 1.0)
    power_balance('lossy forward', res, 0, 1, ja, jb, r2 / r1, 0.8, 1.0, k, r1)
    res = simulate(tmp, 'lossy_backward', lossy, ja, jb, 'b', 1.0)
    power_balance('lossy backward', res, 1, 0, jb, ja, r1 / r2, 0.6, 1.0, k, r2)
    res = simulate(tmp, 'lossy_backlash', lossy + ", backlash = 1.0e-4", ja, jb, 'a', 1.0)
    power_balance('lossy forward through backlash', res, 0, 1, ja, jb, r2 / r1, 0.8, 1.0, k, r1)

    # worm back-driven above the self-locking limit: gamma 20 deg, mu 0.05
    ratio, rw, jw, jwh = 20.0, 0.05, 1.0e-4, 0.05
    gam, mu = 20.0, 0.05
    ef, eb = efficiencies(math.radians(gam), math.radians(20.0), mu)
    worm = (f"type = 'worm_gear', ratio = {ratio}, wheel_radius = {rw}, lead_angle = {gam}, "
            f"friction_coefficient = {mu}, stiffness = 1.0e8, contact_damping = 300.0")
    res = simulate(tmp, 'worm_backdriven', worm, jw, jwh, 'b', 2.0)
    power_balance(f'worm back-driven (eta_b {eb:.4f})', res, 1, 0, jwh, jw, 1.0 / ratio, eb, 2.0, 1.0e8, rw)
    res = simulate(tmp, 'worm_forward', worm, jw, jwh, 'a', 0.05)
    power_balance(f'worm driving (eta_f {ef:.4f})', res, 0, 1, jw, jwh, ratio, ef, 0.05, 1.0e8, rw / ratio)

    # the calculator's fragment pastes into a deck that runs
    f = run(base + ['--friction', '0.05', '--units', 'si', '--stiffness', '1e8'])
    frag = f.stdout[f.stdout.index('! deck fragment'):]
    deck = os.path.join(tmp, 'frag.nml')
    with open(deck, 'w') as fh:
        fh.write("&run title = 'worm fragment', units = 'si', t_end = 0.01, dt = 1.0e-6 /\n")
        fh.write("&node id = 'worm_worm', type = 'inertia', inertia = 1.0e-4 /\n")
        fh.write("&node id = 'worm_wheel', type = 'inertia', inertia = 0.05 /\n")
        fh.write(frag.replace(" /", ", left = 'worm_worm', right = 'worm_wheel' /", 1))
        fh.write("&load node = 'worm_worm', kind = 'constant', value = 0.1 /\n")
    r = run(['run', deck, '--no-output'])
    check('the worm fragment runs: ' + r.stderr.strip()[:300], r.returncode == 0)

    # bad values: file, line, key, value, exit 2
    bad_cases = [
        ('efficiency_forward = 1.2', lossy.replace('efficiency_forward = 0.8', 'efficiency_forward = 1.2'),
         'efficiency_forward', '1.2'),
        ('efficiency = 0', lossy.replace('efficiency_forward = 0.8, efficiency_backward = 0.6', 'efficiency = 0'),
         'efficiency', '0'),
        ('efficiency_backward = -0.1', lossy.replace('efficiency_backward = 0.6', 'efficiency_backward = -0.1'),
         'efficiency_backward', '-0.1'),
        ('lead_angle = 90', worm.replace(f'lead_angle = {gam}', 'lead_angle = 90'), 'lead_angle', '90'),
        ('lead_angle = 0', worm.replace(f'lead_angle = {gam}', 'lead_angle = 0'), 'lead_angle', '0'),
        ('friction_coefficient = -0.05', worm.replace(f'friction_coefficient = {mu}', 'friction_coefficient = -0.05'),
         'friction_coefficient', '-0.05'),
    ]
    for what, element, key, val in bad_cases:
        deck = os.path.join(tmp, 'bad.nml')
        with open(deck, 'w') as fh:
            fh.write("&run title = 'bad', units = 'si', t_end = 0.01, dt = 1.0e-6 /\n")
            fh.write("&node id = 'a', type = 'inertia', inertia = 0.01 /\n")
            fh.write("&node id = 'b', type = 'inertia', inertia = 0.04 /\n")
            fh.write(f"&element id = 'g', left = 'a', right = 'b', {element} /\n")
        r = run(['run', deck, '--no-output'])
        msg = r.stderr.strip()
        check(f'{what}: exit 2 naming file:line, key and value ({msg[:160]})',
              r.returncode == 2 and 'bad.nml:4' in msg and key in msg and val in msg and 'Backtrace' not in msg)

finish()
