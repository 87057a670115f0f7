#!/usr/bin/python3
"""Plot a metric of a trainsim sweep file against the swept parameter.

    /usr/bin/python3 scripts/plot_sweep.py SWEEP.h5 [MORE.h5 ...] --metric mesh.p2p_mean \
        [--x mesh.mesh_frequency] [--label TEXT ...] [--out fig.png] [--fig5-11] [--data d.npz]
    /usr/bin/python3 scripts/plot_sweep.py SWEEP.h5 --te-spectrum mesh [--force] [--out fig.png]
    /usr/bin/python3 scripts/plot_sweep.py RUNUP.h5 SWEEP.h5 --metric mesh.te_order_1   (a run-up over a sweep)
    trainsim plot SWEEP.h5 [MORE.h5 ...] --metric mesh.p2p_mean -o fig.png   (the same)

--te-spectrum ID   the transmission error of gear mesh ID at mesh orders 1..4 (elements/te_order_K,
                   D-104) against the swept parameter: above, one curve per order (a waterfall seen
                   from the side); below, the order map (orders against the parameter, the amplitude
                   in colour, log scale). --force: the mesh force's orders instead.

--metric ID.NAME   an element metric (elements/NAME column ID: p2p_range, p2p_mean,
                   impacts, time_out_of_contact, max_peak_force, ...) or a node metric
                   (speed_min, speed_max); runs/NAME (wall_time, steps, ...) with ID 'run'
--x NAME           the parameter on the x axis (default: the first swept parameter)
--fig5-11          mark Cook's Fig. 5.11 figures (TRAIN's maximum 0.0022 in at 460 teeth/s,
                   its separation range 460-500 teeth/s, the experiment's 0.00325 in near 385)
Axes name the metric and the parameter with their units (from the sweep file's `units`
attribute and the element types; SI lengths and forces with the prefix that suits their
size). With two or more swept parameters the runs are grouped by the parameters other
than --x: one curve per combination of their values, named in the legend with units
(a 6 x 2 grid against its first parameter: 2 curves of 6 points).
Failed runs are marked with a red x on the axis; runs whose mesh lost contact (impacts > 0)
are filled markers when the metric is an element metric. Runs that did not settle within
their budget (&run settle_tol; runs/settled = 0) are ringed in orange: their figures are of a
transient, not a steady state. A continuation sweep (runs/branch
1 up, 2 down) draws each branch as its own curve: up with triangles pointing right, down
with triangles pointing left, in the order the runs were made.
A run-up file (trainsim runup, D-109) has the sweep file's layout with one "run" per tracked
block (its mesh frequency as the parameter): it is drawn as a line (dots where the block had
impacts), so a run-up and a sweep given together share the axes.
"""

import argparse
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from trainsim_figures import (METRIC_WORDS, describe_figure, display_unit, key_unit,  # noqa: E402
                              label as axis_label, metric_unit, pretty)

matplotlib.rcParams["svg.fonttype"] = "none"     # text stays text in an SVG


def strings(ds):
    return [s.decode() if isinstance(s, bytes) else str(s) for s in ds[:]]


def text_attr(f, name):
    v = f.attrs.get(name, "")
    return v.decode() if isinstance(v, bytes) else str(v)


def target_type(f, target):
    """('element' | 'node' | 'run' | None, type name) of a parameter's TARGET."""
    if target == "run":
        return "run", None
    group, _, k = target.partition("#")
    for kind in ("elements", "nodes"):
        ids = strings(f[kind]["ids"]) if "ids" in f[kind] else []
        types = strings(f[kind]["types"]) if "types" in f[kind] else [None] * len(ids)
        if k and group == kind[:-1] and k.isdigit() and 1 <= int(k) <= len(ids):
            return kind[:-1], types[int(k) - 1]
        if not k and target in ids:
            return kind[:-1], types[ids.index(target)]
    return None, None


def parameter_unit(f, name, units):
    """Unit of a swept parameter TARGET.KEY (None when it cannot be told, e.g. a load's value)."""
    target, _, key = name.rpartition(".")
    kind, etype = target_type(f, target)
    return key_unit(key, units, etype if kind == "element" else None)


