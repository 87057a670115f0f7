#!/usr/bin/python3
"""Export quantities, the event table, the metrics and impact load spectra of a
trainsim history file (HDF5, docs/output-format.md) as CSV or JSON.

usage:
  trainsim_export.py FILE QUANTITY [QUANTITY ...] [--t0 T] [--t1 T] [--every N] [-o OUT.csv]
  trainsim_export.py FILE --events [--t0 T] [--t1 T] [-o OUT.csv]
  trainsim_export.py FILE --metrics [-o OUT.csv]
  trainsim_export.py FILE --summary json [-o OUT.json]
  trainsim_export.py FILE --spectrum [--force-bins N|--bins E0,E1,...] [--velocity-bins N|E0,E1,...] [-o OUT.csv]
  trainsim_export.py FILE --rainflow [--element ID ...] [--bins E0,E1,...] [--t0 T] [--t1 T] [-o OUT.csv]
  trainsim_export.py FILE --list

QUANTITY is ID.NAME: a node's theta or omega (drive.omega), an element's torque_left,
torque_right, displacement, force, contact or pairs (mesh.displacement), a state by
name (state.drive.speed), energy.kinetic|potential|dissipated|input|balance, or an input
of the run as it saw it (input.load.load_torque, input.drive.prescribed_speed,
input.motor.voltage: the columns of /inputs).
--t0/--t1 keep samples in [t0, t1] s; --every N keeps every N-th of those. The CSV
header names each column with its unit, e.g. `mesh.displacement [in]`.

The impact load spectrum counts, per clearance element, the contacts begun (event
kinds contact_front and contact_rear, as /metrics/impacts) by peak-force bin and by
approach-velocity bin: N equal bins from 0 to the element's largest value, or fixed
edges E0,E1,... (--bins, in the file's force unit; --velocity-bins E0,E1,... in its
length/s) that stay the same from run to run, so two designs can be compared; fixed
edges add a row below E0 and one above the last edge, so nothing is dropped.

--rainflow counts the cycles of each element's force series (/elements/force, the mesh
or contact force; a shaft's torque) by rainflow (ASTM E1049-85 §5.4.4, half cycles
counted 0.5; scripts/trainsim_rainflow.py): one row per range with its mean and count,
or with --bins the cycles per range bin, ready for a load-duration (Miner) sum.
"""
import argparse
import csv
import io
import json
import sys

import h5py
import numpy as np

from trainsim_rainflow import rainflow, rainflow_histogram

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
    if "inputs" in f:
        names += [f"input.{e}" for e in attr_list(f["inputs"], "column_names")]
    return names


def quantity(f, name):
    """(values over all samples, unit) of QUANTITY `name`."""
    head, _, tail = name.partition(".")
    if head in ("energy", "state", "input") and (head != "input" or "inputs" in f):
        ds = f[{"energy": "energy", "state": "states", "input": "inputs"}[head]]
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


def bin_edges(values, bins):
    """Histogram edges: `bins` a count N (N equal bins from 0 to the largest value) or a
    list of fixed edges (used as given)."""
    if isinstance(bins, int):
        top = float(values.max()) if values.size and values.max() > 0 else 1.0
        return np.linspace(0.0, top, bins + 1)
    return np.asarray(bins, dtype=float)


def fixed_counts(values, edges):
    """Counts in [e_k, e_k+1) (the last bin closed), with the count below e_0 and above
    e_n as an extra first and last bin [-inf, e_0) and (e_n, inf]."""
    inside, _ = np.histogram(values[(values >= edges[0]) & (values <= edges[-1])], bins=edges)
    below, above = int((values < edges[0]).sum()), int((values > edges[-1]).sum())
    return [-np.inf] + edges.tolist() + [np.inf], [below] + inside.tolist() + [above]


