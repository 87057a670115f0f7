#!/usr/bin/env python3
"""Thesis-style figures from a trainsim HDF5 history.

    plot_history.py FILE.h5 [--element ID] [--out PNG] [--t0 S] [--t1 S]

For one element (default: the first element with a clearance, else the first
element) draws one PNG with

  * the relative displacement (transmission error for a gear pair) against
    time, with the contact thresholds +-b (b = the element's `half_backlash`,
    `half_clearance` or `clearance`/2 from /elements/<id>) and, on a secondary
    axis along the top, the tooth pairs in contact (Figs. 3.12, 5.12-5.14,
    7.2-7.3); for clearance elements without tooth zones the contact face
    (+1 front, 0 none, -1 rear) is drawn there instead; contact onsets from the
    event table are marked on the threshold they cross;
  * the element force against time (contact/mesh force; shaft torque for a
    shaft) (Figs. 3.15, 3.21, 7.4);
  * the phase plane: displacement against its rate, the rate computed by
    differentiating the recorded displacement (Figs. 3.14, 3.17, 3.20).

`--element all` draws every clearance element (every element if there is
none), one PNG each, named <out stem>_<id>.png.

It also prints a summary of the event table (counts, first impact, approach
velocities, restitution, damping, peak forces, contact durations) and the run
statistics. Needs h5py, numpy and matplotlib (Agg backend, no display).
"""
import argparse
import os
import sys

import numpy as np

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402

try:
    import h5py
except ImportError:  # pragma: no cover
    sys.exit("plot_history.py: needs h5py (apt-get install python3-h5py, or pip install h5py)")

CLEARANCE_TYPES = ("spur_gear", "helical_gear", "keyed_joint", "clearance_coupling")
KIND_NAMES = {1: "contact_front", 2: "contact_rear", 3: "separation", 4: "zone"}

# unit prefixes: the plotted quantity is multiplied by `factor` and labelled `label`
_PREFIX = {0: "", -3: "m", -6: "µ", -9: "n", 3: "k", 6: "M"}


def _strings(a):
    return [x.decode() if isinstance(x, (bytes, np.bytes_)) else str(x) for x in a]


def scale_for(values, unit):
    """A power of 1000 that brings max|values| into [1, 1000), and its axis label unit."""
    vmax = float(np.nanmax(np.abs(values))) if len(values) else 0.0
    if not np.isfinite(vmax) or vmax == 0.0:
        return 1.0, unit
    e3 = int(np.floor(np.log10(vmax) / 3.0)) * 3
    e3 = max(min(e3, 6), -9)
    if e3 == 0:
        return 1.0, unit
    if unit in ("in", "lbf", "lbf*in", "in/s"):
        # no SI prefixes on inch units: say the power of ten
        return 10.0 ** (-e3), f"1e{e3} {unit}"
    return 10.0 ** (-e3), _PREFIX.get(e3, f"1e{e3} ") + unit


class History:
    """What the plots need from one file."""

    def __init__(self, path):
        self.path = path
        with h5py.File(path, "r") as f:
            self.title = f.attrs.get("title", b"")
            self.title = self.title.decode() if isinstance(self.title, bytes) else str(self.title)
            self.units = f.attrs.get("units", b"in-lbf-s")
            self.units = self.units.decode() if isinstance(self.units, bytes) else str(self.units)
            self.t = f["time"][:]
            el = f["elements"]
            self.ids = _strings(el.attrs["ids"])
            self.types = _strings(el.attrs["types"])
            self.disp_units = _strings(el.attrs["displacement_units"])
            self.left = np.asarray(el.attrs["left"])
            self.right = np.asarray(el.attrs["right"])
            self.disp = el["displacement"][:]
            self.force = el["force"][:]
            self.contact = el["contact"][:]
            self.pairs = el["pairs"][:]
            self.params = {}
            for j, eid in enumerate(self.ids):
                name = eid if eid else f"_{j + 1}"
                g = el.get(name)
                self.params[eid] = {k: float(v) for k, v in g.attrs.items()} if g is not None else {}
            ev = f["events"]
            self.ev_t = ev["time"][:]
            self.ev_el = ev["element"][:]
            self.ev_kind = ev["kind"][:]
            self.ev_v = ev["approach_velocity"][:]
            self.ev_e = ev["restitution"][:]
            self.ev_d = ev["damping"][:]
            self.ev_peak = ev["peak_force"][:]
            self.ev_dur = ev["duration"][:]
            self.stats = {k: (v.item() if hasattr(v, "item") else v) for k, v in f["run_stats"].attrs.items()}

    def column(self, ident):
        """Column index of an element given by id or by 1-based index."""
        if ident in self.ids:
            return self.ids.index(ident)
        if ident.isdigit() and 1 <= int(ident) <= len(self.ids):
            return int(ident) - 1
        raise SystemExit(f"plot_history.py: no element '{ident}' in {self.path}; elements: {', '.join(self.ids)}")

    def clearance_columns(self):
        return [j for j, ty in enumerate(self.types) if ty in CLEARANCE_TYPES]

    def half_clearance(self, j):
        p = self.params.get(self.ids[j], {})
        if "half_backlash" in p:
            return p["half_backlash"]
        if "half_clearance" in p:
            return p["half_clearance"]
        if "clearance" in p:
            return 0.5 * p["clearance"]
        return None

    def force_unit(self, j):
        torque = {"in-lbf-s": "lbf*in", "si": "N*m"}.get(self.units, "torque")
        force = {"in-lbf-s": "lbf", "si": "N"}.get(self.units, "force")
        return force if self.disp_units[j] in ("in", "m") else torque


