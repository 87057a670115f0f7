"""No wrong answer with exit 0 (issue 20 item 3, D-55): a sweep of contact law x
damping x start x integrator x dt on one loaded gear mesh (the GHM rig's mesh,
798.8 lb-in through it, as ../shared/repro/smith_law_creep.nml). Every run must
  - exit 2 (refused before the first step) or 1 (stopped while running), with a
    message that names the node or element, or
  - exit 0 with a physically bounded answer: the mesh displacement within the
    half backlash plus 5x the larger of the static deflection under the load
    (F/k, F = 798.8/3.7588 lbf) and the penetration of the start's impact
    (V sqrt(m_eff/k)), and an energy residual below 1e-2 of the energy scale
    (a correct run keeps it near 1e-6; the limits come from the mechanics, not
    from what the code printed).
Also: the Smith deck itself is refused under rk4 at the rig's dt, and cvode-bdf
gives its creep to 212.5 lbf (= 798.8/3.7588) with the displacement 0.005..0.0051 in.
Usage: check_contact_stability.py TRAINSIM [--quick]"""
import math, os, re, subprocess, sys, tempfile

exe = os.path.abspath(sys.argv[1])
quick = "--quick" in sys.argv

K, RB, J, B, T = 234500.0, 3.7588, 0.987, 0.005, 798.8
M_EFF = 1.0 / (2.0 * RB**2 / J)
F_STATIC = T / RB
V_IMPACT = RB * 2.0                     # n1 starts at 2 rad/s against n2 at rest
LAWS = {
    "goldsmith": "restitution_law = 'goldsmith'",
    "smith": "restitution_law = 'smith'",
    "constant_e0.3": "restitution_law = 'constant', restitution = 0.3",
    "smith_vmin1e-6": "restitution_law = 'smith', min_approach_velocity = 1.0e-6",
    "linear_d10": "contact_law = 'linear', contact_damping = 10.0",
    "linear_d1e4": "contact_law = 'linear', contact_damping = 1.0e4",
    "linear_d1e6": "contact_law = 'linear', contact_damping = 1.0e6",
    "elasto_d10": "contact_law = 'elasto_backlash', contact_damping = 10.0",
    "elasto_d1e4": "contact_law = 'elasto_backlash', contact_damping = 1.0e4",
    "elasto_d1e6": "contact_law = 'elasto_backlash', contact_damping = 1.0e6",
}
FIXED = ["rk4", "rk4-thesis", "euler"]
ADAPTIVE = ["cvode-bdf", "cvode-adams", "arkode-dp", "arkode-verner"]
DTS = [8.0e-6, 1.0e-6]
STARTS = ["closed", "impact"]
if quick:
    LAWS = {k: LAWS[k] for k in ("smith", "linear_d1e6", "elasto_d1e4")}
    ADAPTIVE = ["cvode-bdf", "arkode-dp"]


def deck(law, start, integ, dt):
    if start == "closed":
        init = ("&initial node = 'n1', angle = 0.0013302117697137385 /\n"
                "&initial node = 'n2', angle = 0.0 /\n")
        if "contact_law" not in LAWS[law]:
            law_keys = LAWS[law] + ", initial_contact_velocity = 1.0e-3"
        else:
            law_keys = LAWS[law]
    else:
        init = "&initial node = 'n1', angle = 0.0, speed = 2.0 /\n&initial node = 'n2', angle = 0.0 /\n"
        law_keys = LAWS[law]
    return (f"&run t_end = 0.005, dt = {dt!r}, integrator = '{integ}', output_interval = 1.0e-4 /\n"
            f"&node id = 'n1', type = 'inertia', inertia = {J} /\n"
            f"&node id = 'n2', type = 'inertia', inertia = {J} /\n"
            f"&element id = 'mesh', type = 'spur_gear', stiffness = {K}, rb_driver = {RB}, rb_driven = {RB},\n"
            f"         teeth = 32, contact_ratio = 1.6676, approach_angle = 0.1637, half_backlash = {B},\n"
            f"         {law_keys} /\n"
            f"&load node = 'n1', kind = 'constant', value = {T} /\n"
            f"&load node = 'n2', kind = 'constant', value = {-T} /\n" + init)


def run(text, tmp):
    path = os.path.join(tmp, "deck.nml")
    with open(path, "w") as f:
        f.write(text)
    try:
        r = subprocess.run([exe, "run", "deck.nml", "--no-output"], cwd=tmp, capture_output=True, text=True,
                           timeout=120)
        return r.returncode, r.stdout, r.stderr
    except subprocess.TimeoutExpired:
        return None, "", "timeout"


