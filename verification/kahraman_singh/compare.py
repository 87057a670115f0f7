#!/usr/bin/python3
"""Run trainsim's Kahraman-Singh-type sweep (inputs/sweep_kahraman_singh.nml) and compare it
with the independent reference (ks_reference.py) on the same grid of Omega, up and down.

    compare.py TRAINSIM [--short] [--ref REF.json] [--h5 SWEEP.h5] [--table]

Per point: the regime (no_impact / single_sided / double_sided), the response amplitude
x_amp = (max - min)/2 of the dynamic transmission error over the measured cycles, in units
of the half backlash b; per branch: the grid intervals of the jumps (neighbours whose
regime changes between neighbours). Exit 0 when everything agrees within the
tolerances (README.md, "Tolerances"), 1 when not, 77 when this trainsim does not have the
spur gear's Fourier stiffness and TE keys yet (mesh26's; the comparison is then not made).

--short: the CTest's version, 8 values of Omega (0.35 to 0.7 by 0.05, both branches): the up-sweep's
jump bracketed (0.60 -> 0.65), the hysteresis (0.60 single-sided down), double-sided at 0.40 down
and the jump down 0.40 -> 0.35, with the reference computed here on the same grid.
"""
import argparse
import json
import math
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
import ks_reference as ref  # noqa: E402

F_UNIT = 291.59642622813755     # teeth/s at Omega = 1: omega_n / (2 pi), README "Mapping"
B = 0.005                       # half backlash, in
FOURIER_DECK = os.path.join(ROOT, "inputs", "sweep_kahraman_singh.nml")
# The cases: the deck, the reference's parameters, the full grid and the CTest's short one.
CASES = {
    "fourier": {"deck": FOURIER_DECK,
                "params": ref.DEFAULT,
                "full": [0.3 + 0.0125 * i for i in range(41)],
                "short": [0.35, 0.4, 0.45, 0.5, 0.55, 0.6, 0.65, 0.7]},
    "two_level": {"deck": os.path.join(HERE, "two_level_sweep.nml"),
                  "params": dict(ref.DEFAULT, e=[0.0, 0.0, 0.0], two_level={"c2": 1.8, "mp": 1.6676}),
                  "full": [0.8 + 0.025 * i for i in range(29)],
                  "short": [0.9, 0.95, 1.0, 1.1, 1.2]},
}
DECK = CASES["fourier"]["deck"]

# Tolerances (README.md): both sides integrate the same ODE with RK4 and located events.
AMP_RTOL = 1e-4      # settled, same regime: amplitude to 1e-4 relative (README "Tolerances")
AMP_ATOL = 3e-5      # plus 3e-5 b: what trainsim's settle_tol 1e-6 (of delta's scale, up to 2.6 b) leaves
MEASURE = 40         # measured mesh cycles (the sweep deck's measure_cycles, the reference's measure)
JUMP_STEPS = 1       # a jump's grid interval may move by one grid step (slow transient at a fold)


def sweep_deck(values, deck=None):
    """The bundled sweep deck with its Omega grid replaced by `values` (mesh frequencies)."""
    text = open(deck or DECK).read()
    vals = ", ".join("%.9g" % v for v in values)
    new, n = re.subn(r"&sweep parameter = 'mesh.mesh_frequency'[^/]*/",
                     "&sweep parameter = 'mesh.mesh_frequency', values = %s, continuation = 'both' /" % vals, text)
    assert n == 1
    return new


def has_fourier_keys(exe):
    """Whether this trainsim reads the spur gear's Fourier stiffness / TE keys."""
    with tempfile.TemporaryDirectory() as tmp:
        deck = os.path.join(tmp, "probe.nml")
        with open(DECK) as f:
            text = f.read()
        open(deck, "w").write(text)
        r = subprocess.run([exe, "run", deck, "--no-output", "--set", "run.t_end=1e-4", "--set", "run.settle_tol=0"],
                           capture_output=True, text=True, timeout=120)
        if r.returncode == 2 and re.search(r"unknown key '(stiffness_model|stiffness_harmonics|te_harmonics|"
                                           r"stiffness_phases|te_phases)'", r.stderr):
            return False, r.stderr.strip().splitlines()[-1]
        if r.returncode != 0:
            raise SystemExit("trainsim failed on the probe run (exit %d): %s" % (r.returncode, r.stderr[-500:]))
        return True, ""


