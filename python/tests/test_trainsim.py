"""The Python package against trainsim's own files (run by the CTest case python_package
in a fresh venv; TRAINSIM_EXE names the program, TRAINSIM_SOURCE the source tree).

- The Fig. 5.11 sweep (inputs/sweep_ghm_mesh_frequency.nml, 27 runs) made in-process
  equals the file of `trainsim sweep` bit for bit in every column both have (wall times
  and ranks aside), from the deck's &sweep groups and from a dict of the same values.
- A run's series equals its HDF5 history (`trainsim run -o`) bit for bit, column by
  column, with the same names and units; so do the event table and the metrics.
- A bad deck raises TrainsimError naming the file and line.
- A session (a run advanced step by step) equals the run at its output times bit for bit,
  and a restored point continues bit for bit.
"""
import os
import subprocess

import numpy as np
import pytest

import trainsim

EXE = os.environ["TRAINSIM_EXE"]
SRC = os.environ["TRAINSIM_SOURCE"]
FIG511 = os.path.join(SRC, "inputs", "sweep_ghm_mesh_frequency.nml")
GHM = os.path.join(SRC, "inputs", "gregory_harris_munro.nml")


def same(a, b):
    if a.dtype == object or b.dtype == object:
        return list(a) == list(b)
    return np.array_equal(a, b, equal_nan=True)


@pytest.fixture(scope="module")
def cli_sweep(tmp_path_factory):
    path = tmp_path_factory.mktemp("sweep") / "fig5_11.h5"
    subprocess.run([EXE, "sweep", FIG511, "-o", str(path), "--progress", "0"], check=True, capture_output=True)
    return trainsim.read_sweep(path)


def compare_sweeps(py, cli):
    common = [c for c in cli.columns if c in py.columns and c not in ("run.wall_time", "run.rank")]
    # 4 params, status, message, 102 element (3 x 34), 20 node and 7 run figures (+ run.branch from a file)
    assert len(common) == 135 + ("run.branch" in py.columns), common
    differ = [c for c in common if not same(py[c], cli[c])]
    assert not differ, f"columns differ from the CLI sweep file: {differ}"
    assert list(py["status"]) == [1] * 27


def test_fig511_sweep_from_the_deck_equals_cli_file(cli_sweep):
    compare_sweeps(trainsim.sweep(FIG511), cli_sweep)


def test_fig511_sweep_from_a_dict_equals_cli_file(cli_sweep):
    grid = {"mesh.mesh_frequency": np.linspace(385, 645, 27), "mesh.settle_cycles": [100],
            "mesh.measure_cycles": [60], "mesh.settle_max_cycles": [2000]}
    compare_sweeps(trainsim.sweep(FIG511, grid), cli_sweep)


def test_run_series_equals_hdf5_history(tmp_path):
    h5 = tmp_path / "ghm.h5"
    subprocess.run([EXE, "run", GHM, "-o", str(h5), "--set", "run.t_end=0.005"], check=True, capture_output=True)
    ref = trainsim.read_run(h5)
    sim = trainsim.Simulation.from_deck(GHM)
    sim.set("run.t_end", "0.005")
    s = sim.run(output=tmp_path / "api.h5")
    assert s.names == ref.series.names
    assert s.units == ref.series.units
    assert len(s) == 626                     # 0 .. 0.005 s every 8e-6 s
    differ = [n for n in s.names if not np.array_equal(s[n], ref.series[n])]
    assert not differ, differ
    assert s["elements/contact"].dtype == np.int32
    ev = sim.events
    for c in ("time", "element", "kind", "peak_force", "duration", "force"):
        assert np.array_equal(ev[c], ref.events[c]), c
    assert list(ev["kind_name"]) == list(ref.events["kind_name"])
    assert sim.metrics["mesh.p2p_mean"] == ref.metrics["mesh.p2p_mean"]
    # the history the API wrote beside its series is the CLI's too
    again = trainsim.read_run(tmp_path / "api.h5")
    assert all(np.array_equal(again.series[n], ref.series[n]) for n in s.names)


def test_bad_deck_raises_with_file_and_line(tmp_path):
    bad = tmp_path / "bad.nml"
    bad.write_text("&run t_end = 0.1, dt = 1e-5 /\n&node id = 'a', type = 'inertia', inertia = -1.0 /\n")
    with pytest.raises(trainsim.TrainsimError) as e:
        trainsim.Simulation.from_deck(bad).run()
    assert f"{bad}:2" in str(e.value) and "inertia" in str(e.value)
    assert e.value.code == 1
    with pytest.raises(trainsim.TrainsimError) as e:
        trainsim.Simulation.from_text("&run t_end = 0.1 /\n&nod id = 'a' /\n", name="deck.nml").run()
    assert "deck.nml:2" in str(e.value)
    sim = trainsim.Simulation.from_deck(GHM)
    sim.set("mesh.half_backlash", -1.0)
    with pytest.raises(trainsim.TrainsimError, match="half_backlash"):
        sim.run()
    with pytest.raises(trainsim.TrainsimError, match="nosuch"):
        sim.set("nosuch.key", 1.0)