def impact_spectrum(f, force_bins=10, velocity_bins=10):
    """Per clearance element with impacts: counts by peak-force bin and by approach-velocity bin.

    force_bins, velocity_bins: a count N of equal bins from 0 to the element's largest
    value, or a list of fixed edges (then a bin below the first and above the last edge
    is added, so the counts still sum to the impacts).
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
            edges = bin_edges(values, nb)
            if isinstance(nb, int):
                counts, _ = np.histogram(values, bins=edges)
                spec[key + "_edges"], spec[key + "_counts"] = edges.tolist(), counts.tolist()
            else:
                spec[key + "_edges"], spec[key + "_counts"] = fixed_counts(values, edges)
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


def rainflow_cycles(f, elements=None, t0=None, t1=None):
    """{element id: (force unit, [(range, mean, count, t_start, t_end)])}: the rainflow
    cycles of each element's /elements/force column over the window (every element, or
    the ids in `elements`)."""
    ids = attr_list(f["elements"], "ids")
    for ident in elements or []:
        if ident not in ids:
            raise ExportError(f"unknown element '{ident}'; elements: {', '.join(ids)}")
    t = f["time"][:]
    idx = window(t, t0, t1)
    units = attr_list(f["elements/force"], "column_units")
    out = {}
    for j, ident in enumerate(ids):
        if elements and ident not in elements:
            continue
        x = f["elements/force"][idx, j]
        tw = t[idx]
        out[ident] = (units[j], [(r, m, n, tw[a], tw[b]) for r, m, n, a, b in rainflow(x)])
    return out


def rainflow_table(cycles, edges=None):
    """(header, columns): one row per counted range (element, unit, range, mean, count,
    the times of its two reversals), or with `edges` the cycles per range bin (a bin
    below the first edge and one above the last included)."""
    rows = []
    if edges is None:
        header = ["element_id", "unit", "range", "mean", "cycles", "t_from [s]", "t_to [s]"]
        for ident, (u, cyc) in cycles.items():
            rows += [[ident, u, float(r), float(m), n, float(ta), float(tb)] for r, m, n, ta, tb in cyc]
    else:
        header = ["element_id", "unit", "range_low", "range_high", "cycles"]
        edges = np.asarray(edges, dtype=float)
        for ident, (u, cyc) in cycles.items():
            counts, below, above = rainflow_histogram(cyc, edges)
            lows, highs = [-np.inf] + edges.tolist(), edges.tolist() + [np.inf]
            for lo, hi, n in zip(lows, highs, [below] + counts.tolist() + [above]):
                rows.append([ident, u, lo, hi, float(n)])
    return header, [list(col) for col in zip(*rows)] if rows else [[] for _ in header]


def parse_bins(text, option):
    """--force-bins / --velocity-bins / --bins: a count N or fixed edges E0,E1,... (increasing)."""
    if text is None:
        return None
    parts = [x for x in text.replace(" ", "").split(",") if x]
    try:
        if len(parts) == 1 and "," not in text:
            n = int(parts[0])
            if n < 1:
                raise ExportError(f"{option} must be >= 1, got {n}")
            return n
        edges = [float(x) for x in parts]
    except ValueError:
        raise ExportError(f"{option}: expected a bin count N or edges E0,E1,... (numbers), got '{text}'")
    if len(edges) < 2 or not np.all(np.isfinite(edges)) or np.any(np.diff(edges) <= 0):
        raise ExportError(f"{option}: the edges must be at least two finite numbers in increasing order, got '{text}'")
    return edges


def write_csv(header, cols, out):
    w = csv.writer(out, lineterminator="\n")
    w.writerow(header)
    for row in zip(*cols):
        w.writerow([repr(float(x)) if isinstance(x, (float, np.floating)) else
                    int(x) if isinstance(x, (np.integer,)) else x for x in row])


def main(argv=None):
    p = argparse.ArgumentParser(prog="trainsim export", description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("file", help="a history file of trainsim run (HDF5)")
    p.add_argument("quantities", nargs="*", help="ID.NAME of each column to export (--list shows them)")
    p.add_argument("--t0", type=float, help="keep samples and events from t0 (s) on")
    p.add_argument("--t1", type=float, help="keep samples and events up to t1 (s)")
    p.add_argument("--every", type=int, default=1, help="keep every N-th sample of the window (default 1)")
    p.add_argument("--events", action="store_true", help="the event table, one row per event")
    p.add_argument("--metrics", action="store_true", help="the run's figures (/metrics), one row per element")
    p.add_argument("--summary", choices=["json"], help="the run's description, statistics and metrics as JSON")
    p.add_argument("--spectrum", action="store_true",
                   help="impact load spectrum: contacts per peak-force and approach-velocity bin")
    p.add_argument("--force-bins", help="N equal bins (default 10) or edges E0,E1,... of the peak force")
    p.add_argument("--velocity-bins", help="N equal bins (default 10) or edges E0,E1,... of the approach velocity")
    p.add_argument("--bins", help="fixed edges E0,E1,... in the file's force unit: of the peak force "
                                  "(--spectrum) or of the cycle range (--rainflow)")
    p.add_argument("--rainflow", action="store_true", help="rainflow cycles of each element's force (ASTM E1049)")
    p.add_argument("--element", action="append", help="--rainflow: only this element (repeatable)")
    p.add_argument("--list", action="store_true", help="list every QUANTITY the file holds")
    p.add_argument("-o", "--output", help="write to this file (default: standard output)")
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
                if a.bins and a.force_bins:
                    raise ExportError("give --bins or --force-bins, not both")
                force_bins = parse_bins(a.bins, "--bins") or parse_bins(a.force_bins, "--force-bins") or 10
                velocity_bins = parse_bins(a.velocity_bins, "--velocity-bins") or 10
                write_csv(*spectrum_table(impact_spectrum(f, force_bins, velocity_bins)), buf)
            elif a.rainflow:
                edges = parse_bins(a.bins, "--bins")
                if isinstance(edges, int):
                    raise ExportError("--rainflow --bins needs fixed edges E0,E1,... (in the file's force unit)")
                write_csv(*rainflow_table(rainflow_cycles(f, a.element, a.t0, a.t1), edges), buf)
            elif a.events:
                write_csv(*event_table(f, a.t0, a.t1), buf)
            elif a.metrics:
                write_csv(*metrics_table(f), buf)
            elif a.quantities:
                write_csv(*series_table(f, a.quantities, a.t0, a.t1, a.every), buf)
            else:
                raise ExportError("name a QUANTITY (--list shows them), or --events, --metrics, "
                                  "--summary json, --spectrum, --rainflow")
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