def run_trainsim(exe, values, h5, src=None):
    with tempfile.TemporaryDirectory() as tmp:
        deck = os.path.join(tmp, "ks_sweep.nml")
        open(deck, "w").write(sweep_deck(values, src))
        if os.path.exists(h5):
            os.remove(h5)
        r = subprocess.run([exe, "sweep", deck, "-o", h5, "--progress", "0"], capture_output=True, text=True,
                           timeout=3000)
        if r.returncode != 0:
            raise SystemExit("trainsim sweep failed (exit %d): %s" % (r.returncode, r.stderr[-800:]))


def read_sweep(h5, e_tot):
    import h5py
    out = {"up": [], "down": []}
    with h5py.File(h5, "r") as f:
        names = list(f["parameters/names"].asstr()[:])
        fcol = names.index("mesh.mesh_frequency")
        freq = f["parameters/values"][:, fcol]
        k = list(f["elements/ids"].asstr()[:]).index("mesh")
        dmin = f["elements/disp_min"][:, k]
        dmax = f["elements/disp_max"][:, k]
        sep = f["elements/separations"][:, k]
        imp = f["elements/impacts"][:, k]
        branch = f["runs/branch"][:]
        settled = f["runs/settled"][:]
        status = f["runs/status"][:]
        ncyc = None
    for i in range(len(freq)):
        om = freq[i] / F_UNIT
        xmin, xmax = dmin[i] / B, dmax[i] / B
        if sep[i] == 0:
            reg = "no_impact"
        elif xmin < -1.0 - e_tot:
            reg = "double_sided"          # q = x - e < -1 for sure
        elif xmin > -1.0 + e_tot:
            reg = "single_sided"          # q > -1 for sure
        else:
            reg = "undetermined"
        p = {"run": i, "omega": om, "regime": reg, "x_min": xmin, "x_max": xmax, "x_amp": 0.5 * (xmax - xmin),
             "separations": int(sep[i]), "impacts": int(imp[i]), "settled": int(settled[i]), "status": int(status[i])}
        out["up" if branch[i] == 1 else "down"].append(p)
    out["up"].sort(key=lambda p: p["omega"])
    out["down"].sort(key=lambda p: -p["omega"])
    return out


def resolve_band(exe, src, h5, p):      # src: the sweep deck's text
    """The regime of a run whose TE range leaves it open ("undetermined"): the run is made
    again alone, from the start state the sweep recorded for it (the previous run's end
    angles and its own start speeds, D-43), with the sweep's settle and measure cycles, and
    its own event log says whether a rear-face contact (kind 2) falls in the measured window."""
    import h5py
    i = p["run"]
    with h5py.File(h5, "r") as f:
        ids = list(f["nodes/ids"].asstr()[:])
        branch = f["runs/branch"][:]
        freq = f["parameters/values"][:, list(f["parameters/names"].asstr()[:]).index("mesh.mesh_frequency")]
        same = [j for j in range(len(branch)) if branch[j] == branch[i]]
        same.sort(key=lambda j: freq[j] if branch[i] == 1 else -freq[j])
        k = same.index(i)
        if k == 0:
            return p["regime"]                  # a branch's first run starts from the preload
        ang = f["nodes/end_angle"][same[k - 1], :]
        spd = f["nodes/start_speed"][i, :]
    text = src
    text = re.sub(r"&sweep[^/]*/\n?", "", text)
    text = re.sub(r",?\s*initial_state = 'preload'", "", text)
    text = re.sub(r"&initial[^/]*/\n?", "", text)
    text += "".join("&initial node = '%s', angle = %.17g, speed = %.17g /\n" % (n, a, w)
                    for n, a, w in zip(ids, ang, spd))
    with tempfile.TemporaryDirectory() as tmp:
        deck = os.path.join(tmp, "ks_point.nml")
        out = os.path.join(tmp, "ks_point.h5")
        open(deck, "w").write(text)
        r = subprocess.run([exe, "run", deck, "-o", out, "--set", "mesh.mesh_frequency=%.17g" % freq[i],
                            "--set", "mesh.settle_cycles=100", "--set", "mesh.measure_cycles=40",
                            "--set", "mesh.settle_max_cycles=2000", "--set", "run.output_interval=1e-3"],
                           capture_output=True, text=True, timeout=600)
        if r.returncode != 0:
            raise SystemExit("trainsim run (band point) failed: " + r.stderr[-500:])
        with h5py.File(out, "r") as f:
            t0 = f["run_stats"].attrs["t_metrics"]
            kind = f["events/kind"][:]
            t = f["events/time"][:]
            sep = int(f["metrics/separations"][0])
    if sep != p["separations"]:
        raise SystemExit("run %d made alone: %d separations, in the sweep %d" % (i, sep, p["separations"]))
    return "double_sided" if ((kind == 2) & (t >= t0)).any() else "single_sided"


