#!/usr/bin/python3
"""An interrupted run keeps what it computed; a long run shows its progress (issue 20, item 8).

Usage (as CTest runs it, cwd = repo root):

    /usr/bin/python3 tests/cli/check_interrupt.py <path to trainsim>

1. SIGINT at about half of a run of a few seconds (the Table 5.5 rig, t_end chosen from
   a timed short run so that it takes ~4 s on this build): exit 130, stderr names what was
   kept, the file is readable, root attribute status = 'interrupted', run_stats completed
   = 0, /time ends at or before the interrupt and past a third of t_end, and every series
   equals, sample for sample and to the bit, that of an uninterrupted run to the last
   kept output time (same grid, same steps). The events up to then are the same too.
   SIGTERM: exit 143, kept the same way. A complete run says status = 'complete'.
2. Progress: redirected (stderr a file), TRAINSIM_PROGRESS_INTERVAL=0.2 gives a line every
   ~0.2 s naming t, the percentage, events, elapsed and left; a short run with the default
   interval prints nothing extra; on a terminal (a pty) the line is rewritten in place
   (carriage returns) and cleared at the end.
3. A run with no history file says so: the deck names no output, or --no-output.
"""

import os
import pty
import re
import select
import signal
import subprocess
import sys
import tempfile
import time

import h5py
import numpy as np

DECK = os.path.join(os.getcwd(), "inputs", "gregory_harris_munro.nml")
PROGRESS = re.compile(r"trainsim: t = ([0-9.]+) of ([0-9.]+) s \(([0-9.]+) %\), (\d+) events, "
                      r"[0-9.]+ (s|min [0-9]+ s|h [0-9]+ min) elapsed(, about .* left)?$")
results = []


def check(name, ok, detail=""):
    results.append(ok)
    print(("ok   " if ok else "FAIL ") + name + ("" if ok or not detail else "\n     " + detail))


def run_args(t_end, out):
    return ["run", DECK, "-o", out, "--set", "run.t_end=%r" % t_end, "--set", "run.output_interval=1e-3"]


def series(f):
    """Every dataset whose rows are the output samples, by name."""
    n = f["time"].shape[0]
    found = {}

    def visit(name, obj):
        if isinstance(obj, h5py.Dataset) and obj.ndim >= 1 and obj.shape[0] == n and not name.startswith("events"):
            found[name] = obj[...]
    f.visititems(visit)
    return found


def interrupted_run(exe, tmp, sig, t_end):
    """Start a run, send `sig` once a progress line says it is past half; return rc, stderr, file."""
    out = os.path.join(tmp, "int_%d.h5" % sig)
    env = dict(os.environ, TRAINSIM_PROGRESS_INTERVAL="0.1")
    fe = open(os.path.join(tmp, "stderr_%d" % sig), "w")
    p = subprocess.Popen([exe] + run_args(t_end, out), cwd=tmp, stdout=subprocess.DEVNULL, stderr=fe, env=env)
    sent_at = None
    deadline = time.time() + 600
    while time.time() < deadline and p.poll() is None:
        lines = open(os.path.join(tmp, "stderr_%d" % sig)).read().splitlines()
        pct = [float(m.group(3)) for m in map(PROGRESS.match, lines) if m]
        if pct and pct[-1] >= 45.0:
            p.send_signal(sig)
            sent_at = pct[-1]
            break
        time.sleep(0.05)
    rc = p.wait(timeout=120)
    fe.close()
    return rc, open(os.path.join(tmp, "stderr_%d" % sig)).read(), out, sent_at


