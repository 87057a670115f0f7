"""The FMU of the Table 5.5 rig under FMPy (run by run_fmpy.py in a venv with FMPy).

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
    out = os.path.join(work, os.path.basename(path).replace(".nml", ".fmu"))
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
    return t, w, phi


def cosim(fmu, h, t_end, inputs=None):
    out = ["n2.w", "n3.w", "n4.w", "n2.phi", "n3.phi", "n4.phi"]
    return simulate_fmu(fmu, start_time=0.0, stop_time=t_end, output_interval=h, output=out, input=inputs,
                        validate=False)


def main():
    work = sys.argv[1]
    for integrator in ("rk4", "cvode-bdf"):
        path = deck(work, f"ghm_{integrator}.nml", integrator)
        fmu = fmu_of(path, work, "--input", "n4")
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
            t_end = 0.02 if h > 1e-5 else 0.004
            r = cosim(fmu, h, t_end)
            t, w, phi = run(path, work, h, t_end)
            n = min(len(t), len(r))
            same = len(r) == len(t) and all(np.array_equal(r[f"{k}.w"][:n], w[k][:n]) and
                                            np.array_equal(r[f"{k}.phi"][:n], phi[k][:n]) for k in w)
            worst = max(np.max(np.abs(r[f"{k}.w"][:n] - w[k][:n])) for k in w)
            check(f"{integrator}: communication step {h:g} s ({len(r)} points): FMPy's co-simulation equals "
                  f"trainsim run at every point, bit for bit (largest speed difference {worst:.3g})", same)
    # an input torque step through the FMU's input
    path = deck(work, "ghm_in.nml", "rk4")
    fmu = fmu_of(path, work, "--input", "n4")
    step = deck(work, "ghm_step.nml", "rk4",
                "&load node = 'n4', kind = 'step', value0 = 0.0, value1 = -100.0, t_step = 0.008 /\n")
    inputs = np.array([(0.0, 0.0), (0.008, 0.0), (0.008, -100.0), (0.02, -100.0)],
                      dtype=[("time", np.float64), ("n4.tau", np.float64)])
    h = 4.0e-4
    r = cosim(fmu, h, 0.02, inputs)
    t, w, phi = run(step, work, h)
    scale = max(np.max(np.abs(w[k])) for k in w)
    worst = max(np.max(np.abs(r[f"{k}.w"] - w[k])) for k in w)
    check(f"input torque step of -100 at 0.008 s through n4.tau equals the run with that step load within 1e-12 "
          f"of the speed scale ({worst / scale:.2g})", len(r) == len(t) and worst <= 1e-12 * scale)
    moved = cosim(fmu, h, 0.02)
    check("the input changed the motion (n4 slower at the end)", r["n4.w"][-1] < moved["n4.w"][-1])
    # save and restore mid-run through FMPy's FMI 2.0 API
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    unzipped = extract(fmu)
    s = FMU2Slave(guid=md.guid, unzipDirectory=unzipped, modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="rig")
    s.instantiate()
    s.setupExperiment(startTime=0.0, stopTime=0.02)
    s.enterInitializationMode()
    s.exitInitializationMode()
    outs = [vr[n] for n in ("n2.w", "n3.w", "n4.w", "n4.phi")]
    t = 0.0
    for _ in range(10):
        s.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t += h
    state = s.getFMUstate()
    t_saved = t
    first = []
    for k in range(20):
        if k == 5:
            s.setReal([vr["n4.tau"]], [-300.0])
        s.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t += h
        first.append(s.getReal(outs))
    s.setFMUstate(state)
    t = t_saved
    again = []
    for k in range(20):
        if k == 5:
            s.setReal([vr["n4.tau"]], [-300.0])
        s.doStep(currentCommunicationPoint=t, communicationStepSize=h)
        t += h
        again.append(s.getReal(outs))
    check("restored mid-run (with an input set after the save): the second pass equals the first bit for bit",
          np.array_equal(np.array(first), np.array(again)))
    s.freeFMUstate(state)
    s.terminate()
    s.freeInstance()
    # bad input
    r = subprocess.run([EXE, "fmu", GHM, "-o", os.path.join(work, "bad.fmu"), "--input", "nx"], capture_output=True,
                       text=True)
    check("--input on a node that does not exist: exit 2 naming it", r.returncode == 2 and "'nx'" in r.stderr)
    r = subprocess.run([EXE, "fmu", GHM, "-o", os.path.join(work, "bad.fmu"), "--input", "n1"], capture_output=True,
                       text=True)
    check("--input on a node with a prescribed speed: exit 2 saying so", r.returncode == 2 and "prescribed" in r.stderr)
    check("no FMU left behind by a refusal", not os.path.exists(os.path.join(work, "bad.fmu")))
    print(f"{len(failures)} check(s) failed" if failures else "all checks passed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
