#!/usr/bin/python3
"""Fuzz test: mutated decks must end cleanly.

Usage (as CTest runs it, cwd = repo root):

    /usr/bin/python3 tests/cli/fuzz_decks.py TRAINSIM [--count N] [--seed S]
        [--timeout SEC] [--jobs J] [--failures DIR] [--replay INDEX] [--show INDEX]

From a fixed seed, every deck INDEX (0 .. N-1) is made from one valid seed deck (the
bundled decks of inputs/, verification/ and tests/decks/, plus a few small decks below
that reach the keys the bundled ones do not use), shortened to at most 2000 steps and
without `output`, then given one to three mutations: a value's magnitude (x1e+-3,
x1e+-30, x1e+-300, 0, negative, nan, inf, huge integers), a value swapped for a string
or the reverse, a key deleted, duplicated, renamed (typo) or added (unknown, or valid
for another type), a group deleted or duplicated, `type =` (and the other choice keys)
changed to another valid or an invalid name, the syntax broken (a `/` dropped, an
unbalanced quote, a stray `&` or `=`, the text truncated), non-UTF-8 bytes or a NUL
inserted, the integrator changed among the valid ones.

Besides a plain run, a deck is tried in one of these ways (about a third of the decks):

* `--set`: one or two overrides `TARGET.KEY=VALUE` on the command line, TARGET a node or
  element id, `run`, or GROUP#K (also out of range), KEY a key of the group, a derived
  key (`mesh_frequency`, `settle_cycles`, `measure_cycles`) or a typo, VALUE a mutated
  magnitude or text;
* `sweep`: one or two `&sweep` groups (values, from/to/count with small and absurd counts,
  log scale, zip, continuation) over such paths, run as `trainsim sweep deck.nml -o sw.h5`;
* `table`: a `table_file` load whose file has 2 to 6 lines, each valid or mutated (a third
  column, trailing text, `/`, `,,`, `2*30`, `1e999`, `nan`, tabs, comments, blank lines,
  decreasing times, non-numbers);
* `long`: the run made 100 times longer than MAX_STEPS; after a wall budget (2 s) it is
  sent SIGINT and must end with status 130 within the timeout (or have ended by itself).

Deck INDEX depends only on the seed and INDEX (its own random generator), so a failure
is replayed with `--replay INDEX` (same seed), whatever N was.

Each deck is run as `trainsim run deck.nml -o out.h5` in its own temporary directory
with a timeout, and must:

* end within the timeout (else: a hang);
* exit 0, 1 or 2;
* on exit 1 or 2, print a message starting `trainsim:` on stderr (not a warning);
* print no sign of a crash (backtrace, runtime error, signal) on stdout or stderr;
* leave no `*.part` file; leave `out.h5` only on exit 0, and then one h5py can open;
* on exit 2, name where the bad input is in the first error line: `FILE:LINE:` of the
  deck or a table file, the `--set` argument, or the deck file for a whole-deck error.

Prints one line per failure, then
`fuzz: N decks, X exit 0, Y exit 1, Z exit 2, H hangs, B backtraces, L leftover files`
and exits 1 if any deck failed. Each failing deck is written to the --failures folder
(default: fuzz_failures/ in the current directory) as INDEX.nml with INDEX.txt (seed
deck, mutations, command, exit, stderr).

Mutations whose failure is known and left to another piece of work are listed in
EXPECTED_ELSEWHERE: they are run and reported ("expected elsewhere"), but do not fail
the test.
"""

import argparse
import glob
import math
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ThreadPoolExecutor

# Signs of a crash rather than a clean error report.
FORBIDDEN = [
    "Backtrace",
    "backtrace",
    "Error termination",
    "runtime error",
    "SIGSEGV",
    "SIGFPE",
    "SIGABRT",
    "SIGBUS",
    "Program received signal",
    "Floating point exception",
    "Segmentation fault",
]

MAX_STEPS = 2000

# Failures of these kinds are expected to be fixed by the input-robustness work on the
# deck reader, read_run and the HDF5 sink (other branch): (mutation-substring, reason).
# A failing deck whose mutation list contains one of the substrings is reported, not
# counted as a failure. Keep this list empty when that work has landed.
# An entry "stderr:TEXT" matches a failing deck whose stderr holds TEXT instead.
EXPECTED_ELSEWHERE = [
    ("&run output_interval:", "output_interval budget (reproducer B: a tiny interval overflows the sample "
                              "buffer size, SIGFPE in obs_start in Debug; Release hangs in the sample loop)"),
]

