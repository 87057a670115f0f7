#!/usr/bin/python3
"""Settling until periodic (D-44), continuation start states (D-43) and the limits of the
derived run times (D-45). One case per CTest entry:

    /usr/bin/python3 tests/cli/check_settle.py <trainsim> <case>

cases:
  oscillator    a damped linear oscillator (J, k, c to a fixed node) forced by a sine at
                twice its damped natural frequency and sampled once per forcing period
                T = pi/omega_d: the particular solution repeats exactly and the transient
                alternates in sign, so r_1(j) = |x_j - x_(j-1)| / scale follows in closed form
                (exp(-zeta omega_n t) times constants of the initial state). trainsim must
                report settled with k = 1 within 2 periods of the first j where the closed
                form's r_1 <= settle_tol, and start its metrics there; run from the start
                without settling it measures the transient (larger p2p range)
  period2       the same oscillator forced at half that frequency, sampled every T: the
                steady response repeats after 2 periods and changes sign after one, so
                settle_k must be 2, within 2 periods of the closed form's prediction
  budget        a budget shorter than the closed-form settling: reported as not settled
                (run: summary line and /run_stats settled = 0; sweep: /runs/settled = 0),
                and a settled sweep run reads /runs/settled = 1; without settle_tol, a
                fixed settle_time gets a verdict: the GHM rig at 545 teeth/s (separating
                until cycle 127) is not settled after 100 cycles, settled after 300
  continuation  continuation branches start from the previous run's end state moved by the
                change of nominal speed: a free inertia at nominal 10 rad/s and at 0 rad/s
                (start speeds 10, 11, 12, 13, 14 and 0, 1, 2, 3, 4 under 1 N.m for 1 s: end
                speeds + 0), and the GHM rig's up/down mesh-frequency branches (start =
                previous end + 2 pi (f_new - f_old) / 32 on every free node)
  limits        derived cycle counts cannot take a run beyond the &run limits: measure_cycles
                = 1e300 by --set (run and sweep) and settle_cycles beyond t_end exit 2 naming
                the argument; settle_time at or beyond t_end exits 2 naming the key
"""

import math
import os
import subprocess
import sys
import tempfile

import h5py
import numpy as np

TIMEOUT = 600
FAILS = []


def check(what, cond, detail=""):
    print(("ok   " if cond else "FAIL ") + what + (f": {detail}" if detail else ""))
    if not cond:
        FAILS.append(what)


def run(cmd, cwd):
    return subprocess.run(cmd, cwd=cwd, capture_output=True, text=True, timeout=TIMEOUT)


# ---------------------------------------------------------------- the oscillator
J, FN, ZETA, F0 = 1.0, 10.0, 0.02, 100.0
WN = 2 * math.pi * FN
K = J * WN ** 2
C = 2 * ZETA * WN * J
SIGMA = ZETA * WN
WD = WN * math.sqrt(1 - ZETA ** 2)
T = math.pi / WD          # the settle period: half the damped natural period


def osc_deck(forcing_hz, tol, t_end, extra=""):
    return (f"&run title = 'forced damped oscillator', units = 'si', t_end = {t_end!r}, dt = 1.0e-4, "
            f"output_interval = 1.0e-3, settle_tol = {tol!r}, settle_period = {T!r}{extra} /\n"
            "&node id = 'g', type = 'fixed' /\n"
            f"&node id = 'm', type = 'inertia', inertia = {J!r} /\n"
            f"&element id = 's', type = 'shaft', left = 'm', right = 'g', stiffness = {K!r}, damping = {C!r} /\n"
            f"&load node = 'm', kind = 'sine', amplitude = {F0!r}, frequency = {forcing_hz!r} /\n")