def distinct_samples(t, *series):
    """Drop samples closer in time than 1e-6 of the median spacing to the one
    before (event samples can fall on an output time), keeping the later one."""
    dt = np.diff(t)
    pos = dt[dt > 0]
    if len(pos) == 0:
        return (t,) + series
    tiny = 1e-6 * np.median(pos)
    keep = np.ones(len(t), dtype=bool)
    keep[:-1] = dt > tiny
    return (t[keep],) + tuple(s[keep] for s in series)


def rate(t, x):
    """dx/dt by second-order finite differences on the (non-uniform) sample times."""
    if len(t) < 3:
        return np.zeros_like(x)
    return np.gradient(x, t, edge_order=2)


def print_summary(h):
    print(f"{h.path}: {h.title}")
    print(f"  {len(h.t)} samples, t = {h.t[0]:.6g} .. {h.t[-1]:.6g} s, units {h.units}")
    s = h.stats
    if s:
        print(f"  run: completed={bool(s.get('completed', 0))}, steps={s.get('steps')}, "
              f"rhs_evals={s.get('rhs_evals')}, events={s.get('events')}, wall {s.get('wall_time', 0):.3g} s")
    if len(h.ev_t) == 0:
        print("  event table: empty")
        return
    print("  event table by element:")
    hdr = (f"    {'element':>10} {'type':>18} {'front':>5} {'rear':>5} {'sep':>5} {'zone':>5} "
           f"{'1st impact s':>12} {'V_i min':>9} {'V_i max':>9} {'e min':>7} {'e max':>7} "
           f"{'D min':>10} {'D max':>10} {'peak F':>10} {'dur mean':>10}")
    print(hdr)
    for j, eid in enumerate(h.ids):
        m = h.ev_el == j + 1
        if not m.any():
            continue
        kinds = h.ev_kind[m]
        imp = m & ((h.ev_kind == 1) | (h.ev_kind == 2))
        n = [int((kinds == k).sum()) for k in (1, 2, 3, 4)]
        if imp.any():
            v = np.abs(h.ev_v[imp])
            dur = h.ev_dur[imp]
            dur = dur[dur >= 0]
            row = (f"{h.ev_t[imp][0]:12.6g} {v.min():9.4g} {v.max():9.4g} {h.ev_e[imp].min():7.4f} "
                   f"{h.ev_e[imp].max():7.4f} {h.ev_d[imp].min():10.4g} {h.ev_d[imp].max():10.4g} "
                   f"{h.ev_peak[imp].max():10.4g} {(dur.mean() if len(dur) else float('nan')):10.4g}")
        else:
            row = f"{'-':>12}"
        print(f"    {eid:>10} {h.types[j]:>18} {n[0]:5d} {n[1]:5d} {n[2]:5d} {n[3]:5d} {row}")
        still = imp & (h.ev_dur < 0)
        if still.any():
            print(f"    {'':>10} contact closed at t = {h.ev_t[still][-1]:.6g} s is still closed at the end")


def plot_element(h, j, out, t0=None, t1=None):
    fig = draw_element(h, j, t0, t1)
    fig.savefig(out, bbox_inches="tight")
    plt.close(fig)
    print(f"  wrote {out}")


