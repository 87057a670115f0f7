#!/usr/bin/python3
"""What `trainsim run` prints reads cleanly (issue #21 item 6).

- choice keys by their words (stiffness_fit 'tight', zone_function 'truncate'), not codes;
- ids longer than the old 12/16-character columns printed whole;
- unit names instead of "torque units", in the in-lbf-s and the SI system;
- the wall time with its leading zero; headers on the final-state columns;
- with initial_state = 'preload', the preload's initial angles, which for a torque T on a
  shaft k to ground put the node behind the shaft at T/k (closed form, to 1e-9).

usage: check_printout.py TRAINSIM_EXE
"""
import os
import re
import subprocess
import tempfile

from clicheck import check, EXE, finish


LONG = 'motor_side_inertia_long_name'
KEY = 'the_keyed_joint_of_the_hub'
DECK_IN = f"""&run title = 'print-out', t_end = 0.002, dt = 1.0e-5, initial_state = 'preload' /
&node id = '{LONG}', type = 'inertia', inertia = 0.1 /
&node id = 'n2', type = 'inertia', inertia = 0.2 /
&node id = 'n3', type = 'fixed' /
&element id = '{KEY}', type = 'keyed_joint', diameter = 2.0, half_clearance = 0.001,
         stiffness_fit = 'tight', key_length = 1.5, left = '{LONG}', right = 'n2' /
&element id = 'sh', type = 'shaft', stiffness = 1.0e5, left = 'n2', right = 'n3' /
&load node = '{LONG}', value = 100.0 /
"""
DECK_SI = """&run title = 'si print-out', units = 'si', t_end = 0.001, dt = 1.0e-6 /
&node id = 'pinion', type = 'inertia', inertia = 1.0e-3 /
&node id = 'wheel', type = 'inertia', inertia = 1.0e-2 /
&element id = 'mesh', type = 'spur_gear', teeth_driver = 20, teeth_driven = 80, module = 2.0,
         pressure_angle = 20.0, face_width = 0.02, backlash = 1.0e-4, zone_function = 'truncate' /
&initial node = 'pinion', speed = 10.0 /
"""

with tempfile.TemporaryDirectory() as tmp:
    outs = {}
    for name, text in (('in', DECK_IN), ('si', DECK_SI)):
        path = os.path.join(tmp, name + '.nml')
        with open(path, 'w') as f:
            f.write(text)
        r = subprocess.run([EXE, 'run', path, '--no-output'], capture_output=True, text=True, timeout=120)
        check(f'{name} deck runs (exit {r.returncode}) {r.stderr.strip()[:200]}', r.returncode == 0)
        outs[name] = r.stdout
    a, s = outs['in'], outs['si']

    check('stiffness_fit printed as its word', re.search(r'stiffness_fit\s+tight\s*$', a, re.M) is not None)
    check('zone_function printed as its word', re.search(r'truncate_zones\s+truncate\s*$', s, re.M) is not None)
    check('no choice key printed as a number',
          re.search(r'(stiffness_fit|truncate_zones)\s+[-+0-9.]+E[-+]\d+', a + s) is None)
    check('long node and element ids printed whole', all(
        re.search(r'^\s*' + i + r'\s', a, re.M) for i in (LONG, KEY)))
    check('no "torque units" placeholder', 'torque units' not in a + s)
    check('in-lbf-s summary names lbf*in and lbf', 'lbf*in' in a and 'peak force in lbf' in a)
    check('SI summary names N*m and N', 'in N*m' in s and 'peak force in N' in s)
    check('gear displacement in m (SI) and in (in-lbf-s); shaft in rad',
          re.search(r'^\s*mesh\s+spur_gear\s+(\S+\s+){4}m\s', s, re.M) is not None
          and re.search(r'^\s*sh\s+shaft\s+(\S+\s+){4}rad\s', a, re.M) is not None)
    wall = re.search(r'wall time (\S+) s', a)
    check('wall time with its leading zero', wall is not None and not wall.group(1).startswith('.'))
    check('final-state columns have headers', re.search(r'node\s+angle \(rad\)\s+speed \(rad/s\)', a) is not None)
    m = re.search(r'^\s*n2\s+(\S+)\s*$', a.split('initial angles from the static preload')[-1], re.M) \
        if 'initial angles from the static preload' in a else None
    check('preload angles printed', m is not None)
    if m:
        th = float(m.group(1))
        check(f'n2 preload angle {th:.10g} = T/k = 1e-3 rad (1e-9)', abs(th - 1.0e-3) <= 1e-9)

finish(summary=True)
