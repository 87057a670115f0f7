#!/usr/bin/python3
"""The rigid lossy gear (`rigid_lossy_gear`, D-97) against closed forms.

Two inertias J1 (left, a) and J2 (right, b) joined by the gear, r1 w1 = r2 w2, rho = r1/r2,
constant torques T1 on a and T2 on b, RK4 (the accelerations are constant in each mode, so
RK4 is exact up to roundoff: the tolerances below are roundoff's, 1e-9):
- forward (left drives): a2 = (T2 + eta_f T1/rho) / (J2 + eta_f J1/rho^2);
- backward (right drives): a2 = (T2 + T1/(rho eta_b)) / (J2 + J1/(rho^2 eta_b));
  (the torque on the driven side is eta times the torque the driving side transmits, the
  loss on the left node as in lossy_gear, D-91)
- the power balance: the driven side's power is eta times the driving side's, so the
  dissipated energy is (1 - eta)/eta times the driven node's kinetic energy (from rest,
  one load), to 1e-9 relative; the energy ledger closes to 1e-9 of its scale;
- held: T2 back-drives b while T1 on a lies within the band
  -T2 rho/eta_f <= T1 <= -eta_b T2 rho: both speeds stay exactly 0 (the losses hold
  it); just outside the band on either side it moves at the closed form above;
- the flow turning while moving (a torque step on the left: forward, backward from the
  step, stick, forward back) under rk4, cvode-bdf and arkode-dp, its events located;
- a coast: both spinning, a constant torque against the left's motion, no load on the
  right: backward (the right's inertia drives the left) at the closed form until the speeds
  reach zero at t* = w2(0)/|a2|, a stick there, then forward (the left drives) the other
  way: the speed at t_end is the closed form of both phases; the event table shows the stick;
- against the compliant `lossy_gear` as its stiffness grows (forward): the driving node's
  speed differs from the rigid one by a relative error that falls with the stiffness
  (the mesh transient's 2/(omega_n t), omega_n ~ sqrt(k)).
- bad input: efficiency above 1, exit 2 naming file:line and key.

usage: check_rigid_lossy.py TRAINSIM_EXE
"""
import math
import os
import tempfile

import h5py
import numpy as np

from clicheck import check, EXE, finish, run


R1, R2, J1, J2, EF, EB = 0.02, 0.04, 0.01, 0.04, 0.8, 0.6
RHO = R1 / R2
GEAR = (f"type = 'rigid_lossy_gear', rb_driver = {R1}, rb_driven = {R2}, "
        f"efficiency_forward = {EF}, efficiency_backward = {EB}")


def simulate(tmp, name, element, t1, t2, t_end=0.5, w0=None, dt=1.0e-4, load_a=None):
    integ = name.split('_', 1)[1] if name.startswith('turn_') else 'rk4'
    deck = os.path.join(tmp, name + '.nml')
    with open(deck, 'w') as f:
        f.write(f"&run title = '{name}', units = 'si', t_end = {t_end}, dt = {dt}, integrator = '{integ}', "
                "output_interval = 1.0e-3 /\n")
        f.write(f"&node id = 'a', type = 'inertia', inertia = {J1} /\n")
        f.write(f"&node id = 'b', type = 'inertia', inertia = {J2} /\n")
        if w0 is not None:
            f.write(f"&initial node = 'a', speed = {w0} /\n&initial node = 'b', speed = {w0 * RHO} /\n")
        f.write(f"&element id = 'g', left = 'a', right = 'b', {element} /\n")
        if load_a is not None:
            f.write(f"&load node = 'a', {load_a} /\n")
        elif t1 != 0.0:
            f.write(f"&load node = 'a', kind = 'constant', value = {t1} /\n")
        if t2 != 0.0:
            f.write(f"&load node = 'b', kind = 'constant', value = {t2} /\n")
    h5 = os.path.join(tmp, name + '.h5')
    r = run(['run', deck, '-o', h5])
    check(f'{name}: runs ({r.stderr.strip()[:300]})', r.returncode == 0)
    if r.returncode != 0:
        return None
    with h5py.File(h5) as f:
        return {'t': f['time'][()], 'omega': f['nodes/omega'][()], 'energy': f['energy'][()],
                'kinds': f['events/kind'][()], 'ev_t': f['events/time'][()]}


def a2_forward(t1, t2):
    return (t2 + EF * t1 / RHO) / (J2 + EF * J1 / RHO**2)


def a2_backward(t1, t2):
    return (t2 + t1 / (RHO * EB)) / (J2 + J1 / (RHO**2 * EB))


