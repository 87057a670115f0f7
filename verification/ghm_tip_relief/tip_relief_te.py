#!/usr/bin/python3
"""Loaded static transmission error of the Gregory-Harris-Munro gears (Table 5.5) with the tip
relief the thesis reports (sec. 5.2.5: "tip relief of 0.001 in", designed for 1700 lb/in of
face width; the rig was simulated at 425 lb/in), and its Fourier harmonics in mesh orders:
the excitation that trainsim's spur gear takes as te_harmonics / te_phases (issue 26 item 7).

Assumed (the thesis gives only the amount): linear relief of amount D at the tip of each gear
(both gears alike), over a roll length L from the tip (default: the two-pair zone, L = m_p - 1
base pitches: 'short relief'); each pair of a two-pair zone has half of TRAIN's two-pair
stiffness (c2 k / 2 = 0.9 k), a single pair k (so D = 0 gives TRAIN's two levels exactly).

At roll position u (teeth, the zones of App. F: two pairs for u - floor(u) < m_p - 1) the
entering pair is at roll s = u' (0..m_p from the start of its path) and relieved by
D (1 - s/L) for s < L; the leaving pair at s = u' + 1 by D (1 - (m_p - s)/L) for s > m_p - L.
The loaded deflection delta solves sum_p k_p max(0, delta - g_p) = W (W = T/r_b). In the
linearisation about that state, the mesh force is K(u) (delta - e(u)) with K the stiffness of
the loaded pairs and e = sum k_p g_p / K: for this load and relief every pair in the two-pair
zone is loaded, so K is TRAIN's two-level stiffness and e is the relief's share.

    tip_relief_te.py [--relief 0.001] [--length L] [--load 212.5] [--harmonics 6]
"""
import argparse
import math

K1, MP, TEETH = 234500.0, 1.6676, 32


def relief_of_pair(s, D, L):
    """Relief (in) of a pair at roll s (base pitches from the start of its path, 0..MP)."""
    g = 0.0
    if s < L:
        g += D * (1.0 - s / L)            # the driven gear's tip, at the start of the path
    if s > MP - L:
        g += D * (1.0 - (MP - s) / L)     # the driver's tip, at the end of the path
    return g


def state(u, D, L, W):
    f = u - math.floor(u)
    if f < MP - 1.0:
        pairs = [(0.9 * K1, relief_of_pair(f, D, L)), (0.9 * K1, relief_of_pair(f + 1.0, D, L))]
    else:
        pairs = [(K1, relief_of_pair(f, D, L))]
    # solve sum k max(0, delta - g) = W: piecewise linear, increasing in delta
    gs = sorted(pairs, key=lambda p: p[1])
    for n in range(len(gs), 0, -1):
        act = gs[:n]
        K = sum(k for k, g in act)
        d = (W + sum(k * g for k, g in act)) / K
        if d > gs[n - 1][1]:
            return d, K, sum(k * g for k, g in act) / K
    raise RuntimeError


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--relief", type=float, default=0.001)
    ap.add_argument("--length", type=float, default=MP - 1.0)
    ap.add_argument("--load", type=float, default=798.8 / 3.7588)
    ap.add_argument("--harmonics", type=int, default=6)
    ap.add_argument("--n", type=int, default=20000)
    a = ap.parse_args()
    us = [(i + 0.5) / a.n for i in range(a.n)]
    st = [state(u, a.relief, a.length, a.load) for u in us]
    d = [x[0] for x in st]
    e = [x[2] for x in st]
    d0 = [state(u, 0.0, a.length, a.load)[0] for u in us]
    print("load W = %.4f lbf, relief %.5f in over %.4f base pitches" % (a.load, a.relief, a.length))
    print("loaded static TE (deflection): with relief %.4e .. %.4e in (p-p %.3e); without %.4e .. %.4e (p-p %.3e)"
          % (min(d), max(d), max(d) - min(d), min(d0), max(d0), max(d0) - min(d0)))
    print("pairs in contact throughout the two-pair zone at this load: %s" % all(
        abs(x[1] - (1.8 * K1 if (u - math.floor(u)) < MP - 1 else K1)) < 1e-6 for u, x in zip(us, st)))
    mean = sum(e) / len(e)
    amps, phases = [], []
    for r in range(1, a.harmonics + 1):
        c = 2.0 / a.n * sum(v * math.cos(2 * math.pi * r * u) for v, u in zip(e, us))
        s = 2.0 / a.n * sum(v * math.sin(2 * math.pi * r * u) for v, u in zip(e, us))
        amps.append(math.hypot(c, s))
        phases.append(math.atan2(-s, c))      # e = sum A cos(2 pi r u + phase)
    print("TE of the relief e(u): mean %.4e in" % mean)
    print("te_harmonics = " + ", ".join("%.6e" % x for x in amps))
    print("te_phases    = " + ", ".join("%.6f" % x for x in phases))


if __name__ == "__main__":
    main()
