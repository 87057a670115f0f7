#!/usr/bin/python3
"""Bad decks and command-line misuse must fail cleanly.

Usage (as CTest runs it, cwd = repo root):

    /usr/bin/python3 tests/cli/run_bad_decks.py <path to trainsim>

Every case writes its deck to a fresh temporary directory as ``deck.nml``, runs
``trainsim run deck.nml -o <tmp>/out.h5`` there (or the command line the case gives)
and checks:

* the exit status (2 for input and file errors, 1 for a run that fails numerically);
* that stderr holds every expected substring (file name, ``deck.nml:<line>:``, the
  offending key/value/group, what was expected);
* that stderr holds none of the signs of a crash (backtrace, runtime error, signal);
* that no output file was left behind (neither out.h5 nor any ``*.part`` file).

One line per case (ok/FAIL), then ``N passed, M failed``; exit status 1 if M > 0.
"""

import os
import re
import subprocess
import sys
import tempfile

# Signs of a crash rather than a clean error report.
FORBIDDEN = [
    "Backtrace",
    "Error termination",
    "Fortran runtime error",
    "SIGSEGV",
    "SIGFPE",
    "Program received signal",
]

TIMEOUT = 120  # seconds per case; a hang is a failure

# A small valid train: two disks on one shaft. Line numbers: 1 &run, 2-3 &node, 4 &element.
RUN = "&run t_end = 0.01, dt = 1.0e-4 /\n"
NODES = (
    "&node id = 'a', type = 'inertia', inertia = 5.0 /\n"
    "&node id = 'b', type = 'inertia', inertia = 11.0 /\n"
)
SHAFT = "&element id = 's1', type = 'shaft', stiffness = 1.0e5 /\n"
GOOD = RUN + NODES + SHAFT
# A DC motor on lines 2-3 (for the &controller cases).
MOTOR = ("&node id = 'm', type = 'dc_motor', inertia = 0.1, torque_constant = 0.5,\n"
         "      inductance = 0.01, resistance = 1.0, back_emf_constant = 0.5 /\n")
# A housing node (line 4) and a gear pair on it (line 5, its carrier given by the case).
HOUSING = "&node id = 'h', type = 'inertia', inertia = 2.0 /\n"
GEAR = ("&element id = 'g', type = 'ideal_gear', left = 'a', right = 'b', carrier = '{carrier}', "
        "stiffness = 1.0e5, rb_driver = 1.0, rb_driven = 2.0 /\n")

# A planetary stage (line 2; planets and teeth on line 3), spur meshes, ring held.
PLANETARY = ("&planetary id = 'ps', module = 2.0, face_width = 0.5,\n"
             "  planets = {n}, teeth_sun = {zs}, teeth_planet = {zp}, teeth_ring = {zr},\n"
             "  sun_inertia = 0.01, carrier_inertia = 0.2, planet_inertia = 0.003,\n"
             "  held = 'ring' /\n")

# Three disks of verification/table5_1 (19.68 and 32.25 Hz modes).
TABLE5_1 = (
    "&run title = 'unstable', t_end = {t_end}, dt = {dt}, integrator = 'rk4' /\n"
    "&node id = 'n1', type = 'inertia', inertia = 5.0 /\n"
    "&node id = 'n2', type = 'inertia', inertia = 11.0 /\n"
    "&node id = 'n3', type = 'inertia', inertia = 22.0 /\n"
    "&element id = 'e1', type = 'shaft', stiffness = 100000.0 /\n"
    "&element id = 'e2', type = 'shaft', stiffness = 200000.0 /\n"
    "&initial node = 'n1', angle = 0.1000 /\n"
    "&initial node = 'n2', angle = 0.02353 /\n"
    "&initial node = 'n3', angle = -0.03449 /\n"
)


# A helical pair's deck up to the keys of its last line (line 6: a case adds them and " /\n").
HELICAL = (RUN + NODES + "&element id = 'h', type = 'helical_gear', rb_driver = 1.6, rb_driven = 1.6, teeth = 28,\n"
           "         profile_contact_ratio = 1.6, base_helix_angle = 20, face_width = 1.0,\n         ")
# A spur_gear in the geometry form; {units} goes into &run, {k1} on line 5, {k2} on line 6.
GEOM = ("&run t_end = 0.01, dt = 1.0e-6{units} /\n" + NODES +
        "&element id = 'mesh', type = 'spur_gear', diametral_pitch = 8.0,\n"
        "         {k1}, face_width = 0.7,\n"
        "         {k2} /\n")


def load(text):
    """GOOD plus a &load group (line 5)."""
    return GOOD + "&load " + text + " /\n"


# Each case: name, deck (text; None for CLI cases), args (command line after the
# executable; '{out}' is replaced by the output path; default run deck.nml -o {out}),
# exit (expected status), stderr (substrings that must appear), optional stdout
# (substrings that must appear on stdout), optional output (True: out.h5 must exist).
# F_event_flood.nml of ../shared/repro: a stiff mesh whose zone guard chatters at t = 0
FLOOD = """&run t_end = 2.0e-4, dt = 5.0e-7, integrator = '{integrator}' /
&node id = 'a', type = 'inertia', inertia = 7.537e-3 /
&node id = 'b', type = 'inertia', inertia = 10.082 /
&element id = 'mesh', type = 'spur_gear', stiffness = 18.03e6, rb_driver = 1.6445, rb_driven = 1.6445,
         teeth = 28, contact_ratio = 1.638, approach_angle = 0.1838, half_backlash = 0.001 /
&initial node = 'all', speed = 1e9 /
"""