def summary(out):
    m = re.search(r"max \|residual\|\s+(\S+) \(energy scale\s+([^\s)]+)", out)
    res, scale = (float(m.group(1)), float(m.group(2))) if m else (math.nan, math.nan)
    d = re.search(r"^\s+mesh\s+spur_gear\s+(\S+)\s+(\S+)\s+(\S+)\s+(\S+)", out, re.M)
    dmin, dmax = (float(d.group(3)), float(d.group(4))) if d else (math.nan, math.nan)
    return res, scale, dmin, dmax


failed = 0
counts = {0: 0, 1: 0, 2: 0}
with tempfile.TemporaryDirectory() as tmp:
    cases = []
    for law in LAWS:
        for start in STARTS:
            for integ in FIXED:
                for dt in DTS:
                    cases.append((law, start, integ, dt))
            for integ in ADAPTIVE:
                cases.append((law, start, integ, 1.0e-6))
    for law, start, integ, dt in cases:
        rc, out, err = run(deck(law, start, integ, dt), tmp)
        msg = [l for l in err.splitlines() if l.startswith("trainsim:") and "warning" not in l]
        label = f"{law:15s} {start:6s} {integ:13s} dt={dt:.0e}"
        ok = rc in (0, 1, 2) and "Backtrace" not in err and "runtime error" not in err.lower()
        why = ""
        if rc in (1, 2):
            ok = ok and bool(msg) and ("element 'mesh'" in msg[0] or "node '" in msg[0])
            why = msg[0][:140] if msg else "no message"
        elif rc == 0:
            res, scale, dmin, dmax = summary(out)
            p = max(F_STATIC / K, V_IMPACT * math.sqrt(M_EFF / K) if start == "impact" else 0.0)
            bound = B + 5.0 * p
            bounded = max(abs(dmin), abs(dmax)) <= bound
            # Euler is first order: its ledger error is O(dt) (the run-time check's 0.1 of the scale)
            balanced = res <= (1.0e-1 if integ == "euler" else 1.0e-2) * scale
            ok = ok and bounded and balanced
            why = f"disp {dmin:.4g}..{dmax:.4g} (bound {bound:.4g}), residual {res:.3g} of {scale:.3g}"
        else:
            why = err[-200:]
        if rc in counts:
            counts[rc] += 1
        if not ok:
            failed += 1
        print(f"{'ok  ' if ok else 'FAIL'} {label}: exit {rc} {why}")

    # the reproducer's own deck: refused under rk4 at dt 8e-6; cvode-bdf's creep to 212.5 lbf
    smith = deck("smith", "closed", "rk4", 8.0e-6).replace("t_end = 0.005", "t_end = 0.01")
    rc, out, err = run(smith, tmp)
    ok = rc == 2 and "element 'mesh'" in err and "dt below" in err
    print(f"{'ok  ' if ok else 'FAIL'} smith deck under rk4 at dt 8e-6: exit {rc}")
    failed += 0 if ok else 1
    with open(os.path.join(tmp, "deck.nml"), "w") as f:
        f.write(smith.replace("'rk4'", "'cvode-bdf'"))
    r = subprocess.run([exe, "run", "deck.nml", "-o", "out.h5"], cwd=tmp, capture_output=True, text=True)
    import h5py
    with h5py.File(os.path.join(tmp, "out.h5"), "r") as h:
        force = h["elements/force"][()].reshape(len(h["time"]), -1)[:, 0]
        disp = h["elements/displacement"][()].reshape(len(h["time"]), -1)[:, 0]
    ok = r.returncode == 0 and force is not None and abs(abs(force[-1]) - F_STATIC) <= 1e-3 * F_STATIC
    ok = ok and disp is not None and disp.min() >= B - 1e-12 and disp.max() <= B + 1.2 * F_STATIC / K
    print(f"{'ok  ' if ok else 'FAIL'} smith deck under cvode-bdf: exit {r.returncode}, final force "
          f"{abs(force[-1]) if force is not None else 'n/a'} lbf (expected {F_STATIC:.4f}), disp "
          f"{disp.min() if disp is not None else 'n/a'}..{disp.max() if disp is not None else 'n/a'} in")
    failed += 0 if ok else 1

print(f"{len(cases) + 2 - failed} passed, {failed} failed; exits: {counts}")
sys.exit(1 if failed else 0)
