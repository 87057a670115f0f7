#!/usr/bin/python3
"""Export quantities, the event table, the metrics and impact load spectra of a
trainsim history file (HDF5, docs/output-format.md) as CSV or JSON.

usage:
  trainsim_export.py FILE QUANTITY [QUANTITY ...] [--t0 T] [--t1 T] [--every N] [-o OUT.csv]
  trainsim_export.py FILE --events [--t0 T] [--t1 T] [-o OUT.csv]
  trainsim_export.py FILE --metrics [-o OUT.csv]
  trainsim_export.py FILE --summary json [-o OUT.json]
  trainsim_export.py FILE --spectrum [--force-bins N] [--velocity-bins N] [-o OUT.csv]
  trainsim_export.py FILE --list

QUANTITY is ID.NAME: a node's theta or omega (drive.omega), an element's torque_left,
torque_right, displacement, force, contact or pairs (mesh.displacement), a state by
name (state.drive.speed), or energy.kinetic|potential|dissipated|input|balance.
--t0/--t1 keep samples in [t0, t1] s; --every N keeps every N-th of those. The CSV
header names each column with its unit, e.g. `mesh.displacement [in]`.

The impact load spectrum counts, per clearance element, the contacts begun (event
kinds contact_front and contact_rear, as /metrics/impacts) by peak-force bin and by
approach-velocity bin (N equal bins from 0 to the element's largest value).
"""
import argparse
import csv
import io
import json
import sys

import h5py
import numpy as np

NODE_SETS = ("theta", "omega")
ELEMENT_SETS = ("torque_left", "torque_right", "displacement", "force", "contact", "pairs")
IMPACT_KINDS = (1, 2)   # contact_front, contact_rear


class ExportError(Exception):
    """Bad request (unknown quantity, empty window): reported with exit status 2."""


def attr_list(obj, name):
    return [str(x) for x in obj.attrs.get(name, [])]


def quantity_names(f):
    """Every QUANTITY the file holds."""
    names = [f"{i}.{q}" for i in attr_list(f["nodes"], "ids") for q in NODE_SETS]
    names += [f"{i}.{q}" for i in attr_list(f["elements"], "ids") for q in ELEMENT_SETS]
    names += [f"state.{s}" for s in attr_list(f["states"], "column_names")]
    names += [f"energy.{e}" for e in attr_list(f["energy"], "column_names")]
    return names


def quantity(f, name):
    """(values over all samples, unit) of QUANTITY `name`."""
    head, _, tail = name.partition(".")
    if head == "energy" or head == "state":
        ds = f["energy" if head == "energy" else "states"]
        cols = attr_list(ds, "column_names")
        if tail in cols:
            j = cols.index(tail)
            return ds[:, j], attr_list(ds, "column_units")[j]
        raise ExportError(f"unknown {head} column '{tail}'; valid: {', '.join(cols)}")
    ident, _, q = name.rpartition(".")
    for group, sets in (("nodes", NODE_SETS), ("elements", ELEMENT_SETS)):
        ids = attr_list(f[group], "ids")
        if ident in ids and q in sets:
            ds = f[group][q]
            j = ids.index(ident)
            return ds[:, j], attr_list(ds, "column_units")[j]
    raise ExportError(f"unknown quantity '{name}' (ID.NAME: node {'/'.join(NODE_SETS)}, element "
                      f"{'/'.join(ELEMENT_SETS)}, state.NAME or energy.NAME; --list shows them all)")


def check_history(f, path):
    """Refuse a sweep file: export reads the history of one run."""
    if str(f.attrs.get("format", "")) == "trainsim-sweep":
        raise ExportError("it is a sweep file (trainsim sweep), not the history of one run: plot a metric "
                          f"against the swept parameter with `trainsim plot {path} --metric ID.NAME -o OUT.png`, "
                          "or read its /elements/NAME and /nodes/NAME datasets (one column per run, "
                          "docs/sweeps.md) with h5py")


