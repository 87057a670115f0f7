"""Sweeps in this process: one table, a row per run (as `trainsim sweep`'s file)."""
import itertools
import os

import numpy as np

from . import _lib as L
from ._lib import lib
from ._errors import TrainsimError
from ._simulation import Simulation
from ._tables import Table

STATUS_OK, STATUS_FAILED = 1, 2


def sweep(deck, parameters=None, *, set=None):
    """Run `deck` (a path, or deck text) for every combination of `parameters`
    ({"mesh.mesh_frequency": [385, 390, ...], ...}: a full grid, the first parameter
    varying slowest, as the deck's &sweep groups), serially in this process. Without
    `parameters`, the deck's own &sweep groups give the runs (continuation sweeps are
    made by `trainsim sweep`). `set`: {path: value} applied to every run first.

    Returns a Table with a row per run: the parameters, `status` (1 ok, 2 failed),
    `message`, and every metric (`mesh.p2p_mean`, `n1.speed_max`, `run.steps`, ...;
    NaN for a failed run). An input error (a bad deck, path or value) raises
    TrainsimError; a run that fails is recorded and the sweep goes on.

    For MPI, run the command instead and read its file: see mpi_sweep()."""
    text = isinstance(deck, str) and "\n" in deck
    sim = Simulation.from_text(deck) if text else Simulation.from_deck(deck)
    with sim:
        if parameters is None:
            names, grid = sim.sweep_runs()
        else:
            names = list(parameters)
            axes = [np.atleast_1d(np.asarray(parameters[n], dtype=np.float64)) for n in names]
            grid = np.array(list(itertools.product(*axes)), dtype=np.float64).reshape(-1, len(names))
        rows = grid.shape[0]
        status = np.zeros(rows, dtype=np.int32)
        message = np.empty(rows, dtype=object)
        metric_names, values = None, None
        for i in range(rows):
            sim.clear()
            for path, value in (set or {}).items():
                sim.set(path, value)
            for j, path in enumerate(names):
                sim.set(path, grid[i, j])
            code = lib.trainsim_run(sim._h, 0, None)
            if code in (L.ERR_NUMERIC,):
                status[i], message[i] = STATUS_FAILED, L.message(sim._h)
                continue
            L.check(code, sim._h)
            if metric_names is None:
                metric_names = L.names(sim._h, L.METRICS)
                units = L.names(sim._h, L.METRIC_UNITS)
                values = np.full((rows, len(metric_names)), np.nan)
            L.values(sim._h, lib.trainsim_metrics, len(metric_names), out=values[i])
            status[i], message[i] = STATUS_OK, ""
    columns = {n: grid[:, j] for j, n in enumerate(names)}
    columns["status"] = status
    columns["message"] = message
    col_units = {}
    if metric_names is not None:
        for j, n in enumerate(metric_names):
            columns[n] = values[:, j]
            col_units[n] = units[j]
    return Table(columns, col_units)


def mpi_sweep(deck, output, ranks=2, trainsim="trainsim", mpirun="mpirun", extra=()):
    """Run `trainsim sweep DECK -o OUTPUT` on `ranks` MPI ranks (the deck's &sweep
    groups; the command's own load balancing, resume and file) and read the file
    into the same table as sweep(). `extra`: more arguments (--set ...)."""
    import subprocess
    cmd = [mpirun, "-np", str(ranks)]
    if os.geteuid() == 0:
        cmd.append("--allow-run-as-root")
    cmd += ["--oversubscribe", trainsim, "sweep", os.fspath(deck), "-o", os.fspath(output), *extra]
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode not in (0, 1):
        raise TrainsimError(proc.stderr.strip() or f"{' '.join(cmd)} exited with {proc.returncode}",
                            proc.returncode)
    from ._files import read_sweep
    return read_sweep(output)