def test_notebook_example_runs(tmp_path):
    """docs/examples/fig5_11.py, the Fig. 5.11 study in a dozen lines."""
    env = dict(os.environ, MPLBACKEND="Agg")
    out = subprocess.run(["python", os.path.join(SRC, "docs", "examples", "fig5_11.py"), str(tmp_path / "fig.png")],
                         cwd=SRC, env=env, check=True, capture_output=True, text=True)
    assert "27 runs" in out.stdout
    assert (tmp_path / "fig.png").stat().st_size > 0


def test_pandas_and_xarray_views():
    """The views exist only where pandas / xarray are importable (skipped otherwise)."""
    pd = pytest.importorskip("pandas")
    sim = trainsim.Simulation.from_deck(GHM)
    sim.set("run.t_end", 0.002)
    s = sim.run()
    df = s.to_pandas()
    assert isinstance(df, pd.DataFrame) and df.shape == (len(s), len(s.names) - 1)
    assert np.array_equal(df["nodes/omega/n2"].to_numpy(), s["nodes/omega/n2"])
    assert sim.metrics.to_pandas().loc["mesh.p2p_mean", "value"] == sim.metrics["mesh.p2p_mean"]
    xr = pytest.importorskip("xarray")
    ds = s.to_xarray()
    assert isinstance(ds, xr.Dataset)
    assert np.array_equal(ds["nodes_omega"].sel(nodes_omega_id="n2").values, s["nodes/omega/n2"])


def test_mpi_sweep_reads_back_the_same_table(cli_sweep, tmp_path):
    """mpi_sweep: `mpirun -np 2 trainsim sweep` read back equals the serial file."""
    import shutil
    if shutil.which("mpirun") is None:
        pytest.skip("no mpirun")
    t = trainsim.mpi_sweep(FIG511, tmp_path / "mpi.h5", ranks=2, trainsim=EXE)
    compare_sweeps(t, cli_sweep)


def test_session_steps_equal_the_run_and_restore_continues_bit_for_bit():
    """A session advanced through a run's output times gives its samples bit for bit; a
    restored point continues as the first pass did; an input torque changes the motion."""
    sim = trainsim.Simulation.from_deck(GHM)
    sim.set("run.t_end", 0.004)
    sim.set("run.output_interval", 4e-4)
    s = sim.run()
    sim.start_session(inputs=["n4"])
    point = None
    for k, t in enumerate(s.time[1:], start=1):
        t_now, theta, omega = sim.advance(t)
        assert t_now == t
        assert omega[3] == s["nodes/omega/n4"][k] and theta[3] == s["nodes/theta/n4"][k]
        if k == 3:
            point = sim.save()
    end = sim.state()
    sim.restore(point)
    assert sim.state()[0] == s.time[3]
    again = sim.advance(s.time[-1])
    assert np.array_equal(again[1], end[1]) and np.array_equal(again[2], end[2])
    sim.restore(point)
    sim.set_torque("n4", -5000.0)
    pushed = sim.advance(s.time[-1])
    assert pushed[2][3] < end[2][3]          # a braking torque on n4 slows it
    with pytest.raises(trainsim.TrainsimError, match="n3"):
        sim.set_torque("n3", 1.0)
    with pytest.raises(trainsim.TrainsimError, match="cannot advance"):
        sim.advance(0.0)


def test_session_speed_and_voltage_inputs():
    """A speed input holds the node at the value set, its angle continuous; a voltage input
    on a DC motor changes its current; inputs a node cannot take raise naming the node."""
    sim = trainsim.Simulation.from_deck(GHM)
    sim.set("run.t_end", 0.004)
    sim.start_session(inputs=["n1.speed", "n4"])
    t, theta0, omega0 = sim.advance(0.002)
    assert omega0[0] == 95.2286              # the deck's speed, held from t_start
    sim.set_speed("n1", 100.0)
    t1, theta1, omega1 = sim.advance(0.004)
    assert omega1[0] == 100.0
    assert abs(theta1[0] - (theta0[0] + 100.0 * (t1 - t))) <= 1e-12 * abs(theta1[0])
    with pytest.raises(trainsim.TrainsimError, match="n2"):
        sim.set_speed("n2", 1.0)
    with pytest.raises(trainsim.TrainsimError, match="dc_motor"):
        sim.start_session(inputs=["n1.voltage"])
    motor = trainsim.Simulation.from_deck(os.path.join(SRC, "inputs", "dc_motor_geared_load.nml"))
    motor.set("run.t_end", 0.01)
    runs = []
    for volts in (None, 6.0):
        motor.start_session(inputs=["motor.voltage"])
        if volts is not None:
            motor.set_voltage("motor", volts)
        runs.append(motor.advance(0.01))
    # the deck's start-stop voltage is 0 V at t_start: held there, the train stays at rest;
    # at 6 V the motor has turned and the load follows (the mesh rattles: the motor's own
    # speed changes sign at impacts)
    assert not np.any(runs[0][1]) and not np.any(runs[0][2])
    assert runs[1][1][0] > 0.0 and runs[1][2][2] > 0.0
