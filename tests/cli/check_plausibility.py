#!/usr/bin/python3
"""Unit and topology slips are caught; valid decks give no warning (issue 20, item 7).

Usage: check_plausibility.py TRAINSIM   (cwd = repo root)

1. Seven unit slips a new user made on the SI tracker deck (tests/decks/
   tracker_si_start_stop.nml), each a one-edit copy of it: no units = 'si'; a module in
   metres; a 0.25 m backlash; a 40 m face width; a 14 m key diameter; a load inertia 10^4 x
   too large; a back-EMF constant 100 x the torque constant. Each must give a message
   naming its key (error: exit 2; warning: exit 0, and exit 2 with --strict, for run and
   sweep).
2. The same slips in an in-lbf-s deck of the same kind (inputs/dc_motor_geared_load.nml
   plus a keyed joint), so no rule is tuned to one unit system.
3. Topology: a node joined to nothing and driven by nothing (exit 2), a part of the train
   cut off by a missing element (exit 2), two driven trains side by side (a warning).
4. Every valid deck of every bundled kind, in inch and SI units (inputs/, verification/,
   tests/decks/, with SI versions of the inch-only kinds in tests/decks/si_*.nml), gives
   no plausibility message (`trainsim modes`, which builds the deck as run does).
"""

import glob
import os
import re
import subprocess
import sys
import tempfile

TIMEOUT = 120
failed = 0


def check(what, ok, detail=""):
    global failed
    print(("ok    " if ok else "FAIL  ") + what + ("" if ok or not detail else "\n        " + detail))
    if not ok:
        failed += 1


def run(exe, args, cwd):
    r = subprocess.run([exe] + args, cwd=cwd, capture_output=True, text=True, errors="replace", timeout=TIMEOUT)
    return r.returncode, r.stderr


def edit(text, old, new):
    assert old in text, old
    return text.replace(old, new, 1)


def slip_cases(base, si):
    """(name, deck text, key the message must name, 'error'|'warning')."""
    if si:
        return [
            ("no units = 'si' on an SI deck", edit(base, "units = 'si',", ""), "diameter", "error"),
            ("module in metres", edit(base, "module = 2.0", "module = 0.002"), "module", "error"),
            ("a 0.25 m backlash", edit(base, "backlash = 1.0e-4", "backlash = 0.25"), "backlash", "error"),
            ("a 40 m face width", edit(base, "face_width = 0.02", "face_width = 40.0"), "face_width", "error"),
            ("a 14 m key diameter", edit(base, "diameter = 0.03", "diameter = 14.0"), "diameter", "error"),
            ("load inertia 1e4 x", edit(base, "inertia = 0.5,", "inertia = 5000.0,"), "inertia", "warning"),
            ("back-EMF constant 100 x the torque constant", edit(base, "back_emf_constant = 0.3",
                                                                  "back_emf_constant = 30.0"),
             "back_emf_constant", "error"),
        ]
    return [
        ("units = 'si' on an inch deck", edit(base, "&run ", "&run units = 'si', "), "face_width", "error"),
        ("module in metres", edit(base, "diametral_pitch = 8.0", "module = 0.003175"), "module", "error"),
        ("module in inches (it is always mm)", edit(base, "diametral_pitch = 8.0", "module = 0.125"), "backlash",
         "warning"),
        ("a 10 in backlash", edit(base, "backlash = 0.004", "backlash = 10.0"), "backlash", "error"),
        ("a 1000 in face width", edit(base, "face_width = 0.75", "face_width = 1000.0"), "face_width", "error"),
        ("a 500 in key diameter", edit(base, "diameter = 1.0,", "diameter = 500.0,"), "diameter", "error"),
        ("load inertia 1e4 x", edit(base, "inertia = 2.0,", "inertia = 20000.0,"), "inertia", "warning"),
        ("back-EMF constant 100 x the torque constant", edit(base, "back_emf_constant = 0.0565",
                                                              "back_emf_constant = 5.65"),
         "back_emf_constant", "error"),
        ("k_t = k_e (SI constants) in an inch deck", edit(base, "back_emf_constant = 0.0565",
                                                          "back_emf_constant = 0.5"),
         "back_emf_constant", "error"),
        ("  ... and the message names the missing units = 'si'", edit(base, "back_emf_constant = 0.0565",
                                                                       "back_emf_constant = 0.5"),
         "back_emf_constant", "units = 'si' missing"),
    ]


