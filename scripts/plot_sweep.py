#!/usr/bin/python3
"""Plot a metric of a trainsim sweep file against the swept parameter.

    /usr/bin/python3 scripts/plot_sweep.py SWEEP.h5 [MORE.h5 ...] --metric mesh.p2p_mean \
        [--x mesh.mesh_frequency] [--label TEXT ...] [--out fig.png] [--fig5-11] [--data d.npz]
    trainsim plot SWEEP.h5 [MORE.h5 ...] --metric mesh.p2p_mean -o fig.png   (the same)

--metric ID.NAME   an element metric (elements/NAME column ID: p2p_range, p2p_mean,
                   impacts, time_out_of_contact, max_peak_force, ...) or a node metric
                   (speed_min, speed_max); runs/NAME (wall_time, steps, ...) with ID 'run'
--x NAME           the parameter on the x axis (default: the first swept parameter)
--fig5-11          mark Cook's Fig. 5.11 figures (TRAIN's maximum 0.0022 in at 460 teeth/s,
                   its separation range 460-500 teeth/s, the experiment's 0.00325 in near 385)
Failed runs are marked with a red x on the axis; runs whose mesh lost contact (impacts > 0)
are filled markers when the metric is an element metric. Runs that did not settle within
their budget (&run settle_tol; runs/settled = 0) are ringed in orange: their figures are of a
transient, not a steady state. A continuation sweep (runs/branch
1 up, 2 down) draws each branch as its own curve: up with triangles pointing right, down
with triangles pointing left, in the order the runs were made.
"""

import argparse
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def strings(ds):
    return [s.decode() if isinstance(s, bytes) else str(s) for s in ds[:]]


def read(path, metric, xname):
    with h5py.File(path, "r") as f:
        names = strings(f["parameters/names"]) if "names" in f["parameters"] else []
        if not names:
            sys.exit(f"{path}: the sweep has no parameters")
        xname = xname or names[0]
        if xname not in names:
            sys.exit(f"{path}: no parameter '{xname}'; parameters are: {', '.join(names)}")
        x = f["parameters/values"][:, names.index(xname)]
        status = f["runs/status"][:]
        oid, _, key = metric.rpartition(".")
        impacts = None
        if oid == "run":
            y = f["runs"][key][:].astype(float)
        else:
            for group in ("elements", "nodes"):
                ids = strings(f[group]["ids"]) if "ids" in f[group] else []
                if oid in ids and key in f[group]:
                    y = f[group][key][:, ids.index(oid)].astype(float)
                    if group == "elements":
                        impacts = f["elements/impacts"][:, ids.index(oid)]
                    break
            else:
                el = [k for k in f["elements"] if k not in ("ids", "types")]
                sys.exit(f"{path}: no metric '{metric}'; element ids: {', '.join(strings(f['elements/ids']))}; "
                         f"element metrics: {', '.join(el)}; node metrics: speed_min, speed_max, end_angle, end_speed, start_speed")
        label = f.attrs.get("overrides", b"")
        label = label.decode() if isinstance(label, bytes) else str(label)
        branch = f["runs/branch"][:] if "branch" in f["runs"] else np.zeros(len(x), dtype=int)
        # 1 settled, 0 not settled within the budget, -1 not asked (older files: none)
        settled = f["runs/settled"][:] if "settled" in f["runs"] else -np.ones(len(x))
    return xname, x, y, status, impacts, label, (branch, settled)


def draw(ax, x, y, status, impacts, order, name, mark, settled):
    ok = status[order] == 1
    xs, ys = x[order], y[order]
    line, = ax.plot(xs[ok], ys[ok], "-", lw=1.2, label=name)
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
                label=f"failed run ({failed.sum()})")


def main(argv=None, prog=None):
    ap = argparse.ArgumentParser(prog=prog, description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+")
    ap.add_argument("--metric", required=True)
    ap.add_argument("--x")
    ap.add_argument("--label", action="append")
    ap.add_argument("--out", default="sweep.png")
    ap.add_argument("--fig5-11", dest="fig511", action="store_true")
    ap.add_argument("--fig7-6", dest="fig76", action="store_true",
                    help="mark Cook's Ch. VII contact loss, about 335-480 teeth/s")
    ap.add_argument("--data", help="also save the plotted arrays to this .npz (x, y, status per file and branch)")
    a = ap.parse_args(argv)
    plotted = {}

    fig, ax = plt.subplots(figsize=(8, 5))
    for i, path in enumerate(a.files):
        xname, x, y, status, impacts, label, (branch, settled) = read(path, a.metric, a.x)
        if a.label and i < len(a.label):
            label = a.label[i]
        label = label or path
        for b in sorted(set(branch.tolist())):
            runs = np.flatnonzero(branch == b)
            # fixed starts: by x; a continuation branch: in run order (the path the rig took)
            order = runs[np.argsort(x[runs])] if b == 0 else runs
            name = {0: label, 1: f"{label} (up)", 2: f"{label} (down)"}[b]
            mark = {0: "o", 1: ">", 2: "<"}[b]
            draw(ax, x, y, status, impacts, order, name, mark, settled)
            key = f"f{i}_b{b}"
            plotted[key + "_x"], plotted[key + "_y"], plotted[key + "_status"] = x[order], y[order], status[order]
        pending = status == 0
        if pending.any():
            print(f"{path}: {pending.sum()} run(s) not made yet", file=sys.stderr)
    if a.fig511:
        ax.axvspan(460, 500, color="0.85", zorder=0, label="TRAIN: separation 460-500 teeth/s (Cook 1989)")
        ax.plot([460], [0.0022], "k+", ms=14, mew=2, label="TRAIN max p2p TE 0.0022 in at 460 (Cook)")
        ax.plot([385], [0.00325], "kx", ms=10, mew=2, label="experiment max 0.00325 in near 385 (Cook)")
    if a.fig76:
        ax.axvspan(335, 480, color="0.85", zorder=0, label="TRAIN: contact lost about 335-480 teeth/s (Cook §7.3)")
    ax.set_xlabel(xname)
    ax.set_ylabel(a.metric)
    note = "filled: contact lost (impacts > 0)" if impacts is not None else ""
    ax.set_title(f"{a.metric} vs {xname}" + (f"\n{note}" if note else ""), fontsize=10)
    ax.grid(alpha=0.3)
    if hasattr(ax, "unsettled_handle"):
        ax.unsettled_handle.set_label(f"not settled within the budget ({ax.n_unsettled} runs): a transient")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(a.out, dpi=120)
    if a.data:
        np.savez(a.data, **plotted)
    print(a.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
