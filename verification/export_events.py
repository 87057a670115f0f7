#!/usr/bin/env python3
"""Write the event table of an HDF5 history as CSV (time, element, kind,
approach velocity, restitution, D, peak force, duration).
Usage: export_events.py HISTORY.h5 OUT.csv"""
import sys

import h5py

with h5py.File(sys.argv[1], "r") as f, open(sys.argv[2], "w") as out:
    ev = f["events"]
    ids = [s.decode() if isinstance(s, bytes) else s for s in f["elements"].attrs["ids"]]
    out.write("# %s\n# trainsim %s, integrator %s\n" % (
        f.attrs["title"].decode() if isinstance(f.attrs["title"], bytes) else f.attrs["title"],
        f.attrs["trainsim_version"].decode() if isinstance(f.attrs["trainsim_version"], bytes) else f.attrs["trainsim_version"],
        f.attrs["integrator"].decode() if isinstance(f.attrs["integrator"], bytes) else f.attrs["integrator"]))
    out.write("time_s,element,kind,approach_or_separation_velocity,restitution,damping_D,peak_force,duration_s\n")
    for i in range(len(ev["time"])):
        kind = ev["kind_name"][i]
        kind = kind.decode() if isinstance(kind, bytes) else kind
        out.write("%.9e,%s,%s,%.6e,%.6f,%.6e,%.6e,%.6e\n" % (
            ev["time"][i], ids[ev["element"][i] - 1], kind, ev["approach_velocity"][i],
            ev["restitution"][i], ev["damping"][i], ev["peak_force"][i], ev["duration"][i]))
