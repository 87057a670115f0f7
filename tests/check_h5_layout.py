#!/usr/bin/python3
"""Print the layout of a trainsim HDF5 output file and check that it is complete.

Usage: /usr/bin/python3 tests/check_h5_layout.py FILE

Checks the datasets, groups and attributes described in docs/output-format.md and that
their dimensions agree. Exits 0 when everything is there, 1 (listing the problems)
otherwise, 2 on bad usage.
"""
import sys

import h5py
import numpy as np

ROOT_ATTRS = ["title", "deck_file", "deck", "units", "trainsim_version", "integrator", "created", "status"]
ELEMENT_REAL = ["torque_left", "torque_right", "displacement", "force"]
ELEMENT_INT = ["contact", "pairs"]
ENERGY_NAMES = ["kinetic", "potential", "dissipated", "input", "balance"]
EVENT_COLUMNS = ["time", "element", "kind", "kind_name", "approach_velocity",
                 "restitution", "damping", "peak_force", "duration"]
STATS_INT = ["steps", "rhs_evals", "jac_evals", "root_returns", "error_test_fails",
             "conv_fails", "events", "rejected"]
METRICS = ["torque_min", "torque_max", "force_min", "force_max", "displacement_min", "displacement_max",
           "p2p_range", "p2p_mean", "p2p_swings", "impacts", "separations", "zone_changes",
           "max_approach_velocity", "max_peak_force", "time_out_of_contact", "load_sharing", "kv", "static_force",
           "static_te_mean", "static_te_p2p", "force_mean"] + [f"{s}_order_{k}" for s in ("te", "force") for k in range(1, 5)] + \
    ["rattle_impacts", "rattle_open", "rattle_criterion", "rattle_energy", "rattle_power"]
STATS_REAL = ["wall_time", "t_final"]


def text(value):
    """Fixed-length HDF5 strings arrive as bytes: decode (element-wise for arrays)."""
    if isinstance(value, (bytes, np.bytes_)):
        return value.decode("ascii", "replace")
    if isinstance(value, np.ndarray):
        return [text(v) for v in value.tolist()]
    return value


def short(value, width=60):
    s = repr(text(value))
    return s if len(s) <= width else s[: width - 3] + "..."


def show(f):
    """Print every group and dataset with shape, type, chunking and attributes."""
    def attrs(obj, indent):
        for k, v in obj.attrs.items():
            print(f"{indent}@{k} = {short(v)}")

    print("/")
    attrs(f, "  ")

    def visit(name, obj):
        depth = name.count("/") + 1
        indent = "  " * depth
        if isinstance(obj, h5py.Dataset):
            print(f"{indent}{name}  shape={obj.shape} maxshape={obj.maxshape} "
                  f"dtype={obj.dtype} chunks={obj.chunks} compression={obj.compression}")
        else:
            print(f"{indent}{name}/")
        attrs(obj, indent + "  ")

    f.visititems(visit)


class Checker:
    def __init__(self):
        self.problems = []

    def require(self, condition, message):
        if not condition:
            self.problems.append(message)
        return condition