# Small valid decks that reach keys and types the bundled decks do not use.
EXTRA_SEEDS = {
    "extra:couplings_fixed_table.nml": """\
&run title = 'extra seed: fixed node, damper, couplings, table and sine loads', units = 'si',
     t_end = 0.02, dt = 1.0e-5, integrator = 'rk4', output_interval = 1.0e-4, settle_time = 0.001 /
&node id = 'ground', type = 'fixed' /
&node id = 'a', type = 'inertia', inertia = 1.0e-2, damping = 1.0e-3 /
&node id = 'b', type = 'inertia', inertia = 2.0e-2 /
&node id = 'c', type = 'inertia', inertia = 5.0e-2 /
&element id = 'spring', type = 'shaft', left = 'ground', right = 'a', stiffness = 1.0e3, damping = 0.1 /
&element id = 'cc', type = 'clearance_coupling', left = 'a', right = 'b', clearance = 0.01,
         stiffness = 5.0e3, contact_law = 'yang_sun', restitution_law = 'constant', restitution = 0.7,
         radius = 0.05, min_approach_velocity = 1.0e-3, initial_contact_velocity = 0.01 /
&element id = 'cl', type = 'clearance_coupling', left = 'b', right = 'c', clearance = 0.02,
         stiffness = 2.0e3, contact_law = 'linear', contact_damping = 0.5, no_tension = .true. /
&element id = 'dash', type = 'damper', left = 'a', right = 'c', damping = 0.2 /
&load node = 'a', kind = 'table', times = 0.0, 0.005, 0.01, 0.02, values = 0.0, 5.0, 5.0, -2.0 /
&load node = 'c', kind = 'sine', offset = -1.0, amplitude = 2.0, frequency = 50.0, phase = 0.3 /
&initial node = 'all', speed = 1.0 /
&initial node = 'b', angle = 0.005, speed = 2.0 /
&initial node = 'ground', angle = 0.1 /
""",
    "extra:motor_keyed_fit.nml": """\
&run title = 'extra seed: motor, keyed joint with a fit, smith restitution, ramp speed',
     t_end = 0.01, dt = 2.0e-6, integrator = 'rk4', track_energy = .true. /
&node id = 'm', type = 'dc_motor', inertia = 2.0e-3, damping = 1.0e-4, torque_constant = 0.5,
      back_emf_constant = 0.0565, inductance = 2.0e-3, resistance = 0.5 /
&node id = 'hub', type = 'inertia', inertia = 0.05 /
&node id = 'g', type = 'inertia', inertia = 0.05 /
&node id = 'load', type = 'n01', inertia = 1.0 /
&element id = 'key', type = 'keyed_joint', diameter = 1.0, half_clearance = 0.001, stiffness_fit = 'tight',
         key_length = 1.5, friction = 0.2, phi = 0.3, load_radius = 2.0, friction_velocity = 0.01 /
&element id = 'mesh', type = 'spur_gear', teeth_driver = 20, teeth_driven = 40, diametral_pitch = 8.0,
         pressure_angle = 20.0, face_width = 0.75, backlash = 0.004, restitution_law = 'smith',
         two_pair_factor = 2.0, zone_function = 'truncate' /
&element id = 'out', type = 'el1', stiffness = 2.0e4 /
&load node = 'm', quantity = 'voltage', kind = 'ramp', value0 = 0.0, value1 = 24.0, t0 = 0.0, t1 = 0.005 /
&load node = 'load', kind = 'step', value0 = 0.0, value1 = -10.0, t_step = 0.002 /
&initial node = 'm', current = 1.0, speed = 0.5 /
""",
    "extra:cvode_elasto_helical.nml": """\
&run title = 'extra seed: cvode with an elasto-backlash helical pair', t_end = 0.005, dt = 1.0e-5,
     integrator = 'cvode-bdf', rtol = 1.0e-7, atol_angle = 1.0e-10, atol_speed = 1.0e-8, max_step = 1.0e-5,
     event_tol = 1.0e-12, jacobian = 'analytic' /
&node id = 'drive', type = 'inertia', inertia = 1.0 /
&node id = 'pinion', type = 'inertia', inertia = 0.02 /
&node id = 'gear', type = 'inertia', inertia = 0.08 /
&element id = 'shaft', type = 'shaft', stiffness = 2.0e4 /
&element id = 'mesh', type = 'helical_gear', rb_driver = 1.4, rb_driven = 2.8, teeth = 24,
         profile_contact_ratio = 1.55, base_helix_angle = 18.0, face_width = 1.2, half_backlash = 0.002,
         approach_angle = 0.1, youngs_modulus = 3.0e7, contact_law = 'elasto_backlash', contact_damping = 5.0 /
&load node = 'drive', quantity = 'speed', kind = 'start_stop', value = 20.0, t_accel = 0.001,
      t_cruise = 0.001, t_decel = 0.001, t_dwell = 0.0005, t_start = 0.0002, cycles = 2 /
&load node = 'gear', value = -100.0 /
&initial node = 'all', speed = 0.0 /
""",
    "extra:ideal_gear_module.nml": """\
&run title = 'extra seed: SI ideal gear and module spur pair', units = 'si', t_end = 0.01, dt = 1.0e-6,
     integrator = 'rk4-thesis' /
&node id = 'a', type = 'inertia', inertia = 1.0e-3 /
&node id = 'b', type = 'inertia', inertia = 4.0e-3 /
&node id = 'c', type = 'inertia', inertia = 4.0e-3 /
&element id = 'ig', type = 'ideal_gear', stiffness = 1.0e8, rb_driver = 0.02, rb_driven = 0.04 /
&element id = 'sg', type = 'spur_gear', teeth_driver = 20, teeth_driven = 80, module = 2.0,
         pressure_angle = 20.0, face_width = 0.02, backlash = 1.0e-4, stiffness_per_width = 1.0e10 /
&load node = 'a', value = 1.0 /
""",
}

# Decks that the campaign once failed on (one per distinct cause), run before it with
# the outcome they must have now: (name, deck, exit, substrings of stderr).
_TWO = ("&run t_end = 0.01, dt = 1.0e-4 /\n"
        "&node id = 'a', type = 'inertia', inertia = 5.0 /\n"
        "&node id = 'b', type = 'inertia', inertia = 11.0 /\n")
