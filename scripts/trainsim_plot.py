#!/usr/bin/python3
"""Plot a trainsim history file (HDF5) to PNG, PDF or SVG (by the output's extension).

usage:
  trainsim_plot.py FILE Y [Y ...] [--x X] [--t0 T] [--t1 T] [--events] -o OUT.png
  trainsim_plot.py FILE --te GEAR [--t0 T] [--t1 T] [--events] -o OUT.pdf
  trainsim_plot.py FILE --te-spectrum GEAR [--t0 T] [--t1 T] -o OUT.svg
  trainsim_plot.py FILE --overview [ELEMENT] [--t0 T] [--t1 T] -o OUT.png
  add --data OUT.npz to save the plotted arrays (what a test reads back)
  trainsim_plot.py SWEEP.h5 [MORE.h5 ...] --metric ID.NAME [--x PARAM] [--fig5-11] -o OUT.png
      a sweep file (trainsim sweep): a metric against a swept parameter, continuation
      branches up and down, failed runs marked (scripts/plot_sweep.py --help)

Y and X are quantities as in trainsim_export.py (mesh.displacement, drive.omega,
energy.balance, input.load.load_torque, ...). With --x the plot is Y against X (a phase plane, e.g.
--x mesh.displacement); otherwise against time. --te plots the transmission error of a
gear pair with the contact threshold (the half backlash: below it the teeth are apart)
and, on the right axis, the number of tooth pairs in contact (Figs. 5.12-5.14). --events
marks the element's contact events. --te-spectrum is the amplitude spectrum of the TE
against mesh order (multiples of the mesh frequency, taken from the driver's mean speed
and tooth count). --overview draws the history figure of one element (default: the
first clearance element): its displacement (TE) with the contact thresholds, impacts and
pairs in contact, its force, and its phase plane (verification/plot_history.py, installed
as share/trainsim/scripts/plot_history.py).

Every axis names its quantity and unit. The unit is the file's (root attribute
`units`): inch-pound values in in, lbf, lbf*in; SI values with the prefix that suits
their size (a TE in um, a force in kN). --events draws the events in a strip of ticks
under the plot, one row per kind with its count in the legend, so thousands of events
do not cover the data.
"""
import argparse
import os
import sys
import textwrap

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from trainsim_export import ExportError, attr_list, quantity, window  # noqa: E402
from trainsim_figures import describe_figure, display_unit, label as axis_label  # noqa: E402

# the words for each quantity NAME of ID.NAME on an axis
QUANTITY_WORDS = {"theta": "angle", "omega": "speed", "torque_left": "torque on its left node",
                  "torque_right": "torque on its right node", "displacement": "relative displacement",
                  "force": "force", "contact": "contact face (+1 front, 0 open, -1 rear)",
                  "pairs": "tooth pairs in contact"}
GEAR_TYPES = ("spur_gear", "helical_gear", "ideal_gear")
EVENT_COLOURS = {"contact_front": "C3", "contact_rear": "C1", "separation": "C0", "zone": "0.5"}


def element_index(f, ident):
    ids = attr_list(f["elements"], "ids")
    if ident not in ids:
        raise ExportError(f"unknown element '{ident}'; elements: {', '.join(ids)}")
    return ids.index(ident)


def gear_params(f, ident):
    g = f["elements"][ident].attrs
    if "teeth" not in g or "half_backlash" not in g:
        raise ExportError(f"element '{ident}' is not a gear pair (no teeth / half_backlash)")
    return g


def quantity_words(f, name):
    """What ID.NAME is, in words: 'mesh.displacement (transmission error)'."""
    head, _, tail = name.partition(".")
    if head == "energy":
        return f"{tail} energy" if tail != "balance" else "energy balance residual"
    if head == "state":
        return f"state {tail}"
    ident, _, q = name.rpartition(".")
    words = QUANTITY_WORDS.get(q, q)
    ids = attr_list(f["elements"], "ids")
    if ident in ids:
        etype = attr_list(f["elements"], "types")[ids.index(ident)]
        if q == "displacement" and etype in GEAR_TYPES:
            words = "transmission error"
        elif q == "force":
            words = {"shaft": "shaft torque", "clearance_coupling": "contact torque", "damper": "damper torque"}.get(
                etype, "mesh force" if etype in GEAR_TYPES else "contact force")
    return f"{ident}: {words}"


