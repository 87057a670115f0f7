#!/usr/bin/python3
"""Independent reference for the Kahraman-Singh-type single-mesh case (issue 26).

Integrates the nondimensional single-degree-of-freedom gear pair with backlash,

    x'' + 2 zeta D(q) q' + k(tau) g(q) = F_m,     q = x - e(tau),
    k(tau) = 1 + sum_r a_r cos(r s + phi_r),     e(tau) = sum_r e_r cos(r s + psi_r),
    s = s0 + Omega tau,                          g(q) = q - 1 (q > 1), 0 (|q| <= 1), q + 1 (q < -1),

with x the dynamic transmission error delta / b (b the half backlash), tau = omega_n t,
Omega = omega_mesh / omega_n, and D(q) = 1 in contact, 0 in the gap (trainsim's 'linear'
contact law: damping acts on the penetration rate while a face is in contact; with
--damping always it acts on q' everywhere, as in Kahraman & Singh's equation).

Numerics (nothing shared with trainsim): classical RK4 on a fixed step of 1/steps_per_period
of the mesh period, the contact mode (front / gap / rear) held through a step; a step that
ends in another region is cut at the crossing of q = +-1, located by the secant method on
the RK4 step length (|q - boundary| < 1e-13), the mode switched there and the step completed.
Each Omega is settled until the state at the start of successive mesh periods repeats
(|dx| + |dx'| < settle_tol after at least settle_min periods, at most settle_max), then
measured over measure periods. Sweeps continue the state from point to point (up, down).

Regime of a point, from the range of q over the measured periods (mean load F_m > 0 pushes
the front face into contact):
    no_impact      min q >  1   (the front face never separates)
    single_sided   min q <= 1 and min q > -1   (separates, never reaches the rear face)
    double_sided   min q <= -1  (rear-face contacts)

Usage:
    ks_reference.py sweep --from 0.5 --to 1.6 --count 45 [--json out.json]
    ks_reference.py point --omega 0.9
Only numpy and the standard library.
"""
import argparse
import json
import math
import sys

# The case's parameters (nondimensional, README.md: where each comes from).
DEFAULT = {
    "zeta": 0.05,
    "F_m": 0.1,
    "a": [0.1, 0.05, 0.02],
    "phi": [0.0, 0.0, 0.0],
    "e": [0.2, 0.005, 0.002],
    "psi": [0.0, 0.0, 0.0],
}


class Model:
    def __init__(self, p, damping="contact"):
        self.z2 = 2.0 * p["zeta"]
        self.fm = p["F_m"]
        self.a = list(p["a"])
        self.phi = list(p["phi"])
        self.e = list(p["e"])
        self.psi = list(p["psi"])
        self.always = damping == "always"
        # TRAIN's two-level stiffness instead of the Fourier series (the check of the existing
        # spur gear): k = 1 on one pair, c2 on two pairs (u - floor(u) < mp - 1), u = s / 2 pi
        tl = p.get("two_level")
        self.two_level = tl is not None
        if self.two_level:
            self.c2, self.mp = tl["c2"], tl["mp"]
            self.a = []
        self.kz = 1.0

    def exc(self, s, om):
        """k, e, de/dtau at mesh angle s (Omega = om)."""
        k = self.kz if self.two_level else 1.0
        e = 0.0
        de = 0.0
        for r in range(len(self.a)):
            k += self.a[r] * math.cos((r + 1) * s + self.phi[r])
        for r in range(len(self.e)):
            arg = (r + 1) * s + self.psi[r]
            e += self.e[r] * math.cos(arg)
            de -= self.e[r] * (r + 1) * om * math.sin(arg)
        return k, e, de

    def rhs(self, s, x, v, om, mode):
        k, e, de = self.exc(s, om)
        q = x - e
        qd = v - de
        if mode == 1:
            f = k * (q - 1.0) + self.z2 * qd
        elif mode == -1:
            f = k * (q + 1.0) + self.z2 * qd
        else:
            f = self.z2 * qd if self.always else 0.0
        return v, self.fm - f

    def step(self, s, x, v, h, om, mode):
        """One RK4 step of length h (tau); s advances by om h."""
        hs = om * h
        k1x, k1v = self.rhs(s, x, v, om, mode)
        k2x, k2v = self.rhs(s + 0.5 * hs, x + 0.5 * h * k1x, v + 0.5 * h * k1v, om, mode)
        k3x, k3v = self.rhs(s + 0.5 * hs, x + 0.5 * h * k2x, v + 0.5 * h * k2v, om, mode)
        k4x, k4v = self.rhs(s + hs, x + h * k3x, v + h * k3v, om, mode)
        return (x + h / 6.0 * (k1x + 2 * k2x + 2 * k3x + k4x),
                v + h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v))

    def q(self, s, x, om):
        return x - self.exc(s, om)[1]