# inputs/dc_motor_geared_load.nml with a keyed joint on the load side: an inch deck of the
# tracker's kind (motor, geometry spur gear, key, shaft).
INCH = """&run title = 'inch tracker', t_end = 0.01, dt = 5.0e-6 /
&node id = 'motor', type = 'dc_motor', inertia = 2.0e-3, damping = 1.0e-4,
      torque_constant = 0.5, back_emf_constant = 0.0565, inductance = 2.0e-3, resistance = 0.5 /
&node id = 'gear', type = 'inertia', inertia = 0.05 /
&node id = 'hub', type = 'inertia', inertia = 0.01 /
&node id = 'load', type = 'inertia', inertia = 2.0, damping = 0.5 /
&element id = 'mesh', type = 'spur_gear', left = 'motor', right = 'gear',
         teeth_driver = 20, teeth_driven = 60, diametral_pitch = 8.0, pressure_angle = 20.0,
         face_width = 0.75, backlash = 0.004 /
&element id = 'key', type = 'keyed_joint', diameter = 1.0, half_clearance = 0.001, stiffness = 2.0e6 /
&element id = 'shaft', type = 'shaft', stiffness = 2.0e4, damping = 2.0 /
&load node = 'motor', quantity = 'voltage', kind = 'constant', value = 24.0 /
"""

TOPOLOGY = [
    ("a node joined to nothing, driven by nothing",
     "&run t_end = 0.01, dt = 1.0e-4 /\n&node id = 'a', type = 'inertia', inertia = 5.0 /\n"
     "&node id = 'b', type = 'inertia', inertia = 11.0 /\n&node id = 'spare', type = 'inertia', inertia = 1.0 /\n"
     "&element type = 'shaft', stiffness = 1.0e5 /\n&load node = 'a', value = 10.0 /\n",
     2, ["deck.nml:4:", "'spare'", "joined to no element"]),
    ("a part cut off by a missing element",
     "&run t_end = 0.01, dt = 1.0e-4 /\n&node id = 'a', type = 'inertia', inertia = 5.0 /\n"
     "&node id = 'b', type = 'inertia', inertia = 11.0 /\n&node id = 'c', type = 'inertia', inertia = 1.0 /\n"
     "&node id = 'd', type = 'inertia', inertia = 1.0 /\n"
     "&element left = 'a', right = 'b', type = 'shaft', stiffness = 1.0e5 /\n"
     "&element left = 'c', right = 'd', type = 'shaft', stiffness = 1.0e5 /\n&load node = 'a', value = 10.0 /\n",
     2, ["deck.nml:4:", "'c', 'd'", "stays at rest"]),
    ("two driven trains side by side",
     "&run t_end = 0.01, dt = 1.0e-4 /\n&node id = 'a', type = 'inertia', inertia = 5.0 /\n"
     "&node id = 'b', type = 'inertia', inertia = 11.0 /\n&node id = 'c', type = 'inertia', inertia = 1.0 /\n"
     "&node id = 'd', type = 'inertia', inertia = 1.0 /\n"
     "&element left = 'a', right = 'b', type = 'shaft', stiffness = 1.0e5 /\n"
     "&element left = 'c', right = 'd', type = 'shaft', stiffness = 1.0e5 /\n&load node = 'a', value = 10.0 /\n"
     "&initial node = 'c', speed = 3.0 /\n",
     0, ["deck.nml:4:", "warning", "2 unconnected parts", "'c'"]),
    ("one node alone (a one-mass train) is no topology slip",
     "&run t_end = 0.01, dt = 1.0e-4 /\n&node id = 'a', type = 'inertia', inertia = 5.0 /\n"
     "&load node = 'a', value = 10.0 /\n", 0, []),
]


