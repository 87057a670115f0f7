#!/usr/bin/env python3
"""Two branch files of the same continuation compared where their points differ (issue 27,
D-179): a changed predictor or step control puts the points elsewhere on the same curve,
so the branches are compared by interpolation, not point by point.

- The change points (folds, period-doublings, Neimark-Sacker points, grazings, failed
  points, in branch order) must be the same list: the same kinds in the same order, each
  fold and every other change within --fold-tol / --change-tol in lambda (absolute; a
  grazing is located by bisection to the continuation's lam_tol, 1e-7 of |lambda_0|).
- Between two change points (a piece: lambda monotone, the orbit smooth in lambda), each
  regular point of one branch is compared with the other branch there: its state (the
  scaled unknowns x/s at t0, the branch's own scale) by the cubic Hermite interpolant in
  lambda between the two points of the other that bracket it, with their tangents
  (dx/dlambda = t_x/t_lambda), where both of those have the point's forcing phase (t0 is
  moved along a branch where a memory contact reaches it, and where it moves depends
  on where the points lie: other phases are other coordinates, not compared). The
  interpolant's error is estimated from the other branch itself (the same interpolant
  over twice the spacing at its bracketing points, / 16: O(h^4)); where that is below
  --resolved x --tol the comparison counts and must be within --tol (1e-6 of the state's
  scale). The metric (p2p_range) is compared too, by a cubic through the four nearest
  points, and reported with its estimate but not asserted: its extremes come from
  turning points of the step ends (D-48), which jitter by ~1e-5 relative from point to
  point, so no interpolation of it resolves 1e-6 (measured: leave-one-out on the base's
  own branch).
- The stability of each piece must be the same.

Both directions are checked (new onto old's parameters, old onto new's). Exit 1 on any
disagreement.

Usage: compare_branches.py OLD.h5 NEW.h5 [--metric p2p_range] [--element mesh ...]
"""
import argparse
import sys

import h5py
import numpy as np

KINDS = {1: "fold", 2: "period-doubling", 3: "neimark-sacker", 4: "grazing"}


def read(path, metric):
    with h5py.File(path, "r") as f:
        st = f["runs/status"][:]
        n = int((st != 0).sum())
        return dict(lam=f["parameters/values"][:n, 0], ok=st[:n] == 1, kind=f["runs/kind"][:n],
                    stable=f["runs/stable"][:n], segment=f["runs/segment"][:n], reason=f["runs/reason"][:n],
                    y=f[f"elements/{metric}"][:n, :], period=f["runs/period"][:n],
                    ids=list(f["elements/ids"].asstr()[:]), maps=int(f["runs/maps"][n - 1]),
                    z=f["branch/z"][:n], t=f["branch/tangent"][:n], phase=f["runs/phase"][:n],
                    end=int(f["branch/status"][0]))


def pieces(b):
    """(change points [(kind, lam)], pieces [index arrays]) of branch b: a piece runs between
    two change points (both ends included when they are orbits), regular points inside."""
    changes, out, cur = [], [], []
    for i in range(len(b["lam"])):
        if not b["ok"][i]:
            changes.append(("failed %d" % b["reason"][i], b["lam"][i]))
            out.append(cur)
            cur = []
            continue
        if cur and b["segment"][i] != b["segment"][cur[-1]]:
            changes.append(("segment", b["lam"][i]))
            out.append(cur)
            cur = []
        if b["kind"][i] != 0:
            changes.append((KINDS.get(int(b["kind"][i]), str(b["kind"][i])), b["lam"][i]))
            out.append(cur + [i])
            cur = [i]
            continue
        cur.append(i)
    out.append(cur)
    return changes, [np.array(p, dtype=int) for p in out]


def interp(x, y, at):
    """y(at) by the cubic through the 4 nearest x, and its estimate |cubic - quadratic(3 nearest)|."""
    o = np.argsort(np.abs(x - at))
    if len(x) < 3:
        return None, None
    j4, j3 = o[:4], o[:3]
    c3 = np.polyfit(x[j4] - at, y[j4], min(3, len(j4) - 1))
    c2 = np.polyfit(x[j3] - at, y[j3], 2)
    v = np.polyval(c3, 0.0)
    return v, abs(v - np.polyval(c2, 0.0))


def hermite(b, j, k, at):
    """The state (scaled) at lambda `at` by the cubic Hermite in lambda between b's points j, k."""
    l0, l1 = b["z"][j, -1], b["z"][k, -1]
    d0, d1 = b["t"][j, :-1] / b["t"][j, -1], b["t"][k, :-1] / b["t"][k, -1]
    h = l1 - l0
    s = (at - l0) / h
    return ((2 * s**3 - 3 * s**2 + 1) * b["z"][j, :-1] + (s**3 - 2 * s**2 + s) * h * d0 +
            (-2 * s**3 + 3 * s**2) * b["z"][k, :-1] + (s**3 - s**2) * h * d1)


