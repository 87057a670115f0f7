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


MOTOR = """&run t_end = 0.04, dt = 5.0e-6, integrator = 'rk4', output_interval = 1.0e-3 /
&node id = 'motor', type = 'dc_motor', inertia = 2.0e-3, damping = 1.0e-4, torque_constant = 0.5,
      back_emf_constant = 0.0565, inductance = 2.0e-3, resistance = 0.5 /
&node id = 'gear', type = 'inertia', inertia = 0.05 /
&node id = 'load', type = 'inertia', inertia = 2.0, damping = 0.5 /
&element id = 'mesh', type = 'spur_gear', left = 'motor', right = 'gear', teeth_driver = 20, teeth_driven = 60,
         diametral_pitch = 8.0, pressure_angle = 20.0, face_width = 0.75, backlash = 0.004 /
&element id = 'shaft', type = 'shaft', left = 'gear', right = 'load', stiffness = 2.0e4, damping = 2.0 /
&load node = 'motor', quantity = 'voltage', {law} /
"""

SEQUENCE = """&run t_end = 4.0, dt = 1.0e-5, integrator = 'rk4', output_interval = 0.01, units = 'si' /
&node id = 'm', type = 'dc_motor', inertia = 0.01, torque_constant = 0.05, back_emf_constant = 0.05,
      inductance = 1.0e-3, resistance = 1.0 /
&node id = 'load', type = 'inertia', inertia = 0.01 /
&element id = 's', type = 'shaft', left = 'm', right = 'load', stiffness = 1.0e3, damping = 0.5 /
&controller id = 'pos', motor = 'm', sensor = 'load', measure = 'angle', kp = 40.0, kd = 8.0, filter_time = 1.0e-3,
      v_min = -24.0, v_max = 24.0, current_limit = 30.0, sequence = .true., kind = 'table',
      times = 0.2, 2.0, 4.0, values = 5.0, 10.0, 2.0, tolerance = 1.0e-3, speed_tolerance = 1.0e-2 /
"""


def write(work, name, text):
    path = os.path.join(work, name)
    with open(path, "w") as f:
        f.write(text)
    return path