def reference(omegas, steps=128, params=None):
    m = ref.Model(params or ref.DEFAULT)
    kw = dict(steps_per_period=steps, settle_min=100, settle_max=2000, measure=40)
    return {"up": ref.sweep(m, omegas, **kw), "down": ref.sweep(m, omegas[::-1], **kw)}


def jump_index(points):
    """Jumps of a branch: the grid intervals where the regime changes between neighbours."""
    return [i for i in range(len(points) - 1) if points[i]["regime"] != points[i + 1]["regime"]]


def settled(p):
    return bool(p["settled"]) and p["settled"] != -1


def compare(ts, rf, table=False):
    failures = []
    rows = []
    for br in ("up", "down"):
        a, b = ts[br], rf[br]
        if len(a) != len(b):
            failures.append("%s: %d trainsim runs, %d reference points" % (br, len(a), len(b)))
            continue
        ja, jb = jump_index(a), jump_index(b)
        moved = set()      # points between a jump's two positions, when it moved by a grid step
        if len(ja) != len(jb) or any(abs(x - y) > JUMP_STEPS for x, y in zip(ja, jb)):
            failures.append("%s: jumps at %s (trainsim) vs %s (reference)" % (
                br, [(round(a[j]["omega"], 4), round(a[j + 1]["omega"], 4)) for j in ja],
                [(round(b[j]["omega"], 4), round(b[j + 1]["omega"], 4)) for j in jb]))
        else:
            for x, y in zip(ja, jb):
                moved.update(range(min(x, y) + 1, max(x, y) + 1))
        for i, (p, q) in enumerate(zip(a, b)):
            if abs(p["omega"] - q["omega"]) > 1e-6:
                failures.append("%s: grids differ at %d: %g vs %g" % (br, i, p["omega"], q["omega"]))
                continue
            rel = abs(p["x_amp"] - q["x_amp"]) / q["x_amp"]
            transient = not (settled(p) and settled(q))
            ok_reg = p["regime"] == q["regime"] or i in moved
            ok_amp = abs(p["x_amp"] - q["x_amp"]) <= AMP_RTOL * q["x_amp"] + AMP_ATOL or transient or i in moved
            if p["status"] != 1:
                failures.append("%s Omega %.4f: trainsim run failed" % (br, p["omega"]))
            if not ok_reg:
                failures.append("%s Omega %.4f: regime %s (trainsim) vs %s (reference)" % (
                    br, p["omega"], p["regime"], q["regime"]))
            n_ref = int(round(q["separations_per_period"] * MEASURE))
            if not (transient or i in moved) and p["separations"] != n_ref:
                failures.append("%s Omega %.4f: %d separations in the %d measured cycles (trainsim) vs %d (reference)"
                                % (br, p["omega"], p["separations"], MEASURE, n_ref))
            if not ok_amp:
                failures.append("%s Omega %.4f: amplitude %.6f (trainsim) vs %.6f (reference): beyond %.0e relative + %.0e" % (
                    br, p["omega"], p["x_amp"], q["x_amp"], AMP_RTOL, AMP_ATOL))
            rows.append((br, p["omega"], q["regime"], p["regime"] + (" (events)" if p.get("resolved") else ""),
                         q["x_amp"], p["x_amp"], rel, q["separations_per_period"] * MEASURE, p["separations"], "%d/%d" % (settled(q), settled(p)),
                         transient or i in moved))
    if table:
        print("| branch | Omega | regime (reference) | regime (trainsim) | x_amp reference | x_amp trainsim | "
              "rel. diff | separations ref. | separations trainsim | settled ref./trainsim | exempt |")
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        for r in rows:
            print("| %s | %.4f | %s | %s | %.5f | %.5f | %.1e | %.0f | %d | %s | %s |" % (
                r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8], r[9], "yes" if r[10] else ""))
    else:
        for r in rows:
            print("%-4s Omega %.4f  ref %-12s %.5f   trainsim %-12s %.5f   rel %.2e%s" % (
                r[0], r[1], r[2], r[4], r[3], r[5], r[6], "  (exempt: transient or moved jump)" if r[10] else ""))
    for br in ("up", "down"):
        print("jumps %s: reference %s, trainsim %s" % (
            br, [(round(rf[br][j]["omega"], 4), round(rf[br][j + 1]["omega"], 4)) for j in jump_index(rf[br])],
            [(round(ts[br][j]["omega"], 4), round(ts[br][j + 1]["omega"], 4)) for j in jump_index(ts[br])]))
    return failures


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("trainsim")
    ap.add_argument("--short", action="store_true")
    ap.add_argument("--case", choices=sorted(CASES), default="fourier",
                    help="fourier: the Kahraman-Singh-type case; two_level: TRAIN's two-level stiffness, no TE")
    ap.add_argument("--ref", help="reference JSON from ks_reference.py sweep (the full grid)")
    ap.add_argument("--h5", help="sweep file to write (default: a temporary file)")
    ap.add_argument("--table", action="store_true", help="print a Markdown table")
    args = ap.parse_args()
    case = CASES[args.case]
    ok, why = has_fourier_keys(args.trainsim) if args.case == "fourier" else (True, "")
    if not ok:
        print("WAITING: this trainsim has no Fourier mesh stiffness / TE keys yet (issue 26, mesh26): " + why)
        print("the Kahraman-Singh comparison is not made (skipped, not passed)")
        sys.exit(77)
    e_tot = sum(abs(x) for x in case["params"]["e"])
    if args.short:
        omegas = case["short"]
        rf = reference(omegas, params=case["params"])
    else:
        if args.ref:
            rf = json.load(open(args.ref))
        else:
            rf = reference(case["full"], params=case["params"])
        omegas = [p["omega"] for p in rf["up"]]
    with tempfile.TemporaryDirectory() as tmpdir:
        h5 = args.h5 or os.path.join(tmpdir, "ks.h5")
        run_trainsim(args.trainsim, [o * F_UNIT for o in omegas], h5, case["deck"])
        ts = read_sweep(h5, e_tot)
        for br in ("up", "down"):
            for p in ts[br]:
                if p["regime"] == "undetermined":
                    p["regime"] = resolve_band(args.trainsim, sweep_deck([o * F_UNIT for o in omegas], case["deck"]),
                                               h5, p)
                    p["resolved"] = True
    failures = compare(ts, rf, args.table)
    if failures:
        print("FAIL (%d):" % len(failures))
        for f_ in failures:
            print("  " + f_)
        sys.exit(1)
    print("ok: regimes, jumps and amplitudes agree within the tolerances (amplitude %.0e relative + %.0e b, jumps %d grid step)"
          % (AMP_RTOL, AMP_ATOL, JUMP_STEPS))


if __name__ == "__main__":
    main()
