#!/usr/bin/env python3
"""Table 7.1 damped, continued down from 450 teeth/s with restarts: past the failed point the
branch is shot again from a transient that carries every contact's memory as a run does
(D-156).

Table 7.1 with 500 lb in s/rad on its three shafts: the branch from 450 keeps both meshes in
contact (memory of its start: D = 0), grazes at 433.25 and 426.66 (the meshes begin to
strike), goes on with t0 in mesh1's struck contact (12 points the map restarts with the
held D, warned, D-144) and its corrector fails at 365.906 teeth/s (reason 2). The restarts
shoot the orbit 1 % further down from that state through a transient. Before D-156 the
transient restarted at every period a contact closed at t0 that had opened before (`kept`
false) with the law's start, and Newton met M - I singular: three restarts failed and the
branch stopped at 352.4 (status 1). Now the transient holds every memory, and shooting
checks the converged orbit's open pattern: the second restart (356.906) lands on a
contact-keeping orbit with the memory of the transient's impacts (yang_sun D 82 914 /
57 598, held) - the settled sweep keeps contact at 260-363 teeth/s at this damping
(verification/continuation/README.md) - and the branch reaches the end of its range.
Asserted: the failure at 365.906 (1e-3, reason 2), the branch at the end of its range
(status 0), a last segment of at least 5 points from below 360 down past 335, each with
no impact on either mesh and both memories held with D > 1000.

Usage: check_continue_struck.py TRAINSIM
"""
import os
import tempfile

import h5py

from clicheck import check, finish, run

deck = os.path.abspath("inputs/sweep_two_clearance.nml")
damped = [a for sh in ("shaft1", "shaft3", "shaft5") for a in ("--set", f"{sh}.damping=500")]

with tempfile.TemporaryDirectory() as tmp:
    out = os.path.join(tmp, "down.h5")
    r = run(["continue", deck, *damped, "--param", "mesh1.mesh_frequency=450:335", "--restarts", "3", "-o", out])
    check("450 -> 335 with restarts: exit 1 (failed points), not stopped early",
          r.returncode == 1 and "stopped early" not in r.stderr, r.stderr)
    with h5py.File(out, "r") as f:
        n = int((f["runs/status"][:] != 0).sum())
        lam = f["parameters/values"][:n, 0]
        reason, seg = f["runs/reason"][:n], f["runs/segment"][:n]
        mem, held = f["branch/memory"][:n], f["branch/memory_held"][:n]
        imp = f["elements/impacts"][:n]
        ids = list(f["elements/ids"].asstr()[:])
        end = int(f["branch/status"][0])
    m1, m2 = ids.index("mesh1"), ids.index("mesh2")
    fails = [(round(float(lam[i]), 3), int(reason[i])) for i in range(n) if reason[i] != 0]
    print(f"     {n} points, failed {fails}, end status {end}")
    check("the corrector fails at 365.906 (reason 2)", any(abs(l - 365.906) < 1e-3 and c == 2 for l, c in fails), fails)
    check("the branch reaches the end of its range (status 0)", end == 0, end)
    last = [i for i in range(n) if seg[i] == seg[n - 1] and reason[i] == 0]
    print(f"     last segment: {len(last)} points, {lam[last[0]]:.3f} -> {lam[last[-1]]:.3f}, memory {mem[last[0]]}")
    check("a last segment of >= 5 points from below 360 to below 335",
          len(last) >= 5 and lam[last[0]] < 360 and lam[last[-1]] < 335, (len(last), lam[last]))
    check("each keeps contact on both meshes with the transient's memory held (D > 1000)",
          all(imp[i][m1] == 0 and imp[i][m2] == 0 and (held[i] == 1).all() and mem[i][0] > 1000 and mem[i][3] > 1000
              for i in last))

finish()
