#!/usr/bin/python3
"""trainsim export and trainsim plot (scripts/trainsim_export.py, scripts/trainsim_plot.py),
run through `trainsim export|plot` as a user would, on inputs/start_stop_two_clearances.nml
(a keyed joint and a backlash gear pair starting and stopping: 248 impacts).

- The CSV of a quantity equals the HDF5 dataset (every sample, and a window decimated by 7).
- `--summary json` equals /metrics element by element, and /run_stats.
- The impact load spectrum of each clearance element sums to its /metrics/impacts, by
  peak-force bin and by approach-velocity bin.
- The plotted arrays (--data .npz) are the file's: the TE and its pairs over the window,
  the contact threshold at +/- the gear's half_backlash, the gear's event times; the TE
  spectrum's mesh frequency is N * mean driver speed / 2 pi. PNG, PDF and SVG are written.
- `trainsim plot SWEEP.h5 --metric ...` (a sweep file, inputs/sweep_ghm_continuation.nml
  shortened to 7 frequencies and 30 cycles) plots the sweep file's metric column against the swept
  parameter, one curve per continuation branch, in run order.
- Every figure kind says what it shows (the axes read back through the plot scripts'
  hidden --describe FILE.json, written after the figure is saved): Y against time, two
  Y of two units (left and right axis), a phase plane, --te, --te-spectrum, --events,
  --overview (plot_history.py's figure) and a sweep figure: each axis that shows tick
  labels names its quantity and unit, and the unit is the file's (in and lbf for an
  inch deck; um and kN, chosen for the magnitude, for the SI tracker deck
  tests/decks/tracker_si_start_stop.nml). --events puts one tick per event in a strip
  under the plot (the data line keeps every sample; the strip's ticks per kind equal
  the file's event counts, named with their counts in the legend).
- A 6 x 2 grid sweep (half_backlash x mesh_frequency) against its first parameter is 2
  curves of 6 points, the legend naming each mesh_frequency with its unit (teeth/s);
  against the second, 6 curves of 2 points.

usage: check_export_plot.py TRAINSIM_EXE
"""
import csv
import io
import json
import os
import subprocess
import sys
import tempfile

import re

import h5py
import numpy as np

from clicheck import check, EXE, finish
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def trainsim(*args):
    return subprocess.run([EXE] + list(args), capture_output=True, text=True, timeout=600)


# /work/shared/repro/sweep-and-input/sweep_grid.nml with 6 half_backlash values (400 steps a run)
GRID_6X2 = """&run  title = 'sweep: 6 x 2 grid', t_end = 2.0e-4, dt = 5.0e-7, integrator = 'rk4' /
&node id = 'driver', type = 'inertia', inertia = 7.537e-3 /
&node id = 'driven', type = 'inertia', inertia = 10.082 /
&element id = 'mesh', type = 'spur_gear',
         stiffness = 18.03e6, rb_driver = 1.6445, rb_driven = 1.6445, teeth = 28,
         contact_ratio = 1.6380, approach_angle = 0.1838, half_backlash = 0.001 /
&initial node = 'driver', speed = 10.0 /
&sweep parameter = 'mesh.half_backlash', values = 0.0005, 0.001, 0.002, 0.003, 0.004, 0.005 /
&sweep parameter = 'mesh.mesh_frequency', values = 30.0, 45.0 /
"""
UNIT = re.compile(r"\[[^\]]+\]|\([^)]*(s|in|m|lbf|N|rad|count|Hz)[^)]*\)")


def describe(*args):
    """Plot with --describe; the figure's axes as the script saw them after saving."""
    out = os.path.join(tempfile.gettempdir(), f"describe_{os.getpid()}.json")
    r = trainsim("plot", *args, "--describe", out)
    if r.returncode != 0 or not os.path.exists(out):
        return r, []
    with open(out, encoding="utf-8") as g:
        axes = json.load(g)["axes"]
    os.remove(out)
    return r, axes


