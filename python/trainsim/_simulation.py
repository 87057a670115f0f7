"""Simulation: one deck, its parameters, runs in this process (through libtrainsim_c)."""
import numpy as np

from . import _lib as L
from ._lib import lib
from ._errors import TrainsimError
from ._tables import Table, Series, Metrics


class Simulation:
    """A deck, the parameters set on it and the results of its last run.

    >>> sim = Simulation.from_deck("inputs/gregory_harris_munro.nml")
    >>> sim.set("mesh.half_backlash", 0.004)
    >>> series = sim.run()                       # the sampled history (a Series)
    >>> sim.metrics["mesh.p2p_mean"], sim.events["time"]
    """

    def __init__(self):
        self._h = lib.trainsim_new()
        if not self._h:
            raise MemoryError("trainsim_new failed")
        self.series = None

    @classmethod
    def from_deck(cls, path):
        """Read the deck file `path` (its &sweep groups are kept for sweep())."""
        sim = cls()
        L.check(lib.trainsim_read_file(sim._h, L.encode(path)), sim._h)
        return sim

    @classmethod
    def from_text(cls, text, name=None):
        """A deck given as text; `name` stands for the file name in messages."""
        sim = cls()
        L.check(lib.trainsim_read_text(sim._h, text.encode("utf-8"), None if name is None else L.encode(name)),
                sim._h)
        return sim

    # -- parameters -------------------------------------------------------------------
    def set(self, path, value):
        """Set the deck key `path` (GROUP.KEY, as `trainsim run --set`): a number is set
        exactly (an int as an integer); a str is deck text ("'cvode-bdf'" for a string, "0, 0.1" for a list);
        a list or tuple of numbers is a deck list."""
        if isinstance(value, (bool, np.bool_)):
            raise TypeError(f"set {path}: a bool is not a deck value")
        if isinstance(value, (int, np.integer)):
            code = lib.trainsim_set(self._h, L.encode(path), str(int(value)).encode())
        elif isinstance(value, (float, np.floating)):
            code = lib.trainsim_set_real(self._h, L.encode(path), float(value))
        else:
            if isinstance(value, (list, tuple, np.ndarray)):
                value = ", ".join(repr(float(v)) for v in value)
            code = lib.trainsim_set(self._h, L.encode(path), str(value).encode("utf-8"))
        L.check(code, self._h)
        self.series = None

    def clear(self):
        """Forget every set(): the deck's own values again."""
        L.check(lib.trainsim_clear(self._h), self._h)

    # -- run ----------------------------------------------------------------------------
    def run(self, output=None, series=True, events=True):
        """Run (the model is built first when the deck or a parameter changed).

        Returns the sampled history as a Series (None with series=False); `output`
        also writes the HDF5 history file. Raises TrainsimError if the run fails."""
        flags = (L.RUN_SERIES if series else 0) | (L.RUN_EVENTS if events else 0)
        L.check(lib.trainsim_run(self._h, flags, None if output is None else L.encode(output)), self._h)
        self.series = self._series() if series else None
        return self.series

    def _series(self):
        names = L.names(self._h, L.SERIES)
        units = L.names(self._h, L.SERIES_UNITS)
        n = L.count(self._h, L.SAMPLES)
        data = L.values(self._h, lib.trainsim_series, n * len(names)).reshape(n, len(names))
        return Series(data, names, units)

    @property
    def metrics(self):
        """The last run's metrics by name: `ELEMENT.METRIC` (mesh.p2p_mean, ...),
        `NODE.METRIC` (speed_min, speed_max, end_angle, end_speed, start_speed) and
        `run.STAT` (steps, rhs_evals, events, energy_residual, settled, ...)."""
        names = L.names(self._h, L.METRICS)
        return Metrics(names, L.values(self._h, lib.trainsim_metrics, len(names)), L.names(self._h, L.METRIC_UNITS))

    def metric(self, name):
        v = L.ctypes.c_double()
        L.check(lib.trainsim_metric(self._h, L.encode(name), L.ctypes.byref(v)), self._h)
        return v.value

    @property
    def events(self):
        """The last run's event table (columns as /events of a history file, plus
        `kind_name` and `element_id`)."""
        cols = L.names(self._h, L.EVENT_COLUMNS)
        n = L.count(self._h, L.EVENTS)
        data = L.values(self._h, lib.trainsim_events, n * len(cols)).reshape(n, len(cols))
        table = {c: data[:, j] for j, c in enumerate(cols)}
        table["element"] = table["element"].astype(np.int32)
        table["kind"] = table["kind"].astype(np.int32)
        kinds = np.array([""] + L.names(self._h, L.EVENT_KINDS), dtype=object)
        ids = np.array([""] + self.elements, dtype=object)
        table["kind_name"] = kinds[table["kind"]]
        table["element_id"] = ids[table["element"]]
        return Table(table)

    @property
    def elements(self):
        return L.names(self._h, L.ELEMENTS)

    @property
    def nodes(self):
        return L.names(self._h, L.NODES)

    def sweep_runs(self):
        """The deck's &sweep groups as (parameter names, values: runs x parameters)."""
        names = L.names(self._h, L.SWEEP_PARAMETERS)
        n = L.count(self._h, L.SWEEP_RUNS)
        return names, L.values(self._h, lib.trainsim_sweep_values, n * len(names)).reshape(n, len(names))

    # -- a run advanced step by step (docs/c-api.md "Sessions") --------------------------
    def start_session(self, inputs=()):
        """Start the run at t_start, to be advanced by advance(); `inputs`: the session's
        inputs: "NODE" (or "NODE.tau") an input torque (set_torque), 0 at first;
        "NODE.speed" the node's prescribed speed (set_speed) and "NODE.voltage" a DC
        motor's voltage (set_voltage), each replacing the deck's, at its value at t_start."""
        L.check(lib.trainsim_session_start(self._h, ",".join(inputs).encode("utf-8")), self._h)

    def advance(self, t):
        """Advance the session to time t (up to run.t_end); returns state()."""
        L.check(lib.trainsim_session_advance(self._h, float(t)), self._h)
        return self.state()

    def set_torque(self, node, value):
        """The input torque on `node` from the session's time on."""
        L.check(lib.trainsim_session_set_torque(self._h, L.encode(node), float(value)), self._h)

    def set_speed(self, node, value):
        """The prescribed speed of `node` (an input "NODE.speed") from the session's time
        on, its angle continuous."""
        self.set_input(f"{node}.speed", value)

    def set_voltage(self, node, value):
        """The supply voltage of motor `node` (an input "NODE.voltage") from the session's
        time on."""
        self.set_input(f"{node}.voltage", value)

    def set_input(self, name, value):
        """The input `name` ("NODE.tau", "NODE.speed", "NODE.voltage") from the session's
        time on, held until set again."""
        L.check(lib.trainsim_session_set_input(self._h, L.encode(name), float(value)), self._h)

    def state(self):
        """(t, theta, omega): the session's time and every node's angle and speed."""
        n = L.count(self._h, L.NODES)
        theta, omega, t = np.empty(n), np.empty(n), L.ctypes.c_double()
        L.check(lib.trainsim_session_state(self._h, L.ctypes.byref(t), theta.ctypes.data_as(L._dp),
                                           omega.ctypes.data_as(L._dp), n), self._h)
        return t.value, theta, omega

    def save(self):
        """Save the session's point; returns its number for restore()."""
        point = L.ctypes.c_int()
        L.check(lib.trainsim_session_save(self._h, L.ctypes.byref(point)), self._h)
        return point.value

    def restore(self, point):
        """Go back to a saved point; the run continues as it did after the save."""
        L.check(lib.trainsim_session_restore(self._h, int(point)), self._h)

    # -- lifetime -----------------------------------------------------------------------
    def close(self):
        if getattr(self, "_h", None):
            lib.trainsim_free(self._h)
            self._h = None

    def __del__(self):
        self.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