CASES = [
    # ---- sanity: the base deck is good, so the failures below are the edits' doing
    dict(name="baseline good deck runs", deck=GOOD, exit=0, stderr=[], output=True),
    # a load step at 100.1 s one ulp before the output time 99.9 + 2 x 0.1 = 100.10000000000001
    # s, with 1e-9 dt below one ulp of t: was "internal: ... left the state", exit 2
    # a DC motor held by a brake at standstill: the constraint solve asked the motor's own
    # derivatives in a buffer lent to the RHS (segmentation fault before the first step).
    # 1 V / 0.5 ohm = 2 A after 12.5 L/R, k_t 2 A = 1 N m < 2 N m static: held, speed exactly 0.
    dict(name="a DC motor held by a brake at standstill runs (was SIGSEGV); held at speed 0, 2 A",
         deck="&run t_end = 0.05, dt = 1.0e-5, units = 'si' /\n"
              "&node id = 'motor', type = 'dc_motor', inertia = 2.0e-3, damping = 1.0e-4, torque_constant = 0.5,\n"
              "      back_emf_constant = 0.5, inductance = 2.0e-3, resistance = 0.5 /\n"
              "&node id = 'ground', type = 'fixed' /\n"
              "&element id = 'brake', type = 'brake', left = 'motor', right = 'ground', torque_sliding = 1.6,\n"
              "         torque_static = 2.0 /\n"
              "&load node = 'motor', quantity = 'voltage', kind = 'constant', value = 1.0 /\n",
         exit=0, stderr=[], stdout=["motor   0.000000000E+00   0.000000000E+00   1.99"], output=True),
    dict(name="a breakpoint one ulp before an output time is that instant (long run, small dt)",
         deck="&run t_start = 99.9, t_end = 100.2, dt = 1.0e-5, output_interval = 0.1 /\n" + NODES + SHAFT +
              "&load node = 'b', kind = 'step', value0 = 0.0, value1 = 1.0, t_step = 100.1 /\n",
         exit=0, stderr=[], output=True),
    dict(name="&initial node='all' is accepted", deck=GOOD + "&initial node = 'all', speed = 10.0 /\n",
         exit=0, stderr=[], output=True),

    # ---- unknown names
    dict(name="unknown key in &node",
         deck=RUN + "&node id = 'a', type = 'inertia', inertia = 5.0,\n      diameter = 3.0 /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:3:", "unknown key 'diameter'", "inertia", "valid keys are"]),
    dict(name="unknown key in &run",
         deck="&run t_end = 0.01, dt = 1.0e-4, tend = 3.0 /\n" + NODES + SHAFT,
         exit=2, stderr=["deck.nml:1:", "unknown key 'tend'", "t_end", "valid keys are"]),
    dict(name="unknown group name",
         deck=RUN + NODES + SHAFT + "&nodes id = 'c', type = 'inertia', inertia = 1.0 /\n",
         exit=2, stderr=["deck.nml:5:", "unknown group '&nodes'", "valid groups are", "node"]),
    dict(name="unknown node type",
         deck=RUN + "&node id = 'a', type = 'disk', inertia = 5.0 /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:2:", "unknown node type 'disk'", "valid node types are", "inertia"]),
    dict(name="unknown element type",
         deck=RUN + NODES + "&element id = 's1', type = 'spring', stiffness = 1.0e5 /\n",
         exit=2, stderr=["deck.nml:4:", "unknown element type 'spring'", "valid element types are", "shaft"]),
    dict(name="unknown integrator",
         deck="&run t_end = 0.01, dt = 1.0e-4, integrator = 'leapfrog' /\n" + NODES + SHAFT,
         exit=2, stderr=["deck.nml:1:", "unknown integrator 'leapfrog'", "valid integrators are", "rk4"]),
    dict(name="unknown unit system",
         deck="&run t_end = 0.01, dt = 1.0e-4, units = 'cgs' /\n" + NODES + SHAFT,
         exit=2, stderr=["deck.nml:1:", "unknown unit system 'cgs'", "si"]),
    dict(name="unknown load kind (time function)",
         deck=load("node = 'b', kind = 'square', value = 1.0"),
         exit=2, stderr=["deck.nml:5:", "unknown time function kind 'square'", "valid kinds are", "table"]),
    dict(name="unknown load quantity",
         deck=load("node = 'b', quantity = 'force', value = 1.0"),
         exit=2, stderr=["deck.nml:5:", "unknown load quantity 'force'", "torque, speed, angle, acceleration, voltage"]),

    # ---- topology
    dict(name="element joins a missing node",
         deck=RUN + NODES + "&element id = 's1', type = 'shaft', left = 'a',\n"
         "         right = 'zz', stiffness = 1.0e5 /\n",
         exit=2, stderr=["deck.nml:5:", "'s1'", "'zz'", "not defined"]),
    dict(name="element joins a node to itself",
         deck=RUN + NODES + "&element id = 's1', type = 'shaft', left = 'a', right = 'a', stiffness = 1.0e5 /\n",
         exit=2, stderr=["deck.nml:4:", "'s1'", "'a'", "to itself"]),
    # n-port elements (D-73): a gear pair's carrier (housing) node
    dict(name="gear carrier is a missing node",
         deck=RUN + NODES + HOUSING + GEAR.format(carrier="zz"),
         exit=2, stderr=["deck.nml:5:", "'g'", "carrier = 'zz'", "not defined"]),
    dict(name="gear carrier is the driver's node",
         deck=RUN + NODES + HOUSING + GEAR.format(carrier="a"),
         exit=2, stderr=["deck.nml:5:", "'g'", "carrier = 'a'", "already its left node", "distinct"]),
    dict(name="gear carrier is the driven gear's node",
         deck=RUN + NODES + HOUSING + GEAR.format(carrier="b"),
         exit=2, stderr=["deck.nml:5:", "'g'", "carrier = 'b'", "already its right node"]),
    dict(name="carrier on an element that has none (a shaft)",
         deck=RUN + NODES + HOUSING + "&element id = 's1', type = 'shaft', left = 'a', right = 'b', "
         "carrier = 'h', stiffness = 1.0e5 /\n",
         exit=2, stderr=["deck.nml:5:", "unknown key 'carrier'", "shaft"]),
    dict(name="static preload with a gear on a carrier (not yet)",
         deck="&run t_end = 0.01, dt = 1.0e-4, initial_state = 'preload' /\n" + NODES + HOUSING
         + GEAR.format(carrier="h") + "&load node = 'b', value = 1.0 /\n",
         exit=2, stderr=["deck.nml:5:", "'g'", "preload", "more than two ports", "carrier"]),
    # internal meshes and &planetary stages (issue 25): line 2 &planetary, its keys on lines 3-5
    dict(name="internal ideal gear whose ring is not larger than its pinion",
         deck=RUN + NODES + HOUSING + "&element id = 'g', type = 'ideal_gear', left = 'a', right = 'b', "
         "carrier = 'h', mesh = 'internal', stiffness = 1.0e5, rb_driver = 2.0, rb_driven = 2.0 /\n",
         exit=2, stderr=["deck.nml:5:", "rb_driven", "internal mesh", "larger than"]),
    dict(name="unknown mesh kind of a gear pair",
         deck=RUN + NODES + HOUSING + GEAR.format(carrier="h").replace(" /", ", mesh = 'inside' /"),
         exit=2, stderr=["deck.nml:5:", "mesh", "'inside'", "external, internal"]),
    dict(name="driven_sense = 'driver' without a carrier",
         deck=RUN + NODES + "&element id = 'g', type = 'ideal_gear', left = 'a', right = 'b', "
         "driven_sense = 'driver', stiffness = 1.0e5, rb_driver = 1.0, rb_driven = 2.0 /\n",
         exit=2, stderr=["deck.nml:4:", "driven_sense", "needs a carrier"]),
    dict(name="planetary: tooth counts that cannot assemble equally spaced",
         deck=RUN + PLANETARY.format(n=4, zs=21, zp=30, zr=81),
         exit=2, stderr=["deck.nml:3:", "&planetary #1", "key 'planets'", "(21 + 81)/4", "cannot be assembled"]),
    dict(name="planetary: ring smaller than sun + 2 planets",
         deck=RUN + PLANETARY.format(n=3, zs=21, zp=30, zr=78),
         exit=2, stderr=["deck.nml:3:", "&planetary #1", "key 'teeth_ring'", "teeth_sun + 2 teeth_planet = 81",
                         "got 78"]),
    dict(name="planetary: zero planets",
         deck=RUN + PLANETARY.format(n=0, zs=21, zp=30, zr=81),
         exit=2, stderr=["deck.nml:3:", "&planetary #1", "key 'planets'", "got 0"]),
    dict(name="planetary: a member given twice (an inertia and held)",
         deck=RUN + PLANETARY.format(n=3, zs=21, zp=30, zr=81).replace("held = 'ring'", "held = 'sun'"),
         exit=2, stderr=["deck.nml:2:", "&planetary #1", "the sun needs exactly one of", "gives 2"]),
    dict(name="planetary: planet angle that does not assemble",
         deck=RUN + PLANETARY.format(n=3, zs=21, zp=30, zr=81).replace(" /", ", planet_angles = 0, 100, 240 /"),
         exit=2, stderr=["deck.nml:5:", "key 'planet_angles'", "planet angle 2 = 100", "cannot be assembled"]),
    dict(name="planetary: a backlash per planet of the wrong count",
         deck=RUN + PLANETARY.format(n=3, zs=21, zp=30, zr=81).replace(" /", ", sun_backlash = 0.01, 0.02 /"),
         exit=2, stderr=["deck.nml:5:", "key 'sun_backlash'", "one per planet (3)", "got 2"]),
    dict(name="planetary: unknown key",
         deck=RUN + PLANETARY.format(n=3, zs=21, zp=30, zr=81).replace(" /", ", planet_inertial = 2 /"),
         exit=2, stderr=["deck.nml:5:", "planet_inertial", "planet_inertia"]),
    dict(name="chain default runs out of nodes",
         deck=GOOD + "&element id = 's2', type = 'shaft', stiffness = 1.0e5 /\n",
         exit=2, stderr=["deck.nml:5:", "'s2'", "not defined", "right"]),
    dict(name="duplicate node id",
         deck=RUN + "&node id = 'a', type = 'inertia', inertia = 5.0 /\n"
         "&node id = 'a', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:3:", "duplicate node id 'a'"]),
    dict(name="duplicate element id",
         deck=RUN + NODES + "&node id = 'c', type = 'inertia', inertia = 22.0 /\n"
         "&element id = 's1', type = 'shaft', stiffness = 1.0e5 /\n"
         "&element id = 's1', type = 'shaft', stiffness = 2.0e5 /\n",
         exit=2, stderr=["deck.nml:6:", "duplicate element id 's1'"]),
    dict(name="no &node group",
         deck=RUN,
         exit=2, stderr=["deck.nml", "no &node group"]),

    # ---- physical values
    dict(name="negative inertia",
         deck=RUN + "&node id = 'a', type = 'inertia', inertia = -5.0 /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:2:", "inertia", "must be > 0", "-5"]),
    dict(name="zero inertia",
         deck=RUN + "&node id = 'a', type = 'inertia', inertia = 0.0 /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:2:", "inertia", "must be > 0"]),
    dict(name="negative shaft damping",
         deck=RUN + NODES + "&element id = 's1', type = 'shaft', stiffness = 1.0e5, damping = -1.0 /\n",
         exit=2, stderr=["deck.nml:4:", "damping", "must be >= 0"]),
    dict(name="zero shaft stiffness",
         deck=RUN + NODES + "&element id = 's1', type = 'shaft', stiffness = 0.0 /\n",
         exit=2, stderr=["deck.nml:4:", "stiffness", "must be > 0"]),
    dict(name="ideal gear with zero base radius",
         deck=RUN + NODES + "&element id = 'g1', type = 'ideal_gear', stiffness = 1.0e6,\n"
         "         rb_driver = 0.0, rb_driven = 2.0 /\n",
         exit=2, stderr=["deck.nml:5:", "rb_driver", "must be > 0"]),

    # ---- &run timing
    dict(name="zero dt",
         deck="&run t_end = 0.01, dt = 0.0 /\n" + NODES + SHAFT,
         exit=2, stderr=["deck.nml:1:", "dt", "must be > 0"]),
    dict(name="negative dt",
         deck="&run t_end = 0.01,\n     dt = -1.0e-4 /\n" + NODES + SHAFT,
         exit=2, stderr=["deck.nml:2:", "dt", "must be > 0", "-"]),
    dict(name="dt longer than the run",
         deck="&run t_end = 0.01, dt = 0.1 /\n" + NODES + SHAFT,
         exit=2, stderr=["deck.nml:1:", "dt", "longer than the run"]),
    dict(name="t_end before t_start",
         deck="&run t_start = 1.0, t_end = 0.5, dt = 1.0e-4 /\n" + NODES + SHAFT,
         exit=2, stderr=["deck.nml:1:", "t_end", "later than t_start"]),
    dict(name="t_end equal to t_start",
         deck="&run t_start = 0.5, t_end = 0.5, dt = 1.0e-4 /\n" + NODES + SHAFT,
         exit=2, stderr=["deck.nml:1:", "t_end", "later than t_start"]),
    dict(name="dt so small that the step count overflows",
         deck="&run t_end = 1.0, dt = 1.0e-20 /\n" + NODES + SHAFT,
         exit=2, stderr=["deck.nml:1:", "dt"]),
    dict(name="rtol out of range",
         deck="&run t_end = 0.01, dt = 1.0e-4, rtol = 2.0 /\n" + NODES + SHAFT,
         exit=2, stderr=["deck.nml:1:", "rtol", "(0, 1)"]),
    dict(name="negative output_interval",
         deck="&run t_end = 0.01, dt = 1.0e-4, output_interval = -1.0 /\n" + NODES + SHAFT,
         exit=2, stderr=["deck.nml:1:", "output_interval", ">= 0"]),

    # ---- missing fields and bad values
    dict(name="missing stiffness of a shaft",
         deck=RUN + NODES + "&element id = 's1', type = 'shaft', damping = 1.0 /\n",
         exit=2, stderr=["deck.nml:4:", "missing required key 'stiffness'", "real number"]),
    dict(name="missing t_end",
         deck="&run dt = 1.0e-4 /\n" + NODES + SHAFT,
         exit=2, stderr=["deck.nml:1:", "missing required key 't_end'"]),
    dict(name="missing node type",
         deck=RUN + "&node id = 'a', inertia = 5.0 /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:2:", "missing required key 'type'"]),
    dict(name="non-numeric value",
         deck=RUN + "&node id = 'a', type = 'inertia', inertia = abc /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:2:", "'inertia'", "expected a real number", "'abc'"]),
    dict(name="number with trailing text",
         deck=RUN + "&node id = 'a', type = 'inertia', inertia = 5.0kg /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:2:", "'inertia'", "expected a real number", "'5.0kg'"]),
    dict(name="number out of range",
         deck=RUN + "&node id = 'a', type = 'inertia', inertia = 1.0e999 /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:2:", "'inertia'", "out of range"]),
    # D-28's range holds for a contact law's parameters too (fuzz deck 298: 5e30 ran CVODE
    # through a contact whose time constant was 1e-33 s)
    dict(name="contact_damping out of range",
         deck=RUN + "&node id = 'a', type = 'inertia', inertia = 5.0 /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n"
         "&element id = 'g', type = 'spur_gear', stiffness = 234500.0, rb_driver = 3.7588, rb_driven = 3.7588, "
         "teeth = 32, contact_ratio = 1.6676, approach_angle = 0.1637, half_backlash = 0.005, "
         "contact_law = 'linear', contact_damping = 5.0e30 /\n",
         exit=2, stderr=["deck.nml:4:", "contact_damping", "out of range"]),
    dict(name="quoted number",
         deck=RUN + "&node id = 'a', type = 'inertia', inertia = '5.0' /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:2:", "'inertia'", "real number", "quoted", "5.0"]),
    dict(name="two values for a scalar",
         deck=RUN + "&node id = 'a', type = 'inertia', inertia = 5.0, 6.0 /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:2:", "'inertia'", "expected one value, got 2"]),
    dict(name="bad logical",
         deck="&run t_end = 0.01, dt = 1.0e-4, track_energy = maybe /\n" + NODES + SHAFT,
         exit=2, stderr=["deck.nml:1:", "'track_energy'", "logical", "'maybe'"]),
    dict(name="duplicate key",
         deck=RUN + "&node id = 'a', type = 'inertia', inertia = 5.0,\n      inertia = 6.0 /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:3:", "duplicate key 'inertia'", "line 2"]),
    dict(name="missing '=' after a key",
         deck=RUN + "&node id = 'a', type = 'inertia' inertia 5.0 /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:2:", "missing '='", "'inertia'"]),
    dict(name="repeat count",
         deck=load("node = 'b', kind = 'table', times = 0.0, 1.0, values = 2*0.0"),
         exit=2, stderr=["deck.nml:5:", "repeat count", "2*0.0"]),

    # ---- syntax
    dict(name="unterminated string",
         deck=RUN + "&node id = 'a, type = 'inertia', inertia = 5.0 /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:2:", "unterminated string"]),
    dict(name="group not closed at end of file",
         deck=GOOD + "&initial node = 'a', angle = 0.1\n",
         exit=2, stderr=["deck.nml:5:", "not closed", "'/'"]),
    dict(name="group not closed before the next group",
         deck=RUN + "&node id = 'a', type = 'inertia', inertia = 5.0\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:3:", "not closed", "&node", "line 2"]),
    dict(name="text outside a group",
         deck="hello\n" + GOOD,
         exit=2, stderr=["deck.nml:1:", "text outside a group", "'hello'"]),
    dict(name="group closed twice",
         deck=RUN + NODES + SHAFT.rstrip("\n") + " /\n",
         exit=2, stderr=["deck.nml:4:", "text outside a group", "'/'"]),
    dict(name="'&' without a group name",
         deck=GOOD + "& node = 'a', angle = 0.1 /\n",
         exit=2, stderr=["deck.nml:5:", "group name"]),
    dict(name="empty deck",
         deck="! nothing but a comment\n",
         exit=2, stderr=["deck.nml", "&run", "found 0"]),

    # ---- &run count
    dict(name="no &run group",
         deck=NODES + SHAFT,
         exit=2, stderr=["deck.nml", "exactly one &run group", "found 0"]),
    dict(name="two &run groups",
         deck=RUN + NODES + SHAFT + RUN,
         exit=2, stderr=["deck.nml", "exactly one &run group", "found 2"]),

    # ---- loads, speeds, initial conditions
    dict(name="load on a missing node",
         deck=load("node = 'zz', value = -798.8"),
         exit=2, stderr=["deck.nml:5:", "load on node 'zz'", "not defined"]),
    dict(name="prescribed speed on a fixed node",
         deck=RUN + "&node id = 'a', type = 'fixed' /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT
         + "&load node = 'a', quantity = 'speed', value = 10.0 /\n",
         exit=2, stderr=["deck.nml:5:", "'a'", "fixed", "cannot have a prescribed speed"]),
    dict(name="two prescribed speeds on one node",
         deck=load("node = 'a', quantity = 'speed', value = 10.0")
         + "&load node = 'a', quantity = 'speed', value = 20.0 /\n",
         exit=2, stderr=["deck.nml:6:", "'a'", "already has a prescribed speed"]),
    # speed-dependent loads, prescribed angle and acceleration (issue 23 item 3)
    dict(name="unknown speed_law",
         deck=load("node = 'a', speed_law = 'cubic', w_nominal = 10.0, value = -1.0"),
         exit=2, stderr=["deck.nml:5:", "&load", "speed_law", "'cubic'", "quadratic"]),
    dict(name="speed_law without w_nominal",
         deck=load("node = 'a', speed_law = 'quadratic', value = -1.0"),
         exit=2, stderr=["deck.nml:5:", "w_nominal"]),
    dict(name="negative w_nominal",
         deck=load("node = 'a', speed_law = 'linear', w_nominal = -3.0, value = -1.0"),
         exit=2, stderr=["deck.nml:5:", "w_nominal", "must be > 0", "-3"]),
    dict(name="zero w_reg of the sign law",
         deck=load("node = 'a', speed_law = 'sign', w_reg = 0.0, value = -1.0"),
         exit=2, stderr=["deck.nml:5:", "w_reg", "must be > 0"]),
    dict(name="speed table with decreasing speeds",
         deck=load("node = 'a', speed_law = 'table', speeds = 0.0, 10.0, 5.0, torques = 0.0, -1.0, -2.0"),
         exit=2, stderr=["deck.nml:5:", "speeds", "must not decrease", "entry 3"]),
    dict(name="speed table of unequal lengths",
         deck=load("node = 'a', speed_law = 'table', speeds = 0.0, 10.0, torques = 0.0"),
         exit=2, stderr=["deck.nml:5:", "torques", "2 speeds but 1 torques"]),
    dict(name="speed_law on a prescribed speed is an unknown key",
         deck=load("node = 'a', quantity = 'speed', speed_law = 'linear', value = 1.0"),
         exit=2, stderr=["deck.nml:5:", "speed_law"]),
    dict(name="prescribed angle from a table is refused",
         deck=load("node = 'a', quantity = 'angle', kind = 'table', times = 0.0, 1.0, values = 0.0, 1.0"),
         exit=2, stderr=["deck.nml:5:", "kind", "'table'", "constant, sine"]),
    dict(name="prescribed angle and speed on one node",
         deck=load("node = 'a', quantity = 'angle', kind = 'sine', amplitude = 0.1, frequency = 1.0")
         + "&load node = 'a', quantity = 'speed', value = 20.0 /\n",
         exit=2, stderr=["deck.nml:6:", "'a'", "already has a prescribed speed, angle or acceleration"]),
    dict(name="prescribed acceleration on a fixed node",
         deck=RUN + "&node id = 'a', type = 'fixed' /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT
         + "&load node = 'a', quantity = 'acceleration', value = 10.0 /\n",
         exit=2, stderr=["deck.nml:5:", "'a'", "cannot have a prescribed acceleration"]),
    dict(name="unknown bore_friction of a keyed joint",
         deck=RUN + NODES + "&element id = 'k', type = 'keyed_joint', diameter = 2.0, half_clearance = 0.01, "
         "stiffness = 1.0e6, friction = 0.3, bore_friction = 'bore' /\n",
         exit=2, stderr=["deck.nml:4:", "bore_friction", "'bore'", "hub_load", "key_force"]),
    dict(name="two voltage sources on one motor",
         deck=RUN + "&node id = 'm', type = 'dc_motor', inertia = 0.1, torque_constant = 8.85,\n"
         "      inductance = 0.01, resistance = 1.0, back_emf_constant = 1.0 /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT
         + "&load node = 'm', quantity = 'voltage', value = 24.0 /\n"
         "&load node = 'm', quantity = 'voltage', value = 12.0 /\n",
         exit=2, stderr=["deck.nml:7:", "'m'", "voltage"]),
    dict(name="voltage on an inertia node",
         deck=load("node = 'a', quantity = 'voltage', value = 24.0"),
         exit=2, stderr=["deck.nml:5:", "'a'", "no voltage input", "dc_motor"]),
    dict(name="table load with times/values of different lengths",
         deck=load("node = 'b', kind = 'table',\n      times = 0.0, 0.5, 1.0,\n      values = 0.0, 1.0"),
         exit=2, stderr=["deck.nml:7:", "3 times but 2 values"]),
    dict(name="table load with decreasing times",
         deck=load("node = 'b', kind = 'table',\n      times = 0.0, 0.5, 0.2,\n      values = 0.0, 1.0, 2.0"),
         exit=2, stderr=["deck.nml:6:", "times", "must not decrease"]),
    dict(name="table load without times",
         deck=load("node = 'b', kind = 'table'"),
         exit=2, stderr=["deck.nml:5:", "'table'", "times", "values"]),
    dict(name="table_file that does not exist",
         deck=load("node = 'b', kind = 'table', table_file = 'no-such-table.txt'"),
         exit=2, stderr=["deck.nml:5:", "table_file", "no-such-table.txt"]),
    dict(name="table_file that is not UTF-8 text (a Latin-1 degree sign in a comment)",
         deck=load("node = 'b', kind = 'table', table_file = 'latin1.txt'"),
         files={"latin1.txt": b"# torque at 20\xb0C\n0.0 1.0\n1.0 2.0\n"},
         exit=2, stderr=["deck.nml:5:", "table_file", "latin1.txt:1:", "UTF-8", "0xB0"]),
    dict(name="table_file with a row that is not two numbers",
         deck=load("node = 'b', kind = 'table', table_file = 'rows.txt'"),
         files={"rows.txt": b"0.0 1.0\r\n1.0 2.0\r\n2.0 x\r\n"},
         exit=2, stderr=["deck.nml:5:", "table_file", "rows.txt:3:", "expected two numbers"]),

    # ---- issue 21 item 4: messages that find the line (D-62)
    dict(name="misspelt required key in spur_gear geometry form: its own line, did you mean",
         deck=GEOM.format(units="", k1="teeth_driver = 28, teeth_drivn = 56", k2="backlash = 0.004"),
         exit=2, stderr=["deck.nml:5:", "unknown key 'teeth_drivn'", "did you mean 'teeth_driven'?",
                         "required key 'teeth_driven'"]),
    dict(name="misspelt required key in a shaft: its own line, did you mean",
         deck=RUN + NODES + "&element id = 's1', type = 'shaft',\n         stifness = 1.0e5 /\n",
         exit=2, stderr=["deck.nml:5:", "unknown key 'stifness'", "did you mean 'stiffness'?"]),
    dict(name="misspelt optional key: unknown key with did you mean",
         deck=RUN + "&node id = 'a', type = 'inertia', inertia = 5.0,\n      dampng = 0.1 /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:3:", "unknown key 'dampng'", "did you mean 'damping'?", "valid keys are"]),
    dict(name="missing rb_driver beside rb_driven: a missing key, not a misspelling",
         deck=RUN + NODES + "&element id = 'g', type = 'ideal_gear', stiffness = 1.0e5, rb_driven = 2.0 /\n",
         exit=2, stderr=["deck.nml:4:", "missing required key 'rb_driver'"], not_stderr=["did you mean"]),
    dict(name="a fractional tooth count (constants form): refused with its line",
         deck=RUN + NODES + "&element id = 'g', type = 'spur_gear', stiffness = 2.3e5, rb_driver = 1.9, rb_driven = 1.9,\n"
         "         teeth = 32.5, contact_ratio = 1.6, approach_angle = 0.18, half_backlash = 0.001 /\n",
         exit=2, stderr=["deck.nml:", "'teeth'", "a whole number of teeth, got 32.5"]),
    dict(name="a fractional tooth count (geometry form)",
         deck=GEOM.format(units="", k1="teeth_driver = 28, teeth_driven = 56.5", k2="backlash = 0.004"),
         exit=2, stderr=["deck.nml:", "'teeth_driven'", "a whole number of teeth, got 56.5"]),
    dict(name="a fractional tooth count (helical gear)",
         deck=RUN + NODES + "&element id = 'h', type = 'helical_gear', rb_driver = 1.6, rb_driven = 1.6, teeth = 28.5,\n"
         "         profile_contact_ratio = 1.6, base_helix_angle = 20, face_width = 1.0,\n         half_backlash = 0.002 /\n",
         exit=2, stderr=["deck.nml:4:", "'teeth'", "a whole number of teeth, got 28.5"]),
    dict(name="missing teeth_driver beside teeth_driven: a missing key, not a misspelling",
         deck=GEOM.format(units="", k1="teeth_driven = 56", k2="backlash = 0.004"),
         exit=2, stderr=["deck.nml:4:", "missing required key 'teeth_driver'"], not_stderr=["did you mean"]),
    dict(name="missing t_accel beside t_decel: a missing key, not a misspelling",
         deck=load("node = 'b', kind = 'start_stop', value = 10.0, t_decel = 0.1"),
         exit=2, stderr=["deck.nml:5:", "missing required key 't_accel'"], not_stderr=["did you mean"]),
    dict(name="far-off unknown key suggests nothing",
         deck="&run t_end = 0.01, dt = 1.0e-4, colour = 3.0 /\n" + NODES + SHAFT,
         exit=2, stderr=["deck.nml:1:", "unknown key 'colour'", "valid keys are"], not_stderr=["did you mean"]),
    dict(name="unknown group lists every group the reader takes, sweep too",
         deck=RUN + NODES + SHAFT + "&sweeps parameter = 's1.stiffness', values = 1e5 /\n",
         exit=2, stderr=["deck.nml:5:", "unknown group '&sweeps'", "run, node, element, load, initial, controller, fmu, planetary, sweep"]),
    dict(name="half_backlash in the spur_gear geometry form is explained (in-lbf-s)",
         deck=GEOM.format(units="", k1="teeth_driver = 28, teeth_driven = 56", k2="half_backlash = 0.002"),
         exit=2, stderr=["deck.nml:6:", "half_backlash belongs to TRAIN's constants form", "geometry form",
                         "TOTAL backlash", "2 x half_backlash", "in in)"]),
    dict(name="negative tooth_friction is refused (D-98)",
         deck=GEOM.format(units="", k1="teeth_driver = 28, teeth_driven = 56", k2="backlash = 0.004, tooth_friction = -0.05"),
         exit=2, stderr=["deck.nml:6:", "&element", "tooth_friction must be >= 0", "-0.05"]),
    dict(name="unknown tooth_friction_model is refused (D-98)",
         deck=GEOM.format(units="", k1="teeth_driver = 28, teeth_driven = 56",
                          k2="backlash = 0.004, tooth_friction = 0.05, tooth_friction_model = 'stribeck'"),
         exit=2, stderr=["deck.nml:6:", "&element", "unknown tooth_friction_model 'stribeck'", "valid: constant, speed"]),
    dict(name="tooth_friction_velocity <= 0 is refused (D-98)",
         deck=GEOM.format(units="", k1="teeth_driver = 28, teeth_driven = 56",
                          k2="backlash = 0.004, tooth_friction = 0.05, tooth_friction_velocity = 0.0"),
         exit=2, stderr=["deck.nml:6:", "&element", "tooth_friction_velocity must be > 0", "got 0"]),
    dict(name="tip relief by both length and start roll is refused (D-117)",
         deck=GEOM.format(units="", k1="teeth_driver = 28, teeth_driven = 56",
                          k2="backlash = 0.004, tip_relief = 1e-3, tip_relief_length = 0.05, tip_relief_start_roll = 20.0"),
         exit=2, stderr=["deck.nml:6:", "'tip_relief_start_roll'", "not both"]),
    dict(name="tip relief starting below mid-path is refused (D-117)",
         deck=GEOM.format(units="", k1="teeth_driver = 28, teeth_driven = 56",
                          k2="backlash = 0.004, tip_relief = 1e-3, tip_relief_start_roll = 5.0"),
         exit=2, stderr=["deck.nml:6:", "'tip_relief_start_roll'", "must lie between the roll angle of mid-path"]),
    dict(name="negative crowning of a helical_gear is refused (D-116)",
         deck=HELICAL + "half_backlash = 0.002, crowning = -1e-4 /\n",
         exit=2, stderr=["deck.nml:6:", "&element", "crowning must be >= 0", "-0.0001"]),
    dict(name="unknown helical stiffness_model is refused (D-116)",
         deck=HELICAL + "half_backlash = 0.002, stiffness_model = 'zones' /\n",
         exit=2, stderr=["deck.nml:6:", "unknown stiffness_model 'zones'", "valid: contact_lines, iso6336"]),
    dict(name="helical iso6336 with youngs_modulus is refused (D-116)",
         deck=HELICAL + "half_backlash = 0.002, stiffness_model = 'iso6336', youngs_modulus = 3e7 /\n",
         exit=2, stderr=["deck.nml:6:", "'stiffness_model'", "no youngs_modulus"]),
    dict(name="helical 'speed' tooth friction with tooth_friction_velocity <= 0 is refused (D-129)",
         deck=HELICAL + "half_backlash = 0.002, approach_angle = 0.17, tooth_friction = 0.05,\n"
         "         tooth_friction_model = 'speed', tooth_friction_velocity = -1.0 /\n",
         exit=2, stderr=["deck.nml:7:", "&element", "tooth_friction_velocity must be > 0", "got -1"]),
    dict(name="unknown helical tooth_friction_model is refused (D-129)",
         deck=HELICAL + "half_backlash = 0.002, approach_angle = 0.17, tooth_friction = 0.05,\n"
         "         tooth_friction_model = 'stribeck' /\n",
         exit=2, stderr=["deck.nml:7:", "&element", "unknown tooth_friction_model 'stribeck'", "valid: constant, speed"]),
    dict(name="negative helical tooth_friction is refused (D-116)",
         deck=HELICAL + "half_backlash = 0.002, tooth_friction = -0.05 /\n",
         exit=2, stderr=["deck.nml:6:", "tooth_friction must be >= 0", "-0.05"]),
    dict(name="backlash in the spur_gear constants form is explained (SI)",
         deck="&run t_end = 0.01, dt = 1.0e-6, units = 'si' /\n" + NODES +
         "&element id = 'mesh', type = 'spur_gear', stiffness = 3.0e9, rb_driver = 0.04, rb_driven = 0.08,\n"
         "         teeth = 28, contact_ratio = 1.6, approach_angle = 0.18,\n         backlash = 1.0e-4 /\n",
         exit=2, stderr=["deck.nml:6:", "'backlash'", "geometry form", "constants form", "'half_backlash' = backlash / 2",
                         "in m)"]),
    dict(name="backlash in a helical_gear is explained",
         deck=HELICAL + "backlash = 0.004 /\n",
         exit=2, stderr=["deck.nml:6:", "helical_gear takes 'half_backlash'", "half your value, in in"]),
    dict(name="negative backlash in an SI geometry deck names the unit m",
         deck=GEOM.format(units=", units = 'si'", k1="teeth_driver = 28, teeth_driven = 56", k2="backlash = -1.0e-4")
         .replace("diametral_pitch = 8.0, face_width = 0.7", "module = 3.0, face_width = 0.02"),
         exit=2, stderr=["deck.nml:6:", "backlash must be >= 0", " m"], stderr_re=[r"got -\S+ m$"]),
    dict(name="zero face width in an in-lbf-s geometry deck names the unit in",
         deck=GEOM.format(units="", k1="teeth_driver = 28, teeth_driven = 56", k2="backlash = 0.004")
         .replace("face_width = 0.7", "face_width = 0.0"),
         exit=2, stderr=["deck.nml:5:", "face_width must be > 0"], stderr_re=[r"got \S+ in$"]),
] + [
    # friction elements (D-81): the element on line 4, the offending key on line 5
    dict(name=f"{etype}: {key} = {value} is refused",
         deck=RUN + NODES + f"&element id = 'f1', type = '{etype}', left = 'a', right = 'b',\n"
         f"         {extra}{key} = {value} /\n",
         exit=2, stderr=["deck.nml:5:", f"key '{key}'", f"got {shown}", what])
    for etype, key, value, shown, extra, what in [
        ("bearing_friction", "torque_sliding", "-1.0", "-1", "", "must be >= 0"),
        ("brake", "viscous", "-0.5", "-0.5", "torque_sliding = 2.0, ", "must be >= 0"),
        ("clutch", "torque_static", "3.0", "3", "torque_sliding = 5.0, ", "the sliding torque 5"),
        ("clutch", "engagement", "1.5", "1.5", "torque_sliding = 5.0, ", "must be in [0, 1]"),
        ("brake", "engagement_values", "0.0, -0.2", "-0.2", "torque_sliding = 5.0, engagement_times = 0.0, 1.0, ",
         "must be in [0, 1]"),
        ("bearing_friction", "friction_torques", "1.0, -2.0", "-2", "friction_speeds = 0.0, 1.0, ", "must be >= 0"),
        ("one_way_clutch", "capacity", "0.0", "0", "", "must be > 0"),
    ]
] + [
    # list-directed READ took these (a '/' or ',,' kept the line before's value, '2*30' a
    # repeat count, extra columns and text were ignored): each is now its line's error
    dict(name=f"table_file line 3 = {bad!r}",
         deck=load("node = 'b', kind = 'table', table_file = 'tab.txt'"),
         files={"tab.txt": b"0.00 -5.0\n0.15 -5.0\n" + bad + b"\n0.30 30.0\n"},
         exit=2, stderr=["deck.nml:5:", "table_file", "tab.txt:3:", what])
    for bad, what in [(b"0.20 /", "expected two numbers"), (b"0.20,,", "expected two numbers"),
                      (b"0.20 30.0 lbf*in", "expected two numbers"), (b"0.20 30.0 7.0", "expected two numbers"),
                      (b"0.20 2*30.0", "expected two numbers"), (b"0.20 nan", "expected two numbers"),
                      (b"0.20 1e999", "out of range"), (b"0.20 -1e-999", "out of range"),
                      (b"0.20 1e25", "out of range"), (b",0.20 30", "expected two numbers"),
                      (b"0.20, 30,", "expected two numbers")]
] + [
    dict(name="table_file whose first line is '0.00 /'",
         deck=load("node = 'b', kind = 'table', table_file = 'tab.txt'"),
         files={"tab.txt": b"0.00 /\n0.30 30.0\n"},
         exit=2, stderr=["tab.txt:1:", "expected two numbers", "'0.00 /'"]),
    dict(name="table_file with blank, tab-only and comment lines, tabs and a comma as separators",
         deck=load("node = 'b', kind = 'table', table_file = 'tab.txt'"),
         files={"tab.txt": b"# t  T\n\t\n  \n0.00\t-5.0\n! gust\n0.15, -5.0\n 0.20 ,30.0\r\n0.30\t \t30.0\n"},
         args=["run", "deck.nml", "--no-output"], exit=0, stderr=[]),
    dict(name="table_file times that decrease name the table line",
         deck=load("node = 'b', kind = 'table', table_file = 'tab.txt'"),
         files={"tab.txt": b"0.0 1.0\n# c\n0.5 2.0\n0.4 3.0\n"},
         exit=2, stderr=["deck.nml:5:", "tab.txt:4:", "must not decrease", "line 3"]),
    dict(name="table_file with no data rows",
         deck=load("node = 'b', kind = 'table', table_file = 'tab.txt'"),
         files={"tab.txt": b"# nothing\n\n"},
         exit=2, stderr=["deck.nml:5:", "tab.txt", "no data rows"]),
    dict(name="ramp ending before it starts",
         deck=load("node = 'b', kind = 'ramp', value1 = 5.0, t0 = 0.5, t1 = 0.2"),
         exit=2, stderr=["deck.nml:5:", "t1", "later than its start"]),
    dict(name="sine with zero frequency",
         deck=load("node = 'b', kind = 'sine', amplitude = 1.0, frequency = 0.0"),
         exit=2, stderr=["deck.nml:5:", "frequency", "> 0"]),
    dict(name="start_stop with zero cycles",
         deck=load("node = 'b', kind = 'start_stop', value = 1.0, t_accel = 0.1,\n"
                   "      t_cruise = 0.1, t_decel = 0.1, cycles = 0"),
         exit=2, stderr=["deck.nml:6:", "cycles", ">= 1"]),
    dict(name="unknown key for a time function",
         deck=load("node = 'b', kind = 'constant', value = 1.0, amplitude = 2.0"),
         exit=2, stderr=["deck.nml:5:", "unknown key 'amplitude'", "valid keys are"]),
    dict(name="initial conditions for a missing node",
         deck=GOOD + "&initial node = 'zz', angle = 0.1 /\n",
         exit=2, stderr=["deck.nml:5:", "'zz'", "not defined"]),
    dict(name="two &initial groups for one node",
         deck=GOOD + "&initial node = 'a', angle = 0.1 /\n&initial node = 'a', speed = 1.0 /\n",
         exit=2, stderr=["deck.nml:6:", "'a'", "two &initial groups"]),
    dict(name="initial speed of a fixed node",
         deck=RUN + "&node id = 'a', type = 'fixed' /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT
         + "&initial node = 'a', speed = 3.0 /\n",
         exit=2, stderr=["deck.nml:5:", "'a'", "fixed", "speed must be 0"]),
    dict(name="dc_motor missing its resistance",
         deck=RUN + "&node id = 'a', type = 'dc_motor', inertia = 0.1, torque_constant = 1.0,\n"
         "      inductance = 0.01, back_emf_constant = 0.113 /\n"
         "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT,
         exit=2, stderr=["deck.nml:2:", "missing required key 'resistance'"]),

    # ---- files
    dict(name="deck path does not exist", deck=None,
         args=["run", "{tmp}/no-such-deck.nml", "-o", "{out}"],
         exit=2, stderr=["cannot open deck", "no-such-deck.nml"]),
    dict(name="deck path is a directory", deck=None, mkdir="adir.nml",
         args=["run", "{tmp}/adir.nml", "-o", "{out}"],
         exit=2, stderr=["adir.nml"]),
    dict(name="unwritable output path", deck=GOOD,
         args=["run", "deck.nml", "-o", "/nonexistent-dir/out.h5"],
         exit=2, stderr=["/nonexistent-dir/out.h5", "cannot write output file"]),
    dict(name="output path is a directory", deck=GOOD, mkdir="out.h5",
         args=["run", "deck.nml", "-o", "{out}"],
         exit=2, stderr=["out.h5", "cannot write output file"], keep_out=True),

    # ---- numerics
    dict(name="unstable time step blows up",
         deck=TABLE5_1.format(t_end=5, dt=0.05),
         exit=1, stderr=["warning", "stability limit", "blew up", "time step"]),
    # an event flood (F_event_flood.nml of ../shared/repro): the remedy names what the
    # integrator in use steps by (D-51): dt for rk4, the tolerances for cvode-bdf
    dict(name="event flood under rk4 names dt against the stability limit",
         deck=FLOOD.format(integrator="rk4"),
         exit=1, stderr=["event flood", "dt = 5.0E-7 s", "stability limit"]),
    dict(name="event flood under cvode-bdf names rtol and max_step, not dt",
         deck=FLOOD.format(integrator="cvode-bdf"),
         exit=1, stderr=["event flood", "rtol (now 1.0E-8)", "max_step"],
         not_stderr=["The time step dt", "take dt below"]),
    dict(name="dt too coarse for the contact mode of an open clearance is warned about",
         deck="&run t_end = 2e-4, dt = 5e-5 /\n"
              "&node type = 'inertia', inertia = 7.537e-3 /\n&node type = 'inertia', inertia = 10.082 /\n"
              "&element type = 'spur_gear', stiffness = 18.03e6, rb_driver = 1.6445, rb_driven = 1.6445,"
              " teeth = 28, contact_ratio = 1.638, approach_angle = 0.1838, half_backlash = 0.001 /\n",
         exit=0, stderr=["warning", "every clearance closed", "would be safe"], output=True),

    # ---- command line
    dict(name="no arguments", deck=None, args=[],
         exit=2, stderr=["usage"]),
    dict(name="--help", deck=None, args=["--help"],
         exit=0, stderr=[], stdout=["usage"]),
    dict(name="--version", deck=None, args=["--version"],
         exit=0, stderr=[], stdout=["trainsim"]),
    dict(name="unknown command", deck=None, args=["simulate", "deck.nml"],
         exit=2, stderr=["unknown command 'simulate'"]),
    dict(name="run without a deck", deck=None, args=["run"],
         exit=2, stderr=["run needs a deck file"]),
    dict(name="-o without a file name", deck=GOOD, args=["run", "deck.nml", "-o"],
         exit=2, stderr=["-o needs a file name"]),
    dict(name="unknown option", deck=GOOD, args=["run", "deck.nml", "--fast"],
         exit=2, stderr=["unexpected argument '--fast'"]),
    dict(name="modes on a good deck", deck=GOOD, args=["modes", "deck.nml"],
         exit=0, stderr=[], stdout=["Hz"]),
    dict(name="modes with a bad value", deck=RUN + NODES.replace("5.0", "-5.0") + SHAFT,
         args=["modes", "deck.nml"],
         exit=2, stderr=["deck.nml:2:", "inertia", "must be > 0"]),
] + [
    # &controller (issue 23 item 4): a motor (line 2), a disk (line 4), a shaft (line 5),
    # the controller on line 6
    dict(name=name, deck=RUN + MOTOR + "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT
         + "&controller " + keys + " /\n", exit=2, stderr=stderr)
    for name, keys, stderr in [
        ("controller on a node that does not exist", "motor = 'm', sensor = 'table', kp = 1.0, value = 1.0",
         ["deck.nml:6:", "&controller", "sensor", "'table'", "not defined"]),
        ("controller on a motor that does not exist", "motor = 'x', kp = 1.0, value = 1.0",
         ["deck.nml:6:", "motor", "'x'", "not defined"]),
        ("controller on an inertia node", "motor = 'b', kp = 1.0, value = 1.0",
         ["deck.nml:6:", "motor", "'b'", "dc_motor"]),
        ("controller with a negative gain", "motor = 'm', kp = 1.0, ki = -2.0, value = 1.0",
         ["deck.nml:6:", "ki", "must be >= 0", "-2"]),
        ("controller with reversed supply limits", "motor = 'm', kp = 1.0, v_min = 24.0, v_max = -24.0, value = 1.0",
         ["deck.nml:6:", "v_max", "reversed", "-24"]),
        ("controller derivative without a filter", "motor = 'm', kp = 1.0, kd = 0.5, value = 1.0",
         ["deck.nml:6:", "filter_time", "kd"]),
        ("controller with an unknown anti-windup", "motor = 'm', kp = 1.0, anti_windup = 'clamp', value = 1.0",
         ["deck.nml:6:", "anti_windup", "'clamp'", "conditional"]),
        ("controller with a negative current limit", "motor = 'm', kp = 1.0, current_limit = -5.0, value = 1.0",
         ["deck.nml:6:", "current_limit", "must be >= 0"]),
        ("sequence on a speed", "motor = 'm', kp = 1.0, sequence = .true., kind = 'table', times = 0.0, "
         "values = 1.0, tolerance = 0.01, speed_tolerance = 0.1", ["deck.nml:6:", "sequence", "measure = 'angle'"]),
        ("sequence without tolerance", "motor = 'm', measure = 'angle', kp = 1.0, sequence = .true., "
         "kind = 'table', times = 0.0, values = 1.0, speed_tolerance = 0.1", ["deck.nml:6:", "tolerance"]),
        ("sequence with an unknown hold", "motor = 'm', measure = 'angle', kp = 1.0, sequence = .true., "
         "kind = 'table', times = 0.0, values = 1.0, tolerance = 0.01, speed_tolerance = 0.1, hold = 'brake'",
         ["deck.nml:6:", "hold", "'brake'", "servo"]),
        ("controller with an unknown key", "motor = 'm', kp = 1.0, value = 1.0, gain = 3.0",
         ["deck.nml:6:", "gain", "&controller"]),
        ("sequence commanding a brake that is not an element", "motor = 'm', measure = 'angle', kp = 1.0, "
         "sequence = .true., kind = 'table', times = 0.0, values = 1.0, tolerance = 0.01, speed_tolerance = 0.1, "
         "brake = 'hold'", ["deck.nml:6:", "brake", "'hold'", "not an element"]),
        ("sequence commanding an element that is not a brake", "motor = 'm', measure = 'angle', kp = 1.0, "
         "sequence = .true., kind = 'table', times = 0.0, values = 1.0, tolerance = 0.01, speed_tolerance = 0.1, "
         "brake = 's1'", ["deck.nml:6:", "brake", "'s1'", "shaft", "type 'brake'"]),
    ]
] + [
    dict(name="controller and a voltage load on one motor",
         deck=RUN + MOTOR + "&node id = 'b', type = 'inertia', inertia = 11.0 /\n" + SHAFT
         + "&load node = 'm', quantity = 'voltage', value = 24.0 /\n"
         + "&controller motor = 'm', kp = 1.0, value = 1.0 /\n",
         exit=2, stderr=["deck.nml:7:", "motor", "'m'", "voltage load"]),
]