def closed_form(omega_f):
    """x(t), v(t) from rest under F0 sin(omega_f t): J x'' + c x' + k x = F."""
    X = F0 / math.hypot(K - J * omega_f ** 2, C * omega_f)
    delta = math.atan2(C * omega_f, K - J * omega_f ** 2)
    A = -X * math.sin(-delta)
    # x_h = e^{-sigma t}(A cos wd t + B sin wd t) with x_h(0) = -x_p(0), v_h(0) = -v_p(0)
    B = (-X * omega_f * math.cos(-delta) + SIGMA * A) / WD

    def x(t):
        return X * math.sin(omega_f * t - delta) + math.exp(-SIGMA * t) * (A * math.cos(WD * t) + B * math.sin(WD * t))

    def v(t):
        e = math.exp(-SIGMA * t)
        return (X * omega_f * math.cos(omega_f * t - delta)
                + e * ((-SIGMA * A + WD * B) * math.cos(WD * t) + (-SIGMA * B - WD * A) * math.sin(WD * t)))
    return x, v


def predicted(omega_f, tol, k_want):
    """First sample j at which the documented criterion (D-44) holds on the closed form:
    r_k(j) = max(|dx| / max|x|, |dv| / max|v|) over samples 0..j; k = 1 at r_1 <= tol,
    k = 2 at r_2 <= tol at two successive samples with r_1 > sqrt(tol)."""
    x, v = closed_form(omega_f)
    xs, vs = [], []
    sx = sv = 0.0
    hits2 = 0
    for j in range(0, 100000):
        t = j * T
        xs.append(x(t)); vs.append(v(t))
        sx = max(sx, abs(xs[-1])); sv = max(sv, abs(vs[-1]))

        def r(k):
            return max(abs(xs[-1] - xs[-1 - k]) / sx, abs(vs[-1] - vs[-1 - k]) / sv)
        if j >= 1 and k_want == 1 and r(1) <= tol:
            return j
        if j >= 2:
            hits2 = hits2 + 1 if r(2) <= tol else 0
            if k_want == 2 and hits2 >= 2 and r(1) > math.sqrt(tol):
                return j
    raise RuntimeError("no prediction")


def stats(path):
    with h5py.File(path, "r") as f:
        return dict(f["run_stats"].attrs)


def case_oscillator(exe, tmp):
    tol = 1e-6
    omega_f = 2 * WD              # forcing period = T
    j_pred = predicted(omega_f, tol, 1)
    # the envelope: r_1 = a e^{-sigma j T}, so j* ~ ln(a/tol)/(sigma T): the same within a period
    print(f"closed form: settled at sample {j_pred} (t = {j_pred * T:.4f} s, sigma T = {SIGMA * T:.4f})")
    with open(os.path.join(tmp, "osc.nml"), "w") as f:
        f.write(osc_deck(omega_f / (2 * math.pi), tol, 4.0))
    p = run([exe, "run", "osc.nml", "-o", "osc.h5"], tmp)
    check("oscillator run exits 0", p.returncode == 0, p.stderr.strip())
    if p.returncode != 0:
        return
    s = stats(os.path.join(tmp, "osc.h5"))
    check("settled, k = 1", s.get("settled") == 1 and s.get("settle_k") == 1, str(s))
    n = int(s.get("settle_periods", -1))
    check(f"settle detection within 2 periods of the closed form ({j_pred})", abs(n - j_pred) <= 2, f"trainsim {n}")
    check("metrics start at the settle instant", abs(s["t_metrics"] - n * T) < 1e-9, f"{s['t_metrics']} vs {n * T}")
    check("the run ends a measured window (t_end - t_start) after the settling",
          abs(s["t_final"] - (n * T + 4.0)) < 1e-9, f"t_final {s['t_final']}")
    check("the summary says it settled", "settled: the state repeats after 1 period" in p.stdout)
    # the measured range is the steady amplitude: 2 X of the closed form, to RK4's accuracy
    X = F0 / math.hypot(K - J * omega_f ** 2, C * omega_f)
    with h5py.File(os.path.join(tmp, "osc.h5"), "r") as f:
        rng = float(f["metrics/p2p_range"][0])
    check("p2p range = 2 X of the steady state (samples every 1 ms at 20 Hz: within 1 - cos(0.063) = 2e-3)",
          abs(rng - 2 * X) / (2 * X) < 3e-3, f"{rng} vs {2 * X}")
    p = run([exe, "run", "osc.nml", "--set", "run.settle_tol=0", "-o", "raw.h5"], tmp)
    with h5py.File(os.path.join(tmp, "raw.h5"), "r") as f:
        raw = float(f["metrics/p2p_range"][0])
        check("without settling: no settle attributes", "settled" not in f["run_stats"].attrs)
    check("without settling the transient is measured (range larger by > 1 %)", raw > 1.01 * rng, f"{raw} vs {rng}")