REGRESSIONS = [
    # SIGFPE in inertia_derivatives (torque/J overflowed): a node parameter below 1e-20
    ("tiny inertia", "&run t_end = 0.01, dt = 1.0e-4 /\n&node id = 'a', type = 'inertia', inertia = 1.0e-300 /\n"
     "&node id = 'b', type = 'inertia', inertia = 11.0 /\n&element type = 'shaft', stiffness = 1.0e5 /\n",
     2, ["deck.nml:2:", "'inertia'", "1.0E-300", "out of range", "1.0E-20"]),
    # SIGFPE in shaft_torques, law_elastic_energy, ce_linearise: element parameters near 1e300
    ("huge shaft damping", _TWO + "&element type = 'shaft', stiffness = 1.0e5, damping = 1.0e300 /\n",
     2, ["deck.nml:4:", "'damping'", "out of range", "1.0E+20"]),
    ("huge gear base radius", _TWO + "&element type = 'ideal_gear', stiffness = 1.0e6, rb_driver = 1.0,\n"
     "  rb_driven = 3.7e300 /\n", 2, ["deck.nml:5:", "'rb_driven'", "out of range"]),
    # SIGFPE in contact_ratio (squares of the radii) before the teeth range was checked
    ("huge teeth_driven of a geometry spur gear", _TWO + "&element type = 'spur_gear', teeth_driver = 20,\n"
     "  teeth_driven = 8.0e301, module = 2.0, face_width = 0.02, backlash = 1.0e-4 /\n",
     2, ["deck.nml:5:", "'teeth_driven'", "teeth_driven must be in [1, "]),
    ("huge module of a geometry spur gear", _TWO + "&element type = 'spur_gear', teeth_driver = 20,\n"
     "  teeth_driven = 40, module = 1.0e300, face_width = 0.02, backlash = 1.0e-4 /\n",
     2, ["deck.nml:5:", "'module'", "out of range"]),
    # SIGFPE in inertia_dissipation (the state ran from 0 past 1e154 within one step)
    ("huge sine offset", _TWO + "&element type = 'shaft', stiffness = 1.0e5 /\n"
     "&load node = 'b', kind = 'sine', offset = -5.0e301, amplitude = 1.0, frequency = 10.0 /\n",
     2, ["deck.nml:5:", "'offset'", "out of range"]),
    ("huge table value", _TWO + "&element type = 'shaft', stiffness = 1.0e5 /\n"
     "&load node = 'b', kind = 'table', times = 0.0, 1.0, values = 0.0, 1.0e300 /\n",
     2, ["deck.nml:5:", "'times'", "table point 2", "out of range"]),
    ("huge initial angle", _TWO + "&element type = 'shaft', stiffness = 1.0e5 /\n"
     "&initial node = 'a', angle = 1.0e300 /\n", 2, ["deck.nml:5:", "'angle'", "out of range"]),
    ("huge initial motor current", "&run t_end = 0.01, dt = 1.0e-5 /\n&node id = 'm', type = 'dc_motor',"
     " inertia = 1.0e-3, torque_constant = 0.1,\n  inductance = 1.0e-3, resistance = 1.0, back_emf_constant = 0.1 /\n"
     "&initial node = 'm', current = 1.0e300 /\n", 2, ["deck.nml:4:", "'current'", "out of range"]),
    # 4*cycles + 1 knots overflowed the default integer
    ("start_stop cycles beyond the integer range of the knots", _TWO + "&element type = 'shaft', stiffness = 1.0e5 /\n"
     "&load node = 'b', kind = 'start_stop', value = 1.0, t_accel = 0.001, t_cruise = 0.0, t_decel = 0.001,\n"
     "  cycles = 2147483647 /\n", 2, ["deck.nml:6:", "'cycles'", "<= 1000000", "2147483647"]),
    # 'Fortran runtime error: End of record' writing a mode above 1e38 Hz with f0.1 into 40 characters;
    # since the plausibility checks (D-57) such a train (gear radii of 1e20) is refused first
    ("RK4 warning names a mode above 1e38 Hz", "&run t_end = 1.0e-3, dt = 1.0e-4 /\n"
     "&node id = 'a', type = 'inertia', inertia = 1.0e-20 /\n&node id = 'b', type = 'inertia', inertia = 1.0e-20 /\n"
     "&element type = 'ideal_gear', stiffness = 1.0e20, rb_driver = 1.0e20, rb_driven = 1.0e20 /\n"
     "&initial node = 'a', speed = 1.0 /\n", 2, ["deck.nml:4:", "key 'rb_driver'", "larger than any gear"]),
    # issue 20 item 11, found by the extended campaign (sweeps, --set, table files):
    # SIGFPE in strtod under the table file's list-directed READ (Debug)
    ("table file value 1e999", _TWO + "&element type = 'shaft', stiffness = 1.0e5 /\n"
     "&load node = 'b', kind = 'table', table_file = 'tab.txt' /\n", 2, ["deck.nml:5:", "tab.txt:2:", "out of range"],
     ["run", "deck.nml", "-o", "out.h5"], {"tab.txt": b"0.0 1.0\n0.005 1e999\n"}),
    # SIGFPE in strtod under the derived parameter's list-directed READ (Debug)
    ("--set of a derived parameter to 1e999", _TWO + "&node id = 'c', type = 'inertia', inertia = 1.0 /\n"
     "&element type = 'shaft', stiffness = 1.0e5 /\n&element id = 'g', type = 'ideal_gear', stiffness = 1.0e6,"
     " rb_driver = 1.0, rb_driven = 2.0 /\n&load node = 'a', value = 1.0 /\n", 2,
     ["--set g.mesh_frequency=1e999", "beyond the range"], ["run", "deck.nml", "-o", "out.h5", "--set",
                                                           "g.mesh_frequency=1e999"], {}),
    # SIGFPE in hot_torques: eq. (3.12)'s D divided by an initial_contact_velocity of 1e-32 (Debug)
    ("initial_contact_velocity below 1e-20", _TWO + "&element type = 'clearance_coupling', clearance = 0.01,"
     " stiffness = 5.0e3, contact_law = 'yang_sun', radius = 0.05, initial_contact_velocity = 1.0e-32 /\n"
     "&load node = 'a', value = 1.0 /\n", 2, ["deck.nml:4:", "'initial_contact_velocity'", "out of range"]),
]

INTEGRATORS = ["rk4", "rk4-thesis", "cvode-bdf", "cvode-adams", "arkode-dp", "arkode-verner", "euler"]

# Choice keys: the valid names (aliases included) and a few invalid ones.
CHOICES = {
    "type@node": ["inertia", "fixed", "dc_motor", "n01", "n02", "ground", "INERTIA"],
    "type@element": ["shaft", "keyed_joint", "ideal_gear", "spur_gear", "helical_gear",
                     "clearance_coupling", "damper", "el1", "el2", "el3", "el4", "Spur_Gear"],
    "integrator": INTEGRATORS + ["RK4", "CVODE-BDF"],
    "units": ["si", "in-lbf-s", "ips", "inch", "m-n-s", "SI"],
    "kind": ["constant", "step", "ramp", "sine", "table", "start_stop"],
    "quantity": ["torque", "speed", "voltage"],
    "contact_law": ["yang_sun", "linear", "elasto_backlash"],
    "restitution_law": ["goldsmith", "smith", "constant"],
    "zone_function": ["periodic", "truncate"],
    "stiffness_fit": ["constant", "tight", "loose", "average"],
    "jacobian": ["analytic", "difference_quotient"],
}
INVALID_NAMES = ["", "spring", "rk5", "x" * 300, "inertia inertia", "é", "'", "shaft,", "0"]

# Keys with sample values, added to groups as "valid elsewhere" keys.
KEY_POOL = {
    "run": ["t_start = 0.001", "output_interval = 1.0e-4", "rtol = 1.0e-6", "atol_angle = 1.0e-9",
            "atol_speed = 1.0e-6", "atol_current = 1.0e-6", "max_step = 1.0e-5", "event_tol = 1.0e-10",
            "settle_time = 0.001", "track_energy = .false.", "jacobian = 'difference_quotient'",
            "units = 'si'", "integrator = 'cvode-adams'", "title = 'x'"],
    "node": ["damping = 0.5", "inertia = 1.0", "torque_constant = 0.3", "inductance = 1.0e-3",
             "resistance = 0.5", "back_emf_constant = 0.3"],
    "element": ["damping = 1.0", "stiffness = 1.0e5", "contact_law = 'linear'", "contact_damping = 2.0",
                "restitution_law = 'constant'", "restitution = 0.5", "no_tension = .true.",
                "min_approach_velocity = 1.0e-3", "initial_contact_velocity = 0.1",
                "two_pair_factor = 2.0", "zone_function = 'truncate'", "friction = 0.5",
                "load_radius = 3.0", "phi = 0.3", "friction_angle = 0.5", "friction_velocity = 1.0e-3",
                "stiffness_fit = 'average'", "key_length = 1.0", "radius = 0.5", "youngs_modulus = 3.0e7",
                "stiffness_per_width = 1.0e7", "pressure_angle = 25.0", "approach_angle = 0.2",
                "module = 3.0", "diametral_pitch = 6.0", "clearance = 0.01", "half_backlash = 0.001",
                "left = 'n1'", "right = 'n2'"],
    "load": ["quantity = 'speed'", "quantity = 'voltage'", "kind = 'sine'", "amplitude = 5.0",
             "frequency = 10.0", "offset = 1.0", "phase = 0.5", "t_step = 0.001", "value1 = 3.0",
             "value0 = 1.0", "t0 = 0.0", "t1 = 0.001", "times = 0.0, 1.0", "values = 1.0, 2.0",
             "table_file = 'wind_load.txt'", "t_accel = 0.001", "t_cruise = 0.0", "t_decel = 0.001",
             "t_dwell = 0.001", "cycles = 3", "value = 10.0"],
    "initial": ["angle = 0.01", "speed = 5.0", "current = 2.0", "node = 'all'"],
}