def read(path, metric, xname):
    """What one sweep file contributes: parameter values, the metric, statuses, units."""
    with h5py.File(path, "r") as f:
        names = strings(f["parameters/names"]) if "names" in f["parameters"] else []
        if not names:
            sys.exit(f"{path}: the sweep has no parameters")
        xname = xname or names[0]
        if xname not in names:
            sys.exit(f"{path}: no parameter '{xname}'; parameters are: {', '.join(names)}")
        values = f["parameters/values"][:, :]
        status = f["runs/status"][:]
        units = str(f.attrs.get("units", "in-lbf-s"))
        oid, _, key = metric.rpartition(".")
        impacts, etype, group = None, None, None
        if oid == "run":
            y = f["runs"][key][:].astype(float)
            group = "run"
        else:
            for group in ("elements", "nodes"):
                ids = strings(f[group]["ids"]) if "ids" in f[group] else []
                if oid in ids and key in f[group]:
                    y = f[group][key][:, ids.index(oid)].astype(float)
                    if group == "elements":
                        impacts = f["elements/impacts"][:, ids.index(oid)]
                        etype = strings(f["elements/types"])[ids.index(oid)]
                    break
            else:
                el = [k for k in f["elements"] if k not in ("ids", "types")]
                sys.exit(f"{path}: no metric '{metric}'; element ids: {', '.join(strings(f['elements/ids']))}; "
                         f"element metrics: {', '.join(el)}; node metrics: speed_min, speed_max, end_angle, end_speed, start_speed")
        label = f.attrs.get("overrides", b"")
        label = label.decode() if isinstance(label, bytes) else str(label)
        branch = f["runs/branch"][:] if "branch" in f["runs"] else np.zeros(len(status), dtype=int)
        # 1 settled, 0 not settled within the budget, -1 not asked (older files: none)
        settled = f["runs/settled"][:] if "settled" in f["runs"] else -np.ones(len(status))
        p_units = {n: parameter_unit(f, n, units) for n in names}
        # a run-up file (trainsim runup, D-109): its blocks are the "runs", drawn as one line
        runup = None
        if text_attr(f, "kind") == "runup":
            runup = {k: text_attr(f, k) for k in ("from", "to", "rate", "block_cycles")}
    y_unit = metric_unit(key, units, etype if group == "elements" else None)
    if etype in ("spur_gear", "helical_gear", "ideal_gear"):
        words = METRIC_WORDS.get(key, key).replace("displacement", "transmission error")
    else:
        words = METRIC_WORDS.get(key, key.replace("_", " "))
    return {"names": names, "xname": xname, "values": values, "x": values[:, names.index(xname)], "y": y,
            "status": status, "impacts": impacts, "label": label, "branch": branch, "settled": settled, "units": units,
            "p_units": p_units, "y_unit": y_unit, "y_words": f"{metric}: {words}", "runup": runup}


def param_text(name, value, unit):
    """'mesh.half_backlash = 0.001 in' ('(deck units)' when the unit cannot be told)."""
    if unit == "1":
        return f"{name} = {value:g}"
    return f"{name} = {value:g} {pretty(unit) if unit else '(deck units)'}"


def groups_of(d):
    """Runs grouped by the values of the swept parameters other than x that vary:
    [(legend text, run indices)]; one group of all runs when only x varies."""
    others = [k for k, n in enumerate(d["names"]) if n != d["xname"]
              and len(np.unique(d["values"][:, k])) > 1]
    if not others:
        return [("", np.arange(len(d["x"])))]
    keys = [tuple(row) for row in d["values"][:, others]]
    out = []
    for key in sorted(set(keys)):
        runs = np.array([i for i, k in enumerate(keys) if k == key])
        text = ", ".join(param_text(d["names"][k], v, d["p_units"][d["names"][k]]) for k, v in zip(others, key))
        out.append((text, runs))
    return out


def draw(ax, x, y, status, impacts, order, name, mark, settled, colour=None, failed_label=True):
    ok = status[order] == 1
    xs, ys = x[order], y[order]
    line, = ax.plot(xs[ok], ys[ok], "-", lw=1.2, label=name, color=colour, gid="curve")
    c = line.get_color()
    if impacts is not None:
        lost = (impacts[order] > 0) & ok
        ax.plot(xs[ok & ~lost], ys[ok & ~lost], mark, mfc="white", mec=c, ms=5)
        ax.plot(xs[lost], ys[lost], mark, mfc=c, mec=c, ms=5)
    else:
        ax.plot(xs[ok], ys[ok], mark, color=c, ms=4)
    unsettled = ok & (settled[order] == 0)
    if unsettled.any():
        # one legend entry for the figure (the count of every curve's unsettled runs)
        first = not hasattr(ax, "n_unsettled")
        ax.n_unsettled = getattr(ax, "n_unsettled", 0) + int(unsettled.sum())
        h, = ax.plot(xs[unsettled], ys[unsettled], "o", mfc="none", mec="tab:orange", mew=1.6, ms=11)
        if first:
            ax.unsettled_handle = h
        h.set_label("_")
    failed = status[order] == 2
    if failed.any():
        ax.plot(xs[failed], np.zeros(failed.sum()), "x", color="red", ms=9, mew=2,
                label=f"failed run ({failed.sum()})" if failed_label else "_failed")