def window(t, t0=None, t1=None, every=1):
    """Indices of the samples in [t0, t1], every `every`-th."""
    if every < 1:
        raise ExportError(f"--every must be >= 1, got {every}")
    keep = np.ones(t.shape, bool)
    if t0 is not None:
        keep &= t >= t0
    if t1 is not None:
        keep &= t <= t1
    idx = np.nonzero(keep)[0][::every]
    if idx.size == 0:
        raise ExportError(f"no samples in the window [{t0}, {t1}] s (the run covers [{t[0]}, {t[-1]}] s)")
    return idx


def series_table(f, names, t0=None, t1=None, every=1):
    """(header, columns) of time and the quantities over the window."""
    t = f["time"][:]
    idx = window(t, t0, t1, every)
    header, cols = ["time [s]"], [t[idx]]
    for n in names:
        v, u = quantity(f, n)
        header.append(f"{n} [{u}]")
        cols.append(v[idx])
    return header, cols


def event_table(f, t0=None, t1=None):
    """(header, columns) of the event table, element ids spelled out."""
    ev = f["events"]
    ids = attr_list(f["elements"], "ids")
    t = ev["time"][:]
    keep = np.ones(t.shape, bool)
    if t0 is not None:
        keep &= t >= t0
    if t1 is not None:
        keep &= t <= t1
    header, cols = [], []
    order = ["time", "element", "kind", "kind_name"]
    for name in order + [n for n in ev if n not in order]:
        ds = ev[name]
        values = ds.asstr()[:] if h5py.check_string_dtype(ds.dtype) else ds[:]
        if name == "element":
            header.append("element_id")
            cols.append(np.array([ids[k - 1] if 1 <= k <= len(ids) else "" for k in values], dtype=object)[keep])
        u = ds.attrs.get("units", "")
        header.append(name if u in ("1", "") else f"{name} [{u}]")
        cols.append(values[keep])
    return header, cols


def metrics_table(f):
    """(header, columns): one row per element, one column per metric."""
    m = f["metrics"]
    header, cols = ["element_id"], [np.array(attr_list(f["elements"], "ids"), dtype=object)]
    for name in m:
        u = m[name].attrs.get("units", "")
        header.append(name if u in ("1", "") or u.startswith("mixed") else f"{name} [{u}]")
        cols.append(m[name][:])
    return header, cols


def summary(f):
    """The run as a JSON-ready dict: title, units, run statistics and /metrics by element id."""
    ids = attr_list(f["elements"], "ids")
    out = {key: str(f.attrs[key]) for key in ("title", "units", "integrator", "trainsim_version", "created")
           if key in f.attrs}
    out["samples"] = int(f["time"].shape[0])
    out["t_end"] = float(f["time"][-1]) if f["time"].shape[0] else None
    out["run_stats"] = {k: v.item() if hasattr(v, "item") else v for k, v in f["run_stats"].attrs.items()}
    out["metrics"] = {}
    for j, ident in enumerate(ids):
        out["metrics"][ident] = {name: f["metrics"][name][j].item() for name in f["metrics"]}
    out["metric_units"] = {}
    for name in f["metrics"]:
        ds = f["metrics"][name]
        out["metric_units"][name] = attr_list(ds, "entry_units") or [str(ds.attrs.get("units", ""))] * len(ids)
    return out


def impact_spectrum(f, force_bins=10, velocity_bins=10):
    """Per clearance element with impacts: counts by peak-force bin and by approach-velocity bin.

    Returns {element id: {"impacts": n, "force_edges": [...], "force_counts": [...],
    "velocity_edges": [...], "velocity_counts": [...], "force_unit": u, "velocity_unit": u}}.
    """
    ev = f["events"]
    ids = attr_list(f["elements"], "ids")
    kind, el = ev["kind"][:], ev["element"][:]
    peak, vel = ev["peak_force"][:], np.abs(ev["approach_velocity"][:])
    f_units = attr_list(f["elements/force"], "column_units")
    d_units = attr_list(f["elements/displacement"], "column_units")
    out = {}
    for j, ident in enumerate(ids):
        rows = np.isin(kind, IMPACT_KINDS) & (el == j + 1)
        if not rows.any():
            continue
        spec = {"impacts": int(rows.sum()), "force_unit": f_units[j], "velocity_unit": d_units[j] + "/s"}
        for key, values, nb in (("force", peak[rows], force_bins), ("velocity", vel[rows], velocity_bins)):
            top = float(values.max()) if values.size and values.max() > 0 else 1.0
            edges = np.linspace(0.0, top, nb + 1)
            counts, _ = np.histogram(values, bins=edges)
            spec[key + "_edges"] = edges.tolist()
            spec[key + "_counts"] = counts.tolist()
        out[ident] = spec
    return out