def case_period2(exe, tmp):
    tol = 1e-6
    omega_f = WD                  # forcing period 2T
    j_pred = predicted(omega_f, tol, 2)
    print(f"closed form: period 2 found at sample {j_pred}")
    with open(os.path.join(tmp, "p2.nml"), "w") as f:
        f.write(osc_deck(omega_f / (2 * math.pi), tol, 1.0))
    p = run([exe, "run", "p2.nml", "-o", "p2.h5"], tmp)
    check("period-2 run exits 0", p.returncode == 0, p.stderr.strip())
    if p.returncode != 0:
        return
    s = stats(os.path.join(tmp, "p2.h5"))
    check("settled with k = 2", s.get("settled") == 1 and s.get("settle_k") == 2, str(s))
    n = int(s.get("settle_periods", -1))
    check(f"k = 2 found within 2 periods of the closed form ({j_pred})", abs(n - j_pred) <= 2, f"trainsim {n}")
    # the measured window is a whole number of 2 T
    w = s["t_final"] - s["t_metrics"]
    check("measured window a whole number of 2 T", abs(w / (2 * T) - round(w / (2 * T))) < 1e-6, f"{w / (2 * T)}")


def case_budget(exe, tmp):
    omega_f = 2 * WD
    with open(os.path.join(tmp, "b.nml"), "w") as f:
        f.write(osc_deck(omega_f / (2 * math.pi), 1e-6, 0.5, f", settle_max_time = {20 * T!r}"))
    p = run([exe, "run", "b.nml", "-o", "b.h5"], tmp)
    check("budget run exits 0", p.returncode == 0, p.stderr.strip())
    if p.returncode != 0:
        return
    s = stats(os.path.join(tmp, "b.h5"))
    check("not settled within 20 periods (closed form: %d)" % predicted(omega_f, 1e-6, 1),
          s.get("settled") == 0 and s.get("settle_periods") == 20, str(s))
    check("the summary says NOT SETTLED", "NOT SETTLED" in p.stdout)
    # a sweep: tolerance 1e-6 in 20 periods (no) and 1e-1 (yes)
    with open(os.path.join(tmp, "bs.nml"), "w") as f:
        f.write(osc_deck(omega_f / (2 * math.pi), 1e-6, 0.5, f", settle_max_time = {20 * T!r}")
                + "&sweep parameter = 'run.settle_tol', values = 1e-6, 0.1 /\n")
    p = run([exe, "sweep", "bs.nml", "-o", "bs.h5"], tmp)
    check("sweep exits 0", p.returncode == 0, p.stderr.strip())
    with h5py.File(os.path.join(tmp, "bs.h5"), "r") as f:
        settled = f["runs/settled"][:]
        periods = f["runs/settle_periods"][:]
    check("sweep file: /runs/settled = 0 (budget) and 1", list(settled) == [0, 1], f"{settled}, {periods}")
    # no settle_tol, a fixed settle_time: a verdict at settle_time (to 1e-3), the run unchanged.
    # The GHM rig at 545 teeth/s separates until cycle 127 (issue 20): after 100 cycles it has
    # not settled; after 300 it has (settle_tol 1e-6 settles it at 265)
    here = os.path.dirname(os.path.abspath(__file__))
    deck = os.path.join(os.path.dirname(here), "..", "inputs", "gregory_harris_munro.nml")
    for n, want in ((100, 0), (300, 1)):
        p = run([exe, "run", deck, "--set", "mesh.mesh_frequency=545", "--set", f"mesh.settle_cycles={n}",
                 "--set", "mesh.measure_cycles=60", "-o", f"v{n}.h5"], tmp)
        s = stats(os.path.join(tmp, f"v{n}.h5")) if p.returncode == 0 else {}
        check(f"545 teeth/s, settle_cycles = {n}, no settle_tol: verdict settled = {want}",
              s.get("settled") == want and s.get("settle_tol_given") == 0
              and abs(s.get("t_metrics", 0) - n / 545.0) < 1e-12
              and ("NOT SETTLED by settle_time" in p.stdout) == (want == 0), f"{p.returncode} {s}")