NUMBER_RE = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eEdD][+-]?\d+)?$")

# ----------------------------------------------------------------------------- deck text


def tokenize(text):
    """Tokens of a deck: ('&', name), ('/',), ('=',), ('str', raw), ('word', raw).
    Comments and separators are dropped."""
    toks = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c in " \t\r\n,":
            i += 1
        elif c == "!":
            while i < n and text[i] != "\n":
                i += 1
        elif c in "'\"":
            j = i + 1
            while j < n:
                if text[j] == c:
                    if j + 1 < n and text[j + 1] == c:
                        j += 2
                        continue
                    break
                j += 1
            toks.append(("str", text[i:j + 1]))
            i = j + 1
        elif c == "&":
            j = i + 1
            while j < n and (text[j].isalnum() or text[j] == "_"):
                j += 1
            toks.append(("&", text[i + 1:j]))
            i = j
        elif c == "/":
            toks.append(("/",))
            i += 1
        elif c == "=":
            toks.append(("=",))
            i += 1
        else:
            j = i
            while j < n and text[j] not in " \t\r\n,=/!'\"&":
                j += 1
            toks.append(("word", text[i:j]))
            i = j
    return toks


def parse(text):
    """Groups of a valid deck: [[name, [[key, [value, ...]], ...]], ...]."""
    groups = []
    toks = tokenize(text)
    k = 0
    while k < len(toks):
        t = toks[k]
        assert t[0] == "&", t
        g = [t[1], []]
        k += 1
        while toks[k][0] != "/":
            if toks[k][0] == "word" and k + 1 < len(toks) and toks[k + 1][0] == "=":
                g[1].append([toks[k][1], []])
                k += 2
            else:
                g[1][-1][1].append(toks[k][1])
                k += 1
        groups.append(g)
        k += 1
    return groups


def render(groups):
    lines = []
    for name, entries in groups:
        body = ", ".join(f"{key} = {', '.join(vals)}" for key, vals in entries)
        lines.append(f"&{name} {body} /")
    return "\n".join(lines) + "\n"


def entry(g, key):
    for e in g[1]:
        if e[0].lower() == key:
            return e
    return None


def shorten(groups):
    """At most MAX_STEPS steps of dt, no output file."""
    run = next(g for g in groups if g[0] == "run")
    run[1] = [e for e in run[1] if e[0] != "output"]
    t_start = float(entry(run, "t_start")[1][0]) if entry(run, "t_start") else 0.0
    t_end = float(entry(run, "t_end")[1][0])
    dt = float(entry(run, "dt")[1][0])
    entry(run, "t_end")[1] = [repr(t_start + min(t_end - t_start, MAX_STEPS * dt))]
    return groups


def seed_decks():
    decks = []
    paths = sorted(glob.glob("inputs/*.nml") + glob.glob("verification/**/*.nml", recursive=True)
                   + glob.glob("tests/decks/*.nml"))
    for p in paths:
        with open(p) as f:
            decks.append((p, shorten(parse(f.read()))))
    for name, text in EXTRA_SEEDS.items():
        decks.append((name, shorten(parse(text))))
    return decks

# ----------------------------------------------------------------------------- mutations


def is_number(v):
    return bool(NUMBER_RE.match(v))


def typo(rng, key):
    k = list(key)
    op = rng.randrange(4)
    i = rng.randrange(len(k))
    if op == 0 and len(k) > 1:
        del k[i]
    elif op == 1 and len(k) > 1:
        j = min(i + 1, len(k) - 1)
        k[i], k[j] = k[j], k[i]
    elif op == 2:
        k.insert(i, rng.choice("abcxyz_1"))
    else:
        k[i] = rng.choice("qwxz")
    s = "".join(k)
    if not s or not s[0].isalpha():
        s = "x" + s
    return s if s != key else key + "x"


def new_magnitude(rng, v, soft):
    x = float(v.replace("d", "e").replace("D", "e"))
    if soft:
        op = rng.choice(["x1e3", "x1e-3", "x1e30", "x1e-30", "x1e300", "x1e-300", "x10", "x0.1"])
    else:
        op = rng.choice(["x1e3", "x1e-3", "x1e30", "x1e-30", "x1e300", "x1e-300", "zero", "neg", "nan", "inf",
                         "-inf", "hugeint", "int32", "1e309", "tiny", "-0.0"])
    if op.startswith("x"):
        f = float(op[1:])
        y = x * f if x != 0 else f
        s = repr(y)
        if s in ("inf", "-inf"):
            s = "1.0e308" if y > 0 else "-1.0e308"
        return op, s
    return op, {"zero": "0.0", "neg": repr(-x) if x != 0 else "-1.0", "nan": "nan", "inf": "inf", "-inf": "-inf",
                "hugeint": "99999999999999999999999", "int32": "2147483648", "1e309": "1.0e309",
                "tiny": "4.9e-324", "-0.0": "-0.0"}[op]


def group_kind(g):
    """Key into KEY_POOL / CHOICES for the group's `type`."""
    return g[0]


# Mutations that mostly keep a deck valid (so that it reaches the integrators), and all.
SOFT = ["magnitude"] * 4 + ["choice", "integrator", "integrator", "add_pool_key"]
HARD = ["magnitude"] * 6 + ["to_string", "to_number", "delete_key", "duplicate_key", "unknown_key",
                            "rename_key", "delete_group", "duplicate_group", "choice", "choice",
                            "invalid_choice", "integrator", "integrator", "add_pool_key", "add_pool_key",
                            "list_value", "empty_value"]


