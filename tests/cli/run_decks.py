#!/usr/bin/env python3
"""Smoke test: every bundled deck (inputs/, verification/) runs to completion,
exits 0, prints no error, and writes a complete HDF5 history (checked by
tests/check_h5_layout.py); and runs again without a history (--no-output: plain
steps in blocks, D-38), also exiting 0. Neither run may print a Fortran runtime
warning (in the Debug build: an array temporary, i.e. a copy, on the way to the
hot path). Usage: run_decks.py TRAINSIM (cwd = repo root)."""
import glob
import os
import subprocess
import sys
import tempfile

exe = sys.argv[1]
decks = sorted(glob.glob("inputs/*.nml") + glob.glob("verification/**/*.nml", recursive=True))
passed = failed = 0
with tempfile.TemporaryDirectory() as tmp:
    for deck in decks:
        out = os.path.join(tmp, os.path.basename(deck).replace(".nml", ".h5"))
        r = subprocess.run([exe, "run", deck, "-o", out], capture_output=True, text=True, timeout=600)
        problems = []
        if r.returncode != 0:
            problems.append(f"exit {r.returncode}: {r.stderr.strip()[:300]}")
        if deck.endswith("table5_2.nml") and not ("warning" in r.stderr and "stability limit" in r.stderr):
            problems.append("Table 5.2: dt above the RK4 stability limit must be warned about")
        if "error" in r.stderr.lower() or "backtrace" in r.stderr.lower():
            problems.append("stderr: " + r.stderr.strip()[:300])
        n = subprocess.run([exe, "run", deck, "--no-output"], capture_output=True, text=True, timeout=600)
        if n.returncode != 0:
            problems.append(f"--no-output: exit {n.returncode}: {n.stderr.strip()[:300]}")
        for what, text in (("", r.stderr), ("--no-output: ", n.stderr)):
            if "runtime warning" in text:
                i = text.index("runtime warning")
                problems.append(what + "stderr: " + text[max(0, i - 80):i + 120].strip())
        if not os.path.exists(out) or os.path.exists(out + ".part"):
            problems.append("no complete output file")
        else:
            c = subprocess.run(["/usr/bin/python3", "tests/check_h5_layout.py", out], capture_output=True, text=True)
            if c.returncode != 0:
                problems.append("layout: " + (c.stdout + c.stderr).strip()[-300:])
        if problems:
            failed += 1
            print(f"FAIL {deck}: " + "; ".join(problems))
        else:
            passed += 1
            print(f"ok   {deck}")
print(f"{passed} passed, {failed} failed")
sys.exit(1 if failed else 0)
