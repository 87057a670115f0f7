"""The closed-form steady response of the Table 5.5 rig with a linear gear mesh, for the
gear-metric checks (check_gear_metrics.py, check_helical_metrics.py).

The driver's drive inertia held at a constant speed; the pinion J2, the gear J3 and the
load J4 free, shafts K1 with damping CS either side of the mesh (stiffness k, damping c
along the line of action, base radii rb both); a harmonic torque T1 on the gear at W rad/s.

check(ok, text) and finish() are the two scripts' shared verdicts.
"""
import sys

import numpy as np

_fails = 0


def check(ok, text):
    """Print "ok   TEXT" or "FAIL TEXT" and count the failures."""
    global _fails
    print(("ok   " if ok else "FAIL ") + text)
    _fails += not ok


def finish():
    """Exit 1 when a check failed, else 0."""
    print("FAILED: %d check(s)" % _fails if _fails else "all checks passed")
    sys.exit(1 if _fails else 0)


def harmonic_mesh_response(k, c, rb, w, t1, cs, k1=32000.0, inertias=(0.987, 0.987, 100.0)):
    """(TE amplitude, mesh-force amplitude) from the complex solve of K - W^2 M + i W C."""
    km, cm = k * rb * rb, c * rb * rb
    stiff = np.array([[k1 + km, -km, 0], [-km, km + k1, -k1], [0, -k1, k1]])
    damp = np.array([[cs + cm, -cm, 0], [-cm, cm + cs, -cs], [0, -cs, cs]])
    x = np.linalg.solve(stiff - w * w * np.diag(inertias) + 1j * w * damp, np.array([0, t1, 0]))
    return rb * abs(x[0] - x[1]), abs((k + 1j * w * c) * rb * (x[0] - x[1]))