def mutate_structure(rng, groups, kinds):
    """One mutation of the group/entry structure; returns its description (or None)."""
    what = rng.choice(kinds)
    gi = rng.randrange(len(groups))
    g = groups[gi]
    where = f"group {gi} &{g[0]}"
    if what == "magnitude":
        cands = [(g2i, e) for g2i, g2 in enumerate(groups) for e in g2[1] if any(is_number(v) for v in e[1])]
        if not cands:
            return None
        g2i, e = rng.choice(cands)
        vi = rng.choice([i for i, v in enumerate(e[1]) if is_number(v)])
        op, s = new_magnitude(rng, e[1][vi], kinds is SOFT)
        old = e[1][vi]
        e[1][vi] = s
        return f"magnitude {op}: group {g2i} &{groups[g2i][0]} {e[0]}: {old} -> {s}"
    if what == "to_string":
        cands = [e for e in g[1] if e[1] and is_number(e[1][0])]
        if not cands:
            return None
        e = rng.choice(cands)
        old = e[1][0]
        e[1][0] = rng.choice([f"'{old}'", "abc", "'abc'", ".true.", "1.0.0", "5.0kg", "1e", "--1", "0x10"])
        return f"to_string: {where} {e[0]}: {old} -> {e[1][0]}"
    if what == "to_number":
        cands = [e for e in g[1] if e[1] and not is_number(e[1][0])]
        if not cands:
            return None
        e = rng.choice(cands)
        old = e[1][0]
        e[1][0] = rng.choice(["3.0", "0", "-1", "1e300"])
        return f"to_number: {where} {e[0]}: {old} -> {e[1][0]}"
    if what == "delete_key":
        if not g[1]:
            return None
        e = g[1].pop(rng.randrange(len(g[1])))
        return f"delete_key: {where} {e[0]}"
    if what == "duplicate_key":
        if not g[1]:
            return None
        e = rng.choice(g[1])
        g[1].append([e[0], list(e[1])])
        return f"duplicate_key: {where} {e[0]}"
    if what == "unknown_key":
        key = rng.choice(["foo", "Stiffness2", "x" * 80, "t_end_", "a1"])
        g[1].insert(rng.randrange(len(g[1]) + 1), [key, ["1.0"]])
        return f"unknown_key: {where} {key}"
    if what == "rename_key":
        if not g[1]:
            return None
        e = rng.choice(g[1])
        old = e[0]
        e[0] = typo(rng, old) if rng.random() < 0.8 else old.upper()
        return f"rename_key: {where} {old} -> {e[0]}"
    if what == "delete_group":
        groups.pop(gi)
        return f"delete_group: {where}"
    if what == "duplicate_group":
        groups.insert(rng.randrange(len(groups) + 1), [g[0], [[k, list(v)] for k, v in g[1]]])
        return f"duplicate_group: {where}"
    if what in ("choice", "invalid_choice", "integrator"):
        if what == "integrator":
            g = next((x for x in groups if x[0] == "run"), None)
            if g is None:
                return None
            key, pool = "integrator", INTEGRATORS
        else:
            cands = [e[0].lower() for e in g[1] if (e[0].lower() in CHOICES
                                                   or f"{e[0].lower()}@{g[0]}" in CHOICES)]
            if g[0] in ("load",):
                cands += ["kind", "quantity"]
            if g[0] == "element":
                cands += ["contact_law", "restitution_law"]
            if g[0] == "run":
                cands += ["integrator", "units"]
            if not cands:
                return None
            key = rng.choice(cands)
            pool = CHOICES.get(f"{key}@{g[0]}", CHOICES.get(key))
            if pool is None:
                return None
            if what == "invalid_choice":
                pool = INVALID_NAMES
        val = rng.choice(pool)
        e = entry(g, key)
        if e is None:
            g[1].append([key, [f"'{val}'"]])
        else:
            e[1] = [f"'{val}'"]
        return f"{what}: &{g[0]} {key} = '{val}'"
    if what == "add_pool_key":
        pool = KEY_POOL.get(g[0])
        if not pool:
            return None
        kv = rng.choice(pool)
        key, val = kv.split(" = ", 1)
        g[1].append([key, [v.strip() for v in val.split(",")]])
        return f"add_pool_key: {where} {kv}"
    if what == "list_value":
        cands = [e for e in g[1] if e[1]]
        if not cands:
            return None
        e = rng.choice(cands)
        e[1] = e[1] + e[1]
        return f"list_value: {where} {e[0]} = {', '.join(e[1])}"
    if what == "empty_value":
        if not g[1]:
            return None
        e = rng.choice(g[1])
        e[1] = []
        return f"empty_value: {where} {e[0]}"
    return None


def mutate_text(rng, data):
    """One mutation of the deck's bytes; returns (bytes, description)."""
    what = rng.choice(["drop_slash", "unbalanced_quote", "stray_amp", "stray_eq", "truncate", "non_utf8",
                       "nul", "crlf", "stray_slash", "bad_group", "long_line"])
    n = len(data)
    if what == "drop_slash":
        idx = [m.start() for m in re.finditer(rb"/ *\n", data)]
        if not idx:
            return data, None
        i = rng.choice(idx)
        return data[:i] + data[i + 1:], f"drop_slash at byte {i}"
    if what == "unbalanced_quote":
        idx = [m.start() for m in re.finditer(rb"'", data)]
        if not idx:
            return data, None
        i = rng.choice(idx)
        return data[:i] + data[i + 1:], f"unbalanced_quote at byte {i}"
    i = rng.randrange(n + 1)
    if what == "stray_amp":
        return data[:i] + b" & " + data[i:], f"stray_amp at byte {i}"
    if what == "stray_eq":
        return data[:i] + b" = " + data[i:], f"stray_eq at byte {i}"
    if what == "stray_slash":
        return data[:i] + b" / " + data[i:], f"stray_slash at byte {i}"
    if what == "bad_group":
        return data[:i] + b"\n&1x a = 1 /\n" + data[i:], f"bad_group at byte {i}"
    if what == "truncate":
        return data[:i], f"truncate at byte {i}"
    if what == "non_utf8":
        junk = rng.choice([b"\xff\xfe", b"\xc3", b"\xe9", b"\x80\x81\x82", b"\xed\xa0\x80"])
        return data[:i] + junk + data[i:], f"non_utf8 {junk!r} at byte {i}"
    if what == "nul":
        return data[:i] + b"\x00" + data[i:], f"nul at byte {i}"
    if what == "crlf":
        return data.replace(b"\n", b"\r\n"), "crlf"
    if what == "long_line":
        return data[:i] + b" " * 5000 + b"\n" + data[i:], f"long_line at byte {i}"
    return data, None