def prepare_series(f, ys, x=None, t0=None, t1=None):
    """Plotted arrays of Y (against time or X): dict of name -> array, plus (words, unit) of each."""
    t = f["time"][:]
    idx = window(t, t0, t1)
    data = {"time": t[idx]}
    labels = {"time": ("time", "s")}
    for name in ys + ([x] if x else []):
        v, u = quantity(f, name)
        data[name] = v[idx]
        labels[name] = (quantity_words(f, name), u)
    return data, labels


def events_of(f, ident, t0=None, t1=None):
    """Times and kind names of an element's events (every element's: ident None) in the window."""
    ev = f["events"]
    t = ev["time"][:]
    keep = np.ones(t.shape, bool) if ident is None else ev["element"][:] == element_index(f, ident) + 1
    if t0 is not None:
        keep &= t >= t0
    if t1 is not None:
        keep &= t <= t1
    return t[keep], ev["kind_name"].asstr()[:][keep]


def prepare_te(f, gear, t0=None, t1=None):
    """TE, contact threshold (+/- half backlash) and pairs in contact over the window."""
    j = element_index(f, gear)
    g = gear_params(f, gear)
    t = f["time"][:]
    idx = window(t, t0, t1)
    unit = attr_list(f["elements/displacement"], "column_units")[j]
    return {"time": t[idx], "te": f["elements/displacement"][idx, j], "pairs": f["elements/pairs"][idx, j],
            "threshold": np.array([float(g["half_backlash"]), -float(g["half_backlash"])])}, unit


def prepare_te_spectrum(f, gear, t0=None, t1=None):
    """Amplitude spectrum of the TE (mean removed) against mesh order.

    The mesh frequency is N |mean driver speed| / 2 pi (driver = the gear's left node).
    """
    j = element_index(f, gear)
    g = gear_params(f, gear)
    t = f["time"][:]
    idx = window(t, t0, t1)
    if idx.size < 8:
        raise ExportError("the TE spectrum needs at least 8 samples in the window")
    te = f["elements/displacement"][idx, j]
    left = int(f["elements"].attrs["left"][j]) - 1
    w = np.mean(f["nodes/omega"][idx, left])
    f_mesh = float(g["teeth"]) * abs(w) / (2 * np.pi)
    if f_mesh <= 0:
        raise ExportError(f"the driver of '{gear}' does not turn in the window: no mesh frequency")
    dt = float(np.mean(np.diff(t[idx])))
    amp = np.abs(np.fft.rfft(te - te.mean())) * 2.0 / idx.size
    freq = np.fft.rfftfreq(idx.size, dt)
    unit = attr_list(f["elements/displacement"], "column_units")[j]
    return {"order": freq / f_mesh, "amplitude": amp, "mesh_frequency": np.array([f_mesh])}, unit


def event_strip(ax_strip, times, kinds):
    """Events as ticks in a strip under the plot, one row per kind (never over the data);
    returns legend handles naming each kind and its count."""
    from matplotlib.lines import Line2D
    names = [k for k in EVENT_COLOURS if k in set(kinds)] + sorted(set(kinds) - set(EVENT_COLOURS))
    handles = []
    for row, name in enumerate(names):
        tt = times[kinds == name]
        c = EVENT_COLOURS.get(name, "k")
        ax_strip.plot(tt, np.full(tt.size, row), "|", color=c, ms=7, mew=0.6, alpha=0.7, gid=f"events:{name}")
        handles.append(Line2D([], [], ls="none", marker="|", ms=8, mew=1.2, color=c,
                              label=f"event: {name.replace('_', ' ')} ({tt.size})"))
    ax_strip.set_yticks(range(len(names)))
    ax_strip.set_yticklabels([n.replace("_", " ") for n in names], fontsize=6)
    ax_strip.set_ylim(-0.7, max(len(names), 1) - 0.3)
    ax_strip.set_ylabel("event kind", fontsize=7)
    ax_strip.grid(True, axis="x", lw=0.3)
    if not names:
        ax_strip.set_yticks([])
        ax_strip.text(0.5, 0.5, "no events in the window", transform=ax_strip.transAxes, ha="center",
                      va="center", fontsize=7, color="0.4")
    return handles


def is_sweep_file(path):
    """A trainsim sweep file (trainsim sweep -o FILE), not a run's history."""
    try:
        with h5py.File(path, "r") as f:
            return str(f.attrs.get("format", "")) == "trainsim-sweep"
    except OSError:
        return False


