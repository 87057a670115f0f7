"""The FMU of the Table 5.5 rig under FMPy, FMI 3.0 and 2.0 (run by run_fmpy.py in a venv with FMPy).

Reasons for the tolerances: the FMU's doStep runs trainsim's own loop (a session,
docs/c-api.md), so a co-simulation whose communication points are a run's output times
advances exactly as that run does: equal bit for bit. An input step set at a
communication point equals a run of the deck with that step load within 1e-12 of the
speed scale (the run's step ending on the load step takes its last stage 1e-9 dt early,
at the left limit; the FMU's on time).
"""
import os
import subprocess
import sys

import h5py
import numpy as np
from fmpy import read_model_description, extract, simulate_fmu
from fmpy.fmi2 import FMU2Slave
from fmpy.fmi3 import FMU3Slave
from fmpy.validation import validate_fmu

EXE = os.environ["TRAINSIM_EXE"]
SRC = os.environ["TRAINSIM_SOURCE"]
GHM = os.path.join(SRC, "inputs", "gregory_harris_munro.nml")
failures = []


def check(what, ok):
    print(("ok   " if ok else "FAIL ") + what, flush=True)
    if not ok:
        failures.append(what)


def deck(work, name, integrator, extra=""):
    with open(GHM) as f:
        text = f.read()
    text = text.replace("integrator = 'rk4'", f"integrator = '{integrator}'") + extra
    path = os.path.join(work, name)
    with open(path, "w") as f:
        f.write(text)
    return path


def fmu_of(path, work, *args):
    out = os.path.join(work, os.path.basename(path).replace(".nml", "_" + "_".join(args[-1:] or ["3"]) + ".fmu"))
    r = subprocess.run([EXE, "fmu", path, "-o", out, *args], capture_output=True, text=True)
    print(r.stdout, r.stderr, end="")
    return out if r.returncode == 0 else None


def run(path, work, h, t_end=0.02):
    out = os.path.join(work, "ref.h5")
    r = subprocess.run([EXE, "run", path, "-o", out, "--set", f"run.output_interval={h!r}", "--set",
                        f"run.t_end={t_end!r}"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    with h5py.File(out) as f:
        t = f["time"][:]
        cols = [c.decode() if isinstance(c, bytes) else c for c in f["nodes/omega"].attrs["column_names"]]
        w = {n: f["nodes/omega"][:, cols.index(n)] for n in ("n2", "n3", "n4")}
        phi = {n: f["nodes/theta"][:, cols.index(n)] for n in ("n2", "n3", "n4")}
        ecols = [c.decode() if isinstance(c, bytes) else c for c in f["elements/force"].attrs["column_names"]]
        for q, name in (("force", "force"), ("displacement", "disp"), ("contact", "contact")):
            w[f"mesh.{name}"] = f[f"elements/{q}"][:, ecols.index("mesh")].astype(np.float64)
    return t, w, phi


def cosim(fmu, h, t_end, inputs=None):
    out = ["n2.w", "n3.w", "n4.w", "n2.phi", "n3.phi", "n4.phi", "mesh.force", "mesh.disp", "mesh.contact"]
    return simulate_fmu(fmu, start_time=0.0, stop_time=t_end, output_interval=h, output=out, input=inputs,
                        validate=False)


def inputs_and_states(work, fmi):
    """An input torque step through the FMU's input; a state saved and restored mid-run."""
    path = deck(work, "ghm_in.nml", "rk4")
    fmu = fmu_of(path, work, "--input", "n4", "--fmi", fmi)
    step = deck(work, "ghm_step.nml", "rk4",
                "&load node = 'n4', kind = 'step', value0 = 0.0, value1 = -100.0, t_step = 0.008 /\n")
    inputs = np.array([(0.0, 0.0), (0.008, 0.0), (0.008, -100.0), (0.02, -100.0)],
                      dtype=[("time", np.float64), ("n4.tau", np.float64)])
    h = 4.0e-4
    r = cosim(fmu, h, 0.02, inputs)
    t, w, phi = run(step, work, h)
    scale = max(np.max(np.abs(w[k])) for k in phi)
    worst = max(np.max(np.abs(r[f"{k}.w"] - w[k])) for k in phi)
    check(f"FMI {fmi}.0: input torque step of -100 at 0.008 s through n4.tau equals the run with that step load within 1e-12 "
          f"of the speed scale ({worst / scale:.2g})", len(r) == len(t) and worst <= 1e-12 * scale)
    moved = cosim(fmu, h, 0.02)
    check(f"FMI {fmi}.0: the input changed the motion (n4 slower at the end)", r["n4.w"][-1] < moved["n4.w"][-1])
    # save and restore mid-run through FMPy's FMI API
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = extract(fmu)
    if fmi == "2":
        s = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName="rig")
        s.instantiate()
        s.setupExperiment(startTime=0.0, stopTime=0.02)
        s.enterInitializationMode()
        s.exitInitializationMode()
        get, put, save, load, free = s.getReal, s.setReal, s.getFMUstate, s.setFMUstate, s.freeFMUstate
    else:
        s = FMU3Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName="rig")
        s.instantiate()
        s.enterInitializationMode(startTime=0.0, stopTime=0.02)
        s.exitInitializationMode()
        get, put, save, load, free = s.getFloat64, s.setFloat64, s.getFMUState, s.setFMUState, s.freeFMUState
    outs = [vr[n] for n in ("n2.w", "n3.w", "n4.w", "n4.phi")]
    t = 0.0
    for _ in range(10):
        s.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t += h
    state = save()
    t_saved = t
    first = []
    for k in range(20):
        if k == 5:
            put([vr["n4.tau"]], [-300.0])
        s.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t += h
        first.append(get(outs))
    load(state)
    t = t_saved
    again = []
    for k in range(20):
        if k == 5:
            put([vr["n4.tau"]], [-300.0])
        s.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t += h
        again.append(get(outs))
    check(f"FMI {fmi}.0: restored mid-run (with an input set after the save): the second pass equals the first bit for bit",
          np.array_equal(np.array(first), np.array(again)))
    free(state)
    s.terminate()
    s.freeInstance()


