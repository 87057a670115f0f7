#!/usr/bin/python3
"""trainsim gear / trainsim key from the command line.

- The deck fragment `trainsim gear` prints for App. E's gears (k = 18.03e6, J2 for
  350 Hz) pastes into a deck that runs, and that run reproduces the hand-written
  Table 5.3 verification deck (verification/table5_3/table5_3.nml): the constants
  agree to the thesis's printed digits, so the first impact's peak force agrees to
  1e-3 (the spread of those digits: contact ratio 1.638004 vs 1.6380 etc.).
- The keyed-joint fragment of `trainsim key` pastes into a deck that runs.
- Unit slips exit with status 2 and a message naming the slip.

usage: check_calculators.py TRAINSIM_EXE
"""
import os
import subprocess
import tempfile

import h5py
import numpy as np

from clicheck import check, EXE, finish, run
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def fragment(out):
    lines = out.splitlines()
    start = next(i for i, l in enumerate(lines) if l.startswith('! deck fragment'))
    return '\n'.join(lines[start:]) + '\n'


with tempfile.TemporaryDirectory() as tmp:
    g = run(['gear', '--teeth', '28', '28', '--diametral-pitch', '8', '--pressure-angle', '20',
             '--face-width', '0.700', '--backlash', '0.002', '--stiffness', '18.03e6', '--frequency', '350'])
    check('gear exits 0', g.returncode == 0)
    deck = os.path.join(tmp, 'gear.nml')
    with open(deck, 'w') as f:
        f.write("&run title = 'fragment', t_end = 2.0e-4, dt = 5.0e-7, integrator = 'rk4' /\n")
        f.write(fragment(g.stdout))
        f.write("&initial node = 'gear1', speed = 10.0 /\n")
    r1 = run(['run', deck, '-o', os.path.join(tmp, 'frag.h5')])
    check('the gear fragment runs: ' + r1.stderr.strip()[:200], r1.returncode == 0)
    r2 = run(['run', os.path.join(ROOT, 'verification/table5_3/table5_3.nml'), '-o', os.path.join(tmp, 'ref.h5')])
    check('Table 5.3 deck runs', r2.returncode == 0)
    if r1.returncode == 0 and r2.returncode == 0:
        with h5py.File(os.path.join(tmp, 'frag.h5')) as a, h5py.File(os.path.join(tmp, 'ref.h5')) as b:
            fa, fb = a['metrics/max_peak_force'][0], b['metrics/max_peak_force'][0]
            check(f'first-impact peak force {fa:.6g} = Table 5.3 deck {fb:.6g} (1e-3)', abs(fa - fb) <= 1e-3 * fb)
            ta, tb = a['events/time'][0], b['events/time'][0]
            check(f'first contact at {ta:.6g} s = {tb:.6g} s (1e-3)', abs(ta - tb) <= 1e-3 * tb)

    # issue 21 item 4 (D-62): three stages of `gear --id` pasted into one deck do not clash
    frags = []
    for sid, teeth in (('s1', ['20', '40']), ('s2', ['22', '44']), ('s3', ['25', '50'])):
        g3 = run(['gear', '--teeth'] + teeth + ['--diametral-pitch', '8', '--face-width', '0.7',
                                                '--backlash', '0.004', '--id', sid])
        check(f'gear --id {sid} exits 0', g3.returncode == 0)
        frag = fragment(g3.stdout)
        check(f"gear --id {sid}: nodes '{sid}_driver', '{sid}_driven' and the mesh joins them",
              f"&node id = '{sid}_driver'" in frag and f"&node id = '{sid}_driven'" in frag
              and f"left = '{sid}_driver', right = '{sid}_driven'" in frag)
        frags.append(frag)
    deck = os.path.join(tmp, 'three.nml')
    with open(deck, 'w') as f:
        f.write("&run title = 'three stages', t_end = 2.0e-3, dt = 5.0e-7, integrator = 'rk4' /\n")
        f.write(''.join(frags))
        f.write("&element id = 'shaft12', type = 'shaft', left = 's1_driven', right = 's2_driver', stiffness = 1.0e5 /\n")
        f.write("&element id = 'shaft23', type = 'shaft', left = 's2_driven', right = 's3_driver', stiffness = 1.0e5 /\n")
        f.write("&initial node = 's1_driver', speed = 10.0 /\n")
    r3 = run(['run', deck, '-o', os.path.join(tmp, 'three.h5')])
    # a clash would be the refusal "duplicate node id" (exit 2)
    check('three gear --id fragments joined by shafts build and run: ' + r3.stderr.strip()[:300], r3.returncode == 0)

    k = run(['key', '--diameter', '1.0', '--key-length', '1.5', '--clearance', '0.002', '--fit', 'average'])
    check('key exits 0', k.returncode == 0)
    deck = os.path.join(tmp, 'key.nml')
    with open(deck, 'w') as f:
        f.write("&run title = 'key', t_end = 3.0e-4, dt = 5.0e-7 /\n")
        f.write("&node id = 'shaft', type = 'inertia', inertia = 7.537e-3 /\n")
        f.write(fragment(k.stdout))
        f.write("&node id = 'hub', type = 'inertia', inertia = 10.082 /\n")
        f.write("&initial node = 'shaft', speed = 10.0 /\n")
    r = run(['run', deck, '--no-output'])
    check('the key fragment runs: ' + r.stderr.strip()[:200], r.returncode == 0)

    slips = [
        (['--pressure-angle', '0.3491'], 'radians'),
        (['--density', '0.282'], 'weight density'),
        (['--face-width', '700'], 'face width'),
    ]
    for extra, phrase in slips:
        s = run(['gear', '--teeth', '28', '--diametral-pitch', '8', '--face-width', '0.7'] + extra)
        check(f'gear {" ".join(extra)}: exit 2 naming "{phrase}"', s.returncode == 2 and phrase in s.stderr)
    s = run(['gear', '--teeth', '28', '--units', 'si', '--module', '0.003', '--face-width', '0.02'])
    check('gear --module 0.003 (metres): exit 2 naming "metres"', s.returncode == 2 and 'metres' in s.stderr)
    s = run(['gear', '--teeth', '28', '--diametral-pitch', '8', '--face-width', 'O.7'])
    check('gear --face-width O.7: exit 2 naming the option', s.returncode == 2 and '--face-width' in s.stderr)
    s = run(['key', '--diameter', '25', '--key-length', '30', '--units', 'si'])
    check('key --diameter 25 (mm as m): exit 2', s.returncode == 2 and 'diameter' in s.stderr)

    # every numeric option at the edges of double precision and beyond (issue 20 item 11:
    # --points -5 gave 2 rows with exit 0, --points 1e9 did not end): exit 0 or 2 within
    # the timeout, no crash (the Debug build traps on overflow), out-of-range counts refused
    crash = ['Backtrace', 'runtime error', 'SIGFPE', 'SIGSEGV', 'Floating point exception', 'Error termination']
    gear_base = ['gear', '--teeth', '28', '40', '--diametral-pitch', '8', '--face-width', '0.7']
    key_base = ['key', '--diameter', '1.5', '--key-length', '2']
    extremes = ['1e300', '-1e300', '1e-300', '0', '-1', '1e999', '4.9e-324', 'nan', '2*3', 'abc']
    for base, opts in ((gear_base, ['--teeth', '--diametral-pitch', '--module', '--pressure-angle', '--face-width',
                                    '--backlash', '--youngs-modulus', '--density', '--stiffness-per-width',
                                    '--stiffness', '--frequency', '--approach-velocity']),
                       (key_base, ['--diameter', '--key-length', '--key-width', '--key-height', '--clearance',
                                   '--torque-max', '--points'])):
        bad = []
        for opt in opts:
            for v in extremes:
                args = list(base)
                if opt in args:
                    i = args.index(opt)
                    args[i + 1] = v
                    if opt == '--teeth':
                        args[i + 2] = v
                elif opt == '--module':   # instead of the diametral pitch
                    i = args.index('--diametral-pitch')
                    args[i:i + 2] = [opt, v]
                else:
                    args += [opt, v]
                try:
                    s = run(args, timeout=120)
                except subprocess.TimeoutExpired:
                    bad.append(f'{opt} {v}: no end within 120 s')
                    continue
                if s.returncode not in (0, 2) or any(c in s.stderr for c in crash):
                    bad.append(f'{opt} {v}: exit {s.returncode} {s.stderr[-200:]}')
        check(f'{base[0]}: {len(opts)} options x {len(extremes)} extreme values end with exit 0 or 2, no crash',
              not bad)
        for b in bad[:10]:
            print('      ', b)
    for v in ['-5', '1', '1000000000', '1e9', '2.5']:
        s = run(key_base + ['--points', v])
        check(f'key --points {v}: exit 2 naming the valid range [2, 1000]', s.returncode == 2 and '[2, 1000]' in s.stderr)
    for v in ['2', '1000']:
        s = run(key_base + ['--points', v])
        rows = [ln for ln in s.stdout.splitlines() if ln.strip() and ln.split()[0][0].isdigit()]
        check(f'key --points {v}: exit 0 with {v} rows', s.returncode == 0 and len(rows) == int(v))

finish()
