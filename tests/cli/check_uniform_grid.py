"""The history is ready for an FFT: /time is exactly t_start + k*output_interval
(computed from k, not accumulated), the last sample is t_end, and events are not
samples but rows of /events that carry the state at the event.

The deck is the SI start-stop tracker of the robust-runs issue: 3.6 s with an input
breakpoint at 2.1 s, where the accumulated grid used to drift (last sample 3.59992)."""
import os, subprocess, sys, tempfile
import h5py
import numpy as np

exe = sys.argv[1]
deck = os.path.join(os.path.dirname(__file__), "..", "decks", "tracker_si_start_stop.nml")
failed = 0

def check(what, ok):
    global failed
    print(("  ok   " if ok else "  FAIL ") + what)
    failed += 0 if ok else 1

with tempfile.TemporaryDirectory() as tmp:
    for integrator in ("rk4", "cvode-bdf"):
        out = os.path.join(tmp, integrator + ".h5")
        r = subprocess.run([exe, "run", deck, "-o", out, "--set", "run.integrator=" + integrator],
                           capture_output=True, text=True)
        check(f"{integrator}: run exits 0 ({r.returncode}: {r.stderr.strip()[:200]})", r.returncode == 0)
        if r.returncode != 0:
            continue
        with h5py.File(out, "r") as f:
            t = f["time"][:]
            k = np.arange(len(t))
            grid = k * 1.0e-4
            grid[-1] = 3.6
            check(f"{integrator}: {len(t)} samples = 36001", len(t) == 36001)
            check(f"{integrator}: /time equals k*output_interval exactly (max diff {np.max(np.abs(t - grid)) if len(t) == len(grid) else 'n/a'})",
                  len(t) == 36001 and bool(np.all(t == grid)))
            check(f"{integrator}: last sample at t_end = 3.6 exactly", t[-1] == 3.6)
            ev = f["events"]
            n_ev = ev["time"].shape[0]
            check(f"{integrator}: events recorded ({n_ev})", n_ev > 0)
            for col in ("theta_left", "omega_left", "theta_right", "omega_right", "displacement", "force"):
                check(f"{integrator}: /events/{col} has a row per event", col in ev and ev[col].shape[0] == n_ev)

print(f"{failed} failed")
sys.exit(1 if failed else 0)