def draw_element(h, j, t0=None, t1=None):
    """The figure of element column j (trainsim plot --overview draws it too)."""
    eid = h.ids[j]
    t, x, f, pairs, contact = distinct_samples(h.t, h.disp[:, j], h.force[:, j], h.pairs[:, j], h.contact[:, j])
    sel = np.ones(len(t), dtype=bool)
    if t0 is not None:
        sel &= t >= t0
    if t1 is not None:
        sel &= t <= t1
    xdot_all = rate(t, x)
    t, x, f, pairs, contact, xdot = t[sel], x[sel], f[sel], pairs[sel], contact[sel], xdot_all[sel]
    if len(t) < 2:
        raise SystemExit(f"plot_history.py: fewer than two samples of element '{eid}' in the time window")
    b = h.half_clearance(j)
    du = h.disp_units[j]
    fu = h.force_unit(j)

    # time in ms for runs shorter than 1 s
    tf, tu = (1e3, "ms") if t[-1] - t[0] < 1.0 else (1.0, "s")
    xs, xu = scale_for(np.concatenate([x, [b] if b else []]), du)
    fs, fuu = scale_for(f, fu)
    vs, vu = scale_for(xdot, du + "/s")

    fig = plt.figure(figsize=(13, 9), dpi=110)
    gs = fig.add_gridspec(2, 2, height_ratios=[1.15, 1.0], hspace=0.32, wspace=0.22)
    ax_te = fig.add_subplot(gs[0, :])
    ax_f = fig.add_subplot(gs[1, 0])
    ax_ph = fig.add_subplot(gs[1, 1])
    name = "transmission error" if h.types[j] in ("spur_gear", "helical_gear", "ideal_gear") else "relative displacement"
    fig.suptitle(f"{h.title}\n{os.path.basename(h.path)} - element '{eid}' ({h.types[j]})", fontsize=12)

    # --- displacement vs time, thresholds, pairs / contact on a secondary axis
    ax_te.plot(t * tf, x * xs, color="C0", lw=1.0, label=name)
    lo, hi = float(np.min(x)), float(np.max(x))
    span = max(hi - lo, abs(b) if b else 0.0, 1e-300)
    ymin, ymax = lo - 0.08 * span, hi + 0.08 * span
    off_scale, drawn = [], []
    if b is not None:
        for sgn, lab in ((1, "+b"), (-1, "-b")):
            yb = sgn * b
            # draw a threshold the curve reaches or comes near; note the others
            if lo - 0.25 * span <= yb <= hi + 0.25 * span:
                drawn.append((lab, ax_te.axhline(yb * xs, color="C3", ls="--", lw=1.0)))
                ymin, ymax = min(ymin, yb - 0.08 * span), max(ymax, yb + 0.08 * span)
            else:
                off_scale.append(f"{lab} = {sgn * b:.4g} {du}")
        if len(drawn) == 2:
            drawn[0][1].set_label(f"contact thresholds ±b = ±{b:.4g} {du}")
        elif drawn:
            drawn[0][1].set_label(f"contact threshold {drawn[0][0]} = {b if drawn[0][0] == '+b' else -b:.4g} {du}")
        # contact onsets on the threshold they cross
        m = (h.ev_el == j + 1)
        for k, yb, mk in ((1, b, "v"), (2, -b, "^")):
            tt = h.ev_t[m & (h.ev_kind == k)]
            tt = tt[(tt >= t[0]) & (tt <= t[-1])]
            if len(tt) and not (f"{'+b' if k == 1 else '-b'} = {yb:.4g} {du}" in off_scale):
                ax_te.plot(tt * tf, np.full(len(tt), yb * xs), mk, color="C3", ms=3.5, ls="none",
                           label="impact (front face)" if k == 1 else "impact (rear face)")
    # leave the top of the axis free for the square wave (clearance elements)
    height = ymax - ymin
    ax_te.set_ylim(ymin * xs, (ymax + (0.28 if h.types[j] in CLEARANCE_TYPES else 0.0) * height) * xs)
    ax_te.set_xlim(t[0] * tf, t[-1] * tf)
    ax_te.set_xlabel(f"time ({tu})")
    ax_te.set_ylabel(f"{name} ({xu})")
    ax_te.ticklabel_format(axis="y", useOffset=False)
    ax_te.grid(alpha=0.3)
    if off_scale:
        ax_te.text(0.99, 0.02, "off scale: " + ", ".join(off_scale), transform=ax_te.transAxes, fontsize=8,
                   color="C3", va="bottom", ha="right")

    ax2 = ax_te.twinx() if h.types[j] in CLEARANCE_TYPES else None
    if ax2 is None:
        pass
    elif h.types[j] in ("spur_gear", "helical_gear") and np.any(pairs > 0):
        ax2.plot(t * tf, pairs, drawstyle="steps-post", color="C2", lw=1.0, label="pairs in contact")
        ax2.set_ylim(-6.0, 2.4)
        ax2.set_yticks([1, 2])
        ax2.set_ylabel("tooth pairs in contact (count)", color="C2")
    else:
        ax2.plot(t * tf, contact, drawstyle="steps-post", color="C2", lw=1.0, label="contact face")
        ax2.set_ylim(-12.0, 1.6)
        ax2.set_yticks([-1, 0, 1])
        ax2.set_yticklabels(["rear", "open", "front"])
        ax2.set_ylabel("contact face (front, open, rear)", color="C2")
    h1, l1 = ax_te.get_legend_handles_labels()
    h2, l2 = [], []
    if ax2 is not None:
        ax2.tick_params(axis="y", colors="C2")
        h2, l2 = ax2.get_legend_handles_labels()
    ax_te.legend(h1 + h2, l1 + l2, loc="lower center", bbox_to_anchor=(0.5, 1.0), fontsize=8, ncol=4,
                 frameon=False)

    # --- force vs time
    ax_f.plot(t * tf, f * fs, color="C1", lw=1.0)
    ax_f.axhline(0.0, color="k", lw=0.6)
    ax_f.set_xlim(t[0] * tf, t[-1] * tf)
    ax_f.set_xlabel(f"time ({tu})")
    flab = {"shaft": "shaft torque", "ideal_gear": "mesh force", "clearance_coupling": "contact torque"}.get(
        h.types[j], "contact force" if du in ("in", "m") else "element torque")
    ax_f.set_ylabel(f"{flab} ({fuu})")
    ax_f.ticklabel_format(axis="y", useOffset=False)
    ax_f.set_title(f"{flab} vs time", fontsize=10)
    ax_f.grid(alpha=0.3)

    # --- phase plane, coloured by time
    pts = np.column_stack([x * xs, xdot * vs]).reshape(-1, 1, 2)
    segs = np.concatenate([pts[:-1], pts[1:]], axis=1)
    lc = LineCollection(segs, cmap="viridis", linewidths=0.9)
    lc.set_array(0.5 * (t[:-1] + t[1:]) * tf)
    ax_ph.add_collection(lc)
    ax_ph.plot(x[0] * xs, xdot[0] * vs, "o", color="k", ms=4, label="start")
    ax_ph.autoscale()
    if b is not None:
        xl = ax_ph.get_xlim()
        for sgn in (1, -1):
            if xl[0] <= sgn * b * xs <= xl[1]:
                ax_ph.axvline(sgn * b * xs, color="C3", ls="--", lw=1.0)
    ax_ph.axhline(0.0, color="k", lw=0.6)
    ax_ph.set_xlabel(f"{name} ({xu})")
    ax_ph.set_ylabel(f"its rate ({vu}, by differentiation)")
    ax_ph.ticklabel_format(useOffset=False)
    ax_ph.set_title("phase plane", fontsize=10)
    ax_ph.grid(alpha=0.3)
    cb = fig.colorbar(lc, ax=ax_ph, pad=0.02)
    cb.set_label(f"time ({tu})")
    ax_ph.legend(loc="best", fontsize=8)
    return fig


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("file", help="trainsim HDF5 history")
    ap.add_argument("--element", help="element id or 1-based index; 'all' for every clearance element "
                                      "(default: the first clearance element, else the first element)")
    ap.add_argument("--out", help="PNG to write (default: FILE with .png, or FILE_<id>.png with --element all)")
    ap.add_argument("--t0", type=float, help="plot from this time (s)")
    ap.add_argument("--t1", type=float, help="plot up to this time (s)")
    a = ap.parse_args(argv)

    h = History(a.file)
    print_summary(h)
    if len(h.ids) == 0:
        print("  no elements: nothing to plot")
        return 0
    clear = h.clearance_columns()
    if a.element == "all":
        cols = clear if clear else list(range(len(h.ids)))
    elif a.element:
        cols = [h.column(a.element)]
    else:
        cols = [clear[0] if clear else 0]
    stem = os.path.splitext(a.out if a.out else a.file)[0]
    for j in cols:
        if a.out and len(cols) == 1:
            out = a.out
        elif len(cols) == 1 and a.element != "all":
            out = stem + ".png"
        else:
            out = f"{stem}_{h.ids[j] or j + 1}.png"
        plot_element(h, j, out, a.t0, a.t1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
