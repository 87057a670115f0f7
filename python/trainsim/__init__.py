"""trainsim from Python: decks, parameters, runs and sweeps in this process, through
the C interface (libtrainsim_c), and readers for trainsim's files. docs/python.md.

    import trainsim
    sim = trainsim.Simulation.from_deck("inputs/gregory_harris_munro.nml")
    sim.set("mesh.half_backlash", 0.004)
    s = sim.run()                      # Series: s["nodes/omega/n2"], s.time, s.to_pandas()
    sim.metrics["mesh.p2p_mean"]       # metrics by name; sim.events: the event table
    table = trainsim.sweep("inputs/sweep_ghm_mesh_frequency.nml")   # the deck's &sweep groups
"""
from ._errors import TrainsimError
from ._lib import lib as _lib_handle, path as library_path
from ._simulation import Simulation
from ._sweep import sweep, mpi_sweep
from ._tables import Table, Series, Metrics
from ._files import read_run, read_sweep, RunFile

__version__ = _lib_handle.trainsim_library_version().decode()
__all__ = ["Simulation", "TrainsimError", "sweep", "mpi_sweep", "read_run", "read_sweep", "Table", "Series",
           "Metrics", "RunFile", "library_path", "__version__"]