def check(f):
    c = Checker()

    for a in ROOT_ATTRS:
        c.require(a in f.attrs, f"root attribute '{a}' missing")

    for name in ["time", "states", "energy", "inputs", "nodes", "elements", "events", "run_stats", "metrics"]:
        c.require(name in f, f"'/{name}' missing")
    if c.problems:
        return c.problems

    n = f["time"].shape[0]
    c.require(f["time"].ndim == 1, "/time is not 1-D")
    c.require(f["time"].maxshape[0] is None, "/time is not extendible")
    t = f["time"][...]
    c.require(bool(np.all(np.diff(t) >= 0)), "/time is not non-decreasing")

    states = f["states"]
    c.require(states.ndim == 2 and states.shape[0] == n, f"/states shape {states.shape}, expected ({n}, n_states)")
    if c.require("names" in states.attrs, "/states@names missing"):
        c.require(len(states.attrs["names"]) == states.shape[1],
                  f"/states@names has {len(states.attrs['names'])} entries for {states.shape[1]} states")

    energy = f["energy"]
    c.require(energy.shape == (n, 5), f"/energy shape {energy.shape}, expected ({n}, 5)")
    if c.require("names" in energy.attrs, "/energy@names missing"):
        c.require(text(energy.attrs["names"]) == ENERGY_NAMES, f"/energy@names = {text(energy.attrs['names'])}")

    inputs = f["inputs"]
    c.require(inputs.ndim == 2 and inputs.shape[0] == n, f"/inputs shape {inputs.shape}, expected ({n}, n_inputs)")
    for a in ["names", "column_units"]:
        if c.require(a in inputs.attrs, f"/inputs@{a} missing"):
            c.require(len(inputs.attrs[a]) == inputs.shape[1],
                      f"/inputs@{a} has {len(inputs.attrs[a])} entries for {inputs.shape[1]} columns")

    nodes = f["nodes"]
    n_nodes = None
    for a in ["ids", "types"]:
        c.require(a in nodes.attrs, f"/nodes@{a} missing")
    if "ids" in nodes.attrs:
        n_nodes = len(nodes.attrs["ids"])
        if "types" in nodes.attrs:
            c.require(len(nodes.attrs["types"]) == n_nodes, "/nodes@types length differs from @ids")
    for d in ["theta", "omega"]:
        if c.require(d in nodes, f"/nodes/{d} missing") and n_nodes is not None:
            c.require(nodes[d].shape == (n, n_nodes), f"/nodes/{d} shape {nodes[d].shape}, expected ({n}, {n_nodes})")

    el = f["elements"]
    n_el = None
    for a in ["ids", "types", "left", "right", "displacement_units"]:
        c.require(a in el.attrs, f"/elements@{a} missing")
    if "ids" in el.attrs:
        n_el = len(el.attrs["ids"])
        for a in ["types", "left", "right", "displacement_units"]:
            if a in el.attrs:
                c.require(len(el.attrs[a]) == n_el, f"/elements@{a} length differs from @ids")
        if n_nodes is not None:
            for a in ["left", "right"]:
                if a in el.attrs and n_el > 0:
                    idx = np.asarray(el.attrs[a])
                    c.require(bool(np.all((idx >= 1) & (idx <= n_nodes))),
                              f"/elements@{a} = {idx} not within 1..{n_nodes}")
        for i, eid in enumerate(text(el.attrs["ids"])):
            group = eid if eid else f"_{i + 1}"
            c.require(group in el and isinstance(el[group], h5py.Group),
                      f"/elements/{group} parameter group missing")
    for d in ELEMENT_REAL + ELEMENT_INT:
        if c.require(d in el, f"/elements/{d} missing") and n_el is not None:
            c.require(el[d].shape == (n, n_el), f"/elements/{d} shape {el[d].shape}, expected ({n}, {n_el})")
            kind = "i" if d in ELEMENT_INT else "f"
            c.require(el[d].dtype.kind == kind, f"/elements/{d} dtype {el[d].dtype}")

    ev = f["events"]
    n_ev = None
    for col in EVENT_COLUMNS:
        if c.require(col in ev, f"/events/{col} missing"):
            c.require(ev[col].ndim == 1, f"/events/{col} is not 1-D")
            if n_ev is None:
                n_ev = ev[col].shape[0]
            c.require(ev[col].shape[0] == n_ev, f"/events/{col} has {ev[col].shape[0]} rows, expected {n_ev}")
    if "element" in ev and n_el is not None and n_ev:
        e = ev["element"][...]
        c.require(bool(np.all((e >= 0) & (e <= n_el))), f"/events/element out of range: {e}")

    if "metrics" in f:
        mt = f["metrics"]
        for col in METRICS:
            if c.require(col in mt, f"/metrics/{col} missing") and n_el is not None:
                c.require(mt[col].shape == (n_el,), f"/metrics/{col} has shape {mt[col].shape}, expected ({n_el},)")

    rs = f["run_stats"]
    for a in STATS_INT:
        if c.require(a in rs.attrs, f"/run_stats@{a} missing"):
            c.require(np.asarray(rs.attrs[a]).dtype == np.int64, f"/run_stats@{a} is not a 64-bit integer")
    for a in STATS_REAL:
        c.require(a in rs.attrs, f"/run_stats@{a} missing")
    if c.require("completed" in rs.attrs, "/run_stats@completed missing"):
        c.require(int(rs.attrs["completed"]) in (0, 1), "/run_stats@completed is not 0/1")
        # status: 'complete', or 'interrupted' for a run stopped by SIGINT/SIGTERM
        # (the history up to the last output time reached), as run_stats@completed says
        if "status" in f.attrs:
            want = "complete" if int(rs.attrs["completed"]) == 1 else "interrupted"
            c.require(f.attrs["status"] == want, f"root @status is {f.attrs['status']!r}, completed says {want!r}")

    check_self_description(f, c, n)
    return c.problems


def check_self_description(f, c, n):
    """Every dataset has a `units` str; every 2-D series has column names and units and
    /time attached as the dimension scale of its rows; every string reads as str."""
    def visit(name, obj):
        for k, v in obj.attrs.items():
            if name == "time" and k in ("CLASS", "NAME"):
                continue   # written by HDF5's dimension-scale library (H5DS) as fixed-length strings
            if isinstance(v, (bytes, np.bytes_)):
                c.require(False, f"/{name}@{k} reads as bytes, not str (fixed-length string)")
            elif isinstance(v, np.ndarray) and v.dtype.kind in "SO" and k != "DIMENSION_LIST" \
                    and k != "REFERENCE_LIST":
                c.require(all(isinstance(x, str) for x in v.tolist()), f"/{name}@{k} entries are not str")
        if not isinstance(obj, h5py.Dataset):
            return
        u = obj.attrs.get("units")
        c.require(isinstance(u, str) and len(u) > 0, f"/{name} has no units attribute (str)")
        if obj.dtype.kind in "SO":
            c.require(h5py.check_string_dtype(obj.dtype) is not None and
                      h5py.check_string_dtype(obj.dtype).length is None,
                      f"/{name} is not a variable-length string dataset")
            c.require(all(isinstance(x, str) for x in obj.asstr()[...].tolist()), f"/{name} strings are not str")
        if obj.ndim == 2 and name != "time":
            cols = obj.shape[1]
            for a in ("column_names", "column_units"):
                if c.require(a in obj.attrs, f"/{name}@{a} missing"):
                    c.require(len(obj.attrs[a]) == cols, f"/{name}@{a} has {len(obj.attrs[a])} entries for {cols}")
            c.require(len(obj.dims[0]) == 1 and obj.dims[0][0].name == "/time",
                      f"/time is not the dimension scale of the rows of /{name}")
    visit("", f)
    f.visititems(visit)
    c.require(h5py.h5ds.is_scale(f["time"].id), "/time is not a dimension scale")


def main(argv):
    if len(argv) != 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    with h5py.File(argv[1], "r") as f:
        show(f)
        problems = check(f)
    if problems:
        print(f"\nlayout check FAILED ({len(problems)} problem(s)):")
        for p in problems:
            print("  - " + p)
        return 1
    print("\nlayout check passed")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
