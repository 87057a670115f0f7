#!/usr/bin/python3
"""The history file describes itself (docs/output-format.md, "Self-description").

For bundled decks of every element family (spur and helical gears, keyed joint,
coupling, DC motor, SI units):
- `h5dump -A` shows a `units` attribute in every DATASET block (the reader needs no
  other tool than h5dump to know a unit);
- tests/check_h5_layout.py passes: every string attribute reads as str in h5py (no
  .decode()), string datasets are variable-length UTF-8, every 2-D series has
  column_names/column_units and /time as the dimension scale of its rows;
- derived constants are stored: the spur gear's gear_ratio = rb_driven / rb_driver.

usage: check_h5_self_describing.py TRAINSIM_EXE
"""
import os
import re
import subprocess
import sys
import tempfile

import h5py

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import check_h5_layout  # noqa: E402

EXE = sys.argv[1]
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DECKS = ["inputs/start_stop_two_clearances.nml", "inputs/helical_pair.nml", "inputs/dc_motor_geared_load.nml",
         "inputs/loads_table_ramp.nml", "verification/table5_3/table5_3.nml"]
failures = []


def check(what, ok):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)


with tempfile.TemporaryDirectory() as tmp:
    for deck in DECKS:
        out = os.path.join(tmp, os.path.basename(deck) + ".h5")
        r = subprocess.run([EXE, "run", os.path.join(ROOT, deck), "-o", out], capture_output=True, text=True,
                           timeout=600)
        check(f"{deck} runs", r.returncode == 0)
        if r.returncode != 0:
            continue
        with h5py.File(out) as f:
            problems = check_h5_layout.check(f)
            check(f"{deck}: layout and self-description ({'; '.join(problems[:3])})", not problems)
            n_sets = []
            f.visititems(lambda name, o: n_sets.append(name) if isinstance(o, h5py.Dataset) else None)
            ids = list(f["elements"].attrs["ids"])
            types = list(f["elements"].attrs["types"])
            for i, t in zip(ids, types):
                if t == "spur_gear":
                    g = f["elements"][i].attrs
                    check(f"{deck}: {i} gear_ratio = rb_driven / rb_driver",
                          abs(g["gear_ratio"] - g["rb_driven"] / g["rb_driver"]) <= 1e-15 * g["gear_ratio"])
        dump = subprocess.run(["h5dump", "-A", out], capture_output=True, text=True).stdout
        # every DATASET block, up to the next DATASET/GROUP header, names a units attribute
        parts = re.split(r'\n\s*(?=(?:DATASET|GROUP) ")', dump)
        ds_parts = [p for p in parts if p.lstrip().startswith("DATASET")]
        missing = [p.split('"')[1] for p in ds_parts if 'ATTRIBUTE "units"' not in p]
        check(f"{deck}: h5dump -A shows {len(ds_parts)} datasets (h5py: {len(n_sets)}), each with a units "
              f"attribute (missing: {missing[:5]})", not missing and len(ds_parts) == len(n_sets))

sys.exit(1 if failures else 0)