def recap(groups, muts):
    """A valid run made longer than MAX_STEPS steps by the mutations (t_end up, dt down)
    is a legitimately long run, not a hang: cut t_end back (the rejection of absurd step
    counts, > 1e12, is left to the deck)."""
    runs = [g for g in groups if g[0] == "run"]
    if len(runs) != 1:
        return
    keys = ("t_start", "t_end", "dt", "output_interval")
    try:
        get = {e[0]: float(e[1][0]) for e in runs[0][1] if e[0] in keys and len(e[1]) == 1}
        t0, t1, dt, oi = get.get("t_start", 0.0), get["t_end"], get["dt"], get.get("output_interval", 0.0)
    except (KeyError, ValueError):
        return
    if not (dt > 0 and t1 > t0 and math.isfinite(t1 - t0) and (t1 - t0) / dt <= 1e12):
        return
    if (t1 - t0) / dt > MAX_STEPS:
        t1 = t0 + MAX_STEPS * dt
        entry(runs[0], "t_end")[1] = [repr(t1)]
        muts.append(f"(t_end cut to {MAX_STEPS} steps)")
    # output times below dt are steps too (as many as 10 MAX_STEPS)
    if 0 < oi and 10 * MAX_STEPS < (t1 - t0) / oi <= 1e12:
        entry(runs[0], "t_end")[1] = [repr(t0 + max(dt, 10 * MAX_STEPS * oi))]
        muts.append(f"(t_end cut to {10 * MAX_STEPS} output times)")
    # settling until periodic runs on past t_end up to its budget (settle_max_time,
    # by default 1000 settle periods): a small dt makes that a long run, not a hang
    try:
        tol = float(entry(runs[0], "settle_tol")[1][0]) if entry(runs[0], "settle_tol") else 0.0
        ts = float(entry(runs[0], "settle_time")[1][0]) if entry(runs[0], "settle_time") else 0.0
        tmax = float(entry(runs[0], "settle_max_time")[1][0]) if entry(runs[0], "settle_max_time") else 0.0
    except (ValueError, IndexError):
        return
    budget = max(ts, MAX_STEPS * dt)
    if 0 < tol < 1 and 0 <= ts and (tmax == 0 or tmax > budget):
        if entry(runs[0], "settle_max_time"):
            entry(runs[0], "settle_max_time")[1] = [repr(budget)]
        else:
            runs[0][1].append(["settle_max_time", [repr(budget)]])
        muts.append(f"(settling budget cut to {MAX_STEPS} steps)")


DERIVED = ["mesh_frequency", "settle_cycles", "measure_cycles"]


def group_targets(groups):
    """Targets of a deck's groups for --set and &sweep: (target, group)."""
    out = [("run", g) for g in groups if g[0] == "run"]
    count = {}
    for g in groups:
        if g[0] == "sweep":
            continue
        count[g[0]] = count.get(g[0], 0) + 1
        out.append((f"{g[0]}#{count[g[0]]}", g))
        if g[0] in ("node", "element"):
            e = entry(g, "id")
            gid = e[1][0].strip("'\"") if e and e[1] else f"{g[0][0]}{count[g[0]]}"
            out.append((gid, g))
    return out


def random_path(rng, groups):
    """A parameter path TARGET.KEY, mostly valid, sometimes not."""
    targets = group_targets(groups)
    r = rng.random()
    if not targets or r < 0.05:
        return rng.choice(["nosuch.stiffness", "load#99.value", "node#0.inertia", "run.", ".x", "run",
                           "mesh.half backlash", "load#x.value"])
    tgt, g = rng.choice(targets)
    keys = [e[0] for e in g[1] if e[0] not in ("id", "type", "node", "left", "right")]
    if g[0] == "element" and rng.random() < 0.4:
        key = rng.choice(DERIVED)
    elif keys and rng.random() < 0.8:
        key = rng.choice(keys)
    else:
        key = typo(rng, rng.choice(keys)) if keys and rng.random() < 0.5 else \
            rng.choice(KEY_POOL.get(g[0], ["x = 1"])).split(" = ")[0]
    return f"{tgt}.{key}"


def random_value(rng, path, groups, soft):
    """A value for `path`: the current value mutated, a derived-key value, or text."""
    key = path.rsplit(".", 1)[-1]
    if key in DERIVED:
        return rng.choice(["485", "2", "100", "0", "-5", "1e300", "1e-300", "1e19", "1e30", "abc", "nan", "1e999",
                           "2147483648"])
    for tgt, g in group_targets(groups):
        if path.startswith(tgt + "."):
            e = entry(g, key)
            if e and e[1] and is_number(e[1][0]):
                if g[0] == "run" and key.lower() in ("t_end", "dt", "output_interval", "t_start", "settle_time"):
                    # a legitimately long run is not a hang: only halve, double or make absurd
                    x = float(e[1][0].replace("d", "e").replace("D", "e"))
                    return rng.choice([repr(x * 0.5), repr(x * 2.0), "0", "-1.0", "1e300", "1e-300", "nan"])
                return new_magnitude(rng, e[1][0], soft)[1]
            if e and e[1]:
                return e[1][0]
    return rng.choice(["1.0", "0", "-1", "'x'", "1e300", "abc"])


TABLE_LINES_BAD = ["0.20 /", "0.20,,", "0.20 30.0 lbf*in", "0.20 30.0 7.0", "0.20 2*30.0", "0.20 1e999",
                   "0.20 nan", "0.20 -inf", "1e309 1", "abc def", "0.20", "0.20 30 # note", "0.20\t\t30.0,",
                   ",0.2 3", "0.2;3", "0.20 1.0d5", "0x10 3"]
TABLE_LINES_OK = ["# time torque", "", "\t", "   ", "! comment", "0.20\t30.0", "0.20, 30.0", "0.20 ,30.0"]


def make_table(rng):
    """Text of a table file: 2 to 6 rows, increasing times, some lines mutated."""
    lines, t = [], 0.0
    for _ in range(rng.randint(2, 6)):
        r = rng.random()
        if r < 0.15:
            lines.append(rng.choice(TABLE_LINES_BAD))
        elif r < 0.3:
            lines.append(rng.choice(TABLE_LINES_OK))
        else:
            t += rng.choice([0.001, 0.002, -0.003, 0.0, 1e-30])
            lines.append(f"{t!r} {rng.choice(['1.0', '-5.0', '30', '1e25', '0', '2.5e-21', '-1e3'])}")
    return ("\n".join(lines) + rng.choice(["\n", "", "\r\n"])).encode()