def free_inertia(speed):
    return ("&run title = 'continuation', units = 'si', t_end = 1.0, dt = 1.0e-3 /\n"
            "&node id = 'm', type = 'inertia', inertia = 1.0 /\n"
            "&load node = 'm', kind = 'constant', value = 1.0 /\n"
            f"&initial node = 'm', angle = 0.0, speed = {speed} /\n"
            "&sweep parameter = 'load#1.value', values = 1.0, 1.0, 1.0, 1.0, 1.0, continuation = 'both' /\n")


GHM = """&run  title = 'GHM continuation (test)'
      t_end = 0.02, dt = 8.0e-6, integrator = 'rk4', output_interval = 8.0e-6 /
&node id = 'n1', type = 'inertia', inertia = 100.0 /
&node id = 'n2', type = 'inertia', inertia = 0.987 /
&node id = 'n3', type = 'inertia', inertia = 0.987 /
&node id = 'n4', type = 'inertia', inertia = 100.0 /
&element id = 'shaft1', type = 'shaft', stiffness = 32000.0 /
&element id = 'mesh', type = 'spur_gear',
         stiffness = 234500.0, rb_driver = 3.7588, rb_driven = 3.7588, teeth = 32,
         contact_ratio = 1.6676, approach_angle = 0.1637, half_backlash = 0.005 /
&element id = 'shaft3', type = 'shaft', stiffness = 32000.0 /
&load node = 'n1', quantity = 'speed', value = 95.2295 /
&load node = 'n4', value = -798.8 /
&initial node = 'all', speed = 95.2295 /
&initial node = 'n1', angle = -0.187847 /
&initial node = 'n2', angle = -0.212810 /
&initial node = 'n3', angle = -0.214283 /
&initial node = 'n4', angle = -0.239246 /
&sweep parameter = 'mesh.mesh_frequency', values = 480, 490, 500, continuation = 'both' /
&sweep parameter = 'mesh.measure_cycles', values = 10 /
"""


def chain(path):
    """Per run: (previous run or -1, start speeds, end speeds, parameter values)."""
    with h5py.File(path, "r") as f:
        branch = f["runs/branch"][:]
        start = f["nodes/start_speed"][:]
        end = f["nodes/end_speed"][:]
        vals = f["parameters/values"][:] if "parameters" in f else None
        st = f["runs/status"][:]
    return branch, start, end, vals, st


def case_continuation(exe, tmp):
    for w0 in (10.0, 0.0):
        with open(os.path.join(tmp, "c.nml"), "w") as f:
            f.write(free_inertia(w0))
        p = run([exe, "sweep", "c.nml", "-o", f"c{w0:g}.h5"], tmp)
        check(f"nominal {w0:g}: sweep exits 0", p.returncode == 0, p.stderr.strip())
        branch, start, end, _, _ = chain(os.path.join(tmp, f"c{w0:g}.h5"))
        # both: 5 up then 5 down; within a branch run i starts from run i-1's end
        for b, runs in ((1, range(0, 5)), (2, range(5, 10))):
            got = [start[i, 0] for i in runs]
            want = [w0] + [end[i - 1, 0] for i in list(runs)[1:]]
            check(f"nominal {w0:g}, branch {b}: start = previous end (same nominal)",
                  np.allclose(got, want, rtol=0, atol=1e-12), f"{got} vs {want}")
            check(f"nominal {w0:g}, branch {b}: start speeds {w0:g} + 0..4 (1 N.m on 1 kg.m2 for 1 s each)",
                  np.allclose(got, w0 + np.arange(5), rtol=0, atol=1e-9), f"{got}")
    with open(os.path.join(tmp, "ghm.nml"), "w") as f:
        f.write(GHM)
    p = run([exe, "sweep", "ghm.nml", "-o", "ghm.h5"], tmp)
    check("GHM continuation sweep exits 0", p.returncode == 0, p.stderr.strip())
    branch, start, end, vals, _ = chain(os.path.join(tmp, "ghm.h5"))
    f_of = vals[:, 0]
    for i in range(1, len(branch)):
        if branch[i] != branch[i - 1]:
            continue            # the first run of a branch starts from the deck
        shift = 2 * math.pi * (f_of[i] - f_of[i - 1]) / 32.0
        want = end[i - 1, :] + shift     # every node: the gear ratio is 1
        check(f"GHM run {i + 1} ({f_of[i - 1]:g} -> {f_of[i]:g}): start = previous end + {shift:.6f} rad/s",
              np.allclose(start[i, :], want, rtol=0, atol=1e-9 * abs(want).max()),
              f"{start[i, :]} vs {want}")