def run_case(exe, case):
    """Run one case; return a list of problems (empty: the case passed)."""
    problems = []
    with tempfile.TemporaryDirectory(prefix="trainsim-bad-") as tmp:
        out = os.path.join(tmp, "out.h5")
        if case.get("deck") is not None:
            with open(os.path.join(tmp, "deck.nml"), "w") as f:
                f.write(case["deck"])
        for name, data in case.get("files", {}).items():   # extra input files (bytes)
            with open(os.path.join(tmp, name), "wb") as f:
                f.write(data)
        if case.get("mkdir"):
            os.mkdir(os.path.join(tmp, case["mkdir"]))
        args = case.get("args", ["run", "deck.nml", "-o", "{out}"])
        args = [a.replace("{out}", out).replace("{tmp}", tmp) for a in args]
        try:
            proc = subprocess.run([exe] + args, cwd=tmp, capture_output=True, text=True,
                                  errors="replace", timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            return ["timed out after %d s" % TIMEOUT], "", ""
        if proc.returncode != case["exit"]:
            problems.append("exit status %d, expected %d" % (proc.returncode, case["exit"]))
        for s in case["stderr"]:
            if s not in proc.stderr:
                problems.append("stderr lacks %r" % s)
        for s in case.get("not_stderr", []):
            if s in proc.stderr:
                problems.append("stderr shows %r" % s)
        for s in case.get("stderr_re", []):   # a pattern per line (re.M): a unit after a value
            if not re.search(s, proc.stderr, re.M):
                problems.append("stderr lacks a match of %r" % s)
        for s in case.get("stdout", []):
            if s.lower() not in proc.stdout.lower():
                problems.append("stdout lacks %r" % s)
        for s in FORBIDDEN:
            if s in proc.stderr or s in proc.stdout:
                problems.append("output shows a crash (%r)" % s)
        if case.get("output"):
            if not os.path.isfile(out):
                problems.append("out.h5 was not written")
        elif not case.get("keep_out") and os.path.exists(out):
            problems.append("out.h5 was left behind")
        parts = [n for n in os.listdir(tmp) if n.endswith(".part")]
        if parts:
            problems.append("temporary file(s) left behind: %s" % ", ".join(parts))
        return problems, proc.stdout, proc.stderr


def main():
    if len(sys.argv) != 2:
        print("usage: run_bad_decks.py <path to trainsim>", file=sys.stderr)
        return 2
    exe = os.path.abspath(sys.argv[1])
    if not os.access(exe, os.X_OK):
        print("run_bad_decks.py: not an executable: %s" % exe, file=sys.stderr)
        return 2
    passed = failed = 0
    for case in CASES:
        problems, stdout, stderr = run_case(exe, case)
        if problems:
            failed += 1
            print("FAIL  %s" % case["name"])
            for p in problems:
                print("        - %s" % p)
            tail = stderr.strip().splitlines()[-6:]
            for line in tail:
                print("        stderr| %s" % line)
        else:
            passed += 1
            print("ok    %s" % case["name"])
    print("%d passed, %d failed" % (passed, failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
