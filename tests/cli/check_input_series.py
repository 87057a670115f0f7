#!/usr/bin/python3
"""The history's /inputs (issue #21 item 2): every load, prescribed speed and motor
voltage of the deck is a column, named and with its unit, whose values equal the deck's
time functions at the sample times (the definitions of docs/deck.md#time-functions,
written out here independently), to 1e-12 relative; the same with a sweep-style --set
of a load's amplitude; `trainsim export FILE input.NAME` gives them; a deck without
inputs has an empty (n, 0) /inputs.

usage: check_input_series.py TRAINSIM_EXE
"""
import math
import os
import subprocess
import tempfile

import h5py
import numpy as np

from clicheck import check, EXE, finish


def start_stop(t, v, ta, tc, td, tw, t0, n):
    """docs/deck.md: 0 until t0; n times rise over ta, hold tc, fall over td, 0 for tw."""
    out = np.zeros_like(t)
    per = ta + tc + td + tw
    for i, x in enumerate(t):
        u = x - t0
        if u < 0 or u >= n * per:
            continue
        u = u - math.floor(u / per) * per
        if u < ta:
            out[i] = v * u / ta
        elif u < ta + tc:
            out[i] = v
        elif u < ta + tc + td:
            out[i] = v * (1 - (u - ta - tc) / td)
    return out


DECK = """&run title = 'inputs', t_end = 0.05, dt = 1.0e-5, output_interval = 1.0e-4 /
&node id = 'motor', type = 'dc_motor', inertia = 0.01, torque_constant = 1.0,
      back_emf_constant = 0.11298, resistance = 1.0, inductance = 0.001 /
&node id = 'a', type = 'inertia', inertia = 0.2 /
&node id = 'b', type = 'inertia', inertia = 0.3 /
&node id = 'c', type = 'inertia', inertia = 0.1 /
&element id = 's1', type = 'shaft', stiffness = 1.0e4, left = 'motor', right = 'a' /
&element id = 's2', type = 'shaft', stiffness = 1.0e4, left = 'a', right = 'b' /
&element id = 's3', type = 'shaft', stiffness = 1.0e4, left = 'b', right = 'c' /
&load node = 'b', kind = 'sine', offset = 3.0, amplitude = 20.0, frequency = 37.0, phase = 0.4 /
&load node = 'motor', quantity = 'voltage', kind = 'ramp', value0 = 2.0, value1 = 24.0, t0 = 0.01, t1 = 0.03 /
&load node = 'b', kind = 'table', times = 0.0, 0.02, 0.04, values = 0.0, -5.0, 1.0 /
&load node = 'c', quantity = 'speed', kind = 'start_stop', value = 4.0, t_accel = 0.01,
      t_cruise = 0.005, t_decel = 0.01, t_dwell = 0.004, t_start = 0.002, cycles = 2 /
&load node = 'a', kind = 'step', value0 = 1.0, value1 = -7.0, t_step = 0.0123 /
"""

with tempfile.TemporaryDirectory() as tmp:
    deck = os.path.join(tmp, 'in.nml')
    with open(deck, 'w') as f:
        f.write(DECK)
    for label, sets, amp in (('deck', [], 20.0), ('--set load#1.amplitude=-9.5', ['load#1.amplitude=-9.5'], -9.5)):
        out = os.path.join(tmp, 'in.h5')
        args = [EXE, 'run', deck, '-o', out]
        for s in sets:
            args += ['--set', s]
        r = subprocess.run(args, capture_output=True, text=True, timeout=120)
        check(f'{label}: runs (exit {r.returncode}) {r.stderr.strip()[:200]}', r.returncode == 0)
        if r.returncode != 0:
            continue
        with h5py.File(out, 'r') as f:
            t = f['time'][()]
            d = f['inputs']
            names = [x.decode() if isinstance(x, bytes) else x for x in d.attrs['names']]
            units = [x.decode() if isinstance(x, bytes) else x for x in d.attrs['column_units']]
            v = d[()]
            check(f'{label}: /inputs has one row per sample ({v.shape[0]} = {len(t)})', v.shape[0] == len(t))
            want = {
                'b.load_torque#1': ('lbf*in', 3.0 + amp * np.sin(2 * math.pi * 37.0 * t + 0.4)),
                'b.load_torque#2': ('lbf*in', np.interp(t, [0.0, 0.02, 0.04], [0.0, -5.0, 1.0])),
                'a.load_torque': ('lbf*in', np.where(t < 0.0123, 1.0, -7.0)),
                'c.prescribed_speed': ('rad/s', start_stop(t, 4.0, 0.01, 0.005, 0.01, 0.004, 0.002, 2)),
                'motor.voltage': ('V', np.interp(t, [0.01, 0.03], [2.0, 24.0])),
            }
            check(f'{label}: columns are the five inputs {sorted(names)}', sorted(names) == sorted(want))
            for name, (unit, ref) in want.items():
                if name not in names:
                    continue
                j = names.index(name)
                err = np.max(np.abs(v[:, j] - ref)) / max(1.0, np.max(np.abs(ref)))
                check(f'{label}: {name} [{units[j]}] equals its time function (max rel. error {err:.1e} <= 1e-12)',
                      units[j] == unit and err <= 1e-12)

    # the inputs as quantities of trainsim export / plot (input.NAME)
    r = subprocess.run([EXE, 'export', os.path.join(tmp, 'in.h5'), 'input.motor.voltage'],
                       capture_output=True, text=True, timeout=120)
    rows = r.stdout.strip().splitlines()
    check(f'export input.motor.voltage: exit {r.returncode}, header {rows[0] if rows else None}',
          r.returncode == 0 and rows[0] == 'time [s],input.motor.voltage [V]')
    if r.returncode == 0:
        t_v = np.array([[float(x) for x in row.split(',')] for row in rows[1:]])
        ref = np.interp(t_v[:, 0], [0.01, 0.03], [2.0, 24.0])
        check('... its values are the ramp at the sample times (1e-12)', np.max(np.abs(t_v[:, 1] - ref)) <= 1e-12 * 24)

    plain = os.path.join(tmp, 'plain.nml')
    with open(plain, 'w') as f:
        f.write("&run title = 'no inputs', t_end = 0.001, dt = 1.0e-5 /\n"
                "&node id = 'a', type = 'inertia', inertia = 0.2 /\n"
                "&node id = 'b', type = 'inertia', inertia = 0.3 /\n"
                "&element id = 's', type = 'shaft', stiffness = 1.0e4 /\n"
                "&initial node = 'a', speed = 1.0 /\n")
    r = subprocess.run([EXE, 'run', plain, '-o', os.path.join(tmp, 'plain.h5')], capture_output=True, text=True)
    check('a deck without inputs runs', r.returncode == 0)
    if r.returncode == 0:
        with h5py.File(os.path.join(tmp, 'plain.h5'), 'r') as f:
            check(f"... and its /inputs has no columns {f['inputs'].shape}",
                  f['inputs'].shape == (len(f['time']), 0))

finish(summary=True)