def run_nodes(path, work, nodes, *sets):
    """A run's node speeds and angles ({node: array}) and its times, with --set `sets`."""
    out = os.path.join(work, "ref_nodes.h5")
    args = sum((["--set", x] for x in sets), [])
    r = subprocess.run([EXE, "run", path, "-o", out, *args], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    with h5py.File(out) as f:
        cols = [c.decode() if isinstance(c, bytes) else c for c in f["nodes/omega"].attrs["column_names"]]
        w = {n: f["nodes/omega"][:, cols.index(n)] for n in nodes}
        phi = {n: f["nodes/theta"][:, cols.index(n)] for n in nodes}
        return f["time"][:], w, phi


def step_input(name, t_step, before, after, t_end):
    return np.array([(0.0, before), (t_step, before), (t_step, after), (t_end, after)],
                    dtype=[("time", np.float64), (name, np.float64)])


def speed_and_voltage_inputs(work, fmi):
    """A prescribed speed and a motor voltage as FMU inputs: a step through the input equals the
    run whose deck has that step (1e-12 of the scales: as the torque step, the run's last stage
    before the step is taken 1e-9 dt early)."""
    path = deck(work, "ghm_speed_in.nml", "rk4")
    fmu = fmu_of(path, work, "--input", "n1.speed", "--fmi", fmi)
    check(f"FMI {fmi}.0: --input n1.speed made the FMU", fmu is not None)
    if fmu:
        v = {x.name: x for x in read_model_description(fmu).modelVariables}
        check(f"FMI {fmi}.0: input n1.speed, start the deck's 95.2286 rad/s",
              "n1.speed" in v and v["n1.speed"].causality == "input" and float(v["n1.speed"].start) == 95.2286)
        with open(GHM) as f:
            text = f.read().replace("quantity = 'speed', kind = 'constant', value = 95.2286 /",
                                    "quantity = 'speed', kind = 'step', value0 = 95.2286, value1 = 100.0, "
                                    "t_step = 0.008 /")
        step = write(work, "ghm_speed_step.nml", text)
        h = 4.0e-4
        r = simulate_fmu(fmu, start_time=0.0, stop_time=0.02, output_interval=h, validate=False,
                         input=step_input("n1.speed", 0.008, 95.2286, 100.0, 0.02),
                         output=["n1.w", "n2.w", "n3.w", "n4.w", "n1.phi", "n2.phi", "n3.phi", "n4.phi"])
        t, w, phi = run_nodes(step, work, ["n1", "n2", "n3", "n4"], f"run.output_interval={h!r}", "run.t_end=0.02")
        scale = max(np.max(np.abs(w[k])) for k in w)
        ascale = max(np.max(np.abs(phi[k])) for k in phi)
        dw = max(np.max(np.abs(r[f"{k}.w"] - w[k])) for k in ("n2", "n3", "n4"))
        dphi = max(np.max(np.abs(r[f"{k}.phi"] - phi[k])) for k in phi)
        check(f"FMI {fmi}.0: input speed step 95.2286 -> 100 rad/s at 0.008 s through n1.speed equals the run with "
              f"that speed step within 1e-12 of the speed scale ({dw / scale:.2g}) and angle scale "
              f"({dphi / ascale:.2g}); n1 at 100 rad/s at the end",
              len(r) == len(t) and dw <= 1e-12 * scale and dphi <= 1e-12 * ascale and r["n1.w"][-1] == 100.0)
    motor = write(work, "motor_in.nml", MOTOR.format(law="kind = 'constant', value = 24.0") +
                  "&fmu inputs = 'motor.voltage' /\n")
    fmu = fmu_of(motor, work, "--fmi", fmi)
    check(f"FMI {fmi}.0: &fmu inputs = 'motor.voltage' made the FMU", fmu is not None)
    if not fmu:
        return
    step = write(work, "motor_step.nml", MOTOR.format(law="kind = 'step', value0 = 24.0, value1 = 12.0, t_step = 0.02"))
    nodes = ["motor", "gear", "load"]
    r = simulate_fmu(fmu, start_time=0.0, stop_time=0.04, output_interval=1e-3, validate=False,
                     input=step_input("motor.voltage", 0.02, 24.0, 12.0, 0.04),
                     output=[f"{n}.w" for n in nodes])
    t, w, _ = run_nodes(step, work, nodes)
    scale = max(np.max(np.abs(w[k])) for k in w)
    dw = max(np.max(np.abs(r[f"{k}.w"] - w[k])) for k in nodes)
    steady = simulate_fmu(fmu, start_time=0.0, stop_time=0.04, output_interval=1e-3, validate=False,
                          output=["motor.w"])
    check(f"FMI {fmi}.0: motor voltage step 24 -> 12 V at 0.02 s through motor.voltage equals the run with that "
          f"voltage step within 1e-12 of the speed scale ({dw / scale:.2g}); the motor ends slower than at 24 V",
          len(r) == len(t) and dw <= 1e-12 * scale and r["motor.w"][-1] < steady["motor.w"][-1] - 1e-3 * scale)


def typed_parameters(work, fmi):
    """Deck integers are Int32 (FMI 2.0: Integer) parameters, quoted texts String parameters;
    setting one of each before initialisation equals `trainsim run --set` of the same values,
    bit for bit (the same deck edit, the same loop)."""
    motor = write(work, "motor_par.nml", MOTOR.format(law="kind = 'constant', value = 24.0"))
    fmu = fmu_of(motor, work, "--fmi", fmi)
    check(f"FMI {fmi}.0: the motor deck's FMU", fmu is not None)
    if not fmu:
        return
    problems = validate_fmu(fmu)
    check(f"FMI {fmi}.0: FMPy's validation passes with Int32 and String parameters ({problems})", problems == [])
    v = {x.name: x for x in read_model_description(fmu).modelVariables}
    ints, texts = ("Int32", "String") if fmi == "3" else ("Integer", "String")
    check(f"FMI {fmi}.0: mesh.teeth_driven is an {ints} parameter (start 60), run.integrator a String (start rk4), "
          f"mesh.face_width a Float64",
          v["mesh.teeth_driven"].type == ints and int(v["mesh.teeth_driven"].start) == 60 and
          v["run.integrator"].type == texts and v["run.integrator"].start == "rk4" and
          v["mesh.face_width"].type in ("Float64", "Real") and v["mesh.teeth_driven"].causality == "parameter")
    nodes = ["motor", "gear", "load"]
    out = [f"{n}.w" for n in nodes] + [f"{n}.phi" for n in nodes]
    base = simulate_fmu(fmu, start_time=0.0, stop_time=0.04, output_interval=1e-3, validate=False, output=out)
    for values, sets in (({"mesh.teeth_driven": 50}, ["mesh.teeth_driven=50"]),
                         ({"run.integrator": "cvode-bdf"}, ["run.integrator='cvode-bdf'"]),
                         ({"mesh.teeth_driven": 50, "run.integrator": "cvode-bdf"},
                          ["mesh.teeth_driven=50", "run.integrator='cvode-bdf'"])):
        r = simulate_fmu(fmu, start_time=0.0, stop_time=0.04, output_interval=1e-3, validate=False, output=out,
                         start_values=values)
        t, w, phi = run_nodes(motor, work, nodes, *sets)
        same = len(r) == len(t) and all(np.array_equal(r[f"{n}.w"], w[n]) and np.array_equal(r[f"{n}.phi"], phi[n])
                                        for n in nodes)
        changed = not np.array_equal(r["load.w"], base["load.w"])
        check(f"FMI {fmi}.0: parameters {values} equal `trainsim run --set {' --set '.join(sets)}` bit for bit at "
              f"every point, and change the run", same and changed)


def sequence_restored(work):
    """A positioning sequence's progress is part of the FMU state: saved at 1.99 s (target 1
    reached), stepped to 3.99 s (target 2 reached), restored and stepped again: bit for bit."""
    fmu = fmu_of(write(work, "sequence.nml", SEQUENCE), work)
    check("the positioning sequence deck's FMU", fmu is not None)
    if not fmu:
        return
    md = read_model_description(fmu)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    s = FMU3Slave(guid=md.guid, unzipDirectory=extract(fmu), modelIdentifier=md.coSimulation.modelIdentifier,
                  instanceName="sequence")
    s.instantiate()
    s.enterInitializationMode(startTime=0.0, stopTime=4.0)
    s.exitInitializationMode()
    outs = [vr[n] for n in ("m.w", "m.phi", "load.w", "load.phi")]
    h, k = 0.01, 0
    while k < 199:
        s.doStep(currentCommunicationPoint=k * h, communicationStepSize=h)
        k += 1
    state = s.getFMUState()
    at_save = s.getFloat64(outs)
    passes = []
    for _ in range(2):
        s.setFMUState(state)
        rows = []
        for j in range(199, 399):
            s.doStep(currentCommunicationPoint=j * h, communicationStepSize=h)
            rows.append(s.getFloat64(outs))
        passes.append(np.array(rows))
    s.freeFMUState(state)
    s.terminate()
    s.freeInstance()
    check(f"sequence FMU: saved at 1.99 s near target 1 (load at {at_save[3]:.4f} rad), at 3.99 s near target 2 "
          f"({passes[0][-1, 3]:.4f} rad); restored, the second pass equals the first bit for bit",
          abs(at_save[3] - 5.0) < 1e-2 and abs(passes[0][-1, 3] - 10.0) < 1e-2 and
          np.array_equal(passes[0], passes[1]))


def main():
    work = sys.argv[1]
    for fmi in ("3", "2"):
        speed_and_voltage_inputs(work, fmi)
        typed_parameters(work, fmi)
    sequence_restored(work)
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
    r = subprocess.run([EXE, "fmu", GHM, "-o", os.path.join(work, "bad.fmu"), "--input", "n4.speed"],
                       capture_output=True, text=True)
    check("--input n4.speed (no motion prescribed there): exit 2 saying so",
          r.returncode == 2 and "prescribes no motion" in r.stderr)
    r = subprocess.run([EXE, "fmu", GHM, "-o", os.path.join(work, "bad.fmu"), "--input", "n4.voltage"],
                       capture_output=True, text=True)
    check("--input n4.voltage (not a motor): exit 2 saying so", r.returncode == 2 and "dc_motor" in r.stderr)
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