def main():
    if len(sys.argv) < 2:
        print(__doc__, file=sys.stderr)
        return 2
    exe = os.path.abspath(sys.argv[1])
    with tempfile.TemporaryDirectory(prefix="trainsim-int-") as tmp:
        # ---- t_end for a run of ~4 s on this build
        t0 = time.time()
        subprocess.run([exe] + run_args(1.0, os.path.join(tmp, "cal.h5")), cwd=tmp, check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        per_s = max(time.time() - t0, 1e-3)
        t_end = float("%.3g" % min(max(4.0/per_s, 2.0), 400.0))
        print("     calibration: %.3f s of wall time per simulated s; t_end = %g s" % (per_s, t_end))

        # ---- 1. SIGINT at half
        rc, se, out, pct = interrupted_run(exe, tmp, signal.SIGINT, t_end)
        check("SIGINT sent when the progress line said %s %%" % pct, pct is not None, se[-300:])
        check("exit 130 after SIGINT", rc == 130, "exit %d; stderr %s" % (rc, se[-300:]))
        m = re.search(r"interrupted at t = ([0-9.eE+-]+) s by SIGINT; the history up to t = ([0-9.eE+-]+) s "
                      r"\(the last output time reached\) was kept in (\S+), marked incomplete", se)
        check("stderr says where it stopped and what was kept", m is not None, se[-400:])
        check("no temporary file left", not [x for x in os.listdir(tmp) if x.endswith(".part")], str(os.listdir(tmp)))
        ok_file = os.path.exists(out)
        check("the history file was kept", ok_file)
        if ok_file and m:
            t_int = float(m.group(1))
            with h5py.File(out, "r") as f:
                status = f.attrs.get("status")
                completed = int(f["run_stats"].attrs["completed"])
                t_final = float(f["run_stats"].attrs["t_final"])
                tt = f["time"][...]
                a = series(f)
                ev_a = (f["events/time"][...], f["events/kind"][...], f["events/element"][...])
            check("root attribute status = 'interrupted'", status == "interrupted", repr(status))
            check("run_stats: completed = 0, t_final = the interrupt's t", completed == 0 and t_final == t_int,
                  "%d %r %r" % (completed, t_final, t_int))
            check("/time ends at or before the interrupt (%.4f <= %.6f s), past a third of t_end" % (tt[-1], t_int),
                  tt[-1] <= t_int and tt[-1] > t_end/3 and abs(tt[-1] - float(m.group(2))) < 1e-9,
                  "%r %r %r" % (tt[-1], t_int, m.group(2)))
            check("/time is the output grid (k ms) up to its last sample",
                  np.array_equal(tt, np.arange(len(tt))*1e-3) or np.max(np.abs(tt - np.arange(len(tt))*1e-3)) < 1e-12)
            # the same run, uninterrupted, to the last kept output time
            ref = os.path.join(tmp, "ref.h5")
            r = subprocess.run([exe] + run_args(float(repr(tt[-1])), ref), cwd=tmp, capture_output=True, text=True)
            check("the reference run to t = %.4f s ends with exit 0" % tt[-1], r.returncode == 0, r.stderr[-300:])
            if r.returncode == 0:
                with h5py.File(ref, "r") as f:
                    status_ref = f.attrs.get("status")
                    b = series(f)
                    tb = f["time"][...]
                    keep = f["events/time"][...] <= tt[-1]
                    ev_b = (f["events/time"][...][keep], f["events/kind"][...][keep], f["events/element"][...][keep])
                check("a complete run says status = 'complete'", status_ref == "complete", repr(status_ref))
                differ = [k for k in a if k not in b or b[k].shape != a[k].shape or not np.array_equal(a[k], b[k])]
                check("every series (%d datasets, %d samples) equals the uninterrupted run's, to the bit"
                      % (len(a), len(tt)), np.array_equal(tt, tb) and not differ and len(a) >= 8, str(differ[:5]))
                n = len(ev_b[0])
                same_ev = len(ev_a[0]) >= n and all(np.array_equal(x[:n], y) for x, y in zip(ev_a, ev_b))
                check("the events up to then are the same (%d)" % n, same_ev and n > 0)

        # ---- SIGTERM
        rc, se, out, pct = interrupted_run(exe, tmp, signal.SIGTERM, t_end)
        ok = rc == 143 and "by SIGTERM; the history up to t = " in se and os.path.exists(out)
        if ok:
            with h5py.File(out, "r") as f:
                ok = f.attrs.get("status") == "interrupted"
        check("SIGTERM: exit 143, the history kept and marked interrupted", ok, "exit %d; %s" % (rc, se[-300:]))

        # ---- 2. progress, redirected
        env = dict(os.environ, TRAINSIM_PROGRESS_INTERVAL="0.2")
        t_long = float("%.3g" % min(max(1.5/per_s, 1.0), 200.0))
        t0 = time.time()
        r = subprocess.run([exe] + run_args(t_long, os.path.join(tmp, "p.h5")), cwd=tmp, capture_output=True,
                           text=True, env=env)
        wall = time.time() - t0
        lines = [x for x in r.stderr.splitlines() if x.startswith("trainsim: t = ")]
        good = [x for x in lines if PROGRESS.match(x)]
        # a line every 0.2 s once the run is 0.2 s old: the clock is read every 20-100 ms, and
        # setting up the run (deck, stability analysis) takes some of the wall time
        expect = int((wall - 0.5)/0.4)
        check("redirected: a progress line every 0.2 s (%d lines in %.1f s, each t, %%, events, elapsed, left)"
              % (len(lines), wall), r.returncode == 0 and max(expect, 2) <= len(lines) <= wall/0.2 + 1
              and len(good) == len(lines) and "\r" not in r.stderr, r.stderr[-500:])
        pcts = [float(PROGRESS.match(x).group(3)) for x in good]
        check("the percentages grow", pcts == sorted(pcts) and (not pcts or pcts[-1] <= 100.0), str(pcts))
        r = subprocess.run([exe] + run_args(0.05, os.path.join(tmp, "s.h5")), cwd=tmp, capture_output=True,
                           text=True, env={k: v for k, v in os.environ.items() if k != "TRAINSIM_PROGRESS_INTERVAL"})
        check("a short run prints nothing on stderr", r.returncode == 0 and r.stderr == "", r.stderr[-300:])

        # ---- progress on a terminal: one line rewritten in place
        master, slave = pty.openpty()
        p = subprocess.Popen([exe] + run_args(t_long, os.path.join(tmp, "tty.h5")), cwd=tmp,
                             stdout=subprocess.DEVNULL, stderr=slave, env=env)
        os.close(slave)
        got = b""
        while True:
            rd, _, _ = select.select([master], [], [], 0.5)
            if rd:
                try:
                    chunk = os.read(master, 4096)
                except OSError:
                    break
                if not chunk:
                    break
                got += chunk
            elif p.poll() is not None:
                break
        p.wait()
        os.close(master)
        text = got.decode(errors="replace")
        check("on a terminal: the line rewritten in place (carriage returns, no newline) and cleared at the end",
              p.returncode == 0 and text.count("\r") >= 3 and "\n" not in text.replace("\r\n", "")
              and "trainsim: t = " in text and text.endswith("\r"), repr(text[-200:]))

        # ---- 3. nothing saved: said so
        deck = os.path.join(tmp, "noout.nml")
        with open(DECK) as f:
            txt = f.read()
        with open(deck, "w") as f:
            f.write(re.sub(r",\s*output = '[^']*'", "", txt))
        r = subprocess.run([exe, "run", deck], cwd=tmp, capture_output=True, text=True)
        check("a deck with no output: 'no history file was written: the deck names no output'",
              r.returncode == 0 and "no history file was written: the deck names no output" in r.stdout,
              r.stdout[-300:] + r.stderr[-300:])
        r = subprocess.run([exe, "run", DECK, "--no-output"], cwd=tmp, capture_output=True, text=True)
        check("--no-output: 'no history file was written (--no-output'",
              r.returncode == 0 and "no history file was written (--no-output" in r.stdout and
              not os.path.exists(os.path.join(tmp, "gregory_harris_munro.h5")), r.stdout[-300:])
    print("%d of %d checks passed" % (sum(results), len(results)))
    return 0 if all(results) else 1


if __name__ == "__main__":
    sys.exit(main())