def draw_figure(plt, f, a, title):
    """The figure of a history: Y against time or X, --te, or --te-spectrum; events in a
    strip under it. Returns (figure, plotted arrays in the file's units)."""
    strip = a.events and not a.te_spectrum and not a.x
    if strip:
        fig, (ax, ax_ev) = plt.subplots(2, 1, figsize=(8, 5.2), sharex=True, layout="constrained",
                                        gridspec_kw={"height_ratios": [6, 1]})
    else:
        fig, ax = plt.subplots(figsize=(8, 4.5), layout="constrained")
    extra_handles = []
    if a.te_spectrum:
        data, unit = prepare_te_spectrum(f, a.te_spectrum, a.t0, a.t1)
        k, u = display_unit(data["amplitude"], unit)
        ax.plot(data["order"], data["amplitude"] * k, label="TE amplitude")
        ax.set_xlabel(axis_label(f"mesh order: frequency / mesh frequency {data['mesh_frequency'][0]:.4g} Hz", "1"))
        ax.set_ylabel(axis_label(f"{a.te_spectrum} transmission error amplitude", u))
        ax.set_xlim(0, min(10, data["order"][-1]))
    elif a.te:
        data, unit = prepare_te(f, a.te, a.t0, a.t1)
        k, u = display_unit(np.concatenate([data["te"], data["threshold"]]), unit)
        ax.plot(data["time"], data["te"] * k, label="transmission error")
        ax.axhline(data["threshold"][0] * k, color="r", ls="--", lw=0.8, label="contact threshold (b)")
        ax.axhline(data["threshold"][1] * k, color="r", ls=":", lw=0.8, label="rear-face contact (-b)")
        ax.set_xlabel(axis_label("time", "s"))
        ax.set_ylabel(axis_label(f"{a.te} transmission error", u))
        ax2 = ax.twinx()
        ax2.step(data["time"], data["pairs"], where="post", color="0.5", lw=0.7, label="tooth pairs in contact")
        ax2.set_ylabel(axis_label("tooth pairs in contact", "1"))
        ax2.set_ylim(0, 6)
        if a.events:
            te_t, kinds = events_of(f, a.te, a.t0, a.t1)
            data["event_time"] = te_t
            extra_handles = event_strip(ax_ev, te_t, kinds)
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels()
        ax.legend(h1 + h2 + extra_handles, l1 + l2 + [h.get_label() for h in extra_handles],
                  loc="upper right", fontsize=7)
    else:
        if not a.y:
            raise ExportError("name a quantity to plot (Y), or --te GEAR / --te-spectrum GEAR / --overview")
        data, labels = prepare_series(f, a.y, a.x, a.t0, a.t1)
        xs = a.x or "time"
        kx, ux = display_unit(data[xs], labels[xs][1]) if a.x else (1.0, "s")
        units = []
        for name in a.y:
            if labels[name][1] not in units:
                units.append(labels[name][1])
        if len(units) > 2:
            raise ExportError(f"the quantities have {len(units)} units ({', '.join(units)}): at most two "
                              "(a left and a right axis) in one figure")
        axes = [ax] + ([ax.twinx()] if len(units) == 2 else [])
        for axis, unit in zip(axes, units):
            names = [n for n in a.y if labels[n][1] == unit]
            k, u = display_unit(np.concatenate([data[n] for n in names]), unit)
            for n in names:
                axis.plot(data[xs] * kx, data[n] * k, label=labels[n][0], lw=0.8,
                          color=f"C{a.y.index(n)}")
            words = labels[names[0]][0] if len(names) == 1 else "; ".join(labels[n][0] for n in names)
            axis.set_ylabel(axis_label(words, u))
        ax.set_xlabel(axis_label(labels[xs][0], ux))
        if a.events and not a.x:
            ev_t, kinds = events_of(f, None, a.t0, a.t1)
            data["event_time"] = ev_t
            extra_handles = event_strip(ax_ev, ev_t, kinds)
        handles = [h for axis in axes for h in axis.get_legend_handles_labels()[0]]
        if len(a.y) > 1 or extra_handles:
            ax.legend(handles + extra_handles, [h.get_label() for h in handles + extra_handles], fontsize=7,
                      loc="upper right")
    if strip:
        ax_ev.set_xlabel(ax.get_xlabel())
        ax.set_xlabel("")
        ax.tick_params(labelbottom=False)
    ax.set_title(title, fontsize=10)
    ax.grid(True, lw=0.3)
    return fig, data