def main():
    work = sys.argv[1]
    for fmi, integrator in (("3", "rk4"), ("3", "cvode-bdf"), ("2", "rk4"), ("2", "cvode-bdf")):
        path = deck(work, f"ghm_{integrator}.nml", integrator)
        fmu = fmu_of(path, work, "--input", "n4", "--fmi", fmi)
        integrator = f"FMI {fmi}.0, {integrator}"
        check(f"{integrator}: trainsim fmu made the FMU", fmu is not None)
        if fmu is None:
            continue
        problems = validate_fmu(fmu)
        check(f"{integrator}: FMPy's validation passes ({problems})", problems == [])
        md = read_model_description(fmu)
        names = [v.name for v in md.modelVariables]
        check(f"{integrator}: variables n4.phi, n4.w (outputs), n4.tau (input), mesh.half_backlash (parameter)",
              {"n4.phi", "n4.w", "n4.tau", "mesh.half_backlash"} <= set(names))
        # 35 contact events in 0.02 s: spacing about 6e-4 s (the closest 1e-5 s)
        for h in (2.0e-3, 4.0e-4, 2.96e-6):
            if fmi == "2" and h < 1e-5:
                continue   # (the same binary and loop as FMI 3.0: the fine step once is enough)
            t_end = 0.02 if h > 1e-5 else 0.004
            r = cosim(fmu, h, t_end)
            t, w, phi = run(path, work, h, t_end)
            n = min(len(t), len(r))
            same = len(r) == len(t) and all(np.array_equal(r[f"{k}.w"][:n], w[k][:n]) and
                                            np.array_equal(r[f"{k}.phi"][:n], phi[k][:n]) for k in phi)
            same = same and all(np.array_equal(r[k][:n], w[k][:n]) for k in ("mesh.force", "mesh.disp", "mesh.contact"))
            worst = max(np.max(np.abs(r[f"{k}.w"][:n] - w[k][:n])) for k in phi)
            opened = int(np.sum(r["mesh.contact"][:n] == 0))
            check(f"{integrator}: communication step {h:g} s ({len(r)} points): FMPy's co-simulation equals "
                  f"trainsim run at every point, bit for bit: node angles and speeds, the mesh's force, displacement "
                  f"and contact ({opened} points out of contact; largest speed difference {worst:.3g})", same)
    for fmi in ("3", "2"):
        inputs_and_states(work, fmi)
    # bad input
    r = subprocess.run([EXE, "fmu", GHM, "-o", os.path.join(work, "bad.fmu"), "--input", "nx"], capture_output=True,
                       text=True)
    check("--input on a node that does not exist: exit 2 naming it", r.returncode == 2 and "'nx'" in r.stderr)
    r = subprocess.run([EXE, "fmu", GHM, "-o", os.path.join(work, "bad.fmu"), "--input", "n1"], capture_output=True,
                       text=True)
    check("--input on a node with a prescribed speed: exit 2 saying so", r.returncode == 2 and "prescribed" in r.stderr)
    check("no FMU left behind by a refusal", not os.path.exists(os.path.join(work, "bad.fmu")))
    # inputs named in the deck; `trainsim run` of that deck ignores &fmu
    path = deck(work, "ghm_deck_inputs.nml", "rk4", "&fmu inputs = 'n4', 'n3' /\n")
    fmu = fmu_of(path, work)
    names = [v.name for v in read_model_description(fmu).modelVariables] if fmu else []
    check("&fmu inputs = 'n4', 'n3': the FMU has inputs n4.tau and n3.tau", {"n4.tau", "n3.tau"} <= set(names))
    r = subprocess.run([EXE, "run", path, "--no-output"], capture_output=True, text=True)
    check("trainsim run of a deck with &fmu runs as without it", r.returncode == 0)
    bad = deck(work, "ghm_bad_fmu.nml", "rk4", "&fmu input = 'n4' /\n")
    r = subprocess.run([EXE, "fmu", bad, "-o", os.path.join(work, "bad.fmu")], capture_output=True, text=True)
    check("&fmu with a misspelt key: exit 2 naming the file, line and key",
          r.returncode == 2 and "ghm_bad_fmu.nml:" in r.stderr and "'input'" in r.stderr)
    print(f"{len(failures)} check(s) failed" if failures else "all checks passed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
