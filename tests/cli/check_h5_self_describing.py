#!/usr/bin/python3
"""The history file describes itself (docs/output-format.md, "Self-description").

For bundled decks of every element family (spur and helical gears, keyed joint,
coupling, DC motor, SI units):
- `h5dump -A` shows a `units` attribute in every DATASET block (the reader needs no
  other tool than h5dump to know a unit);
- tests/check_h5_layout.py passes: every string attribute reads as str in h5py (no
  .decode()), string datasets are variable-length UTF-8, every 2-D series has
  column_names/column_units and /time as the dimension scale of its rows;
- derived constants are stored: the spur gear's gear_ratio = rb_driven / rb_driver;
- the file holds every input: the deck, the text of every table_file it read
  (/deck_files) and the --set overrides (`overrides`): the deck and tables written
  back from the file into an empty folder, run with the overrides, reproduce the
  run's /metrics exactly;
- the version names the git revision the executable was built from.

usage: check_h5_self_describing.py TRAINSIM_EXE
"""
import os
import re
import shlex
import subprocess
import sys
import tempfile

import h5py

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
import check_h5_layout  # noqa: E402

from clicheck import check, EXE, finish  # noqa: E402
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DECKS = ["inputs/start_stop_two_clearances.nml", "inputs/helical_pair.nml", "inputs/dc_motor_geared_load.nml",
         "inputs/loads_table_ramp.nml", "verification/table5_3/table5_3.nml"]


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


def git_revision():
    try:
        r = subprocess.run(["git", "-C", ROOT, "rev-parse", "HEAD"], capture_output=True, text=True, timeout=60)
    except OSError:
        return None
    return r.stdout.strip() if r.returncode == 0 else None


with tempfile.TemporaryDirectory() as tmp:
    deck = os.path.join(ROOT, "inputs/loads_table_ramp.nml")
    out = os.path.join(tmp, "orig.h5")
    sets = ["--set", "coupling.stiffness=4.5e3", "--set", "run.integrator='rk4'"]
    r = subprocess.run([EXE, "run", deck, "-o", out] + sets, capture_output=True, text=True, timeout=600)
    check("loads_table_ramp runs (with two --set)", r.returncode == 0)
    with h5py.File(out) as f:
        rev = f.attrs["git_revision"]
        head = git_revision()
        if head is None:
            check(f"git_revision is 'unknown' outside a git work tree ({rev!r})", rev == "unknown")
        else:
            # the build may predate the last commit: the revision is a hex prefix of some commit
            # (HEAD when built from it), and the version string carries it
            check(f"git_revision {rev!r} is an abbreviated commit hash",
                  re.fullmatch(r"[0-9a-f]{12}(-dirty)?", rev) is not None)
            check("trainsim_version names the revision", f"(git {rev})" in f.attrs["trainsim_version"])
        v = subprocess.run([EXE, "--version"], capture_output=True, text=True).stdout
        check(f"trainsim --version names the revision ({v.strip()})", rev in v or rev == "unknown")
        g = f["deck_files"].attrs
        paths, files, texts = list(g["paths"]), list(g["files"]), list(g["texts"])
        check(f"/deck_files lists the one table file ({paths})", paths == ["wind_load.txt"] and len(texts) == 1)
        with open(os.path.join(ROOT, "inputs", "wind_load.txt"), encoding="utf-8") as t:
            check("/deck_files text is the table file, byte for byte", texts[0] == t.read())
        # write the inputs back from the file alone, run them, compare the metrics
        again = os.path.join(tmp, "again")
        os.mkdir(again)
        with open(os.path.join(again, "deck.nml"), "w", encoding="utf-8") as d:
            d.write(f.attrs["deck"])
        for p_, t_ in zip(paths, texts):
            with open(os.path.join(again, p_), "w", encoding="utf-8") as d:
                d.write(t_)
        overrides = f.attrs["overrides"]
        check(f"the overrides are recorded as --set writes them ({overrides!r})",
              overrides == "coupling.stiffness=4.5e3 run.integrator='rk4'")
        again_sets = [a for o in shlex.split(overrides, posix=False) for a in ("--set", o)]
        out2 = os.path.join(tmp, "again.h5")
        r = subprocess.run([EXE, "run", os.path.join(again, "deck.nml"), "-o", out2] + again_sets,
                           capture_output=True, text=True, timeout=600)
        check("the deck, tables and overrides taken from the file run", r.returncode == 0)
        if r.returncode == 0:
            with h5py.File(out2) as f2:
                a, b = f["metrics"], f2["metrics"]
                same = sorted(a.keys()) == sorted(b.keys()) and all(
                    (a[k][()] == b[k][()]).all() for k in a.keys() if isinstance(a[k], h5py.Dataset))
                check("the run from the file's own inputs has the same /metrics, bit for bit", same)
                check("its states are the same, bit for bit", (f["states"][()] == f2["states"][()]).all())

with tempfile.TemporaryDirectory() as tmp:
    # a sweep of the same deck: its file holds the table file too
    with open(os.path.join(ROOT, "inputs/loads_table_ramp.nml"), encoding="utf-8") as f:
        text = f.read()
    deck = os.path.join(tmp, "sweep.nml")
    with open(deck, "w", encoding="utf-8") as f:
        f.write(text + "&sweep parameter = 'coupling.stiffness', values = 4.0e3, 5.0e3 /\n"
                       "&sweep parameter = 'run.t_end', values = 0.05 /\n")
    with open(os.path.join(ROOT, "inputs/wind_load.txt"), encoding="utf-8") as f:
        table = f.read()
    with open(os.path.join(tmp, "wind_load.txt"), "w", encoding="utf-8") as f:
        f.write(table)
    out = os.path.join(tmp, "sweep.h5")
    r = subprocess.run([EXE, "sweep", deck, "-o", out], capture_output=True, text=True, timeout=600)
    check(f"a sweep of the table deck runs ({r.stderr.strip()[-160:]})", r.returncode == 0)
    if r.returncode == 0:
        with h5py.File(out) as f:
            g = f["deck_files"].attrs if "deck_files" in f else {}
            check("the sweep file's /deck_files holds the table file's text",
                  list(g.get("paths", [])) == ["wind_load.txt"] and list(g.get("texts", [])) == [table])
            check("the sweep file's version names the revision", "git" in f.attrs["trainsim_version"]
                  or git_revision() is None)

finish()