def compare_states(a, pa, b, pb, tol, resolved):
    """a's regular points against b's state by Hermite interpolation in the same piece and
    phase: (worst resolved difference, compared, not resolved, other phase, failures)."""
    worst, count, unres, other, bad = 0.0, 0, 0, 0, []
    for ia, ib in zip(pa, pb):
        for i in ia:
            if a["kind"][i] != 0:
                continue
            at = a["z"][i, -1]
            br = [(ib[m], ib[m + 1]) for m in range(len(ib) - 1)
                  if min(b["z"][ib[m], -1], b["z"][ib[m + 1], -1]) <= at <= max(b["z"][ib[m], -1], b["z"][ib[m + 1], -1])]
            br = [(j, k) for j, k in br if b["phase"][j] == a["phase"][i] == b["phase"][k]]
            if not br:
                other += 1
                continue
            j, k = br[0]
            m = list(ib).index(j)
            est = 0.0   # the same interpolant over twice the spacing, at b's own points j and k, / 16
            for p, q, r in ((m - 1, m, m + 1), (m, m + 1, m + 2)):
                if p < 0 or r >= len(ib) or len({b["phase"][ib[p]], b["phase"][ib[r]], a["phase"][i]}) > 1:
                    est = np.inf
                    break
                e = np.max(np.abs(hermite(b, ib[p], ib[r], b["z"][ib[q], -1]) - b["z"][ib[q], :-1]))
                est = max(est, e / 16.0)
            if not est < resolved * tol:
                unres += 1
                continue
            d = np.max(np.abs(hermite(b, j, k, at) - a["z"][i, :-1]))
            count += 1
            worst = max(worst, d)
            if d > tol:
                bad.append((a["lam"][i], d, est))
    return worst, count, unres, other, bad


def compare_pieces(a, pa, b, pb, cols, tol, resolved, name):
    """Points of a's pieces against b's same pieces: (worst resolved rel. diff, compared,
    not resolved, failures)."""
    worst, count, unres, bad = 0.0, 0, 0, []
    for ia, ib in zip(pa, pb):
        if len(ia) < 3 or len(ib) < 3:
            continue
        lb = b["lam"][ib]
        lo, hi = lb.min(), lb.max()
        for i in ia[1:-1]:
            at = a["lam"][i]
            if not lo < at < hi:
                continue
            # the other branch's points on each side must bracket it (no extrapolation)
            for c in cols:
                v, est = interp(lb, b["y"][ib, c], at)
                if v is None:
                    continue
                ref = a["y"][i, c]
                scale = max(abs(ref), 1e-300)
                if est / scale > resolved * tol:
                    unres += 1
                    continue
                rel = abs(v - ref) / scale
                count += 1
                worst = max(worst, rel)
                if rel > tol + est / scale:
                    bad.append((name, at, a["ids"][c], ref, v, rel, est / scale))
    return worst, count, unres, bad


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("old")
    ap.add_argument("new")
    ap.add_argument("--metric", default="p2p_range")
    ap.add_argument("--element", nargs="*", help="elements compared (default: all)")
    ap.add_argument("--tol", type=float, default=1e-6, help="relative agreement of the metric")
    ap.add_argument("--resolved", type=float, default=0.1,
                    help="a comparison counts where the interpolation estimate is below this x tol")
    ap.add_argument("--fold-tol", type=float, default=1e-6, help="a fold's lambda, absolute")
    ap.add_argument("--change-tol", type=float, default=1e-4, help="any other change point's lambda, absolute")
    a = ap.parse_args(argv)
    old, new = read(a.old, a.metric), read(a.new, a.metric)
    cols = [old["ids"].index(e) for e in a.element] if a.element else list(range(len(old["ids"])))
    co, po = pieces(old)
    cn, pn = pieces(new)
    ok = True
    print(f"old: {len(old['lam'])} points, {old['maps']} maps, end {old['end']}; "
          f"new: {len(new['lam'])} points, {new['maps']} maps, end {new['end']}")
    if [k for k, _ in co] != [k for k, _ in cn]:
        ok = False
        print("FAIL: the change points differ:\n  old " + ", ".join(f"{k} {v:.6f}" for k, v in co) +
              "\n  new " + ", ".join(f"{k} {v:.6f}" for k, v in cn))
    else:
        for (k, lo), (_, ln) in zip(co, cn):
            t = a.fold_tol if k == "fold" else a.change_tol
            flag = "" if abs(lo - ln) <= t else "  FAIL"
            ok = ok and not flag
            print(f"  {k:16s} old {lo:.9f} new {ln:.9f} diff {ln - lo:+.2e} (tol {t:g}){flag}")
    for ia, ib in zip(po, pn):
        sa = set(old["stable"][ia[1:-1]].tolist()) if len(ia) > 2 else set()
        sb = set(new["stable"][ib[1:-1]].tolist()) if len(ib) > 2 else set()
        if sa and sb and sa != sb:
            ok = False
            print(f"FAIL: stability differs on the piece from {old['lam'][ia[0]]:.6f}: old {sa}, new {sb}")
    for name, x, px, y, py in (("new at old", old, po, new, pn), ("old at new", new, pn, old, po)):
        worst, count, unres, other, bad = compare_states(x, px, y, py, a.tol, a.resolved)
        print(f"state, {name}: {count} points compared, largest difference {worst:.2e} of the scale "
              f"(tol {a.tol:g}); {unres} not resolved by the interpolation, {other} not bracketed by two of the other's points at the same phase of t0")
        for at, d, est in bad[:10]:
            print(f"  FAIL lambda {at:.9f}: {d:.2e} (interpolation estimate {est:.1e})")
        ok = ok and not bad and count > 0
        worst, count, unres, b = compare_pieces(x, px, y, py, cols, a.tol, a.resolved, name)
        print(f"{a.metric}, {name} (not asserted): {count} values within the interpolation's resolution, "
              f"largest rel. diff {worst:.2e}, {len(b)} beyond tol + estimate; {unres} not resolved")
    print("ok" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
