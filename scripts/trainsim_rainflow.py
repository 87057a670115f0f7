#!/usr/bin/python3
"""Rainflow cycle counting (ASTM E1049-85 (2017), §5.4.4), with half cycles.

Written here rather than taken from the `rainflow` or `fatpack` packages (PyPI): the
scripts of `trainsim export` and `trainsim plot` depend only on Debian's python3-numpy,
python3-h5py and python3-matplotlib, and the counting is about 40 lines.

    reversals(x)           the peaks and valleys of a series (plateaus collapsed)
    rainflow(x)            [(range, mean, count, i_start, i_end)], count 0.5 or 1.0
    rainflow_histogram(cycles, edges)   cycles per range bin (below / above the edges too)
"""
import numpy as np


def reversals(x):
    """Indices of the turning points of `x`: the first and last sample and every peak or
    valley between them (a run of equal values counts once, at its last sample)."""
    x = np.asarray(x, dtype=float)
    if x.size < 2:
        return np.arange(x.size)
    keep = np.flatnonzero(np.diff(x) != 0)
    if keep.size == 0:
        return np.array([0])
    idx = np.concatenate([keep, [keep[-1] + 1]])   # the points where x changes, and the last change's end
    d = np.sign(np.diff(x[idx]))
    turn = np.flatnonzero(d[1:] != d[:-1]) + 1      # where the direction changes
    return idx[np.concatenate([[0], turn, [idx.size - 1]])]


def rainflow(x):
    """ASTM E1049 §5.4.4 rainflow counting of series `x`.

    Returns a list of (range, mean, count, i0, i1): count 1.0 for a full cycle, 0.5 for a
    half cycle; i0, i1 the sample indices of the range's two reversals. Steps of the
    standard: (1) read the next reversal; (2) X = the latest range, Y = the one before;
    (3) X < Y: read on; (4) Y holds the start S: count Y as a half cycle and drop its
    first point (the new start is its second); else count Y as one cycle and drop both
    points; compare again; (5) at the end, every range left is a half cycle.
    """
    x = np.asarray(x, dtype=float)
    stack, out = [], []                     # indices of the reversals not yet counted
    for i in reversals(x):
        stack.append(int(i))
        while len(stack) >= 3:
            a, b, c = stack[-3], stack[-2], stack[-1]
            X, Y = abs(x[c] - x[b]), abs(x[b] - x[a])
            if X < Y:
                break
            if len(stack) == 3:             # Y contains the starting point S
                out.append((Y, 0.5 * (x[a] + x[b]), 0.5, a, b))
                stack.pop(0)
            else:
                out.append((Y, 0.5 * (x[a] + x[b]), 1.0, a, b))
                del stack[-3:-1]
    for a, b in zip(stack[:-1], stack[1:]):
        out.append((abs(x[b] - x[a]), 0.5 * (x[a] + x[b]), 0.5, a, b))
    return out


def rainflow_histogram(cycles, edges):
    """Cycles (half cycles count 0.5) per range bin [e_k, e_k+1), the last bin closed;
    returns (counts per bin, count below edges[0], count above edges[-1])."""
    edges = np.asarray(edges, dtype=float)
    r = np.array([c[0] for c in cycles], dtype=float)
    n = np.array([c[2] for c in cycles], dtype=float)
    inside = (r >= edges[0]) & (r <= edges[-1])
    counts, _ = np.histogram(r[inside], bins=edges, weights=n[inside])
    return counts, float(n[r < edges[0]].sum()), float(n[r > edges[-1]].sum())