def ledger(name, res):
    scale = np.max(np.abs(res['energy'][:, :4]))
    worst = np.max(np.abs(res['energy'][:, 4]))
    check(f'{name}: energy ledger closes ({worst:.2e} <= 1e-9 x {scale:.3e})', worst <= 1e-9 * scale)


def moving(name, res, a2, t_end=0.5):
    if res is None:
        return
    w = res['omega'][-1]
    want = a2 * t_end
    check(f'{name}: w_b {w[1]:.12g} = a2 t {want:.12g} (rel {abs(w[1] / want - 1):.1e} <= 1e-9)',
          abs(w[1] / want - 1) <= 1e-9)
    check(f'{name}: w_a = w_b / rho to 1e-12 ({abs(w[0] * RHO - w[1]):.1e})',
          abs(w[0] * RHO - w[1]) <= 1e-12 * abs(w[1]))
    ledger(name, res)


with tempfile.TemporaryDirectory() as tmp:
    # forward and backward from rest, one load: the power balance of the efficiency
    for name, t1, t2, drn_j, drn, eta, a2 in (('forward', 1.0, 0.0, J2, 1, EF, a2_forward(1.0, 0.0)),
                                               ('backward', 0.0, 1.0, J1, 0, EB, a2_backward(0.0, 1.0))):
        res = simulate(tmp, name, GEAR, t1, t2)
        moving(name, res, a2)
        if res is not None:
            e = res['energy'][-1]
            ke = 0.5 * drn_j * res['omega'][-1][drn]**2
            want = (1 - eta) / eta * ke
            check(f'{name}: dissipated {e[2]:.12g} = (1-eta)/eta KE_driven {want:.12g} (P_out = eta P_in; '
                  f'rel {abs(e[2] / want - 1):.1e} <= 1e-9)', abs(e[2] / want - 1) <= 1e-9)
            check(f'{name}: input {e[3]:.12g} = KE + dissipated ({abs(e[3] - e[0] - e[2]):.1e} <= 1e-9 input)',
                  abs(e[3] - e[0] - e[2]) <= 1e-9 * abs(e[3]))

    # held by the losses: T2 = 1 on b, T1 within [-rho/eta_f, -eta_b rho] = [-0.625, -0.3]
    lo, hi = -RHO / EF, -EB * RHO
    for t1 in (0.5 * (lo + hi), lo * 0.999, hi * 1.001):
        res = simulate(tmp, f'held_T1_{t1:.4f}', GEAR, t1, 1.0)
        if res is not None:
            peak = np.max(np.abs(res['omega']))
            check(f'held (T1 = {t1:.4f} in [{lo:.4f}, {hi:.4f}]): speeds exactly 0 over 0.5 s (max |w| {peak:.1e})',
                  peak == 0.0)
            ledger(f'held T1 = {t1:.4f}', res)
    res = simulate(tmp, 'beyond_backward_edge', GEAR, hi * 0.9, 1.0)
    moving(f'back-driven past the band (T1 = {hi * 0.9:.4f})', res, a2_backward(hi * 0.9, 1.0))
    res = simulate(tmp, 'beyond_forward_edge', GEAR, lo * 1.1, 1.0)
    moving(f'driven on past the band (T1 = {lo * 1.1:.4f})', res, a2_forward(lo * 1.1, 1.0))

    # a coast: backward to rest, a stick, forward the other way
    w0, tau, t_end = 20.0, -0.5, 1.0
    ab = a2_backward(tau, 0.0)
    t_star = -(w0 * RHO) / ab
    af = a2_forward(tau, 0.0)
    res = simulate(tmp, 'coast', GEAR, tau, 0.0, t_end=t_end, w0=w0)
    if res is not None:
        want = af * (t_end - t_star)
        w = res['omega'][-1]
        check(f'coast: t* = {t_star:.6f} s; w_b(t_end) {w[1]:.12g} = a2_f (t_end - t*) {want:.12g} '
              f'(rel {abs(w[1] / want - 1):.1e} <= 1e-9)', abs(w[1] / want - 1) <= 1e-9)
        sticks = res['ev_t'][res['kinds'] == 5]
        check(f'coast: a stick at t* ({sticks} vs {t_star:.9f}, to 1e-9 s)',
              len(sticks) >= 1 and abs(sticks[0] - t_star) <= 1e-9)
        ledger('coast', res)

    # the flow turns while moving: spinning, the left's torque steps from +0.5 to -0.5 at
    # 0.1 s: forward, then backward from the step (a flow_backward row there), to rest, stick
    # and forward the other way; every integrator family the same to 1e-9
    w1 = w0 * RHO + a2_forward(0.5, 0.0) * 0.1
    t_star = 0.1 + w1 / -a2_backward(-0.5, 0.0)
    want = a2_forward(-0.5, 0.0) * (2.0 - t_star)
    for integ in ('rk4', 'cvode-bdf', 'arkode-dp'):
        res = simulate(tmp, f'turn_{integ}', GEAR, 0.0, 0.0, t_end=2.0, w0=w0,
                       load_a="kind = 'step', value0 = 0.5, value1 = -0.5, t_step = 0.1")
        if res is None:
            continue
        w = res['omega'][-1]
        kinds, times = list(res['kinds']), res['ev_t']
        check(f'turn ({integ}): w_b(2) {w[1]:.12g} = {want:.12g} (rel {abs(w[1] / want - 1):.1e} <= 1e-9), '
              f'events {kinds} at {times} = [flow_backward 0.1, stick t* {t_star:.9f}, slip_forward t*]',
              abs(w[1] / want - 1) <= 1e-9 and kinds == [10, 5, 6] and abs(times[0] - 0.1) <= 1e-9
              and abs(times[1] - t_star) <= 1e-9)
        ledger(f'turn ({integ})', res)

    # joined to another rigid element: b split into two halves joined by a rigid_join (the
    # cluster's weights, D-97): the same forward motion, ratio 1 bit for bit across the join
    deck = os.path.join(tmp, 'joined.nml')
    with open(deck, 'w') as f:
        f.write("&run title = 'joined', units = 'si', t_end = 0.5, dt = 1.0e-4, integrator = 'rk4', "
                "output_interval = 1.0e-3 /\n")
        f.write(f"&node id = 'a', type = 'inertia', inertia = {J1} /\n")
        f.write(f"&node id = 'b', type = 'inertia', inertia = {J2 / 2} /\n")
        f.write(f"&node id = 'c', type = 'inertia', inertia = {J2 / 2} /\n")
        f.write(f"&element id = 'g', left = 'a', right = 'b', {GEAR} /\n")
        f.write("&element id = 'j', left = 'b', right = 'c', type = 'rigid_join' /\n")
        f.write("&load node = 'a', kind = 'constant', value = 1.0 /\n")
    r = run(['run', deck, '-o', os.path.join(tmp, 'joined.h5')])
    check(f'joined: runs ({r.stderr.strip()[:300]})', r.returncode == 0)
    if r.returncode == 0:
        with h5py.File(os.path.join(tmp, 'joined.h5')) as f:
            res = {'omega': f['nodes/omega'][()], 'energy': f['energy'][()]}
        moving('forward, driven side two halves joined', res, a2_forward(1.0, 0.0))
        check('joined: the two halves bit for bit alike', np.all(res['omega'][:, 1] == res['omega'][:, 2]))

    # the compliant lossy gear converges on the rigid one as its stiffness grows
    a_rigid = a2_forward(1.0, 0.0) / RHO * 0.5
    errs = []
    for k in (1.0e5, 1.0e6, 1.0e7):
        lossy = (f"type = 'lossy_gear', rb_driver = {R1}, rb_driven = {R2}, stiffness = {k}, "
                 f"efficiency_forward = {EF}, efficiency_backward = {EB}, contact_damping = {2.0 * math.sqrt(k) * 0.1}")
        res = simulate(tmp, f'compliant_{k:.0e}', lossy, 1.0, 0.0, dt=1.0e-5)
        if res is not None:
            errs.append(abs(res['omega'][-1][0] / a_rigid - 1))
    check(f'compliant lossy_gear -> rigid as k grows (rel errors {["%.2e" % e for e in errs]} falling, last < 1e-3)',
          len(errs) == 3 and errs[0] > errs[1] > errs[2] and errs[2] < 1e-3)

    # bad input
    deck = os.path.join(tmp, 'bad.nml')
    with open(deck, 'w') as fh:
        fh.write("&run title = 'bad', units = 'si', t_end = 0.01, dt = 1.0e-6 /\n")
        fh.write("&node id = 'a', type = 'inertia', inertia = 0.01 /\n")
        fh.write("&node id = 'b', type = 'inertia', inertia = 0.04 /\n")
        fh.write(f"&element id = 'g', left = 'a', right = 'b', {GEAR.replace(f'efficiency_forward = {EF}', 'efficiency_forward = 1.2')} /\n")
    r = run(['run', deck, '--no-output'])
    msg = r.stderr.strip()
    check(f'efficiency_forward = 1.2: exit 2 naming file:line, key and value ({msg[:160]})',
          r.returncode == 2 and 'bad.nml:4' in msg and 'efficiency_forward' in msg and '1.2' in msg)

finish()