def add_variant(rng, groups, muts, soft):
    """Give the deck a way in other than a plain run: (args, files) (see the docstring)."""
    r = rng.random()
    if r < 0.12:
        sets = []
        for _ in range(rng.choice([1, 1, 2])):
            path = random_path(rng, groups)
            sets += ["--set", f"{path}={random_value(rng, path, groups, soft)}"]
        muts.append("set: " + " ".join(sets[1::2]))
        return ["run", "deck.nml", "-o", "out.h5"] + sets, {}
    if r < 0.22:
        for _ in range(rng.choice([1, 1, 2])):
            path = random_path(rng, groups)
            form = rng.random()
            if form < 0.5:
                vals = ", ".join(random_value(rng, path, groups, True) for _ in range(rng.randint(1, 3)))
                body = f"parameter = '{path}', values = {vals}"
            else:
                a = random_value(rng, path, groups, True)
                b = random_value(rng, path, groups, True)
                body = (f"parameter = '{path}', from = {a}, to = {b}, count = "
                        f"{rng.choice(['1', '2', '3', '0', '-1', '1000000000', '3.5'])}")
                if rng.random() < 0.2:
                    body += ", scale = 'log'"
            if rng.random() < 0.15:
                body += ", mode = 'zip'"
            if rng.random() < 0.15:
                body += f", continuation = '{rng.choice(['up', 'down', 'both', 'sideways'])}'"
            groups.append(["sweep", [[k.strip(), [v.strip()]] for k, v in
                                     (kv.split("=", 1) for kv in re.split(r",\s(?=\w+ =)", body))]])
            muts.append(f"sweep: &sweep {body} /")
        return ["sweep", "deck.nml", "-o", "sw.h5"], {}
    if r < 0.30:
        nodes = [g for g in groups if g[0] == "node"]
        if nodes:
            k = rng.randrange(len(nodes))
            g = nodes[k]
            e = entry(g, "id")
            nid = e[1][0] if e and e[1] else f"'n{k + 1}'"
            groups.append(["load", [["node", [nid]], ["kind", ["'table'"]], ["table_file", ["'tab.txt'"]]]])
            data = make_table(rng)
            muts.append(f"table: node {nid}, tab.txt = {data!r}")
            return ["run", "deck.nml", "-o", "out.h5"], {"tab.txt": data}
    if r < 0.33:
        runs = [g for g in groups if g[0] == "run"]
        if runs and entry(runs[0], "t_end") and entry(runs[0], "dt"):
            try:
                t0 = float(entry(runs[0], "t_start")[1][0]) if entry(runs[0], "t_start") else 0.0
                dt = float(entry(runs[0], "dt")[1][0])
            except ValueError:
                return ["run", "deck.nml", "-o", "out.h5"], {}
            entry(runs[0], "t_end")[1] = [repr(t0 + 100 * MAX_STEPS * dt)]
            muts.append(f"long: t_end = t_start + {100 * MAX_STEPS} dt, SIGINT after {LONG_BUDGET} s")
            return ["run", "deck.nml", "-o", "out.h5", "long"], {}
    return ["run", "deck.nml", "-o", "out.h5"], {}


LONG_BUDGET = 2.0


def make_deck(seed, index, seeds):
    """Deck `index` of the campaign `seed`: (bytes, seed deck name, [mutations], args, files)."""
    rng = random.Random(seed * 1_000_003 + index)
    name, groups = seeds[rng.randrange(len(seeds))]
    groups = [[g[0], [[k, list(v)] for k, v in g[1]]] for g in groups]
    muts = []
    soft = rng.random() < 0.5
    n_mut = rng.choice([1, 1, 1, 2, 2, 3])
    text_mut = not soft and rng.random() < 0.25
    for _ in range(n_mut - (1 if text_mut else 0)):
        for _attempt in range(10):
            d = mutate_structure(rng, groups, SOFT if soft else HARD)
            if d:
                muts.append(d)
                break
    recap(groups, muts)
    args, files = add_variant(rng, groups, muts, soft)
    data = render(groups).encode()
    if text_mut:
        for _attempt in range(10):
            data2, d = mutate_text(rng, data)
            if d:
                data = data2
                muts.append(d)
                break
    return data, name, muts, args, files

# ----------------------------------------------------------------------------- running


def run_one(exe, seed, index, seeds, timeout):
    data, name, muts, args, files = make_deck(seed, index, seeds)
    res = run_deck(exe, data, timeout, args, files)
    res.update(index=index, seed_deck=name, muts=muts)
    return res


# Where a refusal (exit 2) names the bad input: a deck or table file line, a --set
# argument, the library's set, or the deck file itself (a whole-deck error).
LOCATED = re.compile(r"^trainsim: (\S+:-?\d+:|--set |\S+\.nml: error:|sweep file )")