def region(q):
    return 1 if q > 1.0 else (-1 if q < -1.0 else 0)


def advance(m, s, x, v, mode, h, om):
    """One step of length h; with a two-level stiffness the step is cut at the zone changes
    (known instants: s is linear in tau), each piece integrated with its zone's k."""
    if not m.two_level:
        return advance_smooth(m, s, x, v, mode, h, om)
    events = []
    left = h
    while left > 0.0:
        u = s / (2.0 * math.pi)
        fl = math.floor(u)
        f = u - fl
        w = m.mp - 1.0
        if f < w - 1e-12:
            nxt = fl + w
        elif f < 1.0 - 1e-12:
            nxt = fl + 1.0
        else:
            nxt = fl + 1.0 + w
        hz = (nxt * 2.0 * math.pi - s) / om
        hh = min(left, hz)
        if hh <= 0.0:
            hh = left
        um = (s + 0.5 * om * hh) / (2.0 * math.pi)
        m.kz = m.c2 if (um - math.floor(um)) < w else 1.0
        s, x, v, mode, ev = advance_smooth(m, s, x, v, mode, hh, om)
        events.extend(ev)
        left -= hh
        if left < 1e-14 * h:
            break
    return s, x, v, mode, events


def advance_smooth(m, s, x, v, mode, h, om):
    """One step of length h with event location; returns s, x, v, mode, events (list of new modes)."""
    events = []
    left = h
    guard = 0
    while left > 0.0:
        guard += 1
        x1, v1 = m.step(s, x, v, left, om, mode)
        s1 = s + om * left
        q1 = m.q(s1, x1, om)
        r1 = region(q1)
        if r1 == mode:
            return s1, x1, v1, mode, events
        # the boundary crossed: from the front face +1, from the rear -1, from the gap the nearer
        if mode == 1:
            bnd = 1.0
        elif mode == -1:
            bnd = -1.0
        else:
            bnd = 1.0 if q1 > 1.0 else -1.0
        q0 = m.q(s, x, om) - bnd
        f1 = q1 - bnd
        h0, h1 = 0.0, left
        # secant / regula falsi (Illinois) on the step length
        fa, fb = q0, f1
        ha, hb = h0, h1
        hc = left
        for _ in range(60):
            hc = hb - fb * (hb - ha) / (fb - fa) if fb != fa else 0.5 * (ha + hb)
            if not (min(ha, hb) < hc < max(ha, hb)):
                hc = 0.5 * (ha + hb)
            xc, vc = m.step(s, x, v, hc, om, mode)
            fc = m.q(s + om * hc, xc, om) - bnd
            if abs(fc) < 1e-13:
                break
            if (fc > 0) == (fa > 0):
                ha, fa = hc, fc
                fb *= 0.5
            else:
                hb, fb = hc, fc
                fa *= 0.5
        xc, vc = m.step(s, x, v, hc, om, mode)
        s, x, v = s + om * hc, xc, vc
        left -= hc
        # new mode: the region on the far side of the boundary, by the sign of q'
        k, e, de = m.exc(s, om)
        qd = v - de
        if mode == 0:
            mode = 1 if bnd > 0 else -1
        else:
            mode = 0
        if mode == 0 and abs(qd) < 1e-15:
            pass
        events.append(mode)
        if guard > 50:
            raise RuntimeError("event flood at Omega=%g" % om)
    return s, x, v, mode, events


class Extremes:
    """Least and largest value of a sampled signal, each refined by the parabola through the
    sample at a discrete extremum and its two neighbours (sampling error O(h^4), not O(h^2))."""

    def __init__(self):
        self.lo = float("inf")
        self.hi = -float("inf")
        self.w = []

    def add(self, v):
        self.lo = min(self.lo, v)
        self.hi = max(self.hi, v)
        w = self.w
        w.append(v)
        if len(w) > 3:
            del w[0]
        if len(w) == 3:
            a, b, c = w
            d2 = a - 2.0 * b + c
            if (b <= a and b <= c and d2 > 0.0) or (b >= a and b >= c and d2 < 0.0):
                vert = b - (c - a) ** 2 / (8.0 * d2)
                self.lo = min(self.lo, vert)
                self.hi = max(self.hi, vert)