def main(argv=None, prog=None):
    ap = argparse.ArgumentParser(prog=prog, description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+")
    ap.add_argument("--metric")
    ap.add_argument("--te-spectrum", dest="te_spectrum", metavar="ID")
    ap.add_argument("--force", action="store_true", help="with --te-spectrum: the mesh force's orders")
    ap.add_argument("--x")
    ap.add_argument("--label", action="append")
    ap.add_argument("--out", default="sweep.png")
    ap.add_argument("--fig5-11", dest="fig511", action="store_true")
    ap.add_argument("--fig7-6", dest="fig76", action="store_true",
                    help="mark Cook's Ch. VII contact loss, about 335-480 teeth/s")
    ap.add_argument("--data", help="also save the plotted arrays to this .npz (x, y, status per file, group "
                                   "and branch)")
    ap.add_argument("--describe", help=argparse.SUPPRESS)   # the axes as JSON (tests)
    a = ap.parse_args(argv)
    if a.te_spectrum:
        return order_map(a)
    if not a.metric:
        ap.error("give --metric ID.NAME or --te-spectrum ID")
    plotted = {}

    fig, ax = plt.subplots(figsize=(8, 5))
    files = [read(path, a.metric, a.x) for path in a.files]
    xname = files[0]["xname"]
    ky, y_unit = display_unit(np.concatenate([d["y"] for d in files]), files[0]["y_unit"] or "1")
    kx, x_unit = display_unit(np.concatenate([d["x"] for d in files]), files[0]["p_units"][xname] or "1")
    curve = 0
    for i, (path, d) in enumerate(zip(a.files, files)):
        label = a.label[i] if a.label and i < len(a.label) else d["label"] or path
        groups = groups_of(d)
        if d["runup"]:
            r = d["runup"]
            name = label if a.label and i < len(a.label) else \
                f"run-up {float(r['from']):g} -> {float(r['to']):g} at {float(r['rate']):g} /s per s, " \
                f"{r['block_cycles']} cycles a point"
            ax.plot(d["x"] * kx, d["y"] * ky, "-", lw=1.4, color=f"C{curve % 10}", label=name, gid="curve")
            if d["impacts"] is not None and (d["impacts"] > 0).any():
                lost = d["impacts"] > 0
                ax.plot(d["x"][lost] * kx, d["y"][lost] * ky, ".", color=f"C{curve % 10}", ms=4)
            plotted[f"f{i}_runup_x"], plotted[f"f{i}_runup_y"] = d["x"], d["y"]
            curve += 1
            continue
        for g, (gtext, members) in enumerate(groups):
            for b in sorted(set(d["branch"][members].tolist())):
                runs = members[d["branch"][members] == b]
                # fixed starts: by x; a continuation branch: in run order (the path the rig took)
                order = runs[np.argsort(d["x"][runs], kind="stable")] if b == 0 else runs
                name = label if len(files) > 1 or not gtext else ""
                name = ", ".join(t for t in (name, gtext) if t)
                name += {0: "", 1: " (up)", 2: " (down)"}[b]
                mark = {0: "o", 1: ">", 2: "<"}[b]
                draw(ax, d["x"] * kx, d["y"] * ky, d["status"], d["impacts"], order, name, mark, d["settled"],
                     colour=f"C{curve % 10}", failed_label=True)
                curve += 1
                key = f"f{i}_b{b}" if len(groups) == 1 else f"f{i}_g{g}_b{b}"
                plotted[key + "_x"], plotted[key + "_y"], plotted[key + "_status"] = \
                    d["x"][order], d["y"][order], d["status"][order]
        pending = d["status"] == 0
        if pending.any():
            print(f"{path}: {pending.sum()} run(s) not made yet", file=sys.stderr)
    impacts = files[0]["impacts"]
    if a.fig511:
        ax.axvspan(460, 500, color="0.85", zorder=0, label="TRAIN: separation 460-500 teeth/s (Cook 1989)")
        ax.plot([460], [0.0022 * ky], "k+", ms=14, mew=2, label="TRAIN max p2p TE 0.0022 in at 460 (Cook)")
        ax.plot([385], [0.00325 * ky], "kx", ms=10, mew=2, label="experiment max 0.00325 in near 385 (Cook)")
    if a.fig76:
        ax.axvspan(335, 480, color="0.85", zorder=0, label="TRAIN: contact lost about 335-480 teeth/s (Cook §7.3)")
    x_words = METRIC_WORDS.get(xname.rpartition(".")[2])
    ax.set_xlabel(axis_label(f"{xname}: {x_words}" if x_words else xname, x_unit)
                  if files[0]["p_units"][xname] else f"{xname} [deck units]")
    ax.set_ylabel(axis_label(files[0]["y_words"], y_unit))
    note = "filled: contact lost (impacts > 0)" if impacts is not None else ""
    ax.set_title(f"{a.metric} vs {xname}" + (f"\n{note}" if note else ""), fontsize=10)
    ax.grid(alpha=0.3)
    if hasattr(ax, "unsettled_handle"):
        ax.unsettled_handle.set_label(f"not settled within the budget ({ax.n_unsettled} runs): a transient")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(a.out, dpi=120)
    if a.describe:
        describe_figure(fig, a.describe)
    if a.data:
        np.savez(a.data, **plotted)
    print(a.out)
    return 0


def order_map(a):
    """--te-spectrum: the mesh orders of one gear mesh's TE (or force) against the swept parameter."""
    sig = "force" if a.force else "te"
    orders = [1, 2, 3, 4]
    cols = [read(a.files[0], f"{a.te_spectrum}.{sig}_order_{k}", a.x) for k in orders]
    d = cols[0]
    ok = d["status"] == 1
    order = np.argsort(d["x"], kind="stable")
    order = order[ok[order]]
    x = d["x"][order]
    amp = np.array([c["y"][order] for c in cols])          # (order, run)
    y_unit = d["y_unit"] or "1"
    ky, y_unit = display_unit(amp.ravel(), y_unit)
    kx, x_unit = display_unit(x, d["p_units"][d["xname"]] or "1")
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 7.5), sharex=True)
    what = "mesh force" if a.force else "transmission error"
    for k, row in zip(orders, amp):
        ax1.plot(x * kx, row * ky, "-o", ms=3, lw=1.2, label=f"mesh order {k}", gid="curve")
    ax1.set_yscale("log")
    ax1.set_ylabel(axis_label(f"{a.te_spectrum}: {what} amplitude", y_unit))
    ax1.legend(fontsize=8)
    ax1.grid(alpha=0.3, which="both")
    ax1.set_title(f"{a.te_spectrum}: {what} at mesh orders 1-4 (settled window) vs {d['xname']}", fontsize=10)
    floor = max(np.max(amp) * 1e-6, np.min(amp[amp > 0]) if np.any(amp > 0) else 1e-30)
    edges = np.concatenate([[x[0] - (x[1] - x[0]) / 2 if len(x) > 1 else x[0] - 0.5],
                            (x[1:] + x[:-1]) / 2, [x[-1] + (x[-1] - x[-2]) / 2 if len(x) > 1 else x[0] + 0.5]])
    mesh = ax2.pcolormesh(edges * kx, np.arange(0.5, len(orders) + 1), np.log10(np.maximum(amp * ky, floor * ky)),
                          shading="flat", cmap="viridis")
    fig.colorbar(mesh, ax=ax2, label=f"log10 amplitude [{pretty(y_unit)}]")
    ax2.set_yticks(orders)
    ax2.set_ylabel("mesh order")
    x_words = METRIC_WORDS.get(d["xname"].rpartition(".")[2])
    ax2.set_xlabel(axis_label(f"{d['xname']}: {x_words}" if x_words else d["xname"], x_unit))
    fig.tight_layout()
    fig.savefig(a.out, dpi=120)
    if a.describe:
        describe_figure(fig, a.describe)
    if a.data:
        np.savez(a.data, x=x, amplitude=amp, orders=np.array(orders))
    print(a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
