"""Readers for trainsim's files (h5py): a run's history and a sweep file, into the same
containers as in-process results (Series, Table, Metrics)."""
import numpy as np

from ._tables import Series, Table, Metrics

_SERIES_DATASETS = ("states", "nodes/theta", "nodes/omega", "elements/torque_left", "elements/torque_right",
                    "elements/displacement", "elements/force", "elements/contact", "elements/pairs",
                    "energy", "inputs")


def _strings(values):
    return [v.decode("utf-8") if isinstance(v, bytes) else str(v) for v in values]


class RunFile:
    """A history file of `trainsim run` (docs/output-format.md): `series` (a Series with
    the column names of Simulation.run()), `events` (a Table), `metrics` (by
    `ELEMENT.NAME`, the file's /metrics names) and `attrs` (title, deck, units, ...)."""

    def __init__(self, path):
        import h5py
        with h5py.File(path, "r") as f:
            self.attrs = {k: (v.decode() if isinstance(v, bytes) else v) for k, v in f.attrs.items()}
            names, units, blocks = ["time"], ["s"], [f["time"][:].reshape(-1, 1)]
            for d in _SERIES_DATASETS:
                if d not in f:
                    continue
                ds = f[d]
                cols = _strings(ds.attrs.get("column_names", ds.attrs.get("names", [])))
                cu = _strings(ds.attrs.get("column_units", [ds.attrs.get("units", "1")] * len(cols)))
                names += [f"{d}/{c}" for c in cols]
                units += cu
                blocks.append(ds[:].astype(np.float64).reshape(ds.shape[0], len(cols)))
            self.series = Series(np.hstack(blocks), names, units)
            ev = f["events"]
            table = {}
            for c in ev:
                table[c] = ev[c].asstr()[:] if ev[c].dtype.kind == "O" else ev[c][:]
            self.events = Table(table)
            ids = _strings(f["elements"].attrs["ids"])
            mnames, mvals, munits = [], [], []
            if "metrics" in f:
                for c in f["metrics"]:
                    ds = f["metrics"][c]
                    if ds.ndim != 1 or ds.shape[0] != len(ids):
                        continue
                    u = _strings(ds.attrs.get("entry_units", [ds.attrs.get("units", "1")] * len(ids)))
                    for k, i in enumerate(ids):
                        mnames.append(f"{i}.{c}")
                        mvals.append(ds[k])
                        munits.append(u[k] if k < len(u) else u[0])
            self.metrics = Metrics(mnames, mvals, munits)


def read_run(path):
    """Read a `trainsim run` history file (RunFile)."""
    return RunFile(path)


def read_sweep(path):
    """Read a `trainsim sweep` file into a Table with the columns of trainsim.sweep():
    the parameters, `status`, `message`, `ELEMENT.METRIC`, `NODE.METRIC`, `run.STAT`
    (steps, rhs_evals, events, energy_residual, settled, settle_periods, settle_k,
    wall_time: build + run), plus `run.rank` and `run.branch`."""
    import h5py
    cols = {}
    with h5py.File(path, "r") as f:
        n = int(f.attrs["n_runs"])
        if "parameters" in f:
            for j, name in enumerate(f["parameters/names"].asstr()[:]):
                cols[name] = f["parameters/values"][:, j]
        cols["status"] = f["runs/status"][:].astype(np.int32)
        cols["message"] = np.array(list(f["runs/message"].asstr()[:]), dtype=object)
        for group in ("elements", "nodes"):
            ids = list(f[f"{group}/ids"].asstr()[:])
            for k, i in enumerate(ids):
                for m in f[group]:
                    ds = f[f"{group}/{m}"]
                    if ds.ndim == 2 and ds.shape == (n, len(ids)):
                        cols[f"{i}.{m}"] = ds[:, k].astype(np.float64)
        for m in f["runs"]:
            ds = f[f"runs/{m}"]
            if m not in ("status", "message") and ds.ndim == 1 and ds.dtype.kind in "fiu":
                cols[f"run.{m}"] = ds[:].astype(np.float64)
    return Table(cols)