def run_point(m, om, state, steps_per_period=256, settle_min=150, settle_max=3000, settle_tol=1e-9,
              measure=60):
    """Settle and measure at Omega = om from state (s, x, v, mode). Returns (metrics, state)."""
    s, x, v, mode = state
    T = 2.0 * math.pi / om
    h = T / steps_per_period
    last = None
    settled = False
    n_settle = 0
    for p in range(settle_max):
        for _ in range(steps_per_period):
            s, x, v, mode, _ev = advance(m, s, x, v, mode, h, om)
        s = math.fmod(s, 2.0 * math.pi)
        n_settle = p + 1
        cur = (x, v)
        if last is not None and p + 1 >= settle_min:
            if abs(cur[0] - last[0]) + abs(cur[1] - last[1]) < settle_tol:
                settled = True
                break
        last = cur
    ex = {"q": Extremes(), "x": Extremes()}
    n_front = n_rear = n_sep = 0
    for p in range(measure):
        for _ in range(steps_per_period):
            s, x, v, mode, ev = advance(m, s, x, v, mode, h, om)
            for e_ in ev:
                if e_ == 1:
                    n_front += 1
                elif e_ == -1:
                    n_rear += 1
                else:
                    n_sep += 1
            ex["q"].add(m.q(s, x, om))
            ex["x"].add(x)
        s = math.fmod(s, 2.0 * math.pi)
    qmin, qmax = ex["q"].lo, ex["q"].hi
    xmin, xmax = ex["x"].lo, ex["x"].hi
    if qmin > 1.0:
        reg = "no_impact"
    elif qmin > -1.0:
        reg = "single_sided"
    else:
        reg = "double_sided"
    met = {"omega": om, "regime": reg, "q_min": qmin, "q_max": qmax, "x_min": xmin, "x_max": xmax,
           "x_amp": 0.5 * (xmax - xmin), "q_amp": 0.5 * (qmax - qmin),
           "separations_per_period": n_sep / measure, "front_impacts_per_period": n_front / measure,
           "rear_impacts_per_period": n_rear / measure, "settled": settled, "settle_periods": n_settle}
    return met, (s, x, v, mode)


def static_state(m):
    """Mean-load deflection with the mean stiffness: x = 1 + F_m, at rest, front face."""
    return (0.0, 1.0 + m.fm, 0.0, 1)


def sweep(m, omegas, **kw):
    out = []
    state = static_state(m)
    for om in omegas:
        met, state = run_point(m, om, state, **kw)
        out.append(met)
        print("%8.4f %-13s x_amp %.5f q_min %+.4f q_max %+.4f settled %d (%d)" % (
            om, met["regime"], met["x_amp"], met["q_min"], met["q_max"], met["settled"], met["settle_periods"]),
            file=sys.stderr, flush=True)
    return out


def jumps(points):
    """Jumps of a branch: the grid intervals where the regime changes between neighbours."""
    return [(a["omega"], b["omega"], a["regime"], b["regime"], a["x_amp"], b["x_amp"])
            for a, b in zip(points[:-1], points[1:]) if a["regime"] != b["regime"]]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("what", choices=["sweep", "point"])
    ap.add_argument("--from", dest="lo", type=float, default=0.5)
    ap.add_argument("--to", dest="hi", type=float, default=1.6)
    ap.add_argument("--count", type=int, default=45)
    ap.add_argument("--omega", type=float, action="append")
    ap.add_argument("--params", help="JSON file of parameters (default: the case's)")
    ap.add_argument("--damping", choices=["contact", "always"], default="contact")
    ap.add_argument("--steps", type=int, default=256, help="RK4 steps per mesh period")
    ap.add_argument("--settle-min", type=int, default=150)
    ap.add_argument("--settle-max", type=int, default=3000)
    ap.add_argument("--measure", type=int, default=60)
    ap.add_argument("--direction", choices=["up", "down", "both"], default="both")
    ap.add_argument("--json", help="write the results here")
    args = ap.parse_args(argv)
    p = dict(DEFAULT)
    if args.params:
        with open(args.params) as f:
            p.update(json.load(f))
    m = Model(p, args.damping)
    kw = dict(steps_per_period=args.steps, settle_min=args.settle_min, settle_max=args.settle_max,
              measure=args.measure)
    if args.what == "point":
        res = {"params": p, "points": []}
        state = static_state(m)
        for om in args.omega or [1.0]:
            met, state = run_point(m, om, state, **kw)
            res["points"].append(met)
            print(json.dumps(met))
    else:
        if args.count > 1:
            omegas = [args.lo + (args.hi - args.lo) * i / (args.count - 1) for i in range(args.count)]
        else:
            omegas = [args.lo]
        res = {"params": p, "damping": args.damping, "steps_per_period": args.steps}
        if args.direction in ("up", "both"):
            print("up", file=sys.stderr)
            res["up"] = sweep(m, omegas, **kw)
            res["jumps_up"] = jumps(res["up"])
        if args.direction in ("down", "both"):
            print("down", file=sys.stderr)
            res["down"] = sweep(m, omegas[::-1], **kw)
            res["jumps_down"] = jumps(res["down"])
        for k in ("jumps_up", "jumps_down"):
            if k in res:
                print(k, res[k])
    if args.json:
        with open(args.json, "w") as f:
            json.dump(res, f, indent=1)


if __name__ == "__main__":
    main()