def spectrum_table(spec):
    header = ["element_id", "measure", "unit", "bin_low", "bin_high", "impacts"]
    rows = []
    for ident, s in spec.items():
        for key in ("force", "velocity"):
            e, c = s[key + "_edges"], s[key + "_counts"]
            for k in range(len(c)):
                rows.append([ident, "peak_force" if key == "force" else "approach_velocity", s[key + "_unit"],
                             e[k], e[k + 1], c[k]])
    return header, [list(col) for col in zip(*rows)] if rows else [[] for _ in header]


def write_csv(header, cols, out):
    w = csv.writer(out, lineterminator="\n")
    w.writerow(header)
    for row in zip(*cols):
        w.writerow([repr(float(x)) if isinstance(x, (float, np.floating)) else
                    int(x) if isinstance(x, (np.integer,)) else x for x in row])


def main(argv=None):
    p = argparse.ArgumentParser(prog="trainsim export", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file")
    p.add_argument("quantities", nargs="*")
    p.add_argument("--t0", type=float)
    p.add_argument("--t1", type=float)
    p.add_argument("--every", type=int, default=1)
    p.add_argument("--events", action="store_true")
    p.add_argument("--metrics", action="store_true")
    p.add_argument("--summary", choices=["json"])
    p.add_argument("--spectrum", action="store_true")
    p.add_argument("--force-bins", type=int, default=10)
    p.add_argument("--velocity-bins", type=int, default=10)
    p.add_argument("--list", action="store_true")
    p.add_argument("-o", "--output")
    a = p.parse_args(argv)
    try:
        f = h5py.File(a.file, "r")
    except OSError as e:
        print(f"trainsim export: error: cannot read '{a.file}': {e}", file=sys.stderr)
        return 2
    buf = io.StringIO()
    try:
        with f:
            check_history(f, a.file)
            if a.list:
                buf.write("\n".join(quantity_names(f)) + "\n")
            elif a.summary:
                json.dump(summary(f), buf, indent=2)
                buf.write("\n")
            elif a.spectrum:
                if a.force_bins < 1 or a.velocity_bins < 1:
                    raise ExportError("--force-bins and --velocity-bins must be >= 1")
                write_csv(*spectrum_table(impact_spectrum(f, a.force_bins, a.velocity_bins)), buf)
            elif a.events:
                write_csv(*event_table(f, a.t0, a.t1), buf)
            elif a.metrics:
                write_csv(*metrics_table(f), buf)
            elif a.quantities:
                write_csv(*series_table(f, a.quantities, a.t0, a.t1, a.every), buf)
            else:
                raise ExportError("name a QUANTITY (--list shows them), or --events, --metrics, "
                                  "--summary json, --spectrum")
    except ExportError as e:
        print(f"trainsim export: {a.file}: error: {e}", file=sys.stderr)
        return 2
    except (KeyError, OSError, ValueError) as e:
        # a history whose groups are missing or unreadable (damaged, or written by another program)
        print(f"trainsim export: {a.file}: error: not a readable trainsim history (damaged, or not written by "
              f"trainsim run): {e}", file=sys.stderr)
        return 2
    if a.output and a.output != "-":
        with open(a.output, "w") as out:
            out.write(buf.getvalue())
    else:
        sys.stdout.write(buf.getvalue())
    return 0


if __name__ == "__main__":
    sys.exit(main())