def case_limits(exe, tmp):
    here = os.path.dirname(os.path.abspath(__file__))
    deck = os.path.join(os.path.dirname(here), "..", "inputs", "gregory_harris_munro.nml")
    p = run([exe, "run", deck, "--set", "mesh.measure_cycles=1e300", "-o", "x.h5"], tmp)
    check("run --set mesh.measure_cycles=1e300: exit 2, naming the argument and the time limit",
          p.returncode == 2 and "--set mesh.measure_cycles=1e300" in p.stderr and "beyond the time limit" in p.stderr,
          f"exit {p.returncode}: {p.stderr.strip()}")
    check("no history left", not any(n.startswith("x.h5") for n in os.listdir(tmp)))
    with open(deck) as f:
        text = f.read()
    with open(os.path.join(tmp, "sw.nml"), "w") as f:
        f.write(text + "&sweep parameter = 'mesh.measure_cycles', values = 1e30 /\n")
    p = run([exe, "sweep", "sw.nml", "-o", "sw.h5"], tmp)
    check("sweep measure_cycles = 1e30: exit 2, naming the &sweep group and the time limit",
          p.returncode == 2 and "&sweep #1" in p.stderr and "beyond the time limit" in p.stderr,
          f"exit {p.returncode}: {p.stderr.strip()}")
    p = run([exe, "run", deck, "--set", "mesh.settle_cycles=1e6", "-o", "x.h5"], tmp)
    check("settle_cycles = 1e6 beyond t_end: exit 2 naming the argument and settle_time",
          p.returncode == 2 and "--set mesh.settle_cycles=1e6" in p.stderr and "settle_time" in p.stderr,
          f"exit {p.returncode}: {p.stderr.strip()}")
    for v in ("1.0", "0.02"):
        p = run([exe, "run", deck, "--set", f"run.settle_time={v}", "-o", "x.h5"], tmp)
        check(f"run.settle_time={v} at or beyond t_end 0.02: exit 2 naming the key",
              p.returncode == 2 and "settle_time" in p.stderr and "e+308" not in (p.stdout + p.stderr).lower(),
              f"exit {p.returncode}: {p.stderr.strip()}")
    p = run([exe, "run", deck, "--set", "run.settle_tol=1e-6", "--set", "run.settle_max_time=1e13", "-o", "x.h5"],
            tmp)
    check("a settling budget beyond the time limit: exit 2 naming settle_max_time",
          p.returncode == 2 and "settle_max_time" in p.stderr and "beyond the time limit" in p.stderr,
          f"exit {p.returncode}: {p.stderr.strip()}")
    p = run([exe, "run", deck, "--set", "mesh.mesh_frequency=1e300", "-o", "x.h5"], tmp)
    check("mesh_frequency = 1e300: exit 2 naming the argument",
          p.returncode == 2 and "--set mesh.mesh_frequency=1e300" in p.stderr, f"exit {p.returncode}: {p.stderr.strip()}")


def main():
    if len(sys.argv) != 3:
        print(__doc__)
        return 2
    exe = os.path.abspath(sys.argv[1])
    case = globals().get("case_" + sys.argv[2])
    if case is None:
        print(f"unknown case {sys.argv[2]}")
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        case(exe, tmp)
    if FAILS:
        print(f"{len(FAILS)} check(s) failed")
        return 1
    print("all checks passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