def run_deck(exe, data, timeout, args=None, files=None):
    """Run one deck (bytes) in a fresh directory; the outcome and the problems found."""
    args = args or ["run", "deck.nml", "-o", "out.h5"]
    long_run = args[-1] == "long"
    if long_run:
        args = args[:-1]
    tmp = tempfile.mkdtemp(prefix="trainsim_fuzz_")
    try:
        with open(os.path.join(tmp, "deck.nml"), "wb") as f:
            f.write(data)
        shutil.copy("inputs/wind_load.txt", tmp)
        for fname, content in (files or {}).items():
            with open(os.path.join(tmp, fname), "wb") as f:
                f.write(content)
        t0 = time.monotonic()
        cmd = [exe] + args
        interrupted = False
        p = subprocess.Popen(cmd, cwd=tmp, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        try:
            if long_run:
                try:
                    o, e = p.communicate(timeout=LONG_BUDGET)
                except subprocess.TimeoutExpired:
                    p.send_signal(signal.SIGINT)
                    interrupted = True
                    o, e = p.communicate(timeout=timeout)
            else:
                o, e = p.communicate(timeout=timeout)
            code, out, err = p.returncode, o.decode(errors="replace"), e.decode(errors="replace")
        except subprocess.TimeoutExpired:
            p.kill()
            o, e = p.communicate()
            code = None
            out = (o or b"").decode(errors="replace")
            err = (e or b"").decode(errors="replace")
        elapsed = time.monotonic() - t0
        problems = []
        kind = None
        if code is None:
            problems.append(f"hang: no exit within {timeout} s")
            kind = "hang"
        else:
            if code not in (0, 1, 2) and not (interrupted and code == 130):
                problems.append(f"exit status {code}" + (" after SIGINT" if interrupted else ""))
                kind = "crash"
            sweep_failed_runs = args[0] == "sweep" and code == 1 and "failed" in out   # recorded in the file
            if code in (1, 2) and not sweep_failed_runs and not any(
                    ln.startswith("trainsim:") and not ln.startswith("trainsim: warning") for ln in err.splitlines()):
                problems.append(f"exit {code} without a 'trainsim:' message on stderr")
                kind = kind or "message"
            bad = [s for s in FORBIDDEN if s in err or s in out]
            if bad:
                problems.append("crash signs: " + ", ".join(bad))
                kind = "backtrace"
            if code == 2:
                first = next((ln for ln in err.splitlines() if ln.startswith("trainsim:")
                              and not ln.startswith(("trainsim: warning", "trainsim: note"))
                              and ": warning: " not in ln), "")
                if first and not LOCATED.match(first):
                    problems.append("refusal names no line, --set argument or table line: " + first[:200])
                    kind = kind or "unlocated"
            left = [q for q in os.listdir(tmp) if q.endswith(".part")]
            # an interrupted run may keep its history so far (marked incomplete)
            if code not in (0, 130) and os.path.exists(os.path.join(tmp, "out.h5")):
                left.append("out.h5")
            if left:
                problems.append("left behind: " + ", ".join(left))
                kind = kind or "leftover"
            if code == 0 and args[0] == "run":
                h5 = os.path.join(tmp, "out.h5")
                if not os.path.exists(h5):
                    problems.append("exit 0 without out.h5")
                    kind = kind or "output"
                else:
                    c = subprocess.run(["/usr/bin/python3", "-c", "import h5py,sys; h5py.File(sys.argv[1],'r').keys()",
                                        h5], capture_output=True, text=True)
                    if c.returncode != 0:
                        problems.append("out.h5 unreadable: " + c.stderr.strip()[-200:])
                        kind = kind or "output"
        return dict(data=data, code=code, stdout=out, stderr=err, problems=problems, kind=kind, elapsed=elapsed,
                    cmd=" ".join(args), files=files or {})
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def expected_elsewhere(res):
    for sub, why in EXPECTED_ELSEWHERE:
        if sub.startswith("stderr:"):
            if sub[7:] in res["stderr"]:
                return why
        elif any(sub in m for m in res["muts"]):
            return why
    return None


def write_failure(folder, res, seed):
    os.makedirs(folder, exist_ok=True)
    base = os.path.join(folder, f"{res['index']:05d}")
    with open(base + ".nml", "wb") as f:
        f.write(res["data"])
    for fname, content in res.get("files", {}).items():
        with open(base + "." + fname, "wb") as f:
            f.write(content)
    with open(base + ".txt", "w") as f:
        f.write(f"seed {seed}, index {res['index']} (replay: fuzz_decks.py TRAINSIM --seed {seed} "
                f"--replay {res['index']})\nseed deck: {res['seed_deck']}\nmutations:\n")
        for m in res["muts"]:
            f.write(f"  {m}\n")
        f.write(f"command: {res['cmd']}\nexit: {res['code']}\nproblems: {'; '.join(res['problems'])}\n"
                f"--- stderr (tail)\n{res['stderr'][-4000:]}\n--- stdout (tail)\n{res['stdout'][-2000:]}\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("exe")
    ap.add_argument("--count", type=int, default=300)
    ap.add_argument("--seed", type=int, default=20240611)
    ap.add_argument("--timeout", type=float, default=20.0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--failures", default="fuzz_failures")
    ap.add_argument("--replay", type=int, help="run deck INDEX only and print everything about it")
    ap.add_argument("--show", type=int, help="print deck INDEX and its mutations, do not run it")
    a = ap.parse_args()
    exe = os.path.abspath(a.exe)
    seeds = seed_decks()

    if a.show is not None:
        data, name, muts, args, files = make_deck(a.seed, a.show, seeds)
        print(f"seed deck: {name}\nmutations: {muts}\ncommand: trainsim {' '.join(args)}\nfiles: {files}")
        sys.stdout.write(data.decode(errors="replace"))
        return 0
    if a.replay is not None:
        res = run_one(exe, a.seed, a.replay, seeds, a.timeout)
        print(f"seed deck: {res['seed_deck']}\nmutations: {res['muts']}\n--- deck")
        sys.stdout.write(res["data"].decode(errors="replace"))
        print(f"--- exit {res['code']} in {res['elapsed']:.1f} s\n--- stderr\n{res['stderr']}--- stdout (tail)\n"
              f"{res['stdout'][-1500:]}")
        print("problems: " + ("; ".join(res["problems"]) or "none"))
        return 1 if res["problems"] else 0

    t0 = time.monotonic()
    failed = 0
    for name, deck, code, subs, *how in REGRESSIONS:
        res = run_deck(exe, deck.encode(), a.timeout, *how)
        problems = list(res["problems"])
        if res["code"] != code:
            problems.append(f"exit {res['code']}, expected {code}")
        problems += [f"stderr lacks {sub!r}" for sub in subs if sub not in res["stderr"]]
        if problems:
            failed += 1
            print(f"FAIL regression '{name}': {'; '.join(problems)}\n    " +
                  "\n    ".join(res["stderr"].strip().splitlines()[-3:]))
    print(f"regressions: {len(REGRESSIONS)} decks, {failed} failed")
    with ThreadPoolExecutor(max_workers=a.jobs) as pool:
        results = list(pool.map(lambda i: run_one(exe, a.seed, i, seeds, a.timeout), range(a.count)))
    exits = {0: 0, 1: 0, 2: 0}
    tally = dict(hang=0, backtrace=0, leftover=0, unlocated=0)
    elsewhere = 0
    shutil.rmtree(a.failures, ignore_errors=True)
    for res in results:
        if res["code"] in exits:
            exits[res["code"]] += 1
        if not res["problems"]:
            continue
        why = expected_elsewhere(res)
        tag = "expected elsewhere" if why else "FAIL"
        if why:
            elsewhere += 1
        else:
            failed += 1
            if res["kind"] in tally:
                tally[res["kind"]] += 1
        write_failure(a.failures, res, a.seed)
        print(f"{tag} deck {res['index']} ({res['seed_deck']}; {' | '.join(res['muts'])}): "
              f"{'; '.join(res['problems'])}" + (f" [{why}]" if why else ""))
        last = [ln for ln in res["stderr"].splitlines() if ln.strip()][-3:]
        for ln in last:
            print(f"    {ln[:300]}")
    if results:
        slow = max(results, key=lambda r: r["elapsed"])
        print(f"slowest: deck {slow['index']} {slow['elapsed']:.1f} s; total {time.monotonic() - t0:.1f} s")
    print(f"fuzz: {len(results)} decks, {exits[0]} exit 0, {exits[1]} exit 1, {exits[2]} exit 2, "
          f"{tally['hang']} hangs, {tally['backtrace']} backtraces, {tally['leftover']} leftover files, "
          f"{tally['unlocated']} unlocated refusals"
          + (f", {failed} failed" if failed else "")
          + (f", {elsewhere} expected elsewhere" if elsewhere else ""))
    if failed or elsewhere:
        print(f"failing decks written to {os.path.abspath(a.failures)}/")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
