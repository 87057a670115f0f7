#!/usr/bin/env python3
"""RK4 step advice (D-25), checked from outside trainsim.

1. The runaway_at_safe_dt reproducer: the first-order linear system of its
   stiffest state is assembled here from the deck's values (not from trainsim's
   output): eq. 3.9 mesh stiffness of the 20:80, m = 2 mm, 20 deg, 20 mm pair
   times two_pair_factor 1.8, the key and the output shaft, node damping, the
   DC motor's current state, and the impact damping phi(e) sqrt(c k m_eff) of
   both yang_sun contacts swept from none to the Goldsmith bound at 100 in/s.
   numpy's eigenvalues give the largest h with every h*lambda inside RK4's
   region; `trainsim modes --stiffest` must agree to 1e-6 relative.
2. Every bundled deck (inputs/) and the reproducer run with integrator rk4 at
   0.95 x the advice (the smaller of `modes` and `modes --stiffest`) to the
   deck's t_end: exit 0, no blow-up.

Usage: check_dt_advice.py TRAINSIM (cwd = repository root).
"""
import glob
import math
import os
import re
import subprocess
import sys
import tempfile

import numpy as np
from scipy.optimize import brentq, minimize_scalar

exe = sys.argv[1]
failures = []


def rk4_radius(d):
    """First r > 0 with |R(r d)| = 1, R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24."""
    g = lambda r: abs(1 + r * d + (r * d) ** 2 / 2 + (r * d) ** 3 / 6 + (r * d) ** 4 / 24) ** 2 - 1
    r = 0.0
    while g(r + 0.01) <= 0:
        r += 0.01
    return brentq(g, r, r + 0.01, xtol=1e-15, rtol=1e-15) if r > 0 else brentq(g, 1e-9, 0.01)


def limit(a):
    lam = np.linalg.eigvals(a)
    big = max(abs(lam))
    h = math.inf
    for l in lam:
        if abs(l) <= 1e-6 * big:
            continue
        d = complex(min(l.real, 0.0), l.imag)
        h = min(h, rk4_radius(d / abs(d)) / abs(l))
    return h


# ---- 1. the reproducer, assembled from its deck values (SI) -------------------
lbf_per_in2 = 4.4482216152605 / 0.0254**2           # 1 lbf/in per in of face, in N/m^2
phi = math.radians(20.0)
m_mod = 2.0e-3
k_mesh = 1.0e7 / (0.39 + 1.49 * math.cos(phi)) * lbf_per_in2 * 0.02    # eq. 3.9 x face width
r1, r2 = 0.5 * 20 * m_mod * math.cos(phi), 0.5 * 80 * m_mod * math.cos(phi)
c2 = 1.8
k_key, r_key = 3.5e8, 0.015
k_sh, d_sh = 3.1e4, 2.0
J = {"motor": 1.0e-3, "gear": 1.0e-2, "shaft_in": 1.0e-3, "load": 0.5}
d_node = {"motor": 1.0e-4, "load": 0.2}
alpha, alpha_e, R, L = 0.3, 0.3, 0.4, 2.0e-3
v_ips = 1.0 / 0.0254                                   # m/s -> in/s
e_gold = lambda v: min(max(1 - 0.019 * (abs(v) * v_ips) ** 0.48, 0.0), 1.0)
v_min = 1.0e-3 / v_ips                                  # default floor, 1e-3 in/s
e_low = min(e_gold(v_min), e_gold(100.0 / v_ips))      # Goldsmith over [v_min, 100 in/s]
phi_e = 6 * (1 - e_low) / ((2 * e_low - 1) ** 2 + 3)   # D V_i / k, eq. 3.12

names = ["motor", "gear", "shaft_in", "load"]
ix = {n: i for i, n in enumerate(names)}
# states: theta_i (0..3), omega_i (4..7), motor current (8)
n = 9


def system(scale):
    K = np.zeros((4, 4))
    C = np.zeros((4, 4))

    def pair(M, val, a, b, ra, rb):
        g = np.zeros(4)
        g[ix[a]] += ra
        g[ix[b]] -= rb
        M += val * np.outer(g, g)

    m_mesh = 1 / (r1**2 / J["motor"] + r2**2 / J["gear"])
    m_key = 1 / (r_key**2 / J["gear"] + r_key**2 / J["shaft_in"])
    pair(K, c2 * k_mesh, "motor", "gear", r1, r2)
    pair(C, scale * phi_e * math.sqrt(c2 * k_mesh * m_mesh), "motor", "gear", r1, r2)
    pair(K, k_key, "gear", "shaft_in", r_key, r_key)
    pair(C, scale * phi_e * math.sqrt(k_key * m_key), "gear", "shaft_in", r_key, r_key)
    pair(K, k_sh, "shaft_in", "load", 1.0, 1.0)
    pair(C, d_sh, "shaft_in", "load", 1.0, 1.0)
    for nm, d in d_node.items():
        C[ix[nm], ix[nm]] += d
    Minv = np.diag([1 / J[nm] for nm in names])
    A = np.zeros((n, n))
    A[0:4, 4:8] = np.eye(4)
    A[4:8, 0:4] = -Minv @ K
    A[4:8, 4:8] = -Minv @ C
    A[4, 8] = alpha / J["motor"]          # J w' = ... + alpha i
    A[8, 4] = -alpha_e / L                 # L i' = -R i - alpha' w
    A[8, 8] = -R / L
    return A


