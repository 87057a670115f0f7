#!/usr/bin/python3
"""Plot a trainsim history file (HDF5) to PNG, PDF or SVG (by the output's extension).

usage:
  trainsim_plot.py FILE Y [Y ...] [--x X] [--t0 T] [--t1 T] [--events] -o OUT.png
  trainsim_plot.py FILE --te GEAR [--t0 T] [--t1 T] [--events] -o OUT.pdf
  trainsim_plot.py FILE --te-spectrum GEAR [--t0 T] [--t1 T] -o OUT.svg
  add --data OUT.npz to save the plotted arrays (what a test reads back)
  trainsim_plot.py SWEEP.h5 [MORE.h5 ...] --metric ID.NAME [--x PARAM] [--fig5-11] -o OUT.png
      a sweep file (trainsim sweep): a metric against a swept parameter, continuation
      branches up and down, failed runs marked (scripts/plot_sweep.py --help)

Y and X are quantities as in trainsim_export.py (mesh.displacement, drive.omega,
energy.balance, ...). With --x the plot is Y against X (a phase plane, e.g.
--x mesh.displacement); otherwise against time. --te plots the transmission error of a
gear pair with the contact threshold (the half backlash: below it the teeth are apart)
and, on the right axis, the number of tooth pairs in contact (Figs. 5.12-5.14). --events
marks the element's contact events. --te-spectrum is the amplitude spectrum of the TE
against mesh order (multiples of the mesh frequency, taken from the driver's mean speed
and tooth count). Axes carry units, the title is the run's.
"""
import argparse
import os
import sys
import textwrap

import h5py
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from trainsim_export import ExportError, attr_list, quantity, window  # noqa: E402


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


def prepare_series(f, ys, x=None, t0=None, t1=None):
    """Plotted arrays of Y (against time or X): dict of name -> array, plus labels."""
    t = f["time"][:]
    idx = window(t, t0, t1)
    data = {"time": t[idx]}
    labels = {"time": "time [s]"}
    for name in ys + ([x] if x else []):
        v, u = quantity(f, name)
        data[name] = v[idx]
        labels[name] = f"{name} [{u}]"
    return data, labels


def events_of(f, ident, t0=None, t1=None):
    """Times and kind names of an element's events in the window."""
    ev = f["events"]
    j = element_index(f, ident) + 1
    t = ev["time"][:]
    keep = ev["element"][:] == j
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


def is_sweep_file(path):
    """A trainsim sweep file (trainsim sweep -o FILE), not a run's history."""
    try:
        with h5py.File(path, "r") as f:
            return str(f.attrs.get("format", "")) == "trainsim-sweep"
    except OSError:
        return False


def main(argv=None):
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv and not argv[0].startswith("-") and is_sweep_file(argv[0]):
        # a sweep file: a metric against a swept parameter (scripts/plot_sweep.py)
        import plot_sweep
        return plot_sweep.main(["--out" if x in ("-o", "--output") else x for x in argv], prog="trainsim plot")
    p = argparse.ArgumentParser(prog="trainsim plot", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file")
    p.add_argument("y", nargs="*")
    p.add_argument("--x")
    p.add_argument("--te")
    p.add_argument("--te-spectrum")
    p.add_argument("--events", action="store_true")
    p.add_argument("--t0", type=float)
    p.add_argument("--t1", type=float)
    p.add_argument("--data")
    p.add_argument("-o", "--output", required=True)
    a = p.parse_args(argv)
    ext = os.path.splitext(a.output)[1].lower()
    if ext not in (".png", ".pdf", ".svg"):
        print(f"trainsim plot: error: output '{a.output}' must end in .png, .pdf or .svg", file=sys.stderr)
        return 2
    import matplotlib
    matplotlib.use("Agg")
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
            fig, ax = plt.subplots(figsize=(8, 4.5))
            if a.te_spectrum:
                data, unit = prepare_te_spectrum(f, a.te_spectrum, a.t0, a.t1)
                ax.plot(data["order"], data["amplitude"])
                ax.set_xlabel("mesh order (frequency / mesh frequency "
                              f"{data['mesh_frequency'][0]:.4g} Hz)")
                ax.set_ylabel(f"{a.te_spectrum} TE amplitude [{unit}]")
                ax.set_xlim(0, min(10, data["order"][-1]))
            elif a.te:
                data, unit = prepare_te(f, a.te, a.t0, a.t1)
                ax.plot(data["time"], data["te"], label="transmission error")
                ax.axhline(data["threshold"][0], color="r", ls="--", lw=0.8, label="contact threshold (b)")
                ax.axhline(data["threshold"][1], color="r", ls=":", lw=0.8, label="rear-face contact (-b)")
                ax.set_xlabel("time [s]")
                ax.set_ylabel(f"{a.te} TE [{unit}]")
                ax2 = ax.twinx()
                ax2.step(data["time"], data["pairs"], where="post", color="0.5", lw=0.7)
                ax2.set_ylabel("pairs in contact")
                ax2.set_ylim(0, 6)
                if a.events:
                    te_t, kinds = events_of(f, a.te, a.t0, a.t1)
                    data["event_time"] = te_t
                    for tt, k in zip(te_t, kinds):
                        ax.axvline(tt, color="g" if k.startswith("contact") else "0.7", lw=0.4)
                ax.legend(loc="upper right", fontsize=8)
            else:
                if not a.y:
                    raise ExportError("name a quantity to plot (Y), or --te GEAR / --te-spectrum GEAR")
                data, labels = prepare_series(f, a.y, a.x, a.t0, a.t1)
                xs = a.x or "time"
                for name in a.y:
                    ax.plot(data[xs], data[name], label=labels[name], lw=0.8)
                ax.set_xlabel(labels[xs])
                ax.set_ylabel(labels[a.y[0]] if len(a.y) == 1 else "")
                if len(a.y) > 1:
                    ax.legend(fontsize=8)
                if a.events and not a.x:
                    ev_t = f["events/time"][:]
                    keep = np.ones(ev_t.shape, bool)
                    if a.t0 is not None:
                        keep &= ev_t >= a.t0
                    if a.t1 is not None:
                        keep &= ev_t <= a.t1
                    data["event_time"] = ev_t[keep]
                    for tt in ev_t[keep]:
                        ax.axvline(tt, color="0.8", lw=0.4)
            ax.set_title(title, fontsize=10)
            ax.grid(True, lw=0.3)
            fig.tight_layout()
            fig.savefig(a.output)
            plt.close(fig)
            if a.data:
                np.savez(a.data, **{k.replace(".", "__"): np.asarray(v) for k, v in data.items()})
    except ExportError as e:
        print(f"trainsim plot: {a.file}: error: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