def main():
    exe = os.path.abspath(sys.argv[1])
    with open("tests/decks/tracker_si_start_stop.nml") as f:
        si_base = f.read()
    with tempfile.TemporaryDirectory(prefix="trainsim-plaus-") as tmp:
        # 1, 2: the slips
        for si, base in ((True, si_base), (False, INCH)):
            with open(os.path.join(tmp, "base.nml"), "w") as f:
                f.write(base)
            code, err = run(exe, ["run", "base.nml", "--no-output", "--set", "run.t_end=2e-4"], tmp)
            check(f"{'SI' if si else 'inch'} base deck runs with no message", code == 0 and err.strip() == "",
                  err[-400:])
            for name, text, key, kind in slip_cases(base, si):
                with open(os.path.join(tmp, "slip.nml"), "w") as f:
                    f.write(text)
                code, err = run(exe, ["run", "slip.nml", "--no-output", "--set", "run.t_end=2e-4"], tmp)
                names_key = f"key '{key}'" in err and "slip.nml:" in err
                if kind not in ("error", "warning", None):   # a phrase the error must hold
                    ok = code == 2 and names_key and kind in err
                elif kind == "error":
                    ok = code == 2 and names_key and ": error: " in err
                elif kind == "warning":
                    ok = code == 0 and names_key and ": warning: " in err
                else:   # either, as long as the key is named
                    ok = code in (0, 2) and names_key
                check(f"{'SI' if si else 'inch'} slip '{name}': {kind or 'message'} naming key '{key}'", ok,
                      f"exit {code}: {err.strip()[-500:]}")
                if kind == "warning":
                    code, err = run(exe, ["run", "slip.nml", "--no-output", "--strict", "--set", "run.t_end=2e-4"],
                                    tmp)
                    check(f"  ... --strict makes it exit 2", code == 2 and "--strict" in err, err[-300:])
                    with open(os.path.join(tmp, "slip.nml"), "a") as f:
                        f.write("&sweep parameter = 'run.t_end', values = 2e-4, 3e-4 /\n")
                    sw = f"sw_{'si' if si else 'inch'}_{len(name)}_{key}"
                    code, err = run(exe, ["sweep", "slip.nml", "-o", sw + ".h5", "--strict"], tmp)
                    check(f"  ... sweep --strict exits 2 before any run, naming the key",
                          code == 2 and f"key '{key}'" in err and not os.path.exists(os.path.join(tmp, sw + ".h5")),
                          err[-300:])
                    code, err = run(exe, ["sweep", "slip.nml", "-o", sw + "_2.h5"], tmp)
                    check(f"  ... sweep without --strict runs, with the warning", code == 0 and ": warning: " in err,
                          err[-300:])
        # 3: topology
        for name, text, code_expected, subs in TOPOLOGY:
            with open(os.path.join(tmp, "deck.nml"), "w") as f:
                f.write(text)
            code, err = run(exe, ["run", "deck.nml", "--no-output"], tmp)
            missing = [s for s in subs if s not in err]
            check(f"topology: {name}: exit {code_expected}", code == code_expected and not missing
                  and (subs or err.strip() == ""), f"exit {code}, missing {missing}: {err.strip()[-400:]}")
    # 4: no message on any valid deck
    decks = sorted(glob.glob("inputs/*.nml") + glob.glob("verification/**/*.nml", recursive=True)
                   + glob.glob("tests/decks/*.nml"))
    kinds_si, kinds_inch = set(), set()
    for deck in decks:
        with open(deck) as f:
            text = f.read()
        si = re.search(r"units\s*=\s*'si'", text, re.I) is not None
        types = set(re.findall(r"type\s*=\s*'(\w+)'", text))
        (kinds_si if si else kinds_inch).update(types)
        code, err = run(exe, ["modes", os.path.abspath(deck)], os.getcwd())
        msgs = [ln for ln in err.splitlines() if "warning" in ln or "error" in ln]
        check(f"{deck} ({'SI' if si else 'inch'}): no plausibility message", code == 0 and not msgs,
              "\n        ".join(msgs)[:600])
    every = {"inertia", "dc_motor", "shaft", "ideal_gear", "spur_gear", "helical_gear", "keyed_joint",
             "clearance_coupling", "damper"}
    check("the valid SI decks cover every node and element kind", every <= kinds_si, str(every - kinds_si))
    check("the valid inch decks cover every node and element kind", every - {"damper"} <= kinds_inch,
          str(every - kinds_inch))
    print("failed" if failed else "all passed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
