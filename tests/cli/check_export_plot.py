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

usage: check_export_plot.py TRAINSIM_EXE
"""
import csv
import io
import json
import os
import subprocess
import sys
import tempfile

import h5py
import numpy as np

EXE = sys.argv[1]
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
failures = []


def check(what, ok):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


def trainsim(*args):
    return subprocess.run([EXE] + list(args), capture_output=True, text=True, timeout=600)


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

    r = trainsim("export", h5, "mesh.tork")
    check("unknown quantity: exit 2 naming it", r.returncode == 2 and "mesh.tork" in r.stderr)
    r = trainsim("plot", h5, "mesh.force", "-o", os.path.join(tmp, "x.jpg"))
    check("unsupported image format: exit 2", r.returncode == 2 and ".png, .pdf or .svg" in r.stderr)

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
        r = trainsim("plot", sweep, "--metric", "mesh.p2p_range", "-o", png, "--data", npz)
        check(f"trainsim plot reads the sweep file ({r.stderr.strip()[-200:]})", r.returncode == 0)
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

sys.exit(1 if failures else 0)
