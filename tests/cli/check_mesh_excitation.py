#!/usr/bin/python3
"""The spur gear's mesh excitation (issue 26, D-100) through the command line.

- `trainsim gear DECK -o TABLE` of a tip-relieved pair (linear and parabolic): the
  unloaded static TE of every row against the hand geometry, written here independently:
  the pairs in contact at roll u are those with u - m in [0, m_p] for integer m, a pair at
  x = u - m is relieved by C_a (1 - s/L_a)^n with s = min(x, m_p - x) along the line of
  action, and the first pair to touch sets the TE (min over the pairs) -- to 1e-15 of C_a;
- the Fourier stiffness column: numpy's FFT of one tooth period gives back the mean k and
  the harmonics a_k/2 e^{i p_k} to 1e-12 (relative to k);
- with `stiffness_model = 'zones'` given, the Table 5.5 deck runs bit for bit as written
  (every dataset of the history file);
- a run of the rig with the Fourier stiffness and TE of the Kahraman-Singh form closes its
  ledger (the printed residual to 1e-10 of the printed scale);
- bad input: a tip relief longer than half the path of contact, a stiffness table that is
  not periodic, a negative harmonic amplitude, harmonics and phases of different lengths:
  exit 2 and a message naming file:line, the group and the key, no backtrace;
- `--plot OUT.png` writes the figure (when matplotlib is there).

usage: check_mesh_excitation.py TRAINSIM_EXE
"""
import math
import os
import re
import tempfile

import h5py
import numpy as np

from clicheck import check, EXE, failures, finish, run
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


HEAD = ("&run t_end = 1e-3, dt = 1e-6 /\n&node id = 'a', type = 'inertia', inertia = 1.0 /\n"
        "&node id = 'b', type = 'inertia', inertia = 1.0 /\n")
# 20 teeth on r_b = 1: base pitch 2 pi/20; m_p = 1.6
N, MP, PB = 20, 1.6, 2.0 * math.pi / 20
SPUR = ("&element id = 'mesh', type = 'spur_gear', stiffness = 1e6, rb_driver = 1.0, rb_driven = 2.0, "
        "teeth = 20, contact_ratio = 1.6, approach_angle = 0.0, half_backlash = 0.01,\n  ")


def table(tmp, name, keys):
    deck = os.path.join(tmp, name + '.nml')
    with open(deck, 'w') as f:
        f.write(HEAD + SPUR + keys + ' /\n')
    out = os.path.join(tmp, name + '.txt')
    p = run(['gear', deck, '-o', out, '--points', '200'])
    check(f'{name}: trainsim gear exits 0 ({p.stderr.strip()[:200]})', p.returncode == 0)
    return np.loadtxt(out, comments='#', ndmin=2) if p.returncode == 0 else None


def hand_unloaded_relief(u, ca, la, n):
    """min over the pairs in contact of C_a (1 - s/L_a)^n, s the distance from the path's nearer end."""
    best = math.inf
    for m in range(math.floor(u) - 2, math.floor(u) + 1):
        x = u - m
        if 0.0 <= x <= MP:
            s = min(x, MP - x)  # from the path's nearer end, in base pitches
            r = ca * max(0.0, 1.0 - s / la) ** n
            best = min(best, r)
    return best


def ledger_closes(tmp, name, text, tol):
    """Run deck `text`: exit 0 and the printed ledger residual <= tol x the printed scale."""
    deck = os.path.join(tmp, name + '.nml')
    open(deck, 'w').write(text)
    r = run(['run', deck, '-o', os.path.join(tmp, name + '.h5')])
    m = re.search(r'max \|residual\|\s+(\S+) \(energy scale\s+(\S+)', r.stdout)
    check(f'{name}: runs and prints its ledger', r.returncode == 0 and m is not None)
    if m:
        res, scale = float(m.group(1)), float(m.group(2))
        check(f'{name}: ledger closes, residual {res:.2e} of scale {scale:.3e} (<= {tol:g})', res <= tol * scale)
    return deck