def check_labels(kind, axes):
    """Each axis with labelled ticks names a quantity and a unit (an event strip's kind
    axis is categorical); returns the labels."""
    bad, labels = [], []
    for a in axes:
        if a["kind"] == "colorbar":
            if not UNIT.search(a["ylabel"] or a["xlabel"]):
                bad.append(("colorbar", a["ylabel"]))
            labels.append(a["ylabel"])
            continue
        events = a["lines"] and all((ln["gid"] or "").startswith("events:") for ln in a["lines"])
        if a["x_ticks_labelled"]:
            labels.append(a["xlabel"])
            if not UNIT.search(a["xlabel"]):
                bad.append(("x", a["xlabel"]))
        if a["y_ticks_labelled"]:
            labels.append(a["ylabel"])
            if not (UNIT.search(a["ylabel"]) or (events and a["ylabel"] == "event kind")):
                bad.append(("y", a["ylabel"]))
    check(f"{kind}: every axis names its quantity and unit {labels} (bad: {bad})", axes and not bad)
    return labels


def read_csv(text):
    rows = list(csv.reader(io.StringIO(text)))
    return rows[0], rows[1:]


with tempfile.TemporaryDirectory() as tmp:
    h5 = os.path.join(tmp, "ss.h5")
    r = trainsim("run", os.path.join(ROOT, "inputs/start_stop_two_clearances.nml"), "-o", h5)
    check("start_stop_two_clearances runs", r.returncode == 0)
    if r.returncode != 0:
        sys.exit(1)
    f = h5py.File(h5, "r")
    ids = list(f["elements"].attrs["ids"])
    j = ids.index("mesh")
    te = f["elements/displacement"][:, j]
    t = f["time"][:]

    r = trainsim("export", h5, "mesh.displacement")
    check("export exits 0: " + r.stderr.strip()[:200], r.returncode == 0)
    head, rows = read_csv(r.stdout)
    check(f"CSV header names the unit: {head}", head == ["time [s]", "mesh.displacement [in]"])
    col = np.array([float(x[1]) for x in rows])
    check(f"CSV mesh.displacement equals /elements/displacement[:, {j}] ({len(col)} samples, exactly)",
          col.shape == te.shape and np.array_equal(col, te))
    r = trainsim("export", h5, "mesh.displacement", "drive.omega", "--t0", "1.0", "--t1", "1.5", "--every", "7")
    head, rows = read_csv(r.stdout)
    idx = np.nonzero((t >= 1.0) & (t <= 1.5))[0][::7]
    k = list(f["nodes"].attrs["ids"]).index("drive")
    check("windowed, decimated CSV equals the dataset rows [t0, t1][::7]",
          np.array_equal(np.array([[float(a) for a in x] for x in rows]),
                         np.column_stack([t[idx], te[idx], f["nodes/omega"][idx, k]])))

    r = trainsim("export", h5, "--summary", "json")
    s = json.loads(r.stdout)
    same = all(s["metrics"][e][m] == f["metrics"][m][i].item() for i, e in enumerate(ids) for m in f["metrics"])
    check(f"JSON summary equals /metrics ({len(ids)} elements x {len(f['metrics'])} metrics)", same)
    check("JSON summary equals /run_stats",
          all(s["run_stats"][a] == f["run_stats"].attrs[a].item() for a in f["run_stats"].attrs))

    r = trainsim("export", h5, "--spectrum", "--force-bins", "8", "--velocity-bins", "5")
    head, rows = read_csv(r.stdout)
    total = 0
    for i, e in enumerate(ids):
        n = int(f["metrics/impacts"][i])
        by_f = sum(int(x[5]) for x in rows if x[0] == e and x[1] == "peak_force")
        by_v = sum(int(x[5]) for x in rows if x[0] == e and x[1] == "approach_velocity")
        check(f"spectrum of {e}: {by_f} by force, {by_v} by velocity = {n} impacts", by_f == n and by_v == n)
        total += by_f
    check(f"spectrum sums to the run's {int(f['metrics/impacts'][:].sum())} impacts",
          total == int(f["metrics/impacts"][:].sum()) and total > 0)

    png, npz = os.path.join(tmp, "te.png"), os.path.join(tmp, "te.npz")
    r = trainsim("plot", h5, "--te", "mesh", "--t0", "1.0", "--t1", "1.2", "--events", "-o", png, "--data", npz)
    check("plot --te exits 0: " + r.stderr.strip()[:200], r.returncode == 0)
    d = np.load(npz)
    w = np.nonzero((t >= 1.0) & (t <= 1.2))[0]
    check("plotted TE is the dataset over the window", np.array_equal(d["te"], te[w]) and np.array_equal(d["time"], t[w]))
    check("plotted pairs are /elements/pairs", np.array_equal(d["pairs"], f["elements/pairs"][w, j]))
    b = f["elements/mesh"].attrs["half_backlash"]
    check(f"contact threshold at +/- half_backlash {b}", np.array_equal(d["threshold"], [b, -b]))
    ev_t, ev_e = f["events/time"][:], f["events/element"][:]
    check("marked events are the gear's events in the window",
          np.array_equal(d["event_time"], ev_t[(ev_e == j + 1) & (ev_t >= 1.0) & (ev_t <= 1.2)]))
    with open(png, "rb") as g:
        check("PNG written", g.read(8) == b"\x89PNG\r\n\x1a\n")

    svg, npz = os.path.join(tmp, "sp.svg"), os.path.join(tmp, "sp.npz")
    r = trainsim("plot", h5, "--te-spectrum", "mesh", "--t0", "0.5", "--t1", "2.5", "-o", svg, "--data", npz)
    d = np.load(npz)
    w = np.nonzero((t >= 0.5) & (t <= 2.5))[0]
    left = int(f["elements"].attrs["left"][j]) - 1
    fm = f["elements/mesh"].attrs["teeth"] * abs(f["nodes/omega"][w, left].mean()) / (2 * np.pi)
    check(f"TE spectrum's mesh frequency {d['mesh_frequency'][0]:.6g} Hz = N mean(omega)/2pi {fm:.6g}",
          abs(d["mesh_frequency"][0] - fm) <= 1e-12 * fm)
    check("TE spectrum has n/2 + 1 bins", d["amplitude"].shape == (w.size // 2 + 1,))
    with open(svg, "rb") as g:
        check("SVG written", b"<svg" in g.read(2000))

    pdf, npz = os.path.join(tmp, "ph.pdf"), os.path.join(tmp, "ph.npz")
    r = trainsim("plot", h5, "mesh.force", "--x", "mesh.displacement", "-o", pdf, "--data", npz)
    d = np.load(npz)
    check("phase plane: mesh.force against mesh.displacement, as stored",
          np.array_equal(d["mesh__displacement"], te) and np.array_equal(d["mesh__force"], f["elements/force"][:, j]))
    with open(pdf, "rb") as g:
        check("PDF written", g.read(4) == b"%PDF")

    # figures say what they show (inch deck)
    png = os.path.join(tmp, "d.png")
    r, axes = describe(h5, "mesh.displacement", "-o", png)
    labels = check_labels("Y against time", axes)
    check("... the TE in in, against time in s", labels == ["time [s]", "mesh: transmission error [in]"])
    r, axes = describe(h5, "mesh.force", "--x", "mesh.displacement", "-o", png)
    labels = check_labels("phase plane", axes)
    check("... mesh force in lbf against the TE in in",
          labels == ["mesh: transmission error [in]", "mesh: mesh force [lbf]"])
    r, axes = describe(h5, "--te", "mesh", "--t0", "1.0", "--t1", "1.2", "-o", png)
    labels = check_labels("--te", axes)
    check("... TE in in, pairs as a count", "mesh transmission error [in]" in labels
          and "tooth pairs in contact [-]" in labels)
    r, axes = describe(h5, "--te-spectrum", "mesh", "--t0", "0.5", "--t1", "2.5", "-o", png)
    labels = check_labels("--te-spectrum", axes)
    check("... amplitude in in against mesh order [-]", any(x.startswith("mesh order") and x.endswith("[-]")
                                                            for x in labels) and any("[in]" in x for x in labels))
    r, axes = describe(h5, "mesh.displacement", "--events", "-o", png)
    check_labels("--events", axes)
    n_ev = len(f["events/time"])
    kinds = f["events/kind_name"].asstr()[:]
    strip = [a for a in axes if a["lines"] and all((ln["gid"] or "").startswith("events:") for ln in a["lines"])]
    main = [a for a in axes if a not in strip]
    ticks = {ln["gid"][7:]: ln["points"] for a in strip for ln in a["lines"]}
    check(f"--events: the {n_ev} events are ticks in a strip of their own under the plot, by kind {ticks}",
          len(strip) == 1 and ticks == {k: int((kinds == k).sum()) for k in set(kinds)})
    check("--events: the data line keeps every sample and no event line crosses it",
          [ln["points"] for ln in main[0]["lines"]] == [len(t)])
    check(f"--events: the legend names each kind with its count {main[0]['legend']}",
          all(f"event: {k.replace('_', ' ')} ({n})" in main[0]["legend"] for k, n in ticks.items()))
    r, axes = describe(h5, "--overview", "mesh", "--t0", "1.0", "--t1", "1.2", "-o", png)
    check(f"--overview draws plot_history.py's figure ({r.stderr.strip()[-200:]})", r.returncode == 0 and len(axes) >= 4)
    labels = check_labels("--overview", axes)
    check("... TE, force, phase plane and time with their units",
          any(x.startswith("transmission error (") for x in labels) and any(x.startswith("contact force (") for x in labels)
          and any(x.startswith("its rate (") for x in labels) and "time (ms)" in labels)

    r = trainsim("export", h5, "mesh.tork")
    check("unknown quantity: exit 2 naming it", r.returncode == 2 and "mesh.tork" in r.stderr)
    r = trainsim("plot", h5, "mesh.force", "-o", os.path.join(tmp, "x.jpg"))
    check("unsupported image format: exit 2", r.returncode == 2 and ".png, .pdf or .svg" in r.stderr)

with tempfile.TemporaryDirectory() as tmp:
    # SI: units chosen for the magnitude; two units in one figure: a left and a right axis
    h5 = os.path.join(tmp, "si.h5")
    r = trainsim("run", os.path.join(ROOT, "tests/decks/tracker_si_start_stop.nml"), "-o", h5)
    check("the SI tracker deck runs", r.returncode == 0)
    png = os.path.join(tmp, "si.png")
    with h5py.File(h5) as f:
        j = list(f["elements"].attrs["ids"]).index("mesh")
        te_max = float(np.abs(f["elements/displacement"][:, j]).max())
        force_max = float(np.abs(f["elements/force"][:, j]).max())
    r, axes = describe(h5, "mesh.displacement", "mesh.force", "--events", "-o", png)
    labels = check_labels("SI, two units", axes)
    check(f"... the TE (largest {te_max:.3g} m) in um and the mesh force (largest {force_max:.4g} N) in kN, "
          f"on two axes: {labels}",
          1e-6 <= te_max < 1e-3 and 1e3 <= force_max < 1e6 and "mesh: transmission error [µm]" in labels
          and "mesh: mesh force [kN]" in labels)
    r, axes = describe(h5, "--te", "mesh", "--t0", "0.7", "--t1", "0.8", "-o", png)
    check("SI --te: TE in um", "mesh transmission error [µm]" in check_labels("SI --te", axes))
    r, axes = describe(h5, "--overview", "-o", png)
    check("SI --overview: TE in um, force in kN", {"transmission error (µm)", "contact force (kN)"}
          <= set(check_labels("SI --overview", axes)))
    r = trainsim("plot", h5, "mesh.displacement", "motor.omega", "energy.kinetic", "-o", png)
    check("three units in one figure: exit 2 naming them", r.returncode == 2 and "units" in r.stderr)

with tempfile.TemporaryDirectory() as tmp:
    # a 6 x 2 grid: one curve per value of the second parameter
    deck, sweep = os.path.join(tmp, "grid.nml"), os.path.join(tmp, "grid.h5")
    with open(deck, "w", encoding="utf-8") as g:
        g.write(GRID_6X2)
    r = trainsim("sweep", deck, "-o", sweep)
    check(f"the 6 x 2 grid sweep runs ({r.stderr.strip()[-200:]})", r.returncode == 0)
    png, npz = os.path.join(tmp, "grid.png"), os.path.join(tmp, "grid.npz")
    r, axes = describe(sweep, "--metric", "mesh.disp_max", "-o", png, "--data", npz)
    labels = check_labels("sweep figure", axes)
    check(f"... {labels}: the metric and the parameter with their units",
          labels == ["mesh.half_backlash: half backlash [in]", "mesh.disp_max: largest transmission error [in]"])
    curves = [ln for ln in axes[0]["lines"] if ln["gid"] == "curve"]
    check(f"6 x 2 grid against half_backlash: 2 curves of 6 points {[(c['label'], c['points']) for c in curves]}",
          [c["points"] for c in curves] == [6, 6] and
          [c["label"] for c in curves] == ["mesh.mesh_frequency = 30 teeth/s", "mesh.mesh_frequency = 45 teeth/s"])
    check(f"... and the legend names them {axes[0]['legend']}", axes[0]["legend"] == [c["label"] for c in curves])
    d = np.load(npz)
    with h5py.File(sweep) as f:
        names = list(f["parameters/names"].asstr()[()])
        v = f["parameters/values"][:, :]
        y = f["elements/disp_max"][:, 0]
    for g, fm in enumerate((30.0, 45.0)):
        runs = np.flatnonzero(v[:, names.index("mesh.mesh_frequency")] == fm)
        runs = runs[np.argsort(v[runs, names.index("mesh.half_backlash")])]
        check(f"curve {g + 1} is the runs at {fm:g} teeth/s by half_backlash, with the file's values",
              np.array_equal(d[f"f0_g{g}_b0_x"], v[runs, 0]) and np.array_equal(d[f"f0_g{g}_b0_y"], y[runs]))
    r, axes = describe(sweep, "--metric", "mesh.disp_max", "--x", "mesh.mesh_frequency", "-o", png)
    curves = [ln for ln in axes[0]["lines"] if ln["gid"] == "curve"]
    check(f"against mesh_frequency: 6 curves of 2 points, named in in ({curves[0]['label'] if curves else ''})",
          [c["points"] for c in curves] == [2] * 6 and curves[0]["label"] == "mesh.half_backlash = 0.0005 in"
          and axes[0]["xlabel"] == "mesh.mesh_frequency: mesh frequency [teeth/s]")

with tempfile.TemporaryDirectory() as tmp:
    sweep, deck = os.path.join(tmp, "sweep.h5"), os.path.join(tmp, "sweep.nml")
    with open(os.path.join(ROOT, "inputs", "sweep_ghm_continuation.nml"), encoding="utf-8") as f:
        text = f.read()
    for a, b in (("count = 27", "count = 7"), ("values = 100", "values = 20"), ("values = 60", "values = 10")):
        check(f"the continuation deck has '{a}' (shortened for the test)", a in text)
        text = text.replace(a, b)
    with open(deck, "w", encoding="utf-8") as f:
        f.write(text)
    r = trainsim("sweep", deck, "-o", sweep)
    check(f"a continuation sweep runs ({r.stderr.strip()[-200:]})", r.returncode == 0)
    if r.returncode == 0:
        npz, png = os.path.join(tmp, "s.npz"), os.path.join(tmp, "s.png")
        r, axes = describe(sweep, "--metric", "mesh.p2p_range", "-o", png, "--data", npz)
        check(f"trainsim plot reads the sweep file ({r.stderr.strip()[-200:]})", r.returncode == 0)
        labels = check_labels("continuation sweep figure", axes)
        check(f"... p2p range in in against the mesh frequency in teeth/s {labels}",
              labels == ["mesh.mesh_frequency: mesh frequency [teeth/s]",
                         "mesh.p2p_range: peak-to-peak transmission error range [in]"])
        if r.returncode == 0:
            d = np.load(npz)
            with h5py.File(sweep) as f:
                names = list(f["parameters/names"].asstr()[()])
                x = f["parameters/values"][:, names.index("mesh.mesh_frequency")]
                ids = list(f["elements/ids"].asstr()[()])
                y = f["elements/p2p_range"][:, ids.index("mesh")]
                branch = f["runs/branch"][:]
            for b, what in ((1, "up"), (2, "down")):
                runs = np.flatnonzero(branch == b)
                check(f"the {what} branch is plotted in run order: x and p2p_range are the file's ({len(runs)} runs)",
                      len(runs) > 1 and np.array_equal(d[f"f0_b{b}_x"], x[runs])
                      and np.array_equal(d[f"f0_b{b}_y"], y[runs]))
            check("the up branch rises and the down branch falls in frequency",
                  np.all(np.diff(d["f0_b1_x"]) > 0) and np.all(np.diff(d["f0_b2_x"]) < 0))
            check("a PNG is written", os.path.getsize(png) > 1000)

finish()