def draw_overview(f, path, element, t0=None, t1=None):
    """plot_history.py's figure of one element (its TE, force and phase plane)."""
    here = os.path.dirname(os.path.abspath(__file__))
    for d in (here, os.path.join(here, "..", "verification")):   # installed beside us, or the source tree
        if os.path.exists(os.path.join(d, "plot_history.py")) and d not in sys.path:
            sys.path.insert(0, d)
    import plot_history
    h = plot_history.History(path)
    if not h.ids:
        raise ExportError("the run has no elements: nothing to draw")
    if element:
        if element not in h.ids:
            raise ExportError(f"unknown element '{element}'; elements: {', '.join(h.ids)}")
        j = h.ids.index(element)
    else:
        clear = h.clearance_columns()
        j = clear[0] if clear else 0
    fig = plot_history.draw_element(h, j, t0, t1)
    return fig, {"element": np.array([h.ids[j]])}


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv and not argv[0].startswith("-") and is_sweep_file(argv[0]):
        # a sweep file: a metric against a swept parameter (scripts/plot_sweep.py)
        import plot_sweep
        return plot_sweep.main(["--out" if x in ("-o", "--output") else x for x in argv], prog="trainsim plot")
    p = argparse.ArgumentParser(prog="trainsim plot", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", help="a history file of trainsim run (HDF5), or a sweep file (then: --metric ID.NAME [--x PARAM]; trainsim plot SWEEP.h5 --help)")
    p.add_argument("y", nargs="*", help="quantities to draw, as in trainsim export (mesh.displacement, "
                   "drive.omega, input.load.load_torque)")
    p.add_argument("--x", help="a quantity for the x axis (a phase plane); default: time")
    p.add_argument("--te", metavar="GEAR", help="the transmission error of gear pair GEAR with its contact "
                   "threshold and the tooth pairs in contact")
    p.add_argument("--te-spectrum", metavar="GEAR", help="the amplitude spectrum of GEAR's TE against mesh order")
    p.add_argument("--overview", nargs="?", const="", metavar="ELEMENT",
                   help="the history figure of an element (default: the first clearance element)")
    p.add_argument("--events", action="store_true", help="mark contact events as ticks in a strip under the plot")
    p.add_argument("--t0", type=float, help="draw from t0 (s) on")
    p.add_argument("--t1", type=float, help="draw up to t1 (s)")
    p.add_argument("--data", metavar="OUT.npz", help="also save the plotted arrays (numpy .npz)")
    p.add_argument("--describe", help=argparse.SUPPRESS)   # the axes as JSON (tests)
    p.add_argument("-o", "--output", required=True, help="the figure: .png, .pdf or .svg")
    a = p.parse_args(argv)
    ext = os.path.splitext(a.output)[1].lower()
    if ext not in (".png", ".pdf", ".svg"):
        print(f"trainsim plot: error: output '{a.output}' must end in .png, .pdf or .svg", file=sys.stderr)
        return 2
    import matplotlib
    matplotlib.use("Agg")
    matplotlib.rcParams["svg.fonttype"] = "none"     # text stays text in an SVG
    import matplotlib.pyplot as plt
    try:
        f = h5py.File(a.file, "r")
    except OSError as e:
        print(f"trainsim plot: error: cannot read '{a.file}': {e}", file=sys.stderr)
        return 2
    try:
        with f:
            title = str(f.attrs.get("title", os.path.basename(a.file)))
            overrides = str(f.attrs.get("overrides", ""))
            if overrides:   # the deck's title does not know the --set values of this run
                # wrapped to the figure's width (a sweep's override list is long)
                title += "\n" + "\n".join(textwrap.wrap(f"(--set {overrides})", 100))
            if a.overview is not None:
                fig, data = draw_overview(f, a.file, a.overview, a.t0, a.t1)
                fig.savefig(a.output, bbox_inches="tight")
            else:
                fig, data = draw_figure(plt, f, a, title)
                fig.savefig(a.output)
            if a.describe:
                describe_figure(fig, a.describe)
            plt.close(fig)
            if a.data:
                np.savez(a.data, **{k.replace(".", "__"): np.asarray(v) for k, v in data.items()})
    except ExportError as e:
        print(f"trainsim plot: {a.file}: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