with tempfile.TemporaryDirectory() as tmp:
    # tip relief, the unloaded TE against the hand geometry
    ca, la = 1.0e-3, 0.7
    for n, shape in [(1, 'linear'), (2, 'parabolic')]:
        d = table(tmp, 'relief_' + shape, f"tip_relief = {ca}, tip_relief_length = {la * PB!r}, "
                  f"tip_relief_shape = '{shape}'")
        if d is not None:
            # rows at the zone boundary u = m_p - 1 are skipped: either zone's answer is right there
            rows = [r for r in d if abs(r[0] % 1.0 - (MP - 1)) > 1e-9]
            err = max(abs(r[5] - hand_unloaded_relief(r[0], ca, la, n)) for r in rows)
            check(f'{shape} tip relief: unloaded static TE = hand geometry over {len(rows)} rows '
                  f'(max error {err:.2e} <= 1e-15 C_a)', err <= 1e-15 * ca + 1e-19)
            peak = ca * (1.0 - (MP - 1) / (2 * la)) ** n
            check(f'{shape}: the two-pair zone peaks at C_a (1 - (m_p - 1)/(2 L_a))^n = {peak:.6e} '
                  f'(table {d[:, 5].max():.6e})', abs(d[:, 5].max() - peak) < 1e-3 * ca)

    # Fourier stiffness: FFT of one period
    a, p = [0.2, 0.1, 0.05], [0.0, 1.0, -2.0]
    d = table(tmp, 'fourier', "stiffness_model = 'fourier', stiffness_harmonics = 0.2, 0.1, 0.05, "
              "stiffness_phases = 0.0, 1.0, -2.0")
    if d is not None:
        k = d[:, 2]
        f = np.fft.rfft(k) / len(k)
        err = abs(f[0].real - 1e6) / 1e6
        for h in range(1, 4):
            want = 0.5 * a[h - 1] * 1e6 * np.exp(1j * p[h - 1])
            err = max(err, abs(f[h] - want) / 1e6)
        err = max(err, np.abs(f[4:]).max() / 1e6)
        check(f'fourier: FFT of k(u) over a period = mean and harmonics (max error {err:.1e} <= 1e-12)',
              err <= 1e-12)

    # bit for bit with stiffness_model = 'zones' given
    src = open(os.path.join(ROOT, 'inputs', 'gregory_harris_munro.nml')).read()
    zones = src.replace("half_backlash = 0.005 /", "half_backlash = 0.005, stiffness_model = 'zones' /")
    check('the zones deck differs only by the key', zones != src)
    paths = []
    for name, text in [('ghm', src), ('ghm_zones', zones)]:
        deck = os.path.join(tmp, name + '.nml')
        open(deck, 'w').write(text)
        out = os.path.join(tmp, name + '.h5')
        r = run(['run', deck, '-o', out])
        check(f'{name} runs', r.returncode == 0)
        paths.append(out)

    def arrays(path):
        found = {}
        with h5py.File(path, 'r') as h:
            h.visititems(lambda n, o: found.__setitem__(n, o[()]) if isinstance(o, h5py.Dataset)
                         and o.dtype.kind in 'fiu' else None)
        return found

    if all(os.path.exists(x) for x in paths):
        x, y = arrays(paths[0]), arrays(paths[1])
        same = x.keys() == y.keys() and all(np.array_equal(x[n], y[n]) for n in x if n != 'run/statistics')
        check(f"stiffness_model = 'zones': every dataset bit for bit ({len(x)} datasets)", same)

    # the ledger of an excited run (Kahraman-Singh form on the rig)
    ks = src.replace("half_backlash = 0.005 /", "half_backlash = 0.005, stiffness_model = 'fourier', "
                     "stiffness_harmonics = 0.2, 0.1, 0.05, stiffness_phases = 0, 1, 2, "
                     "te_harmonics = 2e-4, 1e-4, 5e-5, te_phases = 0.5, 0, -1 /")
    ledger_closes(tmp, 'ks', ks, 1e-10)

    # the helical gear with a TE (harmonics and run-out): the ledger closes as without one
    # (RK4's own error: 1.1e-10 of the scale without the TE, 2.7e-10 with it, measured)
    src = open(os.path.join(ROOT, 'inputs', 'helical_pair.nml')).read()
    hel = src.replace("half_backlash = 0.002 /", "half_backlash = 0.002, te_harmonics = 2e-4, 5e-5, "
                      "te_phases = 0.3, 1.0, runout_driver = 1e-4, runout_driven = 5e-5 /")
    check('the helical deck takes the TE keys', hel != src)
    deck = ledger_closes(tmp, 'hel', hel, 1e-9)
    open(deck, 'w').write(hel.replace("te_phases = 0.3, 1.0,", "te_phases = 0.3,"))
    r = run(['run', deck, '-o', os.path.join(tmp, 'hel.h5')])
    check(f"helical: harmonics and phases of different lengths: exit 2, key 'te_phases' ({r.stderr.strip()[:120]})",
          r.returncode == 2 and "key 'te_phases'" in r.stderr)

    # bad input
    bad = {
        'tip_relief_length': "tip_relief = 1e-3, tip_relief_length = 0.3",
        'stiffness_factors': "stiffness_model = 'table', stiffness_roll = 0, 0.5, 1, stiffness_factors = 1.4, 1.0, 1.3",
        'stiffness_harmonics': "stiffness_model = 'fourier', stiffness_harmonics = 0.2, -0.1",
        'te_phases': "te_harmonics = 1e-4, 2e-4, te_phases = 0.0",
    }
    for key, keys in bad.items():
        deck = os.path.join(tmp, 'bad_' + key + '.nml')
        open(deck, 'w').write(HEAD + SPUR + keys + ' /\n')
        r = run(['run', deck, '-o', os.path.join(tmp, 'bad.h5')])
        msg = r.stderr.strip()
        check(f'bad {key}: exit 2, file:line, group, key ({msg[:160]})',
              r.returncode == 2 and f'bad_{key}.nml:5: &element' in msg and f"key '{key}'" in msg
              and 'Backtrace' not in msg)

    # the figure
    try:
        import matplotlib  # noqa: F401
        have_mpl = True
    except ImportError:
        have_mpl = False
    if have_mpl:
        deck = os.path.join(tmp, 'relief_linear.nml')
        png = os.path.join(tmp, 'mesh.png')
        r = run(['gear', deck, '--plot', png])
        check('gear --plot writes the figure', r.returncode == 0 and os.path.getsize(png) > 1000)

print(f'{len(failures)} failure(s)')
finish()