grid = [limit(system(j / 16)) for j in range(17)]
jmin = int(np.argmin(grid))
lo, hi = max(jmin - 1, 0) / 16, min(jmin + 1, 16) / 16
res = minimize_scalar(lambda s: limit(system(s)), bounds=(lo, hi), method="bounded", options={"xatol": 1e-10})
h_numpy = min(grid[jmin], res.fun)
undamped = limit(system(0.0))

r = subprocess.run([exe, "modes", "tests/decks/runaway_at_safe_dt.nml", "--stiffest"], capture_output=True, text=True)
m = re.search(r"dt < ([0-9.Ee+-]+) s", r.stdout)
if r.returncode != 0 or not m:
    failures.append(f"modes --stiffest on the reproducer: exit {r.returncode}, {r.stderr.strip()[:200]}")
else:
    h_ts = float(m.group(1))
    rel = abs(h_ts - h_numpy) / h_numpy
    print(f"reproducer, stiffest state: trainsim dt < {h_ts:.10e} s, numpy {h_numpy:.10e} s "
          f"(relative difference {rel:.1e}; without impact damping {undamped:.6e} s)")
    if rel > 1e-6:
        failures.append(f"reproducer advice {h_ts} vs numpy {h_numpy}: {rel:.2e} relative > 1e-6")
    if not h_ts < 1.0e-4:
        failures.append("reproducer advice must be below the dt = 1e-4 s that runs away")


# ---- 2. every bundled deck and the reproducer at 0.95 x the advice ----------------
def advice(deck):
    hs = []
    for extra in ([], ["--stiffest"]):
        r = subprocess.run([exe, "modes", deck] + extra, capture_output=True, text=True, timeout=120)
        m = re.search(r"dt < ([0-9.Ee+-]+) s", r.stdout)
        if r.returncode == 0 and m:
            hs.append(float(m.group(1)))
    return min(hs) if hs else None


def run_group_span(text):
    """(start, end) of the &run group's body, '/' inside quotes skipped."""
    s = re.search(r"&run\b", text, re.I).end()
    q = None
    for i in range(s, len(text)):
        ch = text[i]
        if q:
            if ch == q:
                q = None
        elif ch in "'\"":
            q = ch
        elif ch == "/":
            return s, i
    raise ValueError("no end of &run")


def with_rk4_dt(text, dt):
    s, e = run_group_span(text)
    body = text[s:e]
    body = re.sub(r"\b(dt|output_interval)\s*=\s*[^,/\s]+\s*,?", "", body)
    body = re.sub(r"\b(integrator|output)\s*=\s*('[^']*'|\"[^\"]*\")\s*,?", "", body)
    body = body.rstrip().rstrip(",")
    return text[:s] + body + f", dt = {dt!r}, integrator = 'rk4' " + text[e:]


decks = sorted(glob.glob("inputs/*.nml")) + ["tests/decks/runaway_at_safe_dt.nml"]
with tempfile.TemporaryDirectory() as tmp:
    for deck in decks:
        h = advice(deck)
        if h is None:
            failures.append(f"{deck}: no RK4 advice from trainsim modes")
            continue
        src = open(deck).read()
        path = os.path.join(tmp, os.path.basename(deck))
        with open(path, "w") as f:
            f.write(with_rk4_dt(src, 0.95 * h))
        # relative table files (e.g. wind_load.txt) next to the deck
        for extra in glob.glob(os.path.join(os.path.dirname(deck), "*.txt")):
            dst = os.path.join(tmp, os.path.basename(extra))
            if not os.path.exists(dst):
                os.symlink(os.path.abspath(extra), dst)
        try:
            r = subprocess.run([exe, "run", path], capture_output=True, text=True, timeout=240)
            ok = r.returncode == 0 and "error" not in r.stderr.lower()
            why = f"exit {r.returncode}: {r.stderr.strip()[:300]}"
        except subprocess.TimeoutExpired:
            ok, why = False, "no end within 240 s (runaway)"
        print(f"{'ok  ' if ok else 'FAIL'} {deck}: advice dt < {h:.4e} s, run at {0.95 * h:.4e} s" + ("" if ok else f": {why}"))
        if not ok:
            failures.append(f"{deck} at 0.95 x advice: {why}")

for f in failures:
    print("FAIL", f)
sys.exit(1 if failures else 0)
